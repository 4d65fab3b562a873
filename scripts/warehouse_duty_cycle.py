#!/usr/bin/env python3
"""Writes the warehouse duty-cycle scenarios: one mission per shipped vehicle, as a planner would
hand it over (a CSV reference of t, x, y, psi and the body twist, 20 samples per second), with the
phases of every sample in a sidecar CSV for scripts/duty_cycle_report.py.

The mission, from rest at the origin heading +x: an aisle run, a 90 deg crab into a bay, a docking
creep, a dwell, reversing out, an in-place turn, an aisle run back with a re-orientation under way,
a crab into the opposite bay, its creep, reversing out, an in-place turn back, and a last aisle run:
12 legs with stops between them. Every leg starts and ends at rest with a trapezoidal speed profile
(or a smooth yaw ramp for the in-place turns), within the vehicle's drive limits.

A planner respects the vehicle's steering range too. On a vehicle whose modules steer within
+-90 deg, the aisle run back cannot start as a 90 deg crab and turn under way: the modules on one
side would have to pass their end stop while rolling, a 180 deg swing no controller can make in
motion. There the in-place turn goes 45 deg further, the run back turns from a 45 deg to a -45 deg
crab, and an in-place turn of -45 deg after it restores the heading (13 legs). Every mission is
checked against its vehicle's range: no module's direction of travel crosses an end stop while it
rolls.

Usage: scripts/warehouse_duty_cycle.py [--out configs/scenarios/duty] [--vehicles configs/vehicles] [--check]
Regenerate the shipped files with the defaults; the output is deterministic. --check writes nothing
and fails when a file in --out differs from what it would write (ctest runs it). --self-test checks
that the end-stop check finds the crossing of a mission that turns under way from a 90 deg crab.
"""
import argparse
import math
import os
import re
import sys

DT = 0.05            # s between samples
ACCELERATION = 0.5   # m/s^2 of every leg's ramp (within every shipped vehicle's drive limit)
SLOW = 0.3           # m/s: bay moves
CREEP = 0.05         # m/s: docking
YAW_RATE = 0.5       # rad/s: in-place turns (peak)

PHASES = ("start", "cruise", "turn", "re-steer", "stop")


def vehicle_limits(path):
    """The name, drive speed (m/s), module positions (m, body frame) and steering range (rad, or
    None when the modules have no end stops: no range, or a full turn, as ModuleLimits reads it)
    from a vehicle YAML, read by pattern so the script needs no YAML package."""
    text = open(path, encoding="utf-8").read()
    speed = float(re.search(r"drive_speed:\s*([0-9.eE+-]+)", text).group(1))
    positions = [(float(x), float(y)) for x, y in
                 re.findall(r"position:\s*\[\s*([0-9.eE+-]+)\s*,\s*([0-9.eE+-]+)\s*\]", text)]
    name = re.search(r"name:\s*(\S+)", text).group(1)
    steering = re.search(r"steering_angle:\s*\[\s*([0-9.eE+-]+)\s*,\s*([0-9.eE+-]+)\s*\]", text)
    steering_range = (float(steering.group(1)), float(steering.group(2))) if steering else None
    if steering_range is not None and steering_range[0] <= -math.pi and steering_range[1] >= math.pi:
        steering_range = None
    return name, speed, positions, steering_range


def end_stop_crossings(rows, positions, steering_range, tolerance=math.radians(0.5)):
    """The (module, time) of every stretch of rolling over which a module's direction of travel
    cannot stay within the steering range, even with the wheel reversed (a direction and its
    opposite are the same steering angle). Empty when the range is unlimited."""
    if steering_range is None:
        return []
    low, high = steering_range
    crossings = []
    for i, (px, py) in enumerate(positions):
        stretch = []  # unwrapped directions of travel while the module rolls
        for row in rows + [(rows[-1][0], 0, 0, 0, 0.0, 0.0, 0.0)]:
            vx, vy = row[4] - row[6] * py, row[5] + row[6] * px
            if math.hypot(vx, vy) > 1e-3:
                angle = math.atan2(vy, vx)
                if stretch:
                    angle = stretch[-1][1] + math.remainder(angle - stretch[-1][1], 2 * math.pi)
                stretch.append((row[0], angle))
                continue
            if stretch:
                lo = min(a for _, a in stretch)
                hi = max(a for _, a in stretch)
                # Some whole number of half turns k must put every direction within the range.
                k_min = math.ceil((hi - high - tolerance) / math.pi)
                k_max = math.floor((lo - low + tolerance) / math.pi)
                if k_min > k_max:
                    crossings.append((i, stretch[0][0]))
            stretch = []
    return crossings


