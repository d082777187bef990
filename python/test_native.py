"""Tests of the native module `hjacc` (python/hjacc-native, built with maturin).

    python3 python/test_native.py

Needs the module installed (`pip install target/wheels/hjacc-*.whl`, see python/README.md) and
runs from the repository's root. Checks:
- `hjacc.Table` against the pure-Python reader, to the last bit, on 10,000 random states of the
  firmware's table (some outside the grid, where both refuse);
- a corrupt table and a state of the wrong size raise ValueError;
- `hjacc.run` solves a small two-car config, returns its summary, and writes a table that
  `hjacc.Table` reads; a config with an unknown key raises ValueError naming the key and line.
"""

import math
import os
import random
import struct
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))

import hjacc  # noqa: E402
from hjacc_table import Table as PyTable, TableError  # noqa: E402

DEFAULT_TABLE = os.path.join(ROOT, "firmware", "tables", "default.bin")


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def bits(x):
    return struct.pack("<f", x)


def outcome(lookup, state):
    """What a lookup answers, or that it refused (the default table has no policy bits)."""
    try:
        return lookup(state)
    except ValueError:
        return "refused"


def agree(case, path, n):
    """Checks the native and pure-Python readers on `n` random states of the table at `path`
    (some outside the grid); returns how many policies the table answered."""
    native = hjacc.Table.open(path)
    python = PyTable.open(path)
    case.assertEqual(native.dims, python.dims())
    axes = native.header["axes"]
    rng = random.Random(13)
    outside = policies = 0
    for _ in range(n):
        state = []
        for a in axes:
            span = a["max"] - a["min"]
            state.append(f32(rng.uniform(a["min"] - 0.05 * span, a["max"] + 0.05 * span)))
        try:
            mine = python.value_at(state)
        except TableError:
            mine = None
        if mine is None:
            outside += 1
            case.assertFalse(native.contains(state))
            with case.assertRaises(ValueError):
                native.value_at(state)
            continue
        case.assertEqual(bits(mine), bits(native.value_at(state)), state)
        policy = outcome(python.policy_at, state)
        case.assertEqual(policy, outcome(native.policy_at, state), state)
        policies += policy != "refused"
    case.assertGreater(outside, 0)
    case.assertLess(outside, n)
    return policies


class TableAgainstPurePython(unittest.TestCase):
    def test_every_state_agrees_to_the_last_bit(self):
        # The firmware's table stores no policy bits: both readers refuse every policy.
        self.assertEqual(agree(self, DEFAULT_TABLE, 10_000), 0)

    def test_header_and_error_bound(self):
        native = hjacc.Table.open(DEFAULT_TABLE)
        header = native.header
        self.assertIn("ThreeCarSplit", header["game"])
        self.assertEqual(len(native), os.path.getsize(DEFAULT_TABLE))
        bound = header["error_bound"]
        self.assertEqual(bits(native.error_bound), bits(f32(bound["quantization"] + bound["interpolation"])))
        self.assertEqual(hjacc.FORMAT_VERSION, 4)

    def test_corrupt_tables_and_bad_states_raise(self):
        with open(DEFAULT_TABLE, "rb") as f:
            data = bytearray(f.read())
        data[len(data) // 2] ^= 0x01
        with self.assertRaisesRegex(ValueError, "CRC"):
            hjacc.Table(bytes(data))
        with self.assertRaisesRegex(ValueError, "magic"):
            hjacc.Table(b"\xff" * 4096)
        # A cut file is truncated, not corrupt, in both readers.
        with open(DEFAULT_TABLE, "rb") as f:
            whole = f.read()
        for cut in (300, len(whole) // 2, len(whole) - 1):
            with self.assertRaisesRegex(ValueError, "truncated"):
                hjacc.Table(whole[:cut])
            with self.assertRaisesRegex(TableError, "truncated"):
                PyTable(whole[:cut])
        native = hjacc.Table.open(DEFAULT_TABLE)
        with self.assertRaisesRegex(ValueError, "coordinates"):
            native.value_at([1.0, 2.0])
        with self.assertRaisesRegex(ValueError, "not finite"):
            native.value_at([math.nan, 2.0, 3.0])
        with self.assertRaises(OSError):
            hjacc.Table.open(os.path.join(ROOT, "no-such-table.bin"))


class Run(unittest.TestCase):
    def small_two_car(self, first_line=""):
        with open(os.path.join(ROOT, "solver", "configs", "two-car.toml")) as f:
            text = f.read()
        text = text.replace("points = 201", "points = 21").replace(
            'name = "two-car"', 'name = "two-car-python"'
        )
        return first_line + text

    def test_a_run_returns_its_summary_and_writes_a_readable_table(self):
        with tempfile.TemporaryDirectory() as out:
            path = os.path.join(out, "small.toml")
            with open(path, "w") as f:
                f.write(self.small_two_car())
            summary = hjacc.run(path, out)
            self.assertEqual(summary["name"], "two-car-python")
            self.assertEqual(summary["grid_shape"], [21, 21])
            self.assertGreater(summary["safe_fraction"], 0.0)
            table = hjacc.Table.open(os.path.join(out, "two-car-python", "table.bin"))
            self.assertEqual(len(table), summary["table"]["bytes"])
            # This table has policy bits: both readers agree on them too.
            self.assertGreater(agree(self, os.path.join(out, "two-car-python", "table.bin"), 2_000), 0)
            # Closing at 2 m/s from 20 m is safe; at 14 m/s it is not.
            self.assertGreater(table.value_at([20.0, -2.0]), table.error_bound)
            self.assertLess(table.value_at([20.0, -14.0]), 0.0)

    def test_a_bad_config_names_its_key_and_line(self):
        with tempfile.TemporaryDirectory() as out:
            path = os.path.join(out, "bad.toml")
            with open(path, "w") as f:
                f.write(self.small_two_car("wrong_key = 1\n"))
            with self.assertRaises(ValueError) as caught:
                hjacc.run(path, out)
            message = str(caught.exception)
            self.assertIn("wrong_key", message)
            self.assertIn("line", message)


if __name__ == "__main__":
    unittest.main(verbosity=2)
