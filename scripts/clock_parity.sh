#!/usr/bin/env bash
# Clock parity: every shipped scenario run twice with the same seed, once on the wall clock and once
# on a work clock (--work-clock: deadlines counted in solver reads and the prediction model's module
# evaluations, at the reference machine's rates by default), and one row each comparing the
# wear-aware controller's wear and position RMSE between the two. An anytime controller must do the
# same on both; a row passes within +-5 % (or 0.05 J / 1 mm where the figures are that small).
# `cut`: the wall-clock run's steps whose work-budgeted solve the wall clock cut short (the machine
# ran slower than the budget's rates; 0: its answers did not depend on the machine's speed).
# A measurement, not a test: run it on an otherwise idle machine (nothing building).
# Usage: scripts/clock_parity.sh [BUILD_DIR] [OUT_DIR] [WORK_CLOCK_TICK_S] [SCENARIO ...]
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build/release}
out_dir=${2:-out/clock_parity}
tick=${3:-8e-6}
shift $(( $# < 3 ? $# : 3 ))
scenarios=("$@")
if [ ${#scenarios[@]} -eq 0 ]; then
  scenarios=(configs/scenarios/*.yaml configs/scenarios/layouts/*.yaml)
fi
cli="$build_dir/src/cli/swerve-mpc"
[ -x "$cli" ] || { echo "clock_parity: $cli not built (make demo builds it)" >&2; exit 2; }
for scenario in "${scenarios[@]}"; do
  name=$(basename "$scenario" .yaml)
  "$cli" run "$scenario" --out "$out_dir/wall/$name" --quiet > /dev/null
  "$cli" run "$scenario" --out "$out_dir/work/$name" --quiet --work-clock "$tick" > /dev/null
done
python3 - "$out_dir" "${scenarios[@]}" <<'PY'
import json, os, sys
out = sys.argv[1]
names = [os.path.splitext(os.path.basename(s))[0] for s in sys.argv[2:]]
def within(a, b, rel, absolute):
    return abs(a - b) <= max(rel * max(abs(a), abs(b)), absolute)
print(f"{'scenario':<32}{'wear wall / work [J]':>24}{'RMSE wall / work [mm]':>26}"
      f"{'effort wall / work':>22}{'cut':>6}  parity")
passed = 0
for name in names:
    runs = {}
    for clock in ("wall", "work"):
        with open(os.path.join(out, clock, name, "summary.json")) as f:
            runs[clock] = json.load(f)["controllers"]["wear_mpc"]
    w, k = runs["wall"], runs["work"]
    wear_ok = within(w["wear_total"], k["wear_total"], 0.05, 0.05)
    rmse_ok = within(w["tracking_rmse_m"], k["tracking_rmse_m"], 0.05, 0.001)
    ok = wear_ok and rmse_ok
    passed += ok
    print(f"{name:<32}{w['wear_total']:>12.2f} / {k['wear_total']:<9.2f}"
          f"{1e3 * w['tracking_rmse_m']:>14.1f} / {1e3 * k['tracking_rmse_m']:<9.1f}"
          f"{w['steering_effort_rad2_s']:>11.2f} / {k['steering_effort_rad2_s']:<8.2f}"
          f"{w.get('work_budget_cuts', 0):>6}  "
          + ("ok" if ok else "differs: " + ", ".join(x for x, good in (("wear", wear_ok), ("rmse", rmse_ok)) if not good)))
print(f"Clock parity: {passed} of {len(names)} scenarios within +-5 % (or 0.05 J / 1 mm) of their work-clock run.")
PY
