#!/usr/bin/env python3
"""Checks that the library's includes point downward through its layers (issue 16).

Each layer is a folder under include/swerve/ and src/ (models/ and solvers/ keep their top-level
folders). From the bottom up, a layer may include only itself and the layers before it:

    core, kinematics, models, ocp, solvers, control, sim, app, cli, python

(cli and python are both front ends over app; neither includes the other.)

and YAML (yaml-cpp) and JSON (nlohmann) are read only in app and cli. A file in none of the
layers' folders, or an include of swerve/<folder>/ that names no layer, is a violation too, so a
new folder has to be placed before it can be used.

Usage: check_layers.py [REPO_ROOT]      exit 0 when clean, 1 listing every violation
       check_layers.py --self-test      checks that a planted violation of each kind is caught
"""
import os
import re
import sys
import tempfile

LAYERS = ["core", "kinematics", "models", "ocp", "solvers", "control", "sim", "app", "cli", "python"]
RANK = {name: i for i, name in enumerate(LAYERS)}
# Where each layer's files live, relative to the repository root.
ROOTS = {
    "include/swerve/core": "core", "src/core": "core",
    "include/swerve/kinematics": "kinematics", "src/kinematics": "kinematics",
    "include/swerve/models": "models", "models": "models",
    "include/swerve/ocp": "ocp", "src/ocp": "ocp",
    "include/swerve/solvers": "solvers", "solvers": "solvers",
    "include/swerve/control": "control", "src/control": "control",
    "include/swerve/sim": "sim", "src/sim": "sim",
    "include/swerve/app": "app", "src/app": "app",
    "src/cli": "cli",
    "src/python": "python",
}
# Generated into the build tree by CMake (cmake/version.hpp.in).
GENERATED = {"swerve/version.hpp": "core"}
# Third-party parsers allowed only from the application layer up.
PARSERS = {"yaml-cpp/": "app", "nlohmann/": "app"}
SOURCE = re.compile(r"\.(hpp|cpp|h|cc)$")
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]', re.M)


def layer_of_file(rel_path):
    best = None
    for root, layer in ROOTS.items():
        if rel_path == root or rel_path.startswith(root + "/"):
            if best is None or len(root) > len(best[0]):
                best = (root, layer)
    return best[1] if best else None


def layer_of_include(target):
    if target in GENERATED:
        return GENERATED[target]
    parts = target.split("/")
    if len(parts) >= 3 and parts[0] == "swerve":
        return parts[1] if parts[1] in RANK else "?" + parts[1]
    if len(parts) == 2 and parts[0] == "swerve":
        return "?top-level"
    return None


def check(repo):
    violations = []
    for top in ("include/swerve", "src", "models", "solvers"):
        for directory, _, files in os.walk(os.path.join(repo, top)):
            for name in sorted(files):
                if not SOURCE.search(name):
                    continue
                path = os.path.join(directory, name)
                rel = os.path.relpath(path, repo).replace(os.sep, "/")
                layer = layer_of_file(rel)
                if layer is None:
                    violations.append(f"{rel}: in no layer's folder ({', '.join(sorted(ROOTS))})")
                    continue
                with open(path, encoding="utf-8", errors="replace") as f:
                    text = f.read()
                for match in INCLUDE.finditer(text):
                    target = match.group(1)
                    line = text.count("\n", 0, match.start()) + 1
                    for prefix, lowest in PARSERS.items():
                        if target.startswith(prefix) and RANK[layer] < RANK[lowest]:
                            violations.append(f"{rel}:{line}: layer {layer} includes {target}: "
                                              f"only {lowest} and above parse files")
                    used = layer_of_include(target)
                    if used is None:
                        continue
                    if used.startswith("?"):
                        violations.append(f"{rel}:{line}: includes {target}, which is in no layer")
                    elif RANK[used] > RANK[layer]:
                        violations.append(f"{rel}:{line}: layer {layer} includes {target} from the higher "
                                          f"layer {used} (order: {' < '.join(LAYERS)})")
    return violations


def self_test():
    cases = {
        "upward include": ("include/swerve/models/bad.hpp", '#include "swerve/control/controller.hpp"\n'),
        "yaml below app": ("src/kinematics/bad.cpp", "#include <yaml-cpp/yaml.h>\n"),
        "unknown folder": ("src/ocp/bad.cpp", '#include "swerve/mpc/controller.hpp"\n'),
        "file outside layers": ("src/mpc/bad.cpp", "int x;\n"),
    }
    failures = 0
    for what, (rel, text) in cases.items():
        with tempfile.TemporaryDirectory() as repo:
            clean = os.path.join(repo, "include/swerve/control/fine.hpp")
            os.makedirs(os.path.dirname(clean))
            with open(clean, "w") as f:
                f.write('#include "swerve/models/vehicle_model.hpp"\n#include "swerve/version.hpp"\n')
            if check(repo):
                print(f"self-test: a clean tree was reported: {check(repo)}")
                failures += 1
            path = os.path.join(repo, rel)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w") as f:
                f.write(text)
            found = check(repo)
            if len(found) != 1:
                print(f"self-test: {what}: expected one violation, got {found}")
                failures += 1
    print("self-test:", "failed" if failures else f"all {len(cases)} planted violations caught")
    return 1 if failures else 0


def main(argv):
    if len(argv) > 1 and argv[1] == "--self-test":
        return self_test()
    repo = argv[1] if len(argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    violations = check(repo)
    for v in violations:
        print(v)
    if violations:
        print(f"{len(violations)} layering violation(s)")
        return 1
    print("layers: every include points downward (" + " < ".join(LAYERS) + ")")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
