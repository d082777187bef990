//! hjacc's safety controller on a real board: an STM32F407 (or F405) with bxCAN.
//!
//! The control law, the certificate, the faults and the CAN protocol live in the portable
//! [`firmware`] crate; this crate is what a board adds around them, kept apart so that the
//! hardware can change without touching what is proven:
//! - [`clock`]: the controller's monotonic microsecond clock, from a 32-bit hardware counter;
//! - [`takeover`]: the driver's takeover request (a lamp or chime) on an `embedded-hal` 1.0
//!   output pin, on whenever the controller is not certifying;
//! - [`boot`]: where the table is (its own flash slot), and what a restart after a fault of
//!   the board's own means (the minimum-risk manoeuvre until power-on);
//! - [`can_timing`]: the bxCAN bit timing, derived;
//! - [`last_resort`]: the one frame a HardFault or panic handler still sends.
//!
//! Everything here is portable and tested on the host (`embedded-hal-mock` for the pin). The
//! binaries put it on the hardware: `stm32f407` (stm32f4xx-hal, bxcan, defmt over RTT) and
//! `netduino-check`, the board-independent part on QEMU's `netduinoplus2` (an STM32F405).
//!
//! Why stm32f4xx-hal and not embassy-stm32 (measured side by side, docs/board.md, "On a real
//! board"): its bxCAN driver implements `embedded_can::nb::Can`, which the firmware's CAN driver is
//! written against, where embassy's would need an adapter; the loop is a plain periodic loop with
//! no async executor to reason about; and its binary is the smaller of the two.
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::unreachable,
        clippy::cast_possible_truncation
    )
)]

/// Defines the core's HardFault handler: it first moves the stack pointer back to the top of the
/// stack region (`_stack_start`, `memory.x`), then branches to `$handler`, an
/// `extern "C" fn(u32) -> !` that gets the stack pointer the fault left. A stack overflow faults
/// with the stack pointer below RAM, where a handler with a prologue would fault again and lock the
/// core up; on a fresh stack it runs. The faulting context is discarded: the handler never returns.
#[macro_export]
macro_rules! hard_fault_on_fresh_stack {
    ($handler:path) => {
        core::arch::global_asm!(
            ".section .HardFault.hjacc, \"ax\"",
            ".global HardFault",
            ".type HardFault,%function",
            ".thumb_func",
            "HardFault:",
            "mrs r0, msp",
            "movw r1, :lower16:_stack_start",
            "movt r1, :upper16:_stack_start",
            "msr msp, r1",
            "b {handler}",
            ".size HardFault, . - HardFault",
            handler = sym $handler,
        );
    };
}

pub mod boot;
pub mod can_timing;
pub mod clock;
pub mod last_resort;
pub mod takeover;
#[cfg(all(target_os = "none", any(feature = "stm32f407", feature = "qemu")))]
pub mod target;

/// The control period: 50 Hz, the firmware's default.
pub const PERIOD_US: u32 = 20_000;

/// The independent watchdog's timeout, ms: five periods. It is fed once per completed control
/// step (`firmware::run_period` feeds it after the command is sent), so a step that hangs, a
/// loop that stops, or a core locked up by a fault the handlers could not take (a stack
/// overflow) resets the board within this time; the restart is then latched into the
/// minimum-risk manoeuvre ([`boot::restart_fault`]).
pub const WATCHDOG_TIMEOUT_MS: u32 = 100;
