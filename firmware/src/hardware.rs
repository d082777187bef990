//! The traits the hardware implements: the sensors that deliver the inputs, the actuator that
//! takes the commands, the driver's display, the clock and the watchdog. A board crate (or a
//! simulation) implements them; the controller knows none of them.

use crate::controller::Command;
use crate::driver::DriverState;
use crate::inputs::Inputs;

/// The source of the front and rear radar tracks and the ego speed (a radar fusion ECU on CAN,
/// or a simulation).
pub trait Sensors {
    /// The transport's error.
    type Error;
    /// The latest inputs as of `now_us`. Measurements not refreshed keep their old time stamps;
    /// the controller judges their age.
    fn read(&mut self, now_us: u64) -> Result<Inputs, Self::Error>;
}

/// The longitudinal acceleration request to the powertrain and brakes.
pub trait Actuator {
    /// The transport's error.
    type Error;
    /// Requests `acceleration` m/s^2 (negative: braking).
    fn request(&mut self, command: &Command) -> Result<(), Self::Error>;
}

/// The driver's display (an instrument cluster on CAN, or a simulation): whether the ACC is
/// engaged, the set speed and time-gap setting, and why the latest request was refused.
pub trait DriverDisplay {
    /// The transport's error.
    type Error;
    /// Shows `driver` ([`crate::Controller::driver`]).
    fn show(&mut self, driver: &DriverState) -> Result<(), Self::Error>;
}

/// A monotonic clock.
pub trait Clock {
    /// Microseconds since an arbitrary start; never decreasing.
    fn now_us(&mut self) -> u64;
}

/// A watchdog that resets the controller unless fed every period.
pub trait Watchdog {
    /// Feeds the watchdog.
    fn feed(&mut self);
}
