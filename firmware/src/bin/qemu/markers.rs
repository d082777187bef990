//! The instruction counter's step markers (`.ci/count_instructions.py`), shared by the QEMU
//! binaries: it counts the instructions between an entry into `hjacc_step_begin` and the next
//! entry into `hjacc_step_end`, and files the count under the `hjacc_mode_*` marker called next.

use core::hint::black_box;

/// Marks the start of a counted step.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_step_begin() {
    black_box(0x5eed_0001u32);
}

/// Marks the end of a counted step.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_step_end() {
    black_box(0x5eed_0002u32);
}
