#!/usr/bin/env python3
"""Reads a run's run.wpilog with a DataLog reader written here from WPILib's datalog.adoc (no code
shared with the writer or with app_tests' reader) and checks it against the run's CSV logs: for each
controller every entry started once with its type, one sample per step at the CSV step's time (the
solve time at steps that solved), and the poses equal to the CSV's.
Usage: check_wpilog.py <run folder> <controller>...
"""
import collections
import csv
import os
import struct
import sys

TYPES = {"Pose": "struct:Pose2d", "ReferencePose": "struct:Pose2d",
         "ModuleStates/Measured": "struct:SwerveModuleState[]", "ModuleStates/Commanded": "struct:SwerveModuleState[]",
         "WearPerModule": "double[]", "PositionError": "double", "SolveTimeMs": "double",
         "CommandSource": "string", "SolveStatus": "string"}


def read(path):
    data = open(path, "rb").read()
    if data[:6] != b"WPILOG" or struct.unpack_from("<H", data, 6)[0] != 0x0100:
        sys.exit(f"{path}: not a DataLog 1.0 file")
    at = 12 + struct.unpack_from("<I", data, 8)[0]
    names, types, samples = {}, {}, collections.defaultdict(list)
    while at < len(data):
        head = data[at]
        at += 1
        widths = [(head & 3) + 1, ((head >> 2) & 3) + 1, ((head >> 4) & 7) + 1]
        entry, size, stamp = (int.from_bytes(data[at + sum(widths[:i]):at + sum(widths[:i + 1])], "little")
                              for i in range(3))
        at += sum(widths)
        payload = data[at:at + size]
        at += size
        if entry != 0:
            samples[names[entry]].append((stamp, payload))
            continue
        if payload[0] != 0:
            sys.exit(f"{path}: a control record of kind {payload[0]} (only Start is written)")
        new_entry, = struct.unpack_from("<I", payload, 1)
        strings, p = [], 5
        for _ in range(3):
            n, = struct.unpack_from("<I", payload, p)
            strings.append(payload[p + 4:p + 4 + n].decode())
            p += 4 + n
        if new_entry in names or strings[0] in types:
            sys.exit(f"{path}: entry {strings[0]} started twice")
        names[new_entry], types[strings[0]] = strings[0], strings[1]
    if at != len(data):
        sys.exit(f"{path}: the last record runs past the end")
    return types, samples


def main():
    folder, controllers = sys.argv[1], sys.argv[2:]
    types, samples = read(os.path.join(folder, "run.wpilog"))
    failures = []
    for controller in controllers:
        rows = list(csv.DictReader(open(os.path.join(folder, f"{controller}.csv"))))
        stamps = [round(float(r["t"]) * 1e6) for r in rows]
        # The CSV leaves the solve time empty at steps without a solve.
        solved = [s for s, r in zip(stamps, rows) if r["solve_time_ms"] not in ("", "nan") and float(r["solve_time_ms"]) >= 0.0]
        for name, kind in TYPES.items():
            full = f"/SwerveMPC/{controller}/{name}"
            if types.get(full) != kind:
                failures.append(f"{full}: type {types.get(full)}, expected {kind}")
                continue
            got = [s for s, _ in samples[full]]
            want = solved if name == "SolveTimeMs" else stamps
            if got != want:
                failures.append(f"{full}: {len(got)} samples at other times than the CSV's {len(want)} steps")
        for (stamp, payload), row in zip(samples[f"/SwerveMPC/{controller}/Pose"], rows):
            x, y, _ = struct.unpack("<3d", payload)
            if abs(x - float(row["x"])) > 1e-6 or abs(y - float(row["y"])) > 1e-6:
                failures.append(f"/SwerveMPC/{controller}/Pose at {stamp} us: ({x}, {y}) against ({row['x']}, {row['y']})")
    if failures:
        sys.exit("\n".join(failures[:20]))
    print(f"run.wpilog: {len(types)} entries, {sum(len(v) for v in samples.values())} samples, all accounted for")


if __name__ == "__main__":
    main()
