#!/usr/bin/env python3
"""Writes the seed inputs of controller_step_fuzzer (tests/fuzz/corpus/controller_step/*.bin).

Each input is up to 6 records: a flags byte (bit 0: reset() before the step; bit 1: a wrong-sized
measurement, its size the next byte mod 33), the measurement's doubles (10 for the 4-module AGV),
then t and measured_at, all little-endian doubles. Run: python3 tests/fuzz/make_controller_step_corpus.py
"""
import math
import os
import struct

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", "controller_step")


def record(state, t, measured_at=None, reset=False, size=None):
    flags = (1 if reset else 0) | (2 if size is not None else 0)
    out = bytes([flags])
    if size is not None:
        out += bytes([size])
    out += struct.pack("<%dd" % len(state), *state)
    out += struct.pack("<2d", t, t if measured_at is None else measured_at)
    return out


def on_line(t, speed=1.0, y=0.0, steer=0.0):
    return [speed * t, y, 0.0, speed, 0.0, 0.0] + [steer] * 4


inputs = {
    "nominal_on_line": b"".join(record(on_line(0.05 * k), 0.05 * k) for k in range(4)),
    "offset_and_turned_modules": b"".join(record(on_line(0.05 * k, y=0.5, steer=1.2), 0.05 * k) for k in range(3)),
    "nan_burst": record(on_line(0.0), 0.0) + record([math.nan] + on_line(0.05)[1:], 0.05) + record(on_line(0.1), 0.1),
    "inf_and_huge": record([math.inf, -1e300, 1e308, -math.inf, 1e200, 5e-324, 1e300, -1e300, math.inf, 0.0], 1e300),
    "nan_time": record(on_line(0.0), math.nan, math.inf),
    "wrong_sizes": record([0.0] * 3, 0.0, size=3) + record([], 0.05, size=0) + record([0.0] * 32, 0.1, size=32),
    "stale_measurement": record(on_line(0.0), 0.0) + record(on_line(0.0), 2.0, measured_at=0.0) + record(on_line(0.0), 3.0, measured_at=-1e9),
    "time_backwards_and_reset": record(on_line(1.0), 1.0) + record(on_line(0.5), 0.5) + record(on_line(0.5), 0.5, reset=True) + record(on_line(0.6), -10.0),
    "far_from_reference": record([100.0, -50.0, 3.0, 5.0, -5.0, 10.0, 3.1, -3.1, 10.0, -10.0], 0.0),
}

os.makedirs(HERE, exist_ok=True)
for name, data in inputs.items():
    with open(os.path.join(HERE, name + ".bin"), "wb") as f:
        f.write(data)
print("wrote %d inputs, %d bytes" % (len(inputs), sum(len(d) for d in inputs.values())))
