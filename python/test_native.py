"""Tests of the package `hjacc` (python/hjacc-native, built with maturin).

    python3 python/test_native.py

Needs the package installed (`pip install target/wheels/hjacc-*.whl "dask[distributed]"`, see
python/README.md) and runs from anywhere. Checks:
- `hjacc.Table` and the pure-Python `hjacc_table.Table` have one interface: the same public
  names, the same header and attributes, the same answers to the last bit on 10,000 random
  states of the firmware's table (some outside the grid, where both refuse), the same errors;
- every door (run, run_rear, verify, campaign, falsify, sweep) runs, returns what it wrote,
  and refuses nonsense with ValueError naming the argument;
- a sweep runs on a dask.distributed.LocalCluster and gives what it gives on this machine
  (HJACC_SKIP_DASK=1 skips it where dask is not installed; CI does not set it).
"""

import math
import os
import random
import struct
import sys
import tempfile
import unittest
import zlib

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
    case.assertEqual(native.dims, python.dims)
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

    def test_one_interface(self):
        native = hjacc.Table.open(DEFAULT_TABLE)
        python = PyTable.open(DEFAULT_TABLE)
        public = lambda t: sorted(n for n in dir(t) if not n.startswith("_"))
        self.assertEqual(public(native), public(python))
        for name in public(python):
            if not callable(getattr(python, name)):
                self.assertEqual(getattr(native, name), getattr(python, name), name)
        for k in range(python.dims):
            self.assertEqual(native.coordinates(k), python.coordinates(k))
        self.assertEqual(native.header["game"]["kind"], "ThreeCarSplit")
        self.assertEqual(native.horizon["status"], "Proven")
        self.assertEqual(len(native), os.path.getsize(DEFAULT_TABLE))
        self.assertEqual(len(python), len(native))
        self.assertEqual(repr(native), repr(python))
        parts = native.error_bound_parts
        self.assertEqual(bits(native.error_bound), bits(f32(parts["quantization"] + parts["interpolation"])))
        self.assertEqual(hjacc.FORMAT_VERSION, 7)
        for node in (0, 1234, native.nodes - 1):
            self.assertEqual(bits(native.node_value(node)), bits(python.node_value(node)))
        self.assertTrue(native.contains([10.0, 0.0, 0.0]) and python.contains([10.0, 0.0, 0.0]))
        self.assertFalse(native.contains([1e6, 0.0, 0.0]) or python.contains([1e6, 0.0, 0.0]))

    def test_an_infinite_declaration_reads_the_same(self):
        # A vehicle may declare its emergency braking at once (an infinite jerk). The native
        # reader's header went through JSON, which has no infinity: it read None where the pure
        # reader read inf. The default table's declaration (8 m/s^2 at 12 m/s^3, the follower's
        # 1.15 s, the lights' 1.3 and -1.5 m/s^2) with the jerk made infinite, the CRC redone.
        with open(DEFAULT_TABLE, "rb") as f:
            data = bytearray(f.read())
        declared = struct.pack("<5f", 8.0, 12.0, 1.15, 1.3, -1.5)
        at = data.find(declared)
        self.assertGreater(at, 0)
        self.assertEqual(data.find(declared, at + 1), -1)
        data[at + 4 : at + 8] = struct.pack("<f", math.inf)
        data[-4:] = struct.pack("<I", zlib.crc32(bytes(data[:-4])) & 0xFFFFFFFF)
        native, python = hjacc.Table(bytes(data)), PyTable(bytes(data))
        jerk = native.header["game"]["emergency"]["braking"]["jerk"]
        self.assertEqual(jerk, math.inf)
        self.assertEqual(python.header["game"]["emergency"]["braking"]["jerk"], math.inf)
        self.assertEqual(native.header, python.header)

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
        for reader in (hjacc.Table, PyTable):
            table = reader.open(DEFAULT_TABLE)
            with self.assertRaisesRegex(TableError if reader is PyTable else hjacc.TableError, "coordinates"):
                table.value_at([1.0, 2.0])
            with self.assertRaisesRegex(ValueError, "not finite"):
                table.value_at([math.nan, 2.0, 3.0])
            with self.assertRaises(ValueError):
                table.lookup([10.0, 0.0, 0.0])  # no policy bits in this table
            with self.assertRaises(OSError):
                reader.open(os.path.join(ROOT, "no-such-table.bin"))


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


