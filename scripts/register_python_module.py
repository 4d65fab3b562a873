#!/usr/bin/env python3
"""Makes an installed swervempc module importable by the interpreter that runs this script.

`make install` (cmake --install) runs it with the interpreter the module was built for, passing the
folder the module was installed into. A folder already on that interpreter's path (Debian's python3
reads <prefix>/lib/python3.X/dist-packages for the prefix /usr/local) needs nothing. Any other prefix
gets a one-line `swervempc.pth` naming the folder, written into the first writable site folder the
interpreter reads at start-up (its site-packages, else the user's), so `import swervempc` works from
a clean interpreter without PYTHONPATH. SWERVE_PYTHON_PTH_DIR names the folder to write it into
instead (the install test uses a folder of its own).
"""
import os
import site
import sys


def main():
    if len(sys.argv) != 2:
        print("usage: register_python_module.py <folder the module was installed into>", file=sys.stderr)
        return 2
    target = os.path.realpath(sys.argv[1])
    chosen = os.environ.get("SWERVE_PYTHON_PTH_DIR")
    if not chosen and any(os.path.realpath(entry) == target for entry in sys.path if entry):
        print(f"swervempc: {target} is on {sys.executable}'s path")
        return 0
    candidates = [chosen] if chosen else site.getsitepackages() + [site.getusersitepackages()]
    for folder in candidates:
        try:
            os.makedirs(folder, exist_ok=True)
            with open(os.path.join(folder, "swervempc.pth"), "w", encoding="utf-8") as out:
                out.write(target + "\n")
        except OSError:
            continue
        print(f"swervempc: {os.path.join(folder, 'swervempc.pth')} adds {target} to {sys.executable}'s path")
        return 0
    print(f"swervempc: no writable site folder for {sys.executable}; set PYTHONPATH={target}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
