#!/usr/bin/env bash
# Runs the layouts set (configs/scenarios/layouts/: a hard-start and a gentle reference on 2 + caster, 3-, 4-, 6- and
# 8-module vehicles) and prints each comparison table. Usage: scripts/run_layouts.sh [BUILD_DIR] [OUT_DIR]
set -euo pipefail
build_dir=${1:-build/release}
out_dir=${2:-out/layouts}
for scenario in configs/scenarios/layouts/*.yaml; do
  name=$(basename "$scenario" .yaml)
  "$build_dir/src/cli/swerve-mpc" run "$scenario" --out "$out_dir/$name" --quiet
  echo
done
