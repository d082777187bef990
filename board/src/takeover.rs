//! The driver's takeover request: a lamp (or chime) on an `embedded-hal` 1.0 output pin, lit
//! whenever the controller asks for it ([`firmware::Command::takeover`]).
//!
//! An ACC that brakes to a stop on its own (the minimum-risk manoeuvre), drives without its
//! certificate (outside the table's domain) or cannot certify the front (a vehicle cutting in
//! closer than the certificate allows) must tell the driver to take over. The request is off
//! when the certified law brakes harder than the nominal one within its certificate: that is
//! the controller doing its job. The pin is written on every change of the request, and
//! re-written every [`REFRESH_PERIODS`] periods, so a pin disturbed by anything else is put
//! right within that.

use embedded_hal::digital::OutputPin;
use firmware::Mode;

/// The request is written to the pin at least this often (periods), changed or not.
pub const REFRESH_PERIODS: u32 = 50;

/// Errors of the takeover output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error<E> {
    /// The pin could not be driven.
    Pin(E),
}

/// The takeover request on an output pin, active high.
#[derive(Debug)]
pub struct TakeoverRequest<P> {
    pin: P,
    /// What the pin was last set to, if it was set.
    shown: Option<bool>,
    since_write: u32,
}

/// Whether a command of `mode` with the takeover flag `takeover` calls for the driver: the
/// flag, and always in the minimum-risk manoeuvre and without a certificate.
pub fn requested(mode: Mode, takeover: bool) -> bool {
    takeover || matches!(mode, Mode::MinimumRisk | Mode::Uncertified)
}

impl<P: OutputPin> TakeoverRequest<P> {
    /// The request on `pin`; the first [`TakeoverRequest::show`] writes it.
    pub fn new(pin: P) -> Self {
        TakeoverRequest {
            pin,
            shown: None,
            since_write: 0,
        }
    }

    /// Shows the request of the controller's last command (`Controller::mode` and
    /// `Controller::takeover_requested`). A failed write is retried at the next call.
    pub fn show(&mut self, mode: Mode, takeover: bool) -> Result<(), Error<P::Error>> {
        let on = requested(mode, takeover);
        self.since_write = self.since_write.saturating_add(1);
        if self.shown == Some(on) && self.since_write < REFRESH_PERIODS {
            return Ok(());
        }
        self.shown = None;
        if on {
            self.pin.set_high().map_err(Error::Pin)?;
        } else {
            self.pin.set_low().map_err(Error::Pin)?;
        }
        self.shown = Some(on);
        self.since_write = 0;
        Ok(())
    }

    /// The pin, given back.
    pub fn release(self) -> P {
        self.pin
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction};
    use embedded_hal_mock::eh1::MockError;
    use std::io::ErrorKind;

    #[test]
    fn lit_exactly_when_the_controller_is_not_certifying() {
        let expected = [
            Transaction::set(State::Low),  // Nominal, first write
            Transaction::set(State::High), // MinimumRisk
            Transaction::set(State::Low),  // Override
            Transaction::set(State::High), // Uncertified
            Transaction::set(State::Low),  // Nominal
            Transaction::set(State::High), // Override asking for it (a cut-in)
        ];
        let mut lamp = TakeoverRequest::new(Mock::new(&expected));
        for (mode, takeover) in [
            (Mode::Nominal, false),
            (Mode::Nominal, false),
            (Mode::MinimumRisk, true),
            (Mode::MinimumRisk, false),
            (Mode::Override, false),
            (Mode::Nominal, false),
            (Mode::Uncertified, false),
            (Mode::Nominal, false),
            (Mode::Override, true),
        ] {
            lamp.show(mode, takeover).unwrap();
        }
        lamp.release().done();
    }

    #[test]
    fn rewritten_every_refresh_period_unchanged() {
        let refreshes = 3;
        let expected: Vec<_> = (0..=refreshes)
            .map(|_| Transaction::set(State::High))
            .collect();
        let mut lamp = TakeoverRequest::new(Mock::new(&expected));
        for _ in 0..=(refreshes * REFRESH_PERIODS) {
            lamp.show(Mode::MinimumRisk, true).unwrap();
        }
        lamp.release().done();
    }

    #[test]
    fn a_failed_write_is_reported_and_retried() {
        let expected = [
            Transaction::set(State::High).with_error(MockError::Io(ErrorKind::BrokenPipe)),
            Transaction::set(State::High),
        ];
        let mut lamp = TakeoverRequest::new(Mock::new(&expected));
        assert_eq!(
            lamp.show(Mode::MinimumRisk, true),
            Err(Error::Pin(MockError::Io(ErrorKind::BrokenPipe)))
        );
        lamp.show(Mode::MinimumRisk, true).unwrap();
        lamp.release().done();
    }
}
