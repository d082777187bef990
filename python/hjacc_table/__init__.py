"""Reads hjacc safety tables (``table.bin``, format version 7) in Python.

The format is specified byte by byte in ``table-format/README.md``; this reader follows it
and answers exactly as the Rust reader (``table_format::Table``) does, to the last bit:
every arithmetic step of the interpolation is rounded to IEEE single precision in the Rust
reader's order (a sum or product of two single-precision numbers, computed in double
precision and rounded once, is the correctly rounded single-precision result).

Pure Python; ``numpy`` is used only if installed, by :meth:`Table.values` and
:meth:`Table.axis`.

    >>> from hjacc_table import Table
    >>> t = Table.open("firmware/tables/default.bin")
    >>> t.game["kind"], [a["name"] for a in t.axes]
    ('ThreeCarSplit', ['gap_follower', 'follower_speed', 'ego_speed'])
    >>> t.value_at([10.0, 0.0, 0.0])   # the rear value at rest, 10 m behind
"""

import struct
import zlib

__all__ = ["Table", "TableError", "MAGIC", "FORMAT_VERSION"]

MAGIC = b"HJTB"
FORMAT_VERSION = 7
_PREAMBLE = 8
_CRC = 4


class TableError(ValueError):
    """A table the reader refuses, or a state it has no value for."""


def _f32(x):
    """``x`` rounded to the nearest IEEE single-precision number."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


class _Cursor:
    """postcard's wire format, as far as the header uses it."""

    def __init__(self, data):
        self.data = data
        self.at = 0

    def take(self, n):
        if self.at + n > len(self.data):
            raise TableError("the header ends early")
        out = self.data[self.at : self.at + n]
        self.at += n
        return out

    def u8(self):
        return self.take(1)[0]

    def varint(self):
        value, shift = 0, 0
        while True:
            byte = self.u8()
            value |= (byte & 0x7F) << shift
            if byte < 0x80:
                return value
            shift += 7
            if shift > 35:
                raise TableError("a varint is too long")

    def f32(self):
        return struct.unpack("<f", self.take(4))[0]

    def str(self):
        return self.take(self.varint()).decode("utf-8")

    def bounds(self):
        return {"min": self.f32(), "max": self.f32()}

    def idm(self):
        return {
            "max_acceleration": self.f32(),
            "comfortable_deceleration": self.f32(),
            "desired_speed": self.f32(),
            "exponent": self.u8(),
            "jam_distance": self.f32(),
        }


def _game(c):
    index = c.varint()
    if index == 0:
        return {"kind": "TwoCar", "ego": c.bounds(), "leader": c.bounds()}
    if index == 1:
        return {
            "kind": "ThreeCarBaseline",
            "ego": c.bounds(),
            "leader": c.bounds(),
            "follower": c.bounds(),
        }
    if index == 2:
        game = {
            "kind": "ThreeCarIdm",
            "ego": c.bounds(),
            "leader": c.bounds(),
            "follower_clip": c.bounds(),
            "idm": c.idm(),
            "time_gap": c.bounds(),
        }
        speed = c.varint()
        if speed == 0:
            game["follower_speed"] = {"kind": "NominalEgoSpeed", "ego_speed": c.f32()}
        elif speed == 1:
            game["follower_speed"] = {
                "kind": "Adversarial",
                "min_ego_speed": c.f32(),
                "max_speed": c.f32(),
            }
        else:
            raise TableError("unknown follower speed variant %d" % speed)
        return game
    if index == 3:
        return {
            "kind": "ThreeCarIdmSpeeds",
            "ego": c.bounds(),
            "leader": c.bounds(),
            "follower_clip": c.bounds(),
            "idm": c.idm(),
            "time_gap": c.bounds(),
            "max_speed": c.f32(),
        }
    if index == 4:
        game = {"kind": "ThreeCarSplit", "ego": c.bounds(), "leader": c.bounds()}
        # The follower model (format version 5): an enum, one variant so far.
        follower = c.varint()
        if follower != 0:
            raise TableError("unknown follower model %d" % follower)
        game["follower"] = {
            "kind": "Idm",
            "clip": c.bounds(),
            "idm": c.idm(),
            "time_gap": c.bounds(),
        }
        game["max_speed"] = c.f32()
        # The emergency declaration (format version 6; the lights' deceleration since 7).
        game["emergency"] = {
            "braking": {"level": c.f32(), "jerk": c.f32()},
            "follower_reaction_time": c.f32(),
            "lights_deceleration": c.f32(),
            "lights_command": c.f32(),
        }
        return game
    raise TableError("unknown game variant %d" % index)


