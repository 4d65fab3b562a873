#!/usr/bin/env bash
# Unpacks the arm64 (aarch64) builds of SwerveMPC's library dependencies into a private sysroot for
# `make cross-arm64`. Debian's arm64 -dev packages of yaml-cpp (and of Ceres and Ipopt) cannot be
# installed beside the host's amd64 ones, so they are downloaded and unpacked (dpkg -x), never
# installed: the host's packages stay as they are. Header-only dependencies (Eigen, ceres/jet.h,
# CLI11, nlohmann-json) come from the host. Idempotent: an existing sysroot is kept.
# Usage: arm64-sysroot.sh SYSROOT_DIR
set -euo pipefail
sysroot=${1:?usage: arm64-sysroot.sh SYSROOT_DIR}
stamp="$sysroot/.complete"
[ -f "$stamp" ] && exit 0

# Each library with its runtime package (the C and C++ runtimes come with the cross toolchain).
packages=(
  libyaml-cpp-dev libyaml-cpp0.7
  libnlopt-dev libnlopt0 libnlopt-cxx-dev libnlopt-cxx0
  libgtest-dev libgmock-dev
)

sudo_cmd=()
[ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "arm64-sysroot: adding the arm64 architecture to apt (package lists only; nothing arm64 is installed)"
  "${sudo_cmd[@]}" dpkg --add-architecture arm64
fi
if ! apt-cache show libyaml-cpp-dev:arm64 >/dev/null 2>&1; then
  "${sudo_cmd[@]}" apt-get update -qq
fi

debs="$sysroot.debs"
rm -rf "$sysroot" "$debs"
mkdir -p "$sysroot" "$debs"
(cd "$debs" && apt-get download -qq "${packages[@]/%/:arm64}")
for deb in "$debs"/*.deb; do
  dpkg -x "$deb" "$sysroot"
done
rm -rf "$debs"
touch "$stamp"
echo "arm64-sysroot: ${#packages[@]} packages unpacked into $sysroot"
