"""hjacc from Python: solve a config, prove its table, sweep many (on a Dask cluster too), drive
the firmware against a table, and read tables.

The work is done by the project's own Rust code (``hjacc._native``), with the GIL released; this
module gives its table reader the same interface as the pure-Python reader ``hjacc_table`` (a
test holds them to it) and hands a sweep's tasks to Dask.

    >>> import hjacc
    >>> t = hjacc.Table.open("firmware/tables/default.bin")
    >>> t.game["kind"], t.dims, t.error_bound
    ('ThreeCarSplit', 3, 0.01229012...)
    >>> report = hjacc.verify("firmware/tables/default.bin")   # about 15 s
    >>> report["failure"] is None
    True

Doors, each the command line's (``cargo run -p solver -- --help``, ``host-tests --help``):

- :func:`run` and :func:`run_rear`: a level-set config or a rear config, into ``out/<name>/``;
- :func:`verify`: ``solver verify``;
- :func:`sweep`: ``solver sweep``, locally or on a Dask cluster;
- :func:`campaign` and :func:`falsify`: the closed loop (``host-tests campaign``,
  ``host-tests falsify``).

Errors: a bad config, argument or table raises :class:`TableError` (tables) or ``ValueError``
(the rest), with the Rust message naming the key or argument; a missing or unwritable path
raises ``OSError``.
"""

import struct
import sys
import time

from . import _native
from ._native import FORMAT_VERSION, campaign, falsify, run, run_rear, verify

__all__ = [
    "FORMAT_VERSION",
    "Table",
    "TableError",
    "campaign",
    "falsify",
    "run",
    "run_rear",
    "sweep",
    "verify",
]


class TableError(ValueError):
    """A table the reader refuses, or a state it has no value for."""


def _f32(x):
    """``x`` as the single-precision number it was stored as (JSON carries it in decimal)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _tagged(value):
    """serde's enum form ``{"Variant": {fields}}`` (or ``"Variant"``) as ``{"kind": ...}``."""
    if isinstance(value, str):
        return {"kind": value}
    ((kind, fields),) = value.items()
    out = {"kind": kind}
    for k, v in fields.items():
        out[k] = _tagged(v) if k in ("follower_speed", "follower") else v
    return out


