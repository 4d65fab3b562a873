#!/usr/bin/env python3
"""Writes a lane-change reference CSV (t,x,y,psi,vx,vy,r) for the fault scenarios.

The vehicle keeps its heading (psi = 0) and moves sideways by `--width` over `--length` of travel,
on a quintic y(x) = w (10 u^3 - 15 u^4 + 6 u^5), u = (x - start) / length, whose slope and
curvature are zero at both ends. Along x it ramps up at `--acceleration` to `--speed`, cruises and
ramps down to a stop at `--total`.
Usage: scripts/lane_change_reference.py OUT.csv [--width 1.0] [--start 5] [--length 5] [--total 16]
"""
import argparse
import math


def lane(x, start, length, width):
    """y, dy/dx at x."""
    u = min(max((x - start) / length, 0.0), 1.0)
    y = width * (10 * u**3 - 15 * u**4 + 6 * u**5)
    slope = width * (30 * u**2 - 60 * u**3 + 30 * u**4) / length if 0.0 < u < 1.0 else 0.0
    return y, slope


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--width", type=float, default=1.0)
    parser.add_argument("--start", type=float, default=5.0)
    parser.add_argument("--length", type=float, default=5.0)
    parser.add_argument("--total", type=float, default=16.0)
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--acceleration", type=float, default=0.5)
    parser.add_argument("--step", type=float, default=0.05)
    a = parser.parse_args()
    ramp_time = a.speed / a.acceleration
    ramp_distance = 0.5 * a.speed * ramp_time
    cruise_time = (a.total - 2 * ramp_distance) / a.speed
    end = 2 * ramp_time + cruise_time
    rows = []
    steps = int(math.ceil(end / a.step))
    for k in range(steps + 1):
        t = min(k * a.step, end)
        if t < ramp_time:
            x, vx = 0.5 * a.acceleration * t * t, a.acceleration * t
        elif t < ramp_time + cruise_time:
            x, vx = ramp_distance + a.speed * (t - ramp_time), a.speed
        else:
            left = end - t
            x, vx = a.total - 0.5 * a.acceleration * left * left, a.acceleration * left
        y, slope = lane(x, a.start, a.length, a.width)
        rows.append((t, x, y, 0.0, vx, slope * vx, 0.0))
    with open(a.out, "w") as f:
        f.write("t,x,y,psi,vx,vy,r\n")
        for r in rows:
            f.write(",".join(f"{v:.6f}" for v in r) + "\n")


if __name__ == "__main__":
    main()
