"""Compares a value function of this project with one written by hj_reachability.

hjacc writes ``out/<name>/value.npy`` with ``axes.json`` beside it (each axis's name, unit and
node coordinates). hj_reachability users save ``values[-1]`` with ``numpy.save``; its grid is
``hj.Grid.from_lattice_parameters_and_boundary_conditions(hj.sets.Box(lo, hi), shape)``, whose
non-periodic axes are ``numpy.linspace(lo, hi, n)``. Pass its box with ``--lo`` and ``--hi``.

The script takes the two grids' overlap, reads hjacc's value at each of hj_reachability's nodes
inside it by multilinear interpolation (what the solver and the firmware do), and prints the
largest and the root-mean-square difference and how often the two agree on the sign of the
value (the safe set). Pure Python: numpy is not needed to read or compare.

    python3 python/compare_hj_reachability.py out/two-car hj_two_car.npy --lo=-5,-15 --hi=75,15

Exit status 0; 1 on bad input. ``--max-difference D`` makes a larger difference exit 2 (for CI).
"""

import argparse
import ast
import bisect
import json
import math
import os
import struct
import sys


def read_npy(path):
    """The shape and the values (C order, as floats) of a little-endian f4 or f8 .npy file."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:6] != b"\x93NUMPY":
        raise ValueError("%s: not a .npy file" % path)
    major = data[6]
    if major == 1:
        (header_len,) = struct.unpack_from("<H", data, 8)
        start = 10
    else:
        (header_len,) = struct.unpack_from("<I", data, 8)
        start = 12
    header = ast.literal_eval(data[start : start + header_len].decode("latin1"))
    descr, shape = header["descr"], tuple(header["shape"])
    if header.get("fortran_order"):
        raise ValueError("%s: Fortran order is not supported (save a C-ordered array)" % path)
    codes = {"<f4": "f", "<f8": "d"}
    if descr not in codes:
        raise ValueError("%s: dtype %s; expected little-endian float32 or float64" % (path, descr))
    n = 1
    for s in shape:
        n *= s
    values = struct.unpack_from("<%d%s" % (n, codes[descr]), data, start + header_len)
    return shape, list(values)


def strides(shape):
    out = [1] * len(shape)
    for k in range(len(shape) - 2, -1, -1):
        out[k] = out[k + 1] * shape[k + 1]
    return out


def interpolate(axes, values, point):
    """Multilinear interpolation on a rectilinear grid (C order); the point must lie inside."""
    base, frac = [], []
    for coords, x in zip(axes, point):
        i = min(max(bisect.bisect_right(coords, x) - 1, 0), len(coords) - 2)
        base.append(i)
        frac.append((x - coords[i]) / (coords[i + 1] - coords[i]))
    st = strides([len(a) for a in axes])
    total = 0.0
    for corner in range(1 << len(axes)):
        weight, flat = 1.0, 0
        for k in range(len(axes)):
            up = (corner >> k) & 1
            weight *= frac[k] if up else 1.0 - frac[k]
            flat += (base[k] + up) * st[k]
        if weight:
            total += weight * values[flat]
    return total


def compare(run_dir, hj_path, lo, hi):
    """The comparison's figures as a dictionary."""
    with open(os.path.join(run_dir, "axes.json")) as f:
        axes = [a["coordinates"] for a in json.load(f)["axes"]]
    shape, ours = read_npy(os.path.join(run_dir, "value.npy"))
    if list(shape) != [len(a) for a in axes]:
        raise ValueError("value.npy's shape %s does not match axes.json" % (shape,))
    hj_shape, theirs = read_npy(hj_path)
    if not (len(hj_shape) == len(axes) == len(lo) == len(hi)):
        raise ValueError("dimensions differ: hjacc %d, hj_reachability %d, --lo %d, --hi %d"
                         % (len(axes), len(hj_shape), len(lo), len(hi)))
    hj_axes = [[l + (h - l) * i / (n - 1) for i in range(n)] for l, h, n in zip(lo, hi, hj_shape)]
    st = strides(hj_shape)
    worst, squares, count, agree = 0.0, 0.0, 0, 0
    index = [0] * len(hj_shape)
    while True:
        point = [hj_axes[k][index[k]] for k in range(len(index))]
        if all(a[0] <= x <= a[-1] for a, x in zip(axes, point)):
            v_hj = theirs[sum(i * s for i, s in zip(index, st))]
            v_ours = interpolate(axes, ours, point)
            d = v_ours - v_hj
            worst = max(worst, abs(d))
            squares += d * d
            count += 1
            agree += (v_ours > 0) == (v_hj > 0)
        k = len(index) - 1
        while k >= 0:
            index[k] += 1
            if index[k] < hj_shape[k]:
                break
            index[k] = 0
            k -= 1
        if k < 0:
            break
    if count == 0:
        raise ValueError("the two grids do not overlap")
    return {
        "nodes_compared": count,
        "max_abs_difference": worst,
        "rms_difference": math.sqrt(squares / count),
        "sign_agreement": agree / count,
    }


def floats(text):
    return [float(x) for x in text.split(",")]


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("run_dir", help="hjacc's out/<name>/ (value.npy and axes.json)")
    p.add_argument("hj_value", help="hj_reachability's value, saved with numpy.save")
    p.add_argument("--lo", type=floats, required=True, help="hj_reachability's box, lower corner: a,b,...")
    p.add_argument("--hi", type=floats, required=True, help="hj_reachability's box, upper corner: a,b,...")
    p.add_argument("--max-difference", type=float, help="exit 2 if the largest difference exceeds this")
    a = p.parse_args(argv)
    try:
        r = compare(a.run_dir, a.hj_value, a.lo, a.hi)
    except (OSError, ValueError, KeyError) as e:
        print("error: %s" % e, file=sys.stderr)
        return 1
    print("%d nodes of hj_reachability's grid inside hjacc's: largest difference %.4g, "
          "RMS %.4g, same sign (safe set) at %.2f%%"
          % (r["nodes_compared"], r["max_abs_difference"], r["rms_difference"],
             100.0 * r["sign_agreement"]))
    if a.max_difference is not None and r["max_abs_difference"] > a.max_difference:
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