def trapezoid(distance, cruise, acceleration):
    """(duration, speed at time tau) of a rest-to-rest move: a trapezoid, or a triangle when short."""
    ramp = cruise / acceleration
    if acceleration * ramp * ramp >= distance:  # never reaches cruise
        ramp = math.sqrt(distance / acceleration)
        cruise = acceleration * ramp
        flat = 0.0
    else:
        flat = (distance - acceleration * ramp * ramp) / cruise
    duration = 2 * ramp + flat

    def at(tau):
        if tau < ramp:
            return acceleration * tau, 0.5 * acceleration * tau * tau
        if tau < ramp + flat:
            return cruise, 0.5 * acceleration * ramp * ramp + cruise * (tau - ramp)
        rest = max(0.0, duration - tau)
        return acceleration * rest, distance - 0.5 * acceleration * rest * rest

    return duration, ramp, at


def smoothstep(s):
    s = min(max(s, 0.0), 1.0)
    return s * s * (3 - 2 * s)


class Mission:
    def __init__(self):
        self.t, self.x, self.y, self.psi = 0.0, 0.0, 0.0, 0.0
        self.rows = []      # t, x, y, psi, vx, vy, r (body frame)
        self.phases = []    # phase of each row
        self.last_direction = None
        self.emit(0.0, 0.0, 0.0, "stop")

    def emit(self, vx_world, vy_world, r, phase):
        c, s = math.cos(self.psi), math.sin(self.psi)
        vx = c * vx_world + s * vy_world
        vy = -s * vx_world + c * vy_world
        self.rows.append((self.t, self.x, self.y, self.psi, vx, vy, r))
        self.phases.append(phase)

    def dwell(self, seconds):
        for _ in range(int(round(seconds / DT))):
            self.t += DT
            self.emit(0.0, 0.0, 0.0, "stop")

    def move(self, direction_deg, distance, cruise, heading_change_deg=0.0):
        """Straight leg in the world direction, rest to rest; the heading turns by heading_change
        along it (a re-orientation under way). Phases: the ramp up is a start, or a re-steer when the
        direction of travel differs from the last leg's by more than 30 deg; the ramp down a stop."""
        direction = math.radians(direction_deg)
        change = math.radians(heading_change_deg)
        duration, ramp, at = trapezoid(distance, cruise, ACCELERATION)
        resteer = self.last_direction is not None and abs(
            math.remainder(direction - self.last_direction, 2 * math.pi)) > math.radians(30)
        x0, y0, psi0 = self.x, self.y, self.psi
        steps = int(math.ceil(duration / DT))
        for k in range(1, steps + 1):
            tau = min(k * DT, duration)
            speed, travelled = at(tau)
            share = travelled / distance
            self.t += DT
            self.x = x0 + travelled * math.cos(direction)
            self.y = y0 + travelled * math.sin(direction)
            self.psi = psi0 + change * smoothstep(share)
            # d psi / dt = change * smoothstep'(share) * speed / distance
            s = min(max(share, 0.0), 1.0)
            r = change * 6 * s * (1 - s) * speed / distance
            if change != 0.0 and abs(r) > 1e-3:
                phase = "turn"
            elif tau <= ramp:
                phase = "re-steer" if resteer else "start"
            elif tau >= duration - ramp:
                phase = "stop"
            else:
                phase = "cruise"
            self.emit(speed * math.cos(direction), speed * math.sin(direction), r, phase)
        self.last_direction = direction

    def rotate(self, angle_deg):
        """In-place turn with a smooth yaw profile peaking at YAW_RATE."""
        angle = math.radians(angle_deg)
        duration = 1.5 * abs(angle) / YAW_RATE  # smoothstep's peak rate is 1.5x its mean
        psi0 = self.psi
        steps = int(math.ceil(duration / DT))
        for k in range(1, steps + 1):
            s = min(k * DT / duration, 1.0)
            self.t += DT
            self.psi = psi0 + angle * smoothstep(s)
            self.emit(0.0, 0.0, angle * 6 * s * (1 - s) / duration, "turn")
        self.last_direction = None  # the modules are across the body now: the next leg re-steers


def mission(fast, end_stops_at_90=False):
    m = Mission()
    m.dwell(0.5)
    m.move(0, 8.0, fast)                        # 1: aisle run
    m.dwell(1.0)
    m.move(90, 2.0, SLOW)                       # 2: 90 deg crab into the bay (heading held)
    m.move(90, 0.3, CREEP)                      # 3: docking creep
    m.dwell(2.0)
    m.move(-90, 2.3, SLOW)                      # 4: reversing out
    m.dwell(0.5)
    m.rotate(135 if end_stops_at_90 else 90)    # 5: in-place turn (+-90 deg steering: to a 45 deg crab)
    m.dwell(0.5)
    m.move(180, 6.0, fast, heading_change_deg=90)  # 6: aisle run back, re-orienting under way
    if end_stops_at_90:
        m.dwell(0.5)
        m.rotate(-45)                           # 6b: in-place turn back to a 90 deg crab
    m.dwell(1.0)
    m.move(-90, 1.5, SLOW)                      # 7: crab into the opposite bay
    m.move(-90, 0.3, CREEP)                     # 8: docking creep
    m.dwell(2.0)
    m.move(90, 1.8, SLOW)                       # 9: reversing out
    m.dwell(0.5)
    m.rotate(-180)                              # 10: in-place turn back
    m.dwell(0.5)
    m.move(0, 4.0, fast)                        # 11: aisle run
    m.move(0, 0.2, CREEP)                       # 12: creep to the end mark
    m.dwell(1.0)
    return m