def _declared_length(data, header_len):
    """The table's length as its header declares it (header not yet trusted), or None."""
    probe = Table.__new__(Table)
    try:
        probe._decode_header(data, header_len)
    except Exception:
        return None
    nodes = 1
    for a in probe.axes:
        nodes *= a["points"]
    listed = sum(4 * a["points"] for a in probe.axes if a["spacing"] == "Listed")
    policy_len = 0 if probe.policy_encoding == "None" else (nodes + 7) // 8
    return _PREAMBLE + header_len + listed + nodes * (probe.bits // 8) + policy_len + _CRC


class Table:
    """A parsed table: its header as dictionaries, and lookups that match the Rust reader."""

    def __init__(self, data):
        data = bytes(data)
        if len(data) < _PREAMBLE + _CRC:
            raise TableError("truncated: %d bytes" % len(data))
        if data[:4] != MAGIC:
            raise TableError("not a table (bad magic)")
        version, header_len = struct.unpack_from("<HH", data, 4)
        if version != FORMAT_VERSION:
            raise TableError("unsupported version %d (this reader reads %d)" % (version, FORMAT_VERSION))
        if len(data) < _PREAMBLE + header_len + _CRC:
            raise TableError(
                "truncated: %d bytes, the preamble announces at least %d"
                % (len(data), _PREAMBLE + header_len + _CRC)
            )
        stored = struct.unpack_from("<I", data, len(data) - _CRC)[0]
        computed = zlib.crc32(data[:-_CRC]) & 0xFFFFFFFF
        if stored != computed:
            # A file cut short fails its CRC too: say so when the (not yet trusted) header
            # declares more bytes than there are, as the Rust reader does.
            needed = _declared_length(data, header_len)
            if needed is not None and needed > len(data):
                raise TableError("truncated: %d bytes, the header declares %d" % (len(data), needed))
            raise TableError("checksum: stored %08x, computed %08x" % (stored, computed))
        header_end = _PREAMBLE + header_len
        self._decode_header(data, header_len)

        # The payload: breakpoints, values, policy bits.
        self.nodes = 1
        for a in self.axes:
            self.nodes *= a["points"]
        at = header_end
        for a in self.axes:
            if a["spacing"] == "Listed":
                n = a["points"]
                a["breakpoints"] = list(struct.unpack_from("<%df" % n, data, at))
                at += 4 * n
                b = a["breakpoints"]
                if b[0] != a["min"] or b[-1] != a["max"] or any(y <= x for x, y in zip(b, b[1:])):
                    raise TableError("axis %s: breakpoints not increasing from min to max" % a["name"])
        width = self.bits // 8
        values_len = self.nodes * width
        policy_len = 0 if self.policy_encoding == "None" else (self.nodes + 7) // 8
        if len(data) != at + values_len + policy_len + _CRC:
            raise TableError("payload size: expected %d bytes" % (at + values_len + policy_len + _CRC))
        fmt = "<%d%s" % (self.nodes, "B" if width == 1 else "H")
        self._stored = struct.unpack_from(fmt, data, at)
        self._policy = data[at + values_len : at + values_len + policy_len]
        # Per axis, as the Rust reader keeps them.
        self._strides = [1] * len(self.axes)
        for k in range(len(self.axes) - 2, -1, -1):
            self._strides[k] = self._strides[k + 1] * self.axes[k + 1]["points"]
        self._inv_spacing, self._last = [], []
        for a in self.axes:
            spacing = _f32((a["max"] - a["min"]) / float(max(a["points"] - 1, 1)))
            self._inv_spacing.append(_f32(1.0 / spacing))
            self._last.append(float(a["points"] - 1))
        self._len = len(data)

    def _decode_header(self, data, header_len):
        """Decodes the postcard header into this object's fields (raises on a malformed one)."""
        header_end = _PREAMBLE + header_len
        c = _Cursor(data[_PREAMBLE:header_end])
        self.game = _game(c)
        self.min_gap = c.f32()
        seconds = c.f32()
        status = c.varint()
        if status == 0:
            self.horizon = {"seconds": seconds, "status": "Fixed"}
        elif status in (1, 2):
            self.horizon = {
                "seconds": seconds,
                "status": "Converged" if status == 1 else "NotConverged",
                "tolerance": c.f32(),
                "residual": c.f32(),
            }
        elif status == 3:
            self.horizon = {
                "seconds": seconds,
                "status": "Proven",
                "residual": c.f32(),
                "drift": c.f32(),
                "stretch": c.f32(),
            }
        else:
            raise TableError("unknown horizon status %d" % status)
        self.axes = []
        for _ in range(c.varint()):
            axis = {"name": c.str(), "unit": c.str(), "min": c.f32(), "max": c.f32()}
            axis["points"] = c.varint()
            spacing = c.varint()
            if spacing not in (0, 1):
                raise TableError("unknown spacing %d" % spacing)
            axis["spacing"] = "Listed" if spacing == 1 else "Uniform"
            self.axes.append(axis)
        self.trusted_box = [c.bounds() for _ in range(c.varint())]
        self.bits = c.u8()
        self.scale = c.f32()
        self.offset = c.f32()
        self.error_bound_parts = {"quantization": c.f32(), "interpolation": c.f32()}
        # The total as the Rust reader adds it, in single precision.
        self.error_bound = _f32(
            self.error_bound_parts["quantization"] + self.error_bound_parts["interpolation"]
        )
        policy = c.varint()
        if policy not in (0, 1):
            raise TableError("unknown policy encoding %d" % policy)
        self.policy_encoding = "None" if policy == 1 else "SignBitWeightedVote"
        # What solver verify proved of the table (an Option: 0 None, 1 and the record).
        present = c.u8()
        if present == 0:
            self.verification = None
        elif present == 1:
            self.verification = {
                "verifier": c.varint(),
                "rear_margin": c.f32(),
                "certified_cells": c.varint(),
                "proven_cells": c.varint(),
                "shortest_period": c.f32(),
                "longest_period": c.f32(),
                # The measurement error the table was checked under (format version 5).
                "measurement_error": {
                    k: c.f32()
                    for k in (
                        "range",
                        "range_relative",
                        "range_rate",
                        "ego_speed",
                        "ego_speed_relative",
                        "ego_age",
                    )
                },
            }
        else:
            raise TableError("invalid verification flag %d" % present)
        if c.at != header_len:
            raise TableError("the header's length does not match its encoding")
        if self.bits not in (8, 16) or not 1 <= len(self.axes) <= 6:
            raise TableError("invalid header")
        if any(a["points"] < 2 for a in self.axes):
            raise TableError("an axis has fewer than 2 points")
        self.header = {
            "game": self.game,
            "min_gap": self.min_gap,
            "horizon": self.horizon,
            "axes": [dict(a) for a in self.axes],
            "trusted_box": self.trusted_box,
            "quantization": {"bits": self.bits, "scale": self.scale, "offset": self.offset},
            "error_bound": self.error_bound_parts,
            "policy": self.policy_encoding,
            "verification": self.verification,
        }

    @classmethod
    def open(cls, path):
        """Reads and parses the file at ``path``."""
        with open(path, "rb") as f:
            return cls(f.read())

    @property
    def dims(self):
        """The number of state axes."""
        return len(self.axes)

    def lookup(self, state):
        """``(value_at(state), policy_at(state))``."""
        return self.value_at(state), self.policy_at(state)

    def contains(self, state):
        """Whether ``state`` lies on the table's grid."""
        try:
            self._cell(state)
        except (TableError, TypeError, ValueError):
            return False
        return True

    def __len__(self):
        return self._len

    def __repr__(self):
        return "Table(%s, %d axes, %d nodes, %d bytes)" % (
            self.game["kind"],
            self.dims,
            self.nodes,
            len(self),
        )

    def coordinates(self, k):
        """The node coordinates of axis ``k``, as floats."""
        a = self.axes[k]
        if a["spacing"] == "Listed":
            return list(a["breakpoints"])
        step = (a["max"] - a["min"]) / (a["points"] - 1)
        return [_f32(a["min"] + i * step) for i in range(a["points"])]

    def node_value(self, node):
        """The dequantized value at a flat (C-order) node index."""
        return _f32(self.offset + _f32(self.scale * float(self._stored[node])))

    def values(self):
        """Every node's dequantized value: a float32 numpy array shaped like the grid if numpy
        is installed, else a flat list in C order."""
        flat = [self.node_value(k) for k in range(self.nodes)]
        try:
            import numpy as np
        except ImportError:
            return flat
        return np.array(flat, dtype=np.float32).reshape([a["points"] for a in self.axes])

    def _cell(self, state):
        if len(state) != len(self.axes):
            raise TableError("the state has %d coordinates, the table %d axes" % (len(state), len(self.axes)))
        base, frac = 0, []
        for k, (x, a) in enumerate(zip(state, self.axes)):
            x = _f32(x)
            if x != x or x in (float("inf"), float("-inf")):
                raise TableError("axis %d: not finite" % k)
            if x < a["min"] or x > a["max"]:
                raise TableError("axis %d: outside the grid" % k)
            last_cell = a["points"] - 2
            if a["spacing"] == "Uniform":
                s = _f32(_f32(x - a["min"]) * self._inv_spacing[k])
                s = s if s > 0.0 else 0.0
                s = s if s < self._last[k] else self._last[k]
                i = min(int(s), last_cell)
                t = _f32(s - float(i))
            else:
                b = a["breakpoints"]
                lo, hi = 0, last_cell
                while lo < hi:
                    mid = lo + (hi - lo + 1) // 2
                    if b[mid] <= x:
                        lo = mid
                    else:
                        hi = mid - 1
                i = lo
                left, right = b[lo], b[lo + 1]
                t = _f32(_f32(x - left) / _f32(right - left)) if right > left else 0.0
                t = t if t > 0.0 else 0.0
                t = t if t < 1.0 else 1.0
            base += i * self._strides[k]
            frac.append(t)
        return base, frac

    def _corners(self, base, frac):
        """The corners in the Rust reader's order, with weights built as it builds them."""
        d = len(self.axes)
        low = (d + 1) // 2

        def half(axes):
            weight, offset = [1.0], [0]
            for k in axes:
                t = frac[k]
                one_minus = _f32(1.0 - t)
                weight = [_f32(w * one_minus) for w in weight] + [_f32(w * t) for w in weight]
                offset = offset + [o + self._strides[k] for o in offset]
            return weight, offset

        wa, oa = half(range(low))
        wb, ob = half(range(low, d))
        for w_high, o_high in zip(wb, ob):
            for w_low, o_low in zip(wa, oa):
                yield base + o_low + o_high, _f32(w_low * w_high)

    def value_at(self, state):
        """The multilinear interpolation of the dequantized values at ``state``."""
        base, frac = self._cell(state)
        total = 0.0
        for node, w in self._corners(base, frac):
            total = _f32(total + _f32(w * float(self._stored[node])))
        return _f32(self.offset + _f32(self.scale * total))

    def policy_at(self, state):
        """The ego's bang-bang input at ``state``: ``"accelerate"`` or ``"brake"`` (the corners'
        weighted vote; an exact tie takes the heaviest corner's bit)."""
        if self.policy_encoding == "None":
            raise TableError("the table has no policy bits")
        base, frac = self._cell(state)
        vote, heaviest = 0.0, (-1.0, False)
        for node, w in self._corners(base, frac):
            bit = (self._policy[node >> 3] >> (node & 7)) & 1 == 1
            vote = _f32(vote + (w if bit else -w))
            if w > heaviest[0]:
                heaviest = (w, bit)
        accelerate = vote > 0.0 if vote != 0.0 else heaviest[1]
        return "accelerate" if accelerate else "brake"
