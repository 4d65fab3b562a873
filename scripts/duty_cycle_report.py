#!/usr/bin/env python3
"""Per-phase report of warehouse duty-cycle runs (scenarios from scripts/warehouse_duty_cycle.py).

For each run directory (what `swerve-mpc run configs/scenarios/duty/<vehicle>.yaml -o DIR` wrote)
and each controller in it: wear per km, completion time (the reference's duration plus the time the
controller held it, summary.json's reference_delay_s), position RMSE, heading RMS and steering
effort over the whole mission, and wear, position RMSE and steering effort per phase (start,
cruise, turn, re-steer, stop; the phases the generator wrote beside the reference); then whether
wear_mpc meets the duty-cycle goals against practical_baseline (duty_goals).

Phases are taken at the run's time. A controller that held its reference (the practical
baseline's pre-alignment) is late by up to its delay, so its phase split is approximate by that
much; its totals are exact.

Usage: scripts/duty_cycle_report.py RUN_DIR [RUN_DIR ...] [--phases-dir configs/scenarios/duty]
       scripts/duty_cycle_report.py --self-test   (the goal verdicts on hand-made summaries; ctest runs it)
"""
import argparse
import bisect
import csv
import json
import math
import os
import sys

from goal_table import tracks_as_well

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


def self_test():
    """duty_goals on hand-made summaries: every goal met just inside its edge, then each missed alone."""
    def summary(**wear_mpc):
        practical = {"wear_total": 10.0, "tracking_rmse_m": 0.05, "heading_rmse_rad": math.radians(2.0),
                     "steering_effort_rad2_s": 100.0, "deadline_misses": 0, "reference_delay_s": 10.0}
        mpc = {"wear_total": 7.99, "tracking_rmse_m": 0.0699, "heading_rmse_rad": math.radians(2.49),
               "steering_effort_rad2_s": 149.9, "deadline_misses": 0, "reference_delay_s": 11.9}
        mpc.update(wear_mpc)
        return {"duration_s": 90.0, "controllers": {"wear_mpc": mpc, "practical_baseline": practical}}
    failures = []
    # Just inside every goal: 20.1 % less wear, RMSE +1.99 cm, heading +0.49 deg, completion
    # 101.9 / 100 s, effort 1.499x.
    if not duty_goals(summary()).endswith(": met"):
        failures.append("the edge case is not met: " + duty_goals(summary()))
    for key, value, goal in (("wear_total", 8.1, "wear"), ("tracking_rmse_m", 0.0701, "rmse"),
                             ("heading_rmse_rad", math.radians(2.51), "heading"), ("reference_delay_s", 12.1, "completion"),
                             ("steering_effort_rad2_s", 150.1, "effort"), ("deadline_misses", 1, "misses")):
        verdict = duty_goals(summary(**{key: value}))
        if not verdict.endswith("missed: " + goal):
            failures.append(f"{key} = {value} should miss {goal} alone: {verdict}")
    if duty_goals({"duration_s": 1.0, "controllers": {"wear_mpc": {}}}) != "":
        failures.append("a run without practical_baseline is judged")
    if failures:
        sys.exit("self-test failed: " + "; ".join(failures))
    print("self-test passed")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="*")
    parser.add_argument("--phases-dir", default="configs/scenarios/duty")
    parser.add_argument("--self-test", action="store_true", help="check the goal verdicts, read no run")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return
    if not args.runs:
        parser.error("give at least one run directory")
    met = judged = 0
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
        verdict = duty_goals(summary)
        if verdict:
            print(verdict)
            met += verdict.endswith(": met")
            judged += 1
        print()
    if judged:
        print(f"Duty-cycle goals against practical_baseline met on {met} of {judged} vehicles.")


def duty_goals(summary):
    """The duty-cycle goals for wear_mpc against practical_baseline: at least 20 % less wear
    (per km: the same mission, so the totals' ratio), position RMSE <= max(1.1x, +2 cm), heading RMS
    <= max(1.1x, +0.5 deg), completion time <= 1.02x, steering effort <= 1.5x, no deadline miss."""
    runs = summary["controllers"]
    if "wear_mpc" not in runs or "practical_baseline" not in runs:
        return ""
    w, p = runs["wear_mpc"], runs["practical_baseline"]
    duration = summary["duration_s"]
    completion = (duration + w.get("reference_delay_s", 0.0)) / (duration + p.get("reference_delay_s", 0.0))
    saving = 1.0 - w["wear_total"] / p["wear_total"] if p["wear_total"] > 0 else float("nan")
    checks = {
        "wear": saving >= 0.20,
        **tracks_as_well(w, p),
        "completion": completion <= 1.02,
        "effort": w["steering_effort_rad2_s"] <= 1.5 * p["steering_effort_rad2_s"],
        "misses": w["deadline_misses"] == 0,
    }
    failed = [name for name, ok in checks.items() if not ok]
    return (f"wear_mpc against practical_baseline: wear {-100.0 * saving:+.1f} % (goal <= -20 %), "
            f"completion x{completion:.3f}, effort x{w['steering_effort_rad2_s'] / p['steering_effort_rad2_s']:.2f}, "
            f"misses {w['deadline_misses']}: " + ("met" if not failed else "missed: " + ", ".join(failed)))


if __name__ == "__main__":
    main()
