#!/usr/bin/env python3
# Plots one or more scenario runs (summary.json + per-controller CSV logs, optional sweep.json) into PNGs
# next to the data: path, tracking error, wear, slip angles, solve time, where the floor's grip changes the
# grip the controllers' predictions used, and with a sweep the Pareto front.
# Usage: python3 scripts/plot_scenario.py RUN_DIR [RUN_DIR ...]   (needs python3-matplotlib)
import csv, json, math, os, re, sys

try:
    import matplotlib
except ImportError:  # e.g. a pyenv python3 on PATH: fall back to the Debian interpreter that has it
    deb = "/usr/bin/python3"
    if os.path.exists(deb) and os.path.realpath(sys.executable) != os.path.realpath(deb):
        os.execv(deb, [deb] + sys.argv)
    sys.exit("plot_scenario: matplotlib not found for %s (install python3-matplotlib)" % sys.executable)
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

DPI, FOOTPRINT_EVERY_S, PAD_M = 110, 5.0, 0.3


class RunError(Exception):
    pass


def load_csv(path):
    """Columns by header name -> numpy float arrays (NaN where not numeric); 'source' kept as strings."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if len(rows) < 2:
        raise RunError("%s has no data rows" % path)
    header = [h.strip() for h in rows[0]]
    cols = {}
    for j, name in enumerate(header):
        vals = [r[j].strip() if j < len(r) else "" for r in rows[1:]]
        if name == "source":
            cols[name] = vals
            continue
        out = np.full(len(vals), np.nan)
        for k, v in enumerate(vals):
            try:
                out[k] = float(v)
            except ValueError:
                pass
        cols[name] = out
    return cols


def module_ids(cols, prefix):
    ids = sorted(int(m.group(1)) for m in (re.fullmatch(prefix + r"_(\d+)", c) for c in cols) if m)
    return ids


def footprint(summary):
    fp = summary.get("footprint_m")
    if fp and len(fp) >= 3:
        pts = np.asarray(fp, float)
    else:  # bounding box of the module positions, padded
        mp = np.asarray(summary.get("module_positions_m") or [[0.0, 0.0]], float)
        lo, hi = mp.min(axis=0) - PAD_M, mp.max(axis=0) + PAD_M
        pts = np.array([[hi[0], hi[1]], [lo[0], hi[1]], [lo[0], lo[1]], [hi[0], lo[1]]])
    return np.vstack([pts, pts[:1]]) if not np.allclose(pts[0], pts[-1]) else pts


def load_run(run_dir):
    if not os.path.isdir(run_dir):
        raise RunError("%s is not a directory" % run_dir)
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            summary = json.load(f)
        ctrl_info = summary["controllers"]
        if not isinstance(ctrl_info, dict) or not ctrl_info:
            raise RunError("%s/summary.json lists no controllers" % run_dir)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise RunError("%s/summary.json unusable: %s" % (run_dir, e))
    logs = {}
    for name, info in ctrl_info.items():
        path = os.path.join(run_dir, info.get("log_csv") or name + ".csv")
        try:
            cols = load_csv(path)
            if "t" not in cols:
                raise RunError("%s has no 't' column" % path)
            logs[name] = cols
        except (OSError, RunError) as e:
            print("plot_scenario: skipping controller %s: %s" % (name, e), file=sys.stderr)
    if not logs:
        raise RunError("%s: no readable controller logs" % run_dir)
    sweep = None
    sp = os.path.join(run_dir, "sweep.json")
    if os.path.exists(sp):
        try:
            with open(sp) as f:
                sweep = json.load(f)
        except (OSError, ValueError) as e:
            print("plot_scenario: ignoring %s: %s" % (sp, e), file=sys.stderr)
    return summary, logs, sweep


def save(fig, run_dir, name):
    path = os.path.join(run_dir, name)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    print(path)


def plot_path(run_dir, title, summary, logs):
    fig, ax = plt.subplots(figsize=(9, 7))
    fp = footprint(summary)
    ref = next(iter(logs.values()))
    if "x_ref" in ref and "y_ref" in ref:
        ax.plot(ref["x_ref"], ref["y_ref"], "k--", lw=1.2, label="reference")
    for k, (name, c) in enumerate(logs.items()):
        col = "C%d" % k
        ax.plot(c["x"], c["y"], color=col, lw=1.6, label=name)
        t = c["t"]
        slot = np.floor((t - np.nanmin(t)) / FOOTPRINT_EVERY_S)
        for i in np.flatnonzero(np.r_[True, np.diff(slot) > 0]):
            if not np.isfinite(c["psi"][i] + c["x"][i] + c["y"][i]):
                continue
            cs, sn = math.cos(c["psi"][i]), math.sin(c["psi"][i])
            ax.plot(c["x"][i] + cs * fp[:, 0] - sn * fp[:, 1], c["y"][i] + sn * fp[:, 0] + cs * fp[:, 1],
                    color=col, lw=0.7, alpha=0.8)
    ax.set(xlabel="x [m]", ylabel="y [m]", title="%s: path (footprint every %g s)" % (title, FOOTPRINT_EVERY_S))
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    save(fig, run_dir, "path.png")


def plot_tracking(run_dir, title, logs):
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    for k, (name, c) in enumerate(logs.items()):
        if "position_error_m" in c:
            a1.plot(c["t"], c["position_error_m"], color="C%d" % k, label=name)
        if "heading_error_rad" in c:
            a2.plot(c["t"], np.degrees(c["heading_error_rad"]), color="C%d" % k, label=name)
    a1.set(ylabel="position error [m]", title="%s: tracking error" % title)
    a2.set(xlabel="t [s]", ylabel="heading error [deg]")
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(loc="best")
    fig.tight_layout()
    save(fig, run_dir, "tracking_error.png")


def plot_friction(run_dir, title, logs):
    """Where the floor's grip changes: the grip each controller's prediction used against the floor's,
    and its one-period prediction error of position and wear (1 s means)."""
    if not any("friction_scale" in c and np.nanmax(np.abs(c["friction_scale"] - 1.0)) > 1e-9 for c in logs.values()):
        return
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(9, 8.5), sharex=True)
    first = next(c for c in logs.values() if "friction_scale" in c)
    a1.plot(first["t"], first["friction_scale"], "k--", lw=1.4, label="floor (mean under the vehicle)")
    a1.fill_between(first["t"], 0.9 * first["friction_scale"], 1.1 * first["friction_scale"], color="0.85",
                    label="within 10 %")
    for k, (name, c) in enumerate(logs.items()):
        if "prediction_position_error_m" not in c or np.all(np.isnan(c["prediction_position_error_m"])):
            continue
        col = "C%d" % k
        a1.plot(c["t"], c["friction_scale_used"], color=col, label=name)
        dt = np.nanmedian(np.diff(c["t"]))
        window = max(1, int(round(1.0 / dt)))
        kernel = np.ones(window) / window
        a2.plot(c["t"], np.convolve(c["prediction_position_error_m"] * 1e6, kernel, "same"), color=col, label=name)
        a3.plot(c["t"], np.convolve(np.abs(c["prediction_wear_error"]) * 1e3, kernel, "same"), color=col, label=name)
    a1.set(ylabel="grip / tire mu", title="%s: the grip the prediction used" % title)
    a2.set(ylabel="position error [um]\n(one period, 1 s mean)")
    a3.set(xlabel="t [s]", ylabel="|wear error| [mJ]\n(one period, 1 s mean)")
    for a in (a1, a2, a3):
        a.grid(alpha=0.3)
        a.legend(loc="best", fontsize=8)
    fig.tight_layout()
    save(fig, run_dir, "friction.png")


def plot_wear(run_dir, title, summary, logs):
    ctrls = summary["controllers"]
    units = next((ctrls[n].get("wear_units") for n in logs if ctrls[n].get("wear_units")), "wear units")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5))
    finals = {}
    for k, (name, c) in enumerate(logs.items()):
        ids = module_ids(c, "wear")
        if ids:
            w = np.vstack([c["wear_%d" % i] for i in ids])
            a1.plot(c["t"], np.nansum(w, axis=0), color="C%d" % k, label=name)
        per = ctrls[name].get("wear_per_module")
        finals[name] = list(per) if per else [float(c["wear_%d" % i][-1]) for i in ids]
    n_mod = max((len(v) for v in finals.values()), default=0)
    width = 0.8 / max(len(finals), 1)
    # Tires worn before the run (initial_module_wear): each bar stands on that wear, drawn grey.
    initial = summary.get("initial_module_wear") or []
    for k, (name, v) in enumerate(finals.items()):
        x = np.arange(len(v)) + (k - (len(finals) - 1) / 2) * width
        if len(initial) == len(v):
            a2.bar(x, initial, width, color="lightgrey", label="before the run" if k == 0 else None)
        a2.bar(x, v, width, bottom=initial if len(initial) == len(v) else None, color="C%d" % k, label=name)
    a1.set(xlabel="t [s]", ylabel="cumulative total wear [%s]" % units, title="%s: total wear" % title)
    a2.set(xlabel="module", ylabel="wear at the end [%s]" % units, title="%s: wear per module" % title,
           xticks=range(n_mod))
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(loc="best")
    fig.tight_layout()
    save(fig, run_dir, "wear.png")


def plot_slip(run_dir, title, logs):
    fig, axes = plt.subplots(len(logs), 1, figsize=(9, 2.8 * len(logs) + 0.6), sharex=True, squeeze=False)
    for ax, (name, c) in zip(axes[:, 0], logs.items()):
        for i in module_ids(c, "slip_angle"):
            ax.plot(c["t"], np.degrees(c["slip_angle_%d" % i]), lw=1, label="module %d" % i)
        ax.set(ylabel="slip angle [deg]", title="%s: %s" % (title, name))
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8, ncol=4)
    axes[-1, 0].set_xlabel("t [s]")
    fig.tight_layout()
    save(fig, run_dir, "slip_angles.png")


def plot_solve_time(run_dir, title, summary, logs):
    data = {n: c["solve_time_ms"][np.isfinite(c["solve_time_ms"])] for n, c in logs.items() if "solve_time_ms" in c}
    data = {n: v for n, v in data.items() if v.size}
    if not data:
        print("plot_scenario: %s: no solve times, solve_time.png skipped" % run_dir, file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(9, 5))
    allv = np.concatenate(list(data.values()))
    bins = np.linspace(allv.min(), allv.max() if allv.max() > allv.min() else allv.min() + 1.0, 50)
    for name, v in data.items():
        col = "C%d" % list(logs).index(name)
        p99 = summary["controllers"][name].get("solve_time_p99_ms", float(np.percentile(v, 99)))
        ax.hist(v, bins=bins, histtype="step", lw=1.5, color=col, label=name)
        ax.axvline(p99, color=col, ls="--", lw=1, label="%s p99 = %.3g ms" % (name, p99))
    ax.set(xlabel="solve time [ms]", ylabel="steps", title="%s: solve time" % title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    save(fig, run_dir, "solve_time.png")


def plot_pareto(run_dir, title, summary, sweep):
    by_tolerance = sweep.get("swept") == "tracking_tolerance"
    key = "tolerance_position_m" if by_tolerance else "wear_weight"
    pts = sorted(sweep.get("points") or [], key=lambda p: p[key])
    fig, ax = plt.subplots(figsize=(8, 6))
    if pts:
        x, y = [p["tracking_rmse_m"] for p in pts], [p["wear_total"] for p in pts]
        ax.plot(x, y, "o-", color="C0", label="wear MPC, tolerance sweep" if by_tolerance else "wear MPC, lambda sweep")
        for p in pts:
            label = ("tol=%g m" % p[key]) if by_tolerance else ("w=%g" % p[key])
            ax.annotate(label, (p["tracking_rmse_m"], p["wear_total"]),
                        textcoords="offset points", xytext=(5, 5), fontsize=8)
    b = sweep.get("baseline")
    if b:
        ax.plot(b["tracking_rmse_m"], b["wear_total"], "X", ms=12, color="C3", label="baseline")
    units = next((c.get("wear_units") for c in summary["controllers"].values() if c.get("wear_units")), "wear units")
    ax.set(xlabel="tracking RMSE [m]", ylabel="total wear [%s]" % units, title="%s: tracking vs wear" % title)
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    save(fig, run_dir, "pareto.png")


def main(argv):
    if not argv:
        print("usage: plot_scenario.py RUN_DIR [RUN_DIR ...]", file=sys.stderr)
        return 1
    status = 0
    for run_dir in argv:
        try:
            summary, logs, sweep = load_run(run_dir)
            title = str(summary.get("scenario", os.path.basename(os.path.normpath(run_dir))))
            if summary.get("vehicle"):
                title += " (%s)" % summary["vehicle"]
            plot_path(run_dir, title, summary, logs)
            plot_tracking(run_dir, title, logs)
            plot_wear(run_dir, title, summary, logs)
            plot_slip(run_dir, title, logs)
            plot_solve_time(run_dir, title, summary, logs)
            plot_friction(run_dir, title, logs)
            if sweep:
                plot_pareto(run_dir, title, summary, sweep)
        except (RunError, KeyError, TypeError, ValueError, OSError) as e:
            msg = (str(e) if isinstance(e, RunError) else "%s: missing column/field %s" % (run_dir, e)
                   if isinstance(e, KeyError) else "%s: %s" % (run_dir, repr(e)))
            print("plot_scenario: " + msg, file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
