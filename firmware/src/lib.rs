//! hjacc's ACC safety controller: keeps the ego car between a human leader and a human follower
//! using a safety table compiled by the hjacc solver from a Hamilton-Jacobi-Isaacs analysis
//! (Bahati, Gibson & Bayen, arXiv:2112.14344).
//!
//! Why it is built this way:
//! - `#![no_std]`, no heap: it runs on a Cortex-M4F with a fixed memory budget. The table is
//!   read in place (`table_format::Table` borrows the bytes, e.g. from `include_bytes!`), the event
//!   log is a `heapless::Deque`.
//! - No panics on the control path: no `unwrap`, no indexing that can fail, no float-to-index
//!   cast without a range check (the lints below enforce it). Every bad input is a typed
//!   [`Fault`] with a documented reaction (see [`controller`]).
//! - One math module ([`math`]) so that host tests run the target's arithmetic.
//! - Hardware behind traits ([`Sensors`], [`Actuator`], [`DriverDisplay`], [`Clock`],
//!   [`Watchdog`]), with a CAN driver over `embedded-can` ([`can`]). The crate knows no board:
//!   `board-stm32f4` (in `board/`) puts it on an STM32F407.
//!
//! The default table (`tables/default.bin`, 693 KiB) is the split three-car certificate's rear
//! value (see [`controller`]); it comes from
//! `cargo run -p solver --release -- --rear solver/configs/rear/deployment.toml` (part of the
//! main job); copy `out/deployment/table.bin` over it to regenerate it.
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

mod fmt;

pub mod can;
pub mod config;
pub mod controller;
pub mod driver;
pub mod hardware;
pub mod inputs;
pub mod iso15622;
pub mod math;
pub mod sensing;

pub use controller::{
    Authorities, Braking, Certificate, CertificateConfig, Certifier, Command, Config, Controller,
    DriverError, DriverRequest, DriverState, EmergencyDeclaration, Event, FallbackConfig, Fault,
    LawConfig, Mode, OverridePolicy, PlantConfig, CERTIFICATE_TOLERANCE, REAR_SAMPLE_TOLERANCE,
    SPEED_TOLERANCE,
};
pub use hardware::{Actuator, Clock, DriverDisplay, Sensors, Watchdog};
pub use inputs::{Inputs, Measurement, Track};
pub use sensing::{SensorBounds, TrackState};
pub use table_format;

/// The default table: the split three-car certificate at the ego's braking level 3.5 m/s^2,
/// every speed in [0, 35] m/s; the stationary rear value on 133 x 73 x 73 listed breakpoints of
/// 8 bits.
pub static DEFAULT_TABLE: &[u8] = include_bytes!("../tables/default.bin");

/// Runs one control period: reads the sensors, steps the controller, sends the command and
/// feeds the watchdog. A sensor read error yields the minimum-risk manoeuvre (the controller is
/// stepped with the last inputs marked invalid), an actuator error is returned after the
/// watchdog is fed, so that the caller decides.
pub fn run_period<S: Sensors, A: Actuator, C: Clock, W: Watchdog>(
    controller: &mut Controller<'_>,
    sensors: &mut S,
    actuator: &mut A,
    clock: &mut C,
    watchdog: &mut W,
) -> Result<Command, A::Error> {
    period(
        controller,
        &mut (sensors, actuator),
        |io, now| io.0.read(now).ok(),
        |io, command| io.1.request(command),
        clock,
        watchdog,
    )
}

/// [`run_period`] over one transport that both delivers the inputs and takes the command, such
/// as a CAN bus ([`can::CanBus`]): the same period, in the same order, and the driver's state
/// shown on the display after the command is sent ([`DriverDisplay`]). The display is not the
/// control path: a display that could not be shown is the transport's to count
/// ([`can::CanBus::unshown`]), and the period's result is the command's.
pub fn run_period_on_bus<B: Sensors + Actuator + DriverDisplay, C: Clock, W: Watchdog>(
    controller: &mut Controller<'_>,
    bus: &mut B,
    clock: &mut C,
    watchdog: &mut W,
) -> Result<Command, <B as Actuator>::Error> {
    let command = period(
        controller,
        bus,
        |bus, now| bus.read(now).ok(),
        |bus, command| bus.request(command),
        clock,
        watchdog,
    );
    let _ = bus.show(&controller.driver());
    command
}

/// The period, once: the time, the inputs (all invalid if they could not be read), the step,
/// the command sent, and the watchdog fed whatever the send did.
fn period<T, E, C: Clock, W: Watchdog>(
    controller: &mut Controller<'_>,
    io: &mut T,
    read: fn(&mut T, u64) -> Option<Inputs>,
    request: fn(&mut T, &Command) -> Result<(), E>,
    clock: &mut C,
    watchdog: &mut W,
) -> Result<Command, E> {
    let now = clock.now_us();
    let inputs = read(io, now).unwrap_or_else(|| Inputs::invalid(now));
    let command = controller.step(&inputs);
    let sent = request(io, &command);
    watchdog.feed();
    sent.map(|()| command)
}
