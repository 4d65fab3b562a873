#!/usr/bin/env bash
# `make demo`: the paper's two experiments (curve tracking, 60 deg heading offset) on the embedded
# default controller config, each controller on the same simulated plant; prints both comparison
# tables, then the goal table of the whole shipped set (gentle references, figure-eight, layouts),
# and writes summary.json, per-step CSV logs and plots under the output directory.
set -euo pipefail
build_dir=${1:-build/release}
out_dir=${2:-out}
cli="$build_dir/src/cli/swerve-mpc"
mkdir -p "$out_dir"

"$cli" --version
echo "Embedded default target: configs/targets/default.yaml; controller: configs/controllers/default.yaml"
echo
for scenario in curve offset60; do
  echo "== $scenario (configs/scenarios/$scenario.yaml) =="
  "$cli" run "configs/scenarios/$scenario.yaml" --out "$out_dir/$scenario" --log csv,wpilog,mcap
  echo
done
# Runs each scenario quietly into $1/<name> (a layouts/ one as layouts_<name>) and appends its
# output directory to run_dirs.
run_quietly() {
  local out=$1
  shift
  for scenario in "$@"; do
    local name
    name=$(basename "$scenario" .yaml)
    case "$scenario" in */layouts/*) name="layouts_$name" ;; esac
    "$cli" run "$scenario" --out "$out/$name" --quiet > /dev/null
    run_dirs+=("$out/$name")
  done
}
# The whole shipped set (the goal table's goals): the planner-like variants of the paper pair, the
# figure-eight, the noisy crab, the straight line and the layouts set with both references, wear_mpc
# against kinematic_baseline and practical_baseline.
run_dirs=("$out_dir/curve" "$out_dir/offset60")
run_quietly "$out_dir/set" configs/scenarios/curve_smooth.yaml configs/scenarios/offset60_smooth.yaml \
  configs/scenarios/figure8.yaml configs/scenarios/crab90_noisy.yaml configs/scenarios/straight_line.yaml \
  configs/scenarios/layouts/*.yaml
echo "== the shipped set: wear_mpc against kinematic_baseline and practical_baseline (goals: scripts/goal_table.py) =="
python3 scripts/goal_table.py "${run_dirs[@]}"
echo
# The warehouse duty cycles (scripts/warehouse_duty_cycle.py wrote them), one per shipped vehicle:
# the three controllers, wear per km, completion time and the split by phase.
run_dirs=()
run_quietly "$out_dir/duty" configs/scenarios/duty/*.yaml
echo "== warehouse duty cycles: the three controllers, by phase (scripts/duty_cycle_report.py) =="
python3 scripts/duty_cycle_report.py "${run_dirs[@]}"
echo
# Debian's matplotlib lives with the system interpreter (a pyenv or venv python3 may lack it).
python=/usr/bin/python3
[ -x "$python" ] || python=python3
"$python" scripts/plot_scenario.py "$out_dir/curve" "$out_dir/offset60"
echo
echo "Summaries: $out_dir/curve/summary.json, $out_dir/offset60/summary.json (keys: docs/cli.md, 'summary.json')"
