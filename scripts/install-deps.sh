#!/usr/bin/env bash
# Installs the Debian packages SwerveMPC needs, and only those that are missing. Quiet and
# idempotent when everything is present; runs `apt-get update` only when it has to install.
# Usage: install-deps.sh [fuzz] [cross-arm64]   (fuzz: also clang and its libFuzzer runtime, for
# `make fuzz` only; cross-arm64: the aarch64 cross toolchain and qemu-user, for `make cross-arm64`)
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libeigen3-dev
  coinor-libipopt-dev
  libnlopt-cxx-dev
  libceres-dev
  libyaml-cpp-dev
  libgtest-dev libgmock-dev
  libbenchmark-dev
  libcli11-dev
  nlohmann-json3-dev
  python3-matplotlib
  pybind11-dev python3-dev python3-numpy
)

# Optional lists, named on the command line.
fuzz_packages=(clang libclang-rt-dev)
# `make cross-arm64`: the aarch64 cross compiler and the user-mode emulator (the arm64 libraries
# are unpacked into a sysroot by scripts/arm64-sysroot.sh, not installed).
cross_arm64_packages=(g++-aarch64-linux-gnu qemu-user)
for list in "$@"; do
  case "$list" in
    fuzz) packages+=("${fuzz_packages[@]}") ;;
    cross-arm64) packages+=("${cross_arm64_packages[@]}") ;;
    *) echo "install-deps: unknown package list '$list' (known: fuzz, cross-arm64)" >&2; exit 2 ;;
  esac
done

# The independent log readers the tests use (tests/node/package.json), from the npm registry, when
# Node.js is on the machine and they are not installed yet.
install_node_readers() {
  local dir
  dir="$(cd "$(dirname "$0")/.." && pwd)/tests/node"
  if command -v npm >/dev/null && [ ! -d "$dir/node_modules/@mcap/core" ]; then
    echo "install-deps: npm install in tests/node"
    # Without the registry the rest still installs; ctest then skips the MCAP reader's check.
    npm ci --prefix "$dir" --no-audit --no-fund --silent ||
      echo "install-deps: npm ci in tests/node failed: the MCAP log check will not run" >&2
  fi
}
install_node_readers

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
