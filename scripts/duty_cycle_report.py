#!/usr/bin/env python3
"""Per-phase report of warehouse duty-cycle runs (scenarios from scripts/warehouse_duty_cycle.py).

For each run directory (what `swerve-mpc run configs/scenarios/duty/<vehicle>.yaml -o DIR` wrote)
and each controller in it: wear per km, completion time (the reference's duration plus the time the
controller held it, summary.json's reference_delay_s), position RMSE, heading RMS and steering
effort over the whole mission, and wear, position RMSE and steering effort per phase (start,
cruise, turn, re-steer, stop; the phases the generator wrote beside the reference).

Phases are taken at the run's time. A controller that held its reference (the practical
baseline's pre-alignment) is late by up to its delay, so its phase split is approximate by that
much; its totals are exact.

Usage: scripts/duty_cycle_report.py RUN_DIR [RUN_DIR ...] [--phases-dir configs/scenarios/duty]
"""
import argparse
import bisect
import csv
import json
import math
import os

PHASES = ("start", "cruise", "turn", "re-steer", "stop")


def read_phases(path):
    times, phases = [], []
    with open(path, encoding="utf-8") as f:
        for row in csv.DictReader(f):
            times.append(float(row["t"]))
            phases.append(row["phase"])
    return times, phases


def phase_at(times, phases, t):
    i = bisect.bisect_right(times, t + 1e-9) - 1
    return phases[max(0, min(i, len(phases) - 1))]


def controller_rows(log_path, times, phases, period):
    with open(log_path, encoding="utf-8") as f:
        reader = csv.DictReader(f)
        wear_columns = [c for c in reader.fieldnames if c.startswith("wear_") and not c.startswith("wear_rate")]
        rate_columns = [c for c in reader.fieldnames if c.startswith("cmd_steering_rate_")]
        per = {p: {"wear": 0.0, "sq": 0.0, "n": 0, "effort": 0.0, "km": 0.0} for p in PHASES}
        previous_wear, previous_ref = None, None
        for row in reader:
            t = float(row["t"])
            phase = phase_at(times, phases, t)
            wear = sum(float(row[c]) for c in wear_columns)
            ref = (float(row["x_ref"]), float(row["y_ref"]))
            bucket = per[phase]
            if previous_wear is not None:
                bucket["wear"] += wear - previous_wear
                bucket["km"] += math.hypot(ref[0] - previous_ref[0], ref[1] - previous_ref[1]) / 1000.0
            previous_wear, previous_ref = wear, ref
            bucket["sq"] += float(row["position_error_m"]) ** 2
            bucket["n"] += 1
            bucket["effort"] += sum(float(row[c]) ** 2 for c in rate_columns) * period
    return per


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--phases-dir", default="configs/scenarios/duty")
    args = parser.parse_args()
    for run in args.runs:
        summary = json.load(open(os.path.join(run, "summary.json"), encoding="utf-8"))
        vehicle = summary["vehicle"]
        times, phases = read_phases(os.path.join(args.phases_dir, f"{vehicle}.phases.csv"))
        period = summary["control_period_s"]
        print(f"== {summary['scenario']} ({vehicle}): {summary['reference']}")
        print(f"{'controller':20s} {'J/km':>8s} {'time [s]':>9s} {'RMSE [mm]':>10s} {'psi [deg]':>10s} {'effort':>8s}"
              + "".join(f" {p + ' J':>11s}" for p in PHASES))
        phase_tables = {}
        for name, c in summary["controllers"].items():
            per = controller_rows(os.path.join(run, c["log_csv"]), times, phases, period)
            phase_tables[name] = per
            km = sum(b["km"] for b in per.values())
            print(f"{name:20s} {c['wear_total'] / km if km > 0 else float('nan'):8.1f} "
                  f"{summary['duration_s'] + c.get('reference_delay_s', 0.0):9.2f} {1e3 * c['tracking_rmse_m']:10.1f} "
                  f"{math.degrees(c['heading_rmse_rad']):10.3f} {c['steering_effort_rad2_s']:8.2f}"
                  + "".join(f" {per[p]['wear']:11.3f}" for p in PHASES))
        print(f"{'per phase':20s} " + "  ".join(
            f"{p}: RMSE [mm] / effort " + ", ".join(
                f"{n} {1e3 * math.sqrt(t[p]['sq'] / t[p]['n']) if t[p]['n'] else 0:.1f} / {t[p]['effort']:.2f}"
                for n, t in phase_tables.items()) for p in PHASES))
        print()


if __name__ == "__main__":
    main()
