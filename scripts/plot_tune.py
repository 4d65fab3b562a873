#!/usr/bin/env python3
"""Plots a `swerve-mpc tune --scenarios ... --out DIR` result: quality against horizon, one line per
backend, SA knot count, prediction step and control period, for one or more targets (their budgets differ), written next to each tune.json.

Left: the geometric-mean wear ratio to the kinematic baseline over the scenarios each candidate ran
(finalists, which ran all of them, filled; round-1 candidates, which ran the first only, open).
Right: the worst position-RMSE ratio to the baseline over those scenarios. The chosen candidate is
ringed; a cross marks candidates outside the tracking bounds or with a deadline miss.

Usage: /usr/bin/python3 scripts/plot_tune.py out/tune_default [out/tune_raspberry_pi_4 ...]
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def plot(directory):
    path = os.path.join(directory, "tune.json")
    with open(path) as f:
        tune = json.load(f)
    figure, (wear_axis, rmse_axis) = plt.subplots(1, 2, figsize=(11, 4.2))
    # One line per setting other than the horizon: backend, SA knots, prediction step, control period
    # (older tune.json files carry neither of the last two).
    def setting(c):
        return (c["backend"], c["knots"], c.get("dt_s", 0.0), c.get("control_period_s", tune["control_period_s"]))

    def label(key):
        backend, knots, dt, period = key
        text = f"{backend}, {knots} knots" if backend == "sa" else backend
        if dt:
            text += f", dt {1e3 * dt:g} ms"
        return text + f", every {1e3 * period:g} ms"

    for key in sorted({setting(c) for c in tune["candidates"]}):
        rows = sorted((c for c in tune["candidates"] if setting(c) == key), key=lambda c: c["horizon"])
        horizons = [c["horizon"] for c in rows]
        wear = [c["geomean_wear_ratio"] for c in rows]
        worst_rmse = [max(s["rmse_m"] / s["baseline_rmse_m"] for s in c["scenarios"]) for c in rows]
        line, = wear_axis.plot(horizons, wear, "-", label=label(key))
        rmse_axis.plot(horizons, worst_rmse, "-", color=line.get_color())
        for c, w, r in zip(rows, wear, worst_rmse):
            face = line.get_color() if c["finalist"] else "none"
            for axis, value in ((wear_axis, w), (rmse_axis, r)):
                axis.plot(c["horizon"], value, "o", color=line.get_color(), markerfacecolor=face)
                if c["unacceptable"] > 0:
                    axis.plot(c["horizon"], value, "x", color="black", markersize=10)
    best = tune["best"]
    if best is not None and best >= 0:
        c = tune["candidates"][best]
        wear_axis.plot(c["horizon"], c["geomean_wear_ratio"], "o", markersize=16, markerfacecolor="none", color="red",
                       label="chosen")
    wear_axis.set_xlabel("horizon N (steps)")
    wear_axis.set_ylabel("wear / baseline's (geometric mean)")
    rmse_axis.set_xlabel("horizon N (steps)")
    rmse_axis.set_ylabel("worst position RMSE / baseline's")
    rmse_axis.axhline(1.1, color="gray", linestyle=":", linewidth=1)
    wear_axis.legend()
    figure.suptitle(f"tune: {tune['target']}, {1e3 * tune['solve_budget_s']:.0f} ms budget on the target "
                    f"({1e3 * tune['budget_here_s']:.1f} ms here) at its {1e3 * tune['control_period_s']:.0f} ms period")
    figure.tight_layout()
    out = os.path.join(directory, "tune.png")
    figure.savefig(out, dpi=110)
    print("written:", out)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for d in sys.argv[1:]:
        plot(d)
