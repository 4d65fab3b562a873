#!/usr/bin/env python3
"""Estimates each embedded target's cpu_slowdown (its time for one controller step / this machine's)
from instruction counts, without the board (issue 19):

    slowdown = (I_arm64 / I_x86) * R_here / (f_target * IPC_target)

- I_arm64 / I_x86: instructions of the same work on both architectures. The work is a short
  closed-loop run of the wear-aware controller (`swerve-mpc run --work-clock`: deadlines on a clock
  that advances per read, so both builds do the same proposals). Two durations are run and
  subtracted, so start-up (YAML, construction, output) cancels and what is left is controller
  steps. x86-64 is counted by callgrind, aarch64 under qemu-aarch64 (`-d in_asm,exec,nochain`:
  every translated block's instruction count, times its executions). Both builds must use the
  same flags: the x86-64 test build and `make cross-arm64`'s build are both RelWithDebInfo with
  the internal checks.
- R_here: this machine's instructions per second on the same work (callgrind's count of the
  Release CLI over its best-of-5 wall time), so the result needs no cycle counter (this VM has none).
- f_target * IPC_target: the target's clock (published) and instructions per cycle on this kind of
  code (an assumed range, the uncertain input; see TARGETS). A measurement on the board replaces
  it: `perf stat -e instructions,cycles swerve-mpc run ... --work-clock ...` gives the IPC.

Usage: scripts/cpu_slowdown.py [--release build/release] [--test build/test] [--arm64 build/arm64]
Prints the counts, the ratio, R_here and per target the slowdown over its IPC range.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Published clocks; IPC ranges assumed for scalar double-precision code with libm calls and short
# dependent chains (the tire model, Jets), below each core's decode width (A72: 3, A78: 4 per
# cycle, ARM's software optimization guides). Change them, or pass --ipc, when a board measures it.
TARGETS = {
    "raspberry_pi_4": {"core": "Cortex-A72", "clock_hz": 1.5e9, "ipc": (0.9, 1.5)},
    "jetson_orin_nano": {"core": "Cortex-A78AE", "clock_hz": 1.5e9, "ipc": (1.3, 2.2)},
}

SCENARIO = """scenario:
  name: cpu_slowdown_workload
  vehicle: {root}/configs/vehicles/paper_ms_agv.yaml
  duration: {duration}
  reference: {{type: sine, amplitude: 2.0, wavelength: 20.0, length: 40.0, speed: 1.0}}
  simulator:
    seed: 3
  controllers:
    - {{name: wear_mpc, config: {root}/configs/controllers/default.yaml}}
