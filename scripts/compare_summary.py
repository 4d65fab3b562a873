#!/usr/bin/env python3
"""Compares a run's summary.json with a reference summary, metric by metric, within a relative
tolerance: the same scenario gives the same results on another architecture (make cross-arm64)
or after a change that should not alter them. Only deterministic fields are compared (tracking,
wear, effort, fallbacks), never timings.

Usage: compare_summary.py SUMMARY.json REFERENCE.json [--rtol 1e-6]   exit 0 when they agree
       compare_summary.py SUMMARY.json REFERENCE.json --write         (re)writes the reference
"""
import argparse
import json
import math
import sys

FIELDS = ["steps", "tracking_rmse_m", "tracking_max_m", "heading_rmse_rad", "heading_max_rad", "wear_total",
          "frictional_energy_J", "steering_effort_rad2_s", "fallbacks"]


def deterministic_part(summary):
    return {name: {f: run[f] for f in FIELDS if f in run} for name, run in summary["controllers"].items()}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("summary")
    parser.add_argument("reference")
    parser.add_argument("--rtol", type=float, default=1e-6)
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    with open(args.summary) as f:
        got = deterministic_part(json.load(f))
    if args.write:
        with open(args.reference, "w") as f:
            json.dump({"controllers": got}, f, indent=2)
            f.write("\n")
        print(f"written: {args.reference}")
        return 0
    with open(args.reference) as f:
        want = json.load(f)["controllers"]
    problems = []
    for name, fields in want.items():
        if name not in got:
            problems.append(f"{name}: missing from the summary")
            continue
        for field, expected in fields.items():
            actual = got[name].get(field)
            if actual is None or not math.isclose(actual, expected, rel_tol=args.rtol, abs_tol=1e-12):
                problems.append(f"{name}.{field} = {actual}, reference {expected} (rtol {args.rtol:g})")
    for p in problems:
        print(p, file=sys.stderr)
    if not problems:
        print(f"{len(want)} controller(s) agree with {args.reference} within rtol {args.rtol:g}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
