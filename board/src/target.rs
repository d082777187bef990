//! What only exists on the target: the table's flash slot, bounded by the linker's symbols
//! (`memory.x`), and words of RAM that a reset keeps (cortex-m-rt's `.uninit`, never
//! initialised), where the fault handlers leave their marker for the next boot and the loop
//! keeps the acceleration requests' rolling counter; and the controller's state, in `.bss`
//! (where the linker checks it against RAM) rather than on the 16 KiB stack. The binaries'
//! only other unsafe code is their entry and fault handlers.
#![allow(unsafe_code)]

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use firmware::{Config, Controller};

use crate::boot::{counter_from_words, counter_words, FaultMarker};

extern "C" {
    static __table_slot_start: u8;
    static __table_slot_end: u8;
    static _stack_start: u8;
    static _stack_end: u8;
}

/// The word the free stack is painted with.
const STACK_PAINT: u32 = 0x5AC4_5AC4;

/// The stack region (`memory.x`): its lowest address and the one above its top.
fn stack_region() -> (usize, usize) {
    // Only the symbols' addresses are taken.
    (
        addr_of!(_stack_end) as usize,
        addr_of!(_stack_start) as usize,
    )
}

/// Paints the free stack, from the region's bottom to just below the stack pointer, so that
/// [`stack_high_water`] can tell how deep the stack has ever been since. Call once, early.
pub fn paint_stack() {
    let (bottom, _) = stack_region();
    let sp = cortex_m::register::msp::read() as usize;
    // Leave the words right below the stack pointer alone: this function's own calls use them.
    let top = sp.saturating_sub(64) & !3;
    let mut at = bottom;
    while at < top {
        // SAFETY: [bottom, top) is stack below the stack pointer: nothing lives there.
        unsafe { core::ptr::write_volatile(at as *mut u32, STACK_PAINT) };
        at += 4;
    }
}

/// The most stack used since [`paint_stack`], in bytes: from the top of the region down to the
/// lowest word no longer painted (a lower bound if a frame happened to write the paint word).
pub fn stack_high_water() -> usize {
    let (bottom, top) = stack_region();
    let mut at = bottom;
    // SAFETY: reads of the stack region's words, below the stack pointer or in use: any value
    // is a valid u32.
    while at < top && unsafe { core::ptr::read_volatile(at as *const u32) } == STACK_PAINT {
        at += 4;
    }
    top - at
}

/// The table's flash slot (the linker's `TABLE` region), read in place.
pub fn table_slot() -> &'static [u8] {
    // SAFETY: the linker places both symbols at the ends of the TABLE region, which is flash:
    // readable, never written by the program, and 'static.
    unsafe {
        let start = addr_of!(__table_slot_start);
        let end = addr_of!(__table_slot_end);
        core::slice::from_raw_parts(start, (end as usize).saturating_sub(start as usize))
    }
}

/// Two words of RAM that a reset keeps, and power-on fills with garbage: hence a word and its
/// complement wherever they hold a value.
#[repr(transparent)]
pub struct KeptWords(
    // Read and written through raw pointers only (`read`, `write`).
    #[allow(dead_code)] MaybeUninit<[u32; 2]>,
);

impl KeptWords {
    /// Words to place in `.uninit` (`#[link_section = ".uninit.NAME"]`).
    pub const fn new() -> Self {
        KeptWords(MaybeUninit::uninit())
    }
}

impl Default for KeptWords {
    fn default() -> Self {
        KeptWords::new()
    }
}

/// Reads `words`: any bit pattern is a valid `[u32; 2]`.
///
/// # Safety
/// No other access to `words` may run at the same time (single core: no interrupt handler
/// that touches them preempting the caller).
pub unsafe fn read(words: *const KeptWords) -> [u32; 2] {
    // SAFETY: the caller's; the read is volatile so that it is never elided.
    unsafe { core::ptr::read_volatile(words.cast::<[u32; 2]>()) }
}

/// Writes `value` into `words`.
///
/// # Safety
/// As for [`read`].
pub unsafe fn write(words: *mut KeptWords, value: [u32; 2]) {
    // SAFETY: the caller's.
    unsafe { core::ptr::write_volatile(words.cast::<[u32; 2]>(), value) }
}

/// The fault handlers' marker.
#[link_section = ".uninit.HJACC_FAULT_MARKER"]
static mut FAULT_MARKER: KeptWords = KeptWords::new();

/// The marker the last run left, then cleared: call once at boot, before interrupts.
pub fn take_fault_marker() -> FaultMarker {
    // SAFETY: boot runs alone; the fault handlers that write the marker never return.
    unsafe {
        let marker = FaultMarker(read(addr_of!(FAULT_MARKER)));
        write(addr_of_mut!(FAULT_MARKER), FaultMarker::CLEAR.0);
        marker
    }
}

/// Leaves the marker for the next boot: for the fault handlers, which then reset.
pub fn set_fault_marker() {
    // SAFETY: a fault handler runs alone and never returns to the code it interrupted.
    unsafe { write(addr_of_mut!(FAULT_MARKER), FaultMarker::SET.0) }
}

/// The rolling counter of the next acceleration request.
#[link_section = ".uninit.HJACC_REQUEST_COUNTER"]
static mut REQUEST_COUNTER: KeptWords = KeptWords::new();

/// The counter the next acceleration request carries, as the last run left it; 0 after a
/// power-on.
pub fn kept_request_counter() -> u8 {
    // SAFETY: single core; the loop and the fault handlers, which never return, are the only
    // users, one at a time.
    counter_from_words(unsafe { read(addr_of!(REQUEST_COUNTER)) }).unwrap_or(0)
}

/// Keeps the counter the next acceleration request carries, for a fault handler's last frame
/// and for the run after a reset.
pub fn keep_request_counter(counter: u8) {
    // SAFETY: as in `kept_request_counter`.
    unsafe { write(addr_of_mut!(REQUEST_COUNTER), counter_words(counter)) }
}

/// The controller, made once in a static: its state (the command history, the event log, the
/// table's view: about 8 KB) then sits in `.bss`, sized and placed by the linker, and the
/// stack keeps its 16 KiB for the control step's frames. `None` at a second call (there is one
/// controller). The constructor's value is written straight into the static
/// (`cortex_m::singleton!`); `.ci/board.sh`'s stack budget shows that no copy of it passes
/// through the stack.
// The `&'static mut` is the static's, made once; the table is only borrowed by it.
#[allow(clippy::mut_from_ref)]
pub fn controller(
    table: &'static [u8],
    config: Config,
) -> Option<&'static mut Controller<'static>> {
    cortex_m::singleton!(CONTROLLER: Controller<'static> = Controller::new(table, config))
}