SCENARIO = """# Warehouse duty cycle for {name}: {legs} legs with stops (aisle runs, 90 deg crabs into bays,
# docking creeps, reversing out, in-place and moving re-orientations), written by
# scripts/warehouse_duty_cycle.py (regenerate with it; do not edit by hand). Phases per sample:
# {name}.phases.csv (scripts/duty_cycle_report.py).
scenario:
  name: duty_{name}
  description: warehouse duty cycle, {legs} legs, {length:.1f} m in {duration:.1f} s
  vehicle: ../../vehicles/{name}.yaml
  reference:
    type: csv
    file: {name}.csv
  initial_state:
    twist: [0.0, 0.0, 0.0]
    steering: 0.0
  simulator:
    seed: 1
  controllers:
    - {{name: wear_mpc, config: ../../controllers/default.yaml}}
    - {{name: kinematic_baseline, config: ../../controllers/kinematic_baseline.yaml}}
    - {{name: practical_baseline, config: ../../controllers/practical_baseline.yaml}}
"""


def self_test():
    """The end-stop check against hand-derived cases on a +-90 deg vehicle with modules at
    (+-1, +-0.5): the unlimited mission's run back crosses the stop on the left modules (y > 0),
    the limited one nowhere; a plain crab at 90 deg sits on the stop and does not cross it."""
    positions = [(1.0, 0.5), (1.0, -0.5), (-1.0, 0.5), (-1.0, -0.5)]
    steering_range = (-math.pi / 2, math.pi / 2)
    crossed = {module for module, _ in end_stop_crossings(mission(0.9).rows, positions, steering_range)}
    failures = []
    if crossed != {0, 2}:
        failures.append(f"the 90 deg crab turning under way: modules {sorted(crossed)} cross, expected [0, 2]")
    if end_stop_crossings(mission(0.9, end_stops_at_90=True).rows, positions, steering_range):
        failures.append("the mission for +-90 deg steering crosses an end stop")
    crab = Mission()
    crab.move(90, 2.0, SLOW)
    if end_stop_crossings(crab.rows, positions, steering_range):
        failures.append("a plain 90 deg crab is taken for a crossing")
    if end_stop_crossings(mission(0.9).rows, positions, None):
        failures.append("an unlimited range has a crossing")
    if failures:
        sys.exit("self-test failed: " + "; ".join(failures))
    print("self-test passed")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="configs/scenarios/duty")
    parser.add_argument("--vehicles", default="configs/vehicles")
    parser.add_argument("--check", action="store_true", help="compare with --out instead of writing")
    parser.add_argument("--self-test", action="store_true", help="check the end-stop check, write nothing")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return
    stale = []

    def write(path, text):
        if args.check:
            try:
                same = open(path, encoding="utf-8").read() == text
            except OSError:
                same = False
            if not same:
                stale.append(path)
            return
        with open(path, "w", encoding="utf-8") as out:
            out.write(text)

    if not args.check:
        os.makedirs(args.out, exist_ok=True)
    for file in sorted(os.listdir(args.vehicles)):
        if not file.endswith(".yaml"):
            continue
        name, drive_speed, positions, steering_range = vehicle_limits(os.path.join(args.vehicles, file))
        radius = max(math.hypot(x, y) for x, y in positions)
        # Aisle speed: 60 % of the drive speed, at most 1.2 m/s; the in-place turn's wheel speed
        # (YAW_RATE x radius) stays well inside the drive speed on every shipped vehicle.
        fast = round(min(1.2, 0.6 * drive_speed), 2)
        if YAW_RATE * radius > 0.8 * drive_speed:
            sys.exit(f"{file}: an in-place turn at {YAW_RATE} rad/s exceeds its drive speed")
        limited = steering_range is not None
        m = mission(fast, end_stops_at_90=limited)
        crossings = end_stop_crossings(m.rows, positions, steering_range)
        if crossings:
            module, t = crossings[0]
            sys.exit(f"{file}: module {module} would roll across a steering end stop from t = {t:.2f} s")
        length = sum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(m.rows, m.rows[1:]))
        write(os.path.join(args.out, f"{name}.csv"),
              "t,x,y,psi,vx,vy,r\n" + "".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in m.rows))
        write(os.path.join(args.out, f"{name}.phases.csv"),
              "t,phase\n" + "".join(f"{row[0]:.6f},{phase}\n" for row, phase in zip(m.rows, m.phases)))
        write(os.path.join(args.out, f"{name}.yaml"),
              SCENARIO.format(name=name, legs=13 if limited else 12, length=length, duration=m.rows[-1][0]))
        print(f"{name}: {len(m.rows)} samples, {length:.1f} m, {m.rows[-1][0]:.1f} s, aisle {fast} m/s")
    if stale:
        sys.exit("stale (regenerate with scripts/warehouse_duty_cycle.py): " + ", ".join(stale))


if __name__ == "__main__":
    main()
