#!/usr/bin/python3
"""A lower bound of the tire wear a 2-module + 1-caster vehicle needs to follow a reference exactly.

Per reference sample: the body force and yaw moment the reference's motion needs (the CoM's
acceleration and the yaw acceleration, plus the caster's rolling resistance along its velocity; the
caster is self-aligning, so it carries no side force), split between the two modules to minimise
their frictional power. A linear tire slides at F / C times its speed, so its frictional power is
|F|^2 v / C; taking the stiffer of the longitudinal and cornering stiffnesses (C = B C D of the
Magic Formula at the static load, D = mu Fz) makes it a bound from below. Loads are static (three
contacts: statically determinate), no load transfer. The integral over the reference, split by the
phases file when one is given, is the wear no controller that tracks the reference can avoid; a
controller that departs from it within a tolerance can smooth its accelerations and do somewhat
better.

Usage: scripts/caster_wear_floor.py VEHICLE_YAML REFERENCE_CSV [PHASES_CSV]
Needs numpy and PyYAML (Debian: python3-numpy, python3-yaml).
"""
import bisect
import csv
import sys

import numpy as np
import yaml


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def main(vehicle_path, reference_path, phases_path=None):
    vehicle = yaml.safe_load(open(vehicle_path, encoding="utf-8"))["vehicle"]
    modules = [np.array(m["position"], dtype=float) for m in vehicle["modules"]]
    casters = vehicle.get("casters", [])
    if len(modules) != 2 or len(casters) != 1:
        sys.exit(f"{vehicle_path}: needs 2 modules and 1 caster (has {len(modules)} and {len(casters)})")
    caster = np.array(casters[0]["position"], dtype=float)
    rolling = float(casters[0]["rolling_resistance"])
    mass, inertia, g = float(vehicle["mass"]), float(vehicle["yaw_inertia"]), 9.81
    com = np.array(vehicle.get("center_of_mass", [0.0, 0.0]), dtype=float)
    # Static loads: the modules share the front load equally (symmetric about x), the caster the rest.
    x_modules = modules[0][0]
    load_module = mass * g * (com[0] - caster[0]) / (x_modules - caster[0]) / 2.0
    load_caster = mass * g - 2.0 * load_module
    tire = vehicle["tire"]
    stiffness = max(tire["longitudinal"]["B"] * tire["longitudinal"]["C"],
                    tire["lateral"]["B"] * tire["lateral"]["C"]) * tire["mu"] * load_module
    rows = [[float(v) for v in r] for r in list(csv.reader(open(reference_path, encoding="utf-8")))[1:]]
    phase_times, phase_names = [], []
    if phases_path:
        for r in list(csv.reader(open(phases_path, encoding="utf-8")))[1:]:
            phase_times.append(float(r[0]))
            phase_names.append(r[1])
    # Equations: F1 + F2 = m a_com - F_caster; sum (p_i - com) x F_i = I alpha - (caster - com) x F_caster.
    A = np.zeros((3, 4))
    for i, p in enumerate(modules):
        A[0, 2 * i] = A[1, 2 * i + 1] = 1.0
        A[2, 2 * i], A[2, 2 * i + 1] = -(p - com)[1], (p - com)[0]
    total, per_phase = 0.0, {}
    for k in range(1, len(rows) - 1):
        t, _, _, _, vx, vy, r = rows[k]
        dt = 0.5 * (rows[k + 1][0] - rows[k - 1][0])
        v = np.array([vx, vy])
        dv = (np.array(rows[k + 1][4:6]) - np.array(rows[k - 1][4:6])) / (2.0 * dt)
        alpha = (rows[k + 1][6] - rows[k - 1][6]) / (2.0 * dt)
        a_origin = dv + r * np.array([-v[1], v[0]])  # body frame: dv/dt + r x v
        a_com = a_origin + alpha * np.array([-com[1], com[0]]) - r * r * com
        v_caster = v + r * np.array([-caster[1], caster[0]])
        speed_caster = np.linalg.norm(v_caster)
        f_caster = -rolling * load_caster * v_caster / speed_caster if speed_caster > 1e-6 else np.zeros(2)
        b = np.array([mass * a_com[0] - f_caster[0], mass * a_com[1] - f_caster[1],
                      inertia * alpha - cross(caster - com, f_caster)])
        speeds = [np.linalg.norm(v + r * np.array([-p[1], p[0]])) for p in modules]
        weights_inverse = np.diag(np.repeat([stiffness / max(s, 1e-4) for s in speeds], 2))
        forces = weights_inverse @ A.T @ np.linalg.solve(A @ weights_inverse @ A.T, b)
        power = sum((forces[2 * i] ** 2 + forces[2 * i + 1] ** 2) * speeds[i] / stiffness for i in range(2))
        total += power * dt
        if phase_times:
            name = phase_names[max(0, bisect.bisect_right(phase_times, t + 1e-9) - 1)]
            per_phase[name] = per_phase.get(name, 0.0) + power * dt
    print(f"wear floor {total:.3f} J" + ("" if not per_phase else
          " (" + ", ".join(f"{name} {value:.3f}" for name, value in per_phase.items()) + ")"))


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(*sys.argv[1:])
