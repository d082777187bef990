"""Counts the instructions executed per control step on the emulated Cortex-M4F.

Reads QEMU's `-d exec,nochain` log in single-step mode (one instruction per translation block,
so one log line per executed instruction) from a file or FIFO, and counts the lines between
each entry into `hjacc_step_begin` and the next entry into `hjacc_step_end` (the markers the
qemu-scenario binary calls around `Controller::step`). The scenario then calls one marker per
mode or path (every `hjacc_mode_*` symbol: `hjacc_mode_nominal`, ...), which files the step's
count under it. Prints the worst, median and mean over every step and per path, and exits
non-zero when the worst step exceeds BUDGET instructions (docs/board.md justifies each budget
in cycles).
Usage: count_instructions.py ELF LOG [BUDGET]"""
import re
import statistics
import subprocess
import sys

elf, log = sys.argv[1], sys.argv[2]
budget = int(sys.argv[3]) if len(sys.argv) > 3 else None
symbols = {}
for line in subprocess.run(["nm", elf], capture_output=True, text=True, check=True).stdout.splitlines():
    parts = line.split()
    if len(parts) == 3 and parts[2].startswith(("hjacc_step_", "hjacc_mode_")):
        symbols[parts[2]] = int(parts[0], 16) & ~1
begin, end = symbols["hjacc_step_begin"], symbols["hjacc_step_end"]
modes = {address: name.removeprefix("hjacc_mode_").replace("_", "-")
         for name, address in sorted(symbols.items()) if name.startswith("hjacc_mode_")}
per_mode = {name: [] for name in modes.values()}
pending = None
pc_re = re.compile(r"\[[0-9a-f]+/([0-9a-f]+)/")
counts, counting, n = [], False, 0
with open(log, errors="replace") as f:
    for line in f:
        m = pc_re.search(line)
        if not m:
            continue
        pc = int(m.group(1), 16)
        if pc == begin:
            counting, n = True, 0
        elif pc == end and counting:
            counts.append(n)
            counting, pending = False, n
        elif pc in modes and pending is not None:
            per_mode[modes[pc]].append(pending)
            pending = None
        if counting:
            n += 1
if not counts:
    sys.exit("no control step found between the markers")
print(f"instructions per control step over {len(counts)} steps: worst {max(counts)}, "
      f"median {int(statistics.median(counts))}, mean {statistics.mean(counts):.0f} "
      f"(from the begin marker's entry to the end marker's entry)")
for mode, values in per_mode.items():
    if values:
        print(f"  {mode}: {len(values)} steps, worst {max(values)}, "
              f"median {int(statistics.median(values))}")
    else:
        print(f"  {mode}: no step")
if sum(len(v) for v in per_mode.values()) != len(counts):
    sys.exit("a counted step has no mode marker")
if budget is not None:
    if max(counts) > budget:
        sys.exit(f"the worst control step, {max(counts)} instructions, is over its budget of {budget}")
    print(f"worst step within its budget: {max(counts)} of {budget} instructions "
          f"({100 * max(counts) / budget:.0f}%)")