"""


def write_scenario(directory, duration):
    path = os.path.join(directory, f"workload_{duration}.yaml")
    with open(path, "w") as f:
        f.write(SCENARIO.format(root=ROOT, duration=duration))
    return path


def cli_arguments(scenario, out, work_clock):
    return ["run", scenario, "--work-clock", str(work_clock), "--out", out, "--quiet"]


def callgrind_instructions(cli, scenario, out, work_clock):
    result = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", cli]
                            + cli_arguments(scenario, out, work_clock), capture_output=True, text=True)
    match = re.search(r"I\s+refs:\s+([\d,]+)", result.stderr)
    if result.returncode != 0 or match is None:
        sys.exit(f"callgrind run of {cli} failed:\n{result.stderr[-2000:]}")
    return int(match.group(1).replace(",", ""))


def qemu_instructions(cli, sysroot, scenario, out, work_clock):
    # in_asm prints each translated block (its instructions, one per line after an "IN:" header)
    # before it first runs; exec prints the guest pc of every block executed (nochain: every one).
    command = ["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu", "-E",
               f"LD_LIBRARY_PATH=/usr/aarch64-linux-gnu/lib:{sysroot}/usr/lib/aarch64-linux-gnu",
               "-d", "in_asm,exec,nochain", "-D", "/dev/stderr", cli] + cli_arguments(scenario, out, work_clock)
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    block_size = {}
    total = 0
    current, count = None, 0
    exec_pc = re.compile(rb"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
    instruction = re.compile(rb"^0x([0-9a-f]+):")
    for line in process.stderr:
        if line.startswith(b"Trace"):
            match = exec_pc.match(line)
            if match:
                total += block_size[int(match.group(1), 16)]
            continue
        if line.startswith(b"IN:"):
            current, count = None, 0
            continue
        match = instruction.match(line)
        if match:
            if current is None:
                current = int(match.group(1), 16)
            count += 1
            block_size[current] = count
    if process.wait() != 0:
        sys.exit(f"qemu run of {cli} failed ({process.returncode})")
    return total


def best_wall_time(cli, scenario, out, work_clock, repeats=5):
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run([cli] + cli_arguments(scenario, out, work_clock), check=True, stdout=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - start)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--release", default=os.path.join(ROOT, "build/release"))
    parser.add_argument("--test", default=os.path.join(ROOT, "build/test"))
    parser.add_argument("--arm64", default=os.path.join(ROOT, "build/arm64"))
    parser.add_argument("--work-clock", type=float, default=2e-4,
                        help="s per clock read (2e-4: about as many SA proposals per step as a 20 ms "
                             "budget gives on this machine)")
    parser.add_argument("--durations", type=float, nargs=2, default=(0.1, 0.3),
                        help="the two run lengths, s, for the instruction ratio (their difference is the "
                             "counted steps; under qemu each step takes about a minute)")
    parser.add_argument("--rate-durations", type=float, nargs=2, default=(0.1, 1.0),
                        help="the two run lengths, s, for this machine's instruction rate (native)")
    args = parser.parse_args()
    if not 0.0 < args.work_clock <= 1.0:
        sys.exit(f"--work-clock: {args.work_clock}: must be in (0, 1] s")
    short, long_ = sorted(args.durations)
    rate_short, rate_long = sorted(args.rate_durations)
    for flag, (a, b) in (("--durations", (short, long_)), ("--rate-durations", (rate_short, rate_long))):
        if not 0.0 < a < b:
            sys.exit(f"{flag}: {a} {b}: need two different positive lengths")
    clis = {name: os.path.join(directory, "src/cli/swerve-mpc")
            for name, directory in (("release", args.release), ("test", args.test), ("arm64", args.arm64))}
    for name, path in clis.items():
        if not os.path.exists(path):
            sys.exit(f"--{name}: no CLI at {path} (build it first; arm64: make cross-arm64)")
    sysroot = os.path.join(args.arm64, "sysroot")
    steps = round((long_ - short) / 0.05)  # the scenario's control period is 0.05 s
    rate_steps = round((rate_long - rate_short) / 0.05)

    with tempfile.TemporaryDirectory() as directory:
        scenarios = [write_scenario(directory, d) for d in (short, long_)]
        rate_scenarios = [write_scenario(directory, d) for d in (rate_short, rate_long)]
        out = os.path.join(directory, "out")
        x86 = [callgrind_instructions(clis["test"], s, out, args.work_clock) for s in scenarios]
        arm = [qemu_instructions(clis["arm64"], sysroot, s, out, args.work_clock) for s in scenarios]
        release = [callgrind_instructions(clis["release"], s, out, args.work_clock) for s in rate_scenarios]
        wall = [best_wall_time(clis["release"], s, out, args.work_clock) for s in rate_scenarios]

    x86_steps, arm_steps, release_steps = x86[1] - x86[0], arm[1] - arm[0], release[1] - release[0]
    ratio = arm_steps / x86_steps
    rate_here = release_steps / (wall[1] - wall[0])
    print(f"work: {steps} controller steps (runs of {short} s and {long_} s, work clock {args.work_clock} s per read)")
    print(f"instructions per step, RelWithDebInfo: x86-64 {x86_steps / steps:.4g}, aarch64 {arm_steps / steps:.4g}, "
          f"ratio aarch64 / x86-64 {ratio:.3f}")
    print(f"this machine, Release, {rate_steps} steps: {release_steps / rate_steps:.4g} instructions per step in "
          f"{1e3 * (wall[1] - wall[0]) / rate_steps:.2f} ms: R_here = {rate_here / 1e9:.2f} G instructions/s")
    print(f"{'target':<18} {'core':<13} {'clock':>6} {'IPC range':>10} {'slowdown':>14}")
    for name, target in TARGETS.items():
        low_ipc, high_ipc = target["ipc"]
        slowest = ratio * rate_here / (target["clock_hz"] * low_ipc)
        fastest = ratio * rate_here / (target["clock_hz"] * high_ipc)
        middle = ratio * rate_here / (target["clock_hz"] * 0.5 * (low_ipc + high_ipc))
        print(f"{name:<18} {target['core']:<13} {target['clock_hz'] / 1e9:>4.1f}GHz {low_ipc:>4.1f}-{high_ipc:<4.1f}  "
              f"{middle:>5.2f} ({fastest:.2f}-{slowest:.2f})")


if __name__ == "__main__":
    main()
