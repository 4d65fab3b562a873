#!/usr/bin/env python3
"""The goal table: one row per scenario run (a directory holding summary.json), wear_mpc against
kinematic_baseline, and a one-line verdict for the whole set; then the same rows against
practical_baseline where the runs have it.

Usage: scripts/goal_table.py OUT_DIR [OUT_DIR ...]   (each OUT_DIR written by `swerve-mpc run`)

A row meets the goals when wear <= the baseline's, position RMSE <= max(1.1 x, + 0.02 m),
heading RMSE <= max(1.1 x, + 0.5 deg) and steering effort <= max(1.5 x, + 0.5 rad^2/s) of the
baseline's, with zero deadline misses. Against the kinematic baseline the set also asks for a
geometric-mean wear ratio <= 0.6; against the practical baseline every row is asked to be no
worse (Pareto), and the table says how late the practical baseline was (it holds its reference
while its modules pre-align).
"""
import json
import math
import os
import sys

WEAR, BASE, PRACTICAL = "wear_mpc", "kinematic_baseline", "practical_baseline"


def tracks_as_well(w, b):
    """Whether run `w` tracks no worse than run `b` (summary.json controller entries): position RMSE
    <= max(1.1 x, + 0.02 m) and heading RMSE <= max(1.1 x, + 0.5 deg), as {"rmse": .., "heading": ..}."""
    return {
        "rmse": w["tracking_rmse_m"] <= max(1.1 * b["tracking_rmse_m"], b["tracking_rmse_m"] + 0.02),
        "heading": w["heading_rmse_rad"] <= max(1.1 * b["heading_rmse_rad"], b["heading_rmse_rad"] + math.radians(0.5)),
    }


def row(out_dir, base):
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    runs = summary["controllers"]
    if WEAR not in runs or base not in runs:
        return None
    w, b = runs[WEAR], runs[base]
    deg = 180.0 / math.pi
    wear_ratio = w["wear_total"] / b["wear_total"] if b["wear_total"] > 0 else float("inf")
    rmse_ratio = w["tracking_rmse_m"] / b["tracking_rmse_m"] if b["tracking_rmse_m"] > 0 else float("inf")
    checks = {
        "wear": w["wear_total"] <= b["wear_total"],
        **tracks_as_well(w, b),
        "smoothness": w["steering_effort_rad2_s"] <= max(1.5 * b["steering_effort_rad2_s"],
                                                         b["steering_effort_rad2_s"] + 0.5),
        "misses": w["deadline_misses"] == 0,
    }
    return {
        "scenario": summary["scenario"],
        "wear_ratio": wear_ratio,
        "rmse_ratio": rmse_ratio,
        "rmse_mm": (1e3 * w["tracking_rmse_m"], 1e3 * b["tracking_rmse_m"]),
        "heading_deg": (deg * w["heading_rmse_rad"], deg * b["heading_rmse_rad"]),
        "effort": (w["steering_effort_rad2_s"], b["steering_effort_rad2_s"]),
        "misses": w["deadline_misses"],
        "late_s": b.get("reference_delay_s", 0.0),
        "failed": [name for name, ok in checks.items() if not ok],
    }


def table(rows, late):
    print(f"{'scenario':<34}{'wear ratio':>11}{'RMSE ratio':>11}{'RMSE mpc/base [mm]':>20}"
          f"{'heading RMS mpc/base [deg]':>28}{'steering effort mpc/base':>26}{'misses':>8}"
          + (f"{'base late [s]':>14}" if late else "") + "  goals")
    for r in rows:
        verdict = "met" if not r["failed"] else "missed: " + ", ".join(r["failed"])
        print(f"{r['scenario']:<34}{r['wear_ratio']:>11.3f}{r['rmse_ratio']:>11.2f}"
              f"{r['rmse_mm'][0]:>11.1f} / {r['rmse_mm'][1]:<6.1f}"
              f"{r['heading_deg'][0]:>16.3f} / {r['heading_deg'][1]:<9.3f}"
              f"{r['effort'][0]:>14.2f} / {r['effort'][1]:<9.2f}{r['misses']:>8}"
              + (f"{r['late_s']:>14.2f}" if late else "") + f"  {verdict}")
    ratios = [r["wear_ratio"] for r in rows if r["wear_ratio"] > 0 and math.isfinite(r["wear_ratio"])]
    geomean = math.exp(sum(math.log(x) for x in ratios) / len(ratios)) if ratios else float("nan")
    return sum(1 for r in rows if not r["failed"]), geomean


def main(dirs):
    rows = [r for r in (row(d, BASE) for d in dirs) if r is not None]
    if not rows:
        print("no run with both wear_mpc and kinematic_baseline")
        return 1
    met, geomean = table(rows, late=False)
    print(f"Verdict: {met} of {len(rows)} scenarios meet every goal; geometric-mean wear ratio {geomean:.3f} "
          f"({'meets' if geomean <= 0.6 else 'misses'} the <= 0.6 goal).")
    practical = [r for r in (row(d, PRACTICAL) for d in dirs) if r is not None]
    if practical:
        print()
        print("Against practical_baseline (configs/controllers/practical_baseline.yaml):")
        met, geomean = table(practical, late=True)
        print(f"Verdict: wear_mpc is no worse than practical_baseline on {met} of {len(practical)} scenarios; "
              f"geometric-mean wear ratio {geomean:.3f}.")
    return 0


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(sys.argv[1:]))
