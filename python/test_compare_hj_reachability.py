"""Tests of compare_hj_reachability.py on grids whose answer is known: a bilinear function is
interpolated exactly, so the two files agree to f32 rounding; one changed node is found."""

import json
import os
import struct
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare_hj_reachability as c  # noqa: E402


def write_npy(path, shape, values, code):
    descr = {"f": "<f4", "d": "<f8"}[code]
    header = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }" % (descr, repr(tuple(shape)))
    pad = 64 - (10 + len(header) + 1) % 64
    header = header + " " * pad + "\n"
    with open(path, "wb") as f:
        f.write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode("latin1"))
        f.write(struct.pack("<%d%s" % (len(values), code), *values))


def f(x, y):
    return 0.5 * x - 0.2 * y + 0.01 * x * y - 3.0


class Compare(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()
        # hjacc's grid: uneven breakpoints.
        xs = [-5.0, -2.0, 0.0, 1.0, 4.0, 10.0, 20.0, 40.0, 75.0]
        ys = [-15.0, -10.0, -4.0, 0.0, 3.0, 15.0]
        write_npy(os.path.join(self.dir, "value.npy"), (len(xs), len(ys)),
                  [f(x, y) for x in xs for y in ys], "f")
        with open(os.path.join(self.dir, "axes.json"), "w") as out:
            json.dump({"axes": [{"name": "gap_leader", "unit": "m", "coordinates": xs},
                                {"name": "rel_speed_leader", "unit": "m/s", "coordinates": ys}]}, out)
        # hj_reachability's: a uniform box reaching beyond hjacc's on one side.
        self.shape = (31, 17)
        self.lo, self.hi = [-10.0, -15.0], [80.0, 15.0]
        self.hj = [[l + (h - l) * i / (n - 1) for i in range(n)]
                   for l, h, n in zip(self.lo, self.hi, self.shape)]
        self.values = [f(x, y) for x in self.hj[0] for y in self.hj[1]]
        self.path = os.path.join(self.dir, "hj.npy")

    def test_the_same_function_agrees_to_rounding(self):
        write_npy(self.path, self.shape, self.values, "d")
        r = c.compare(self.dir, self.path, self.lo, self.hi)
        inside = sum(1 for x in self.hj[0] if -5.0 <= x <= 75.0) * self.shape[1]
        self.assertEqual(r["nodes_compared"], inside)
        self.assertLess(r["max_abs_difference"], 1e-5)
        self.assertEqual(r["sign_agreement"], 1.0)

    def test_one_changed_node_is_found(self):
        values = list(self.values)
        node = 10 * self.shape[1] + 8  # x = 20, y = 0: inside hjacc's grid
        values[node] += 0.75
        write_npy(self.path, self.shape, values, "f")
        r = c.compare(self.dir, self.path, self.lo, self.hi)
        self.assertAlmostEqual(r["max_abs_difference"], 0.75, places=4)
        self.assertEqual(c.main([self.dir, self.path, "--lo=-10,-15", "--hi=80,15",
                                 "--max-difference", "0.1"]), 2)

    def test_mismatched_dimensions_are_an_error(self):
        write_npy(self.path, (31,), self.values[:31], "d")
        self.assertEqual(c.main([self.dir, self.path, "--lo=-10", "--hi=80"]), 1)


if __name__ == "__main__":
    unittest.main()
