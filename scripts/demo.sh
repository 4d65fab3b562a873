#!/usr/bin/env bash
# `make demo`: runs what SwerveMPC can show today on the embedded default config, with real output.
set -euo pipefail
build_dir=${1:-build/release}
out_dir=${2:-out}
cli="$build_dir/src/cli/swerve-mpc"
mkdir -p "$out_dir"

"$cli" --version
echo
echo "== Embedded default target (configs/targets/default.yaml), as loaded and validated =="
"$cli" check-config configs/targets/default.yaml
