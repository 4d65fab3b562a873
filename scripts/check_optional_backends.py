#!/usr/bin/env python3
"""Checks that the optional backends (Ipopt, Ceres) stay optional: no object file of the build
outside a backend's own code needs a symbol that only the backend's library defines.

A build without Ipopt or Ceres (the arm64 cross build: Debian's arm64 packages of both cannot be
installed beside the x86-64 ones) fails to link when, say, the YAML loader calls
IpoptOptions::validate() and that is defined in solvers/ipopt/ipopt_solver.cpp. The x86-64 build
has every backend and links fine, so only `make cross-arm64` showed it (2026-12-03). This check
finds the same mistake in the full build, from `nm`, in a few seconds:

- a backend's symbols: the strong definitions (nm types T, D, B, R) in its library
  (solvers/<name>/libswerve_solver_<name>.a); weak ones (inline functions, templates) are defined
  wherever they are used and are no dependency;
- the objects allowed to use them: the backend's own (solvers/<name>/), the factory
  (solver_factory.cpp, the one place that names a backend under SWERVE_HAS_<NAME>) and the
  backend's test file (<name>_solver_test.cpp, compiled only where the backend is built);
- every other object file in the build tree must not have any of them undefined.

Usage: scripts/check_optional_backends.py BUILD_DIR [--nm NM]   (exit 1 on a violation)
       scripts/check_optional_backends.py --self-test            (the checker catches a planted one)
"""
import argparse
import os
import subprocess
import sys

OPTIONAL_BACKENDS = ("ipopt", "ceres")
STRONG_TYPES = set("TDBR")


def nm_symbols(nm, path):
    """(defined strong, undefined) external symbols of an object or archive, mangled."""
    result = subprocess.run([nm, "--extern-only", path], capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{nm} {path} failed: {result.stderr.strip()}")
    defined, undefined = set(), set()
    for line in result.stdout.splitlines():
        fields = line.split()
        if len(fields) == 2 and fields[0] == "U":
            undefined.add(fields[1])
        elif len(fields) == 3 and fields[1] in STRONG_TYPES:
            defined.add(fields[2])
    return defined, undefined


def allowed_user(object_path, backend):
    normalised = "/" + object_path.replace(os.sep, "/")
    name = os.path.basename(normalised)
    return (f"/solvers/{backend}/" in normalised or name.startswith("solver_factory.cpp.")
            or name.startswith(f"{backend}_solver_test.cpp."))


def violations(backend_symbols, objects):
    """backend_symbols: {backend: set of strong symbols}; objects: {path: set of undefined symbols}.
    Returns [(backend, object path, symbol)] for every use outside the backend's allowed users."""
    found = []
    for backend, symbols in sorted(backend_symbols.items()):
        for path, undefined in sorted(objects.items()):
            if allowed_user(path, backend):
                continue
            for symbol in sorted(undefined & symbols):
                found.append((backend, path, symbol))
    return found


def demangle(symbol):
    result = subprocess.run(["c++filt", symbol], capture_output=True, text=True)
    return result.stdout.strip() if result.returncode == 0 and result.stdout.strip() else symbol


def check(build_dir, nm):
    backend_symbols = {}
    for backend in OPTIONAL_BACKENDS:
        library = os.path.join(build_dir, "solvers", backend, f"libswerve_solver_{backend}.a")
        if not os.path.exists(library):
            print(f"{backend}: not built here, nothing to check")
            continue
        backend_symbols[backend] = nm_symbols(nm, library)[0]
    objects = {}
    for root, _, files in os.walk(build_dir):
        for name in files:
            if name.endswith(".o"):
                path = os.path.join(root, name)
                objects[os.path.relpath(path, build_dir)] = nm_symbols(nm, path)[1]
    found = violations(backend_symbols, objects)
    for backend, path, symbol in found:
        print(f"{path}: uses {demangle(symbol)}, defined only in the {backend} backend's library "
              f"(a build without {backend} cannot link it; define it in a header, or move the use behind "
              f"the factory)")
    counts = ", ".join(f"{b}: {len(s)} symbols" for b, s in sorted(backend_symbols.items()))
    print(f"checked {len(objects)} objects against {counts or 'no optional backend'}: "
          f"{len(found)} violation(s)")
    return 1 if found else 0


def self_test():
    symbol = "_ZN6swerve12IpoptOptions8validateEv"
    backend_symbols = {"ipopt": {symbol}, "ceres": {"_ZN6swerve11CeresSolverC1Ev"}}
    clean = {
        "solvers/ipopt/CMakeFiles/swerve_solver_ipopt.dir/ipopt_solver.cpp.o": {symbol},
        "solvers/CMakeFiles/swerve_solvers.dir/solver_factory.cpp.o": {symbol, "_ZN6swerve11CeresSolverC1Ev"},
        "tests/solvers/CMakeFiles/solver_tests.dir/ipopt_solver_test.cpp.o": {symbol},
        "CMakeFiles/swerve_config.dir/src/app/controller_config.cpp.o": {"_ZN6swerve9SaOptions8validateEv"},
    }
    planted = dict(clean)
    planted["CMakeFiles/swerve_config.dir/src/app/controller_config.cpp.o"] = {symbol}
    planted["tests/solvers/CMakeFiles/solver_tests.dir/ceres_solver_test.cpp.o"] = {symbol}
    ok = violations(backend_symbols, clean) == [] and violations(backend_symbols, planted) == [
        ("ipopt", "CMakeFiles/swerve_config.dir/src/app/controller_config.cpp.o", symbol),
        ("ipopt", "tests/solvers/CMakeFiles/solver_tests.dir/ceres_solver_test.cpp.o", symbol),
    ]
    print("self-test: " + ("the planted uses are found, the allowed ones pass" if ok else "FAILED"))
    return 0 if ok else 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("build_dir", nargs="?")
    parser.add_argument("--nm", default="nm", help="the nm of the build's toolchain (CMAKE_NM)")
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    if args.self_test:
        return self_test()
    if not args.build_dir:
        parser.error("BUILD_DIR is required")
    return check(args.build_dir, args.nm)


if __name__ == "__main__":
    sys.exit(main())
