//! The driver's controls at run time: engage (SET), cancel, resume, the set speed and the
//! time-gap setting. Each request changes the driver's state only; the command history, which
//! the certificate needs, is kept across every change.

use crate::config::{Config, TIME_GAP_SETTINGS};
use crate::math;

/// A request from the driver's controls (the API: [`Controller::request`]; CAN: frame `0x140`,
/// [`crate::can`]).
///
/// [`Controller::request`]: crate::Controller::request
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriverRequest {
    /// SET: engage at the ego's measured speed as the new set speed (at least 1 m/s).
    Engage,
    /// Disengage: the controller stops commanding ([`Mode::Standby`](crate::Mode::Standby)).
    Cancel,
    /// Engage again at the last set speed; after a stop held longer than `auto_resume_us`, move
    /// off.
    Resume,
    /// A new set speed, m/s (in `[0, envelope.max_speed]`).
    SetSpeed(f32),
    /// A new time-gap setting (an index into `Config::time_gaps`).
    TimeGap(u8),
}

/// Why a driver request was refused (the driver's settings are unchanged). Shown to the
/// driver: the controller returns it from [`Controller::request`], keeps it in
/// [`DriverState::refused`] (sent to the display on CAN, frame `0x210` of [`crate::can`]) and
/// logs it ([`Event::DriverRequestRefused`](crate::Event::DriverRequestRefused)).
///
/// [`Controller::request`]: crate::Controller::request
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DriverError {
    /// The set speed is not a number or outside `[0, envelope.max_speed]`.
    SetSpeedOutOfRange,
    /// The time-gap setting is not one of `Config::time_gaps`.
    NoSuchTimeGap,
    /// Engagement (SET or resume from standby) refused: the state measured in the last standby
    /// period is not certified (its margin is zero or below, or it is outside the table's
    /// domain). Engaging there would leave the certificate nothing to keep and brake at once;
    /// the car stays in standby, and the standby commands' margin says when it is certified.
    NotCertified,
    /// Engagement refused: no certificate could be evaluated in the last standby period (no
    /// table, no plausible or a lost track, no good ego speed, or no standby period since the
    /// last cancel). The car stays in standby.
    CertificateUnknown,
    /// Engagement refused: the state measured in the last standby period is certified, but
    /// the follower behind leaves the commands no time to go down to the brake lights'
    /// command within ISO 15622's jerk limit, so the first engaged steps would be an
    /// emergency braking. The car stays in standby; the driver brakes, or waits for the
    /// follower to drop back.
    NeedsEmergencyBraking,
}

impl core::fmt::Display for DriverError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            DriverError::SetSpeedOutOfRange => "the set speed is out of range",
            DriverError::NoSuchTimeGap => "no such time-gap setting",
            DriverError::NotCertified => "not engaged: the measured state is not certified",
            DriverError::CertificateUnknown => {
                "not engaged: no certificate could be evaluated in standby"
            }
            DriverError::NeedsEmergencyBraking => {
                "not engaged: the follower is too close to brake comfortably"
            }
        })
    }
}

impl core::error::Error for DriverError {}

/// The driver's state.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriverState {
    /// Whether the controller is in control.
    pub engaged: bool,
    /// The speed set-point, m/s.
    pub set_speed: f32,
    /// The time-gap setting (an index into `Config::time_gaps`).
    pub time_gap_setting: u8,
    /// A resume was asked for and not yet used by a move-off.
    pub resume_requested: bool,
    /// Why the latest driver request was refused (`None`: it was taken, or none came yet): what
    /// the driver's display shows ([`crate::can`]'s frame `0x210`).
    pub refused: Option<DriverError>,
    /// How many requests were refused since start, wrapping at 255: a display tells a new
    /// refusal from the one it shows by it, even where frames are lost or the same reason
    /// comes twice.
    pub refusals: u8,
}

impl DriverState {
    /// The state at start: engaged, the configuration's set speed and time-gap setting.
    pub(super) fn new(config: &Config) -> Self {
        DriverState {
            engaged: true,
            set_speed: config.law.set_speed,
            time_gap_setting: config.law.time_gap_setting,
            resume_requested: false,
            refused: None,
            refusals: 0,
        }
    }

    /// Records the outcome of a request: the latest refusal (or none) and the refusals' count.
    pub(super) fn record(&mut self, outcome: Result<(), DriverError>) -> Result<(), DriverError> {
        self.refused = outcome.err();
        if self.refused.is_some() {
            self.refusals = self.refusals.wrapping_add(1);
        }
        outcome
    }

    /// Applies `request`, with the ego's measured speed (for SET) and the envelope's top speed.
    pub(super) fn apply(
        &mut self,
        request: DriverRequest,
        ego_speed: Option<f32>,
        max_speed: f32,
    ) -> Result<(), DriverError> {
        match request {
            DriverRequest::Engage => {
                if let Some(v) = ego_speed.filter(|v| math::is_finite(*v)) {
                    self.set_speed = math::clamp(v, 1.0, max_speed);
                }
                self.engaged = true;
            }
            DriverRequest::Cancel => {
                self.engaged = false;
                self.resume_requested = false;
            }
            DriverRequest::Resume => {
                self.engaged = true;
                self.resume_requested = true;
            }
            DriverRequest::SetSpeed(v) => {
                if !(math::is_finite(v) && (0.0..=max_speed).contains(&v)) {
                    return Err(DriverError::SetSpeedOutOfRange);
                }
                self.set_speed = v;
            }
            DriverRequest::TimeGap(k) => {
                if usize::from(k) >= TIME_GAP_SETTINGS {
                    return Err(DriverError::NoSuchTimeGap);
                }
                self.time_gap_setting = k;
            }
        }
        Ok(())
    }
}