SMALL_REAR = os.path.join(ROOT, "solver", "tests", "sweep", "base.toml")


class Doors(unittest.TestCase):
    """Each door of the command line, from Python: what it writes, and what it refuses."""

    def test_run_rear_then_verify_then_the_closed_loop(self):
        with tempfile.TemporaryDirectory() as out:
            summary = hjacc.run_rear(SMALL_REAR, out)
            self.assertEqual(summary["stopped"], "proven")
            table = os.path.join(out, "sweep-base", "table.bin")
            report = hjacc.verify(table, out)
            self.assertIsNone(report["failure"])
            self.assertEqual(report["report"]["proven"], report["report"]["certified"])
            self.assertTrue(os.path.exists(os.path.join(report["dir"], "verify.json")))
            with self.assertRaisesRegex(ValueError, "range_error"):
                hjacc.verify(table, out, range_error=6.0)
            with self.assertRaisesRegex(ValueError, "periods"):
                hjacc.verify(table, out, periods_ms=[])
            # The closed loop runs the firmware's default table unless given another.
            loop = os.path.join(out, "campaign")
            result = hjacc.campaign(episodes=2, seconds=5.0, out=loop)
            self.assertIsNone(result["failure"])
            self.assertEqual(len(result["groups"]), 24)
            self.assertTrue(os.path.exists(os.path.join(loop, "campaign.json")))
            for bad, name in [({"seconds": -5.0}, "seconds"), ({"episodes": 0}, "episodes"),
                              ({"sensors": "perfect"}, "sensors"), ({"cut_in": "sideways"}, "cut_in"),
                              ({"lag": math.nan}, "lag")]:
                with self.assertRaisesRegex(ValueError, name):
                    hjacc.campaign(out=loop, **bad)
            search = hjacc.falsify(episodes=40, seconds=10.0, out=os.path.join(out, "falsify"))
            self.assertEqual((search["collisions"], search["certificate_losses"]), (0, 0))
            with self.assertRaisesRegex(ValueError, "episodes"):
                hjacc.falsify(episodes=0, out=out)


def sweep_file(folder):
    """A sweep of two tables (the follower braking at 6 and at 8 m/s^2) and two leaders."""
    path = os.path.join(folder, "sweep.toml")
    with open(path, "w") as f:
        f.write(
            'name = "python-sweep"\n'
            'base = "%s"\n'
            "[[points]]\n"
            "[[points]]\n"
            "game.follower = { min = -8.0, max = 2.0 }\n"
            "[[vary]]\n"
            'key = "front.leader_braking"\n'
            "values = [3.5, 8.0]\n"
            "[volume]\n"
            "samples = 20000\n" % SMALL_REAR.replace("\\", "/")
        )
    return path


class Sweep(unittest.TestCase):
    def test_a_sweep_here_and_on_a_dask_cluster_agree(self):
        with tempfile.TemporaryDirectory() as folder:
            path = sweep_file(folder)
            here = hjacc.sweep(path, os.path.join(folder, "here"))
            self.assertEqual((here["tables"], len(here["points"])), (2, 4))
            self.assertTrue(os.path.exists(os.path.join(folder, "here", "python-sweep", "sweep.png")))
            if os.environ.get("HJACC_SKIP_DASK") == "1":
                self.skipTest("HJACC_SKIP_DASK=1")
            from distributed import Client, LocalCluster

            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
                there = hjacc.sweep(path, os.path.join(folder, "dask"), client=client, progress=False)
            self.assertEqual(len(there["points"]), 4)
            for a, b in zip(here["points"], there["points"]):
                self.assertEqual(a["point"], b["point"])
                self.assertEqual(a["volume"], b["volume"])
                self.assertEqual(a["table"]["certified_cells"], b["table"]["certified_cells"])
            self.assertTrue(os.path.exists(os.path.join(folder, "dask", "python-sweep", "sweep.json")))


if __name__ == "__main__":
    unittest.main(verbosity=2)
