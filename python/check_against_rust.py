"""Checks the Python reader against the Rust reader, bit for bit.

    python3 python/check_against_rust.py TABLE RECORDS

RECORDS is what ``cargo run -p table-format --example reference_lookups -- TABLE N RECORDS``
wrote: per state its coordinates, the Rust reader's value (NaN where it refused the state) and
policy (0 brake, 1 accelerate, 255 none). Exits 1 on the first disagreement.
"""

import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hjacc_table import Table, TableError  # noqa: E402


def main(table_path, records_path):
    table = Table.open(table_path)
    d = table.dims
    size = 4 * d + 5
    data = open(records_path, "rb").read()
    if len(data) % size:
        sys.exit("%s: not a whole number of %d-byte records" % (records_path, size))
    checked = refused = 0
    for at in range(0, len(data), size):
        state = struct.unpack_from("<%df" % d, data, at)
        (value,) = struct.unpack_from("<f", data, at + 4 * d)
        policy = data[at + 4 * d + 4]
        try:
            mine = table.value_at(state)
        except TableError:
            mine = float("nan")
        same = (math.isnan(mine) and math.isnan(value)) or struct.pack("<f", mine) == struct.pack("<f", value)
        if not same:
            sys.exit("value at %r: Python %r, Rust %r" % (state, mine, value))
        try:
            action = table.policy_at(state)
            mine_policy = 1 if action == "accelerate" else 0
        except TableError:
            mine_policy = 255
        if mine_policy != policy:
            sys.exit("policy at %r: Python %d, Rust %d" % (state, mine_policy, policy))
        checked += 1
        refused += math.isnan(value)
    print(
        "%s: %d states (%d outside the grid) agree with the Rust reader to the last bit"
        % (table_path, checked, refused)
    )


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