def _floats(value):
    """Every float of a parsed JSON value rounded to single precision, as the file holds it."""
    if isinstance(value, float):
        return _f32(value)
    if isinstance(value, dict):
        return {k: _floats(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_floats(v) for v in value]
    return value


class Table:
    """A parsed table: its header as dictionaries, and lookups by the Rust reader, bit for bit
    as the firmware's. The same interface as ``hjacc_table.Table``:

    - ``Table(data)``, ``Table.open(path)``;
    - ``header`` (the format's fields, ``table-format/README.md``), and from it ``game``,
      ``min_gap``, ``horizon``, ``axes`` (with ``breakpoints`` on a listed axis),
      ``trusted_box``, ``bits``, ``scale``, ``offset``, ``error_bound`` (the total, m: the
      firmware certifies a value above it), ``error_bound_parts``, ``policy_encoding``,
      ``verification``, ``nodes``, ``dims``;
    - ``value_at``, ``policy_at``, ``lookup``, ``contains``, ``coordinates``, ``node_value``,
      ``values``, ``len(table)`` (bytes).
    """

    def __init__(self, data):
        try:
            self._native = _native.Table(bytes(data))
        except ValueError as e:
            raise TableError(str(e)) from None
        raw = self._native.header
        axes = _floats(raw["axes"])
        horizon = {"seconds": _f32(raw["horizon"]["seconds"])}
        horizon.update(_floats(_tagged(raw["horizon"]["status"])))
        horizon["status"] = horizon.pop("kind")
        self.header = {
            "game": _floats(_tagged(raw["game"])),
            "min_gap": _f32(raw["min_gap"]),
            "horizon": horizon,
            "axes": axes,
            "trusted_box": _floats(raw["trusted_box"]),
            "quantization": _floats(raw["quantization"]),
            "error_bound": _floats(raw["error_bound"]),
            "policy": raw["policy"],
            "verification": _floats(raw["verification"]),
        }
        self.game = self.header["game"]
        self.min_gap = self.header["min_gap"]
        self.horizon = self.header["horizon"]
        self.axes = [dict(a) for a in axes]
        for k, a in enumerate(self.axes):
            if a["spacing"] == "Listed":
                a["breakpoints"] = self._native.coordinates(k)
        self.trusted_box = self.header["trusted_box"]
        q = self.header["quantization"]
        self.bits, self.scale, self.offset = q["bits"], q["scale"], q["offset"]
        self.error_bound = self._native.error_bound
        self.error_bound_parts = self.header["error_bound"]
        self.policy_encoding = self.header["policy"]
        self.verification = self.header["verification"]
        self.nodes = 1
        for a in self.axes:
            self.nodes *= a["points"]

    @classmethod
    def open(cls, path):
        """Reads and parses the file at ``path``."""
        with open(path, "rb") as f:
            return cls(f.read())

    @property
    def dims(self):
        """The number of state axes."""
        return len(self.axes)

    def _ask(self, method, state):
        try:
            return method([float(x) for x in state])
        except ValueError as e:
            raise TableError(str(e)) from None

    def value_at(self, state):
        """The multilinear interpolation of the dequantized values at ``state``."""
        return self._ask(self._native.value_at, state)

    def policy_at(self, state):
        """The ego's bang-bang input at ``state``: ``"accelerate"`` or ``"brake"``."""
        return self._ask(self._native.policy_at, state)

    def lookup(self, state):
        """``(value_at(state), policy_at(state))``."""
        return self.value_at(state), self.policy_at(state)

    def contains(self, state):
        """Whether ``state`` lies on the table's grid."""
        try:
            return self._native.contains([float(x) for x in state])
        except (TypeError, ValueError):
            return False

    def coordinates(self, k):
        """The node coordinates of axis ``k``, as floats."""
        return self._ask(lambda _: self._native.coordinates(k), ())

    def node_value(self, node):
        """The dequantized value at a flat (C-order) node index."""
        return self._ask(lambda _: self._native.node_value(node), ())

    def values(self):
        """Every node's dequantized value: a float32 numpy array shaped like the grid if numpy
        is installed, else a flat list in C order."""
        flat = self._native.node_values()
        try:
            import numpy as np
        except ImportError:
            return flat
        return np.array(flat, dtype=np.float32).reshape([a["points"] for a in self.axes])

    def __len__(self):
        return len(self._native)

    def __repr__(self):
        return "Table(%s, %d axes, %d nodes, %d bytes)" % (
            self.game["kind"],
            self.dims,
            self.nodes,
            len(self),
        )


def _run_task(task, sweep_name, out):
    """One task of a sweep, on whichever worker runs it (module level, so Dask can ship it)."""
    return _native.run_sweep_task(task, sweep_name, out)


def sweep(path, out="out", client=None, progress=True):
    """Runs a sweep file (``solver sweep``; ``solver/configs/reference/sweep.toml`` documents
    one): every point's table solved, proven and measured; returns the summary that
    ``out/<name>/sweep.json`` holds.

    Without ``client``, on this machine: the tables in parallel, in Rust. With a
    ``dask.distributed.Client``, one task per distinct table on the cluster's workers (each
    worker needs this package; ``out`` must be a folder every worker and this process can write,
    a shared file system on many machines), and the summary written here from their results.
    ``progress`` prints a line to stderr as each table finishes.
    """
    if client is None:
        return _native.sweep(str(path), str(out))
    from distributed import as_completed

    started = time.time()
    name, tasks = _native.sweep_tasks(str(path))
    futures = client.map(_run_task, tasks, sweep_name=name, out=str(out), pure=False)
    results = []
    for k, future in enumerate(as_completed(futures), 1):
        results.append(future.result())
        if progress:
            print("sweep %s: %d of %d tables" % (name, k, len(tasks)), file=sys.stderr)
    return _native.write_sweep_summary(str(path), results, str(out), time.time() - started)
