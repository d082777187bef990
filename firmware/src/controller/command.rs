//! What one control step gives out: the command, its mode, and the events worth a log line.

use super::Fault;
use crate::driver::DriverError;
use crate::sensing::TrackState;

/// Which law produced the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// The nominal ACC law; the look-ahead showed the front value stays above the margin
    /// through the next period.
    Nominal,
    /// The look-ahead refused the nominal command: the gentlest braking it passes, at most
    /// `beta`.
    Override,
    /// The minimum-risk manoeuvre after a fault.
    MinimumRisk,
    /// The command without a certificate of the rear half, the front still enforced: the
    /// state is outside the table's domain ([`Fault::OutsideDomain`]), or a braking below the
    /// band may still act on the follower's last measurement
    /// ([`Fault::AfterEmergencyBraking`]).
    Uncertified,
    /// Disengaged by the driver: the command is not for the actuator (acceleration 0).
    Standby,
}

/// One control step's output.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Command {
    /// Requested acceleration, m/s^2 (negative: braking). Always finite, always in the
    /// vehicle's envelope, and in the table's band when a table was accepted, but for the
    /// emergency authority's braking below it (flagged [`Command::emergency`]).
    pub acceleration: f32,
    /// Which law produced it.
    pub mode: Mode,
    /// The fault behind a minimum-risk manoeuvre or an uncertified command.
    pub fault: Option<Fault>,
    /// The certificate's margin at the measured state (m): the smaller of the front value
    /// less `front_margin` and the rear value less its error bound and `rear_margin`. The state
    /// is certified when it is positive. `None` when no certificate was evaluated.
    pub margin: Option<f32>,
    /// The driver's takeover request: the front half is not certified (a cut-in, a leader
    /// closer than the certificate allows), the rear half is unknown ([`Mode::Uncertified`]),
    /// or the command is a minimum-risk manoeuvre.
    pub takeover: bool,
    /// The command is the emergency answer to a front the certificate no longer covers (a
    /// cut-in, an engagement into an uncertified state, a leader outside its model): a braking
    /// at once as hard as the leader's worst case needs, within the band where the band
    /// suffices, below it under the emergency authority where it does not; or it
    /// brakes faster than ISO 15622's jerk limit at the ego's speed allows
    /// ([`crate::iso15622`]; a brake ramp configured above the limit) while the ego may be
    /// moving (its measured speed's error box does not reach zero). The takeover request is
    /// raised with it.
    pub emergency: bool,
    /// What the controller made of the leader track ([`TrackState`]).
    pub leader: TrackState,
    /// What the controller made of the follower track.
    pub follower: TrackState,
}

impl Command {
    /// A command of `mode` with nothing else known: no certificate, no takeover request, both
    /// tracks missing (the fields are filled in as the step learns them).
    pub const fn bare(acceleration: f32, mode: Mode, fault: Option<Fault>) -> Self {
        Command {
            acceleration,
            mode,
            fault,
            margin: None,
            takeover: false,
            emergency: false,
            leader: TrackState::Missing,
            follower: TrackState::Missing,
        }
    }
}

/// Something worth a line in the log.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// The mode changed.
    ModeChanged {
        /// Time, microseconds.
        at_us: u64,
        /// The new mode.
        to: Mode,
        /// The fault, for the minimum-risk manoeuvre.
        fault: Option<Fault>,
    },
    /// A leader track that is not the vehicle of the last one (a cut-in, [`TrackState::New`]).
    NewLeader {
        /// Time, microseconds.
        at_us: u64,
        /// The new track's measured gap, m.
        gap: f32,
    },
    /// A driver request was refused (the driver's state is unchanged).
    DriverRequestRefused {
        /// Time, microseconds.
        at_us: u64,
        /// Why.
        error: DriverError,
    },
    /// The state is no longer certified (its margin is zero or below): logged once per
    /// excursion.
    MarginLost {
        /// Time, microseconds.
        at_us: u64,
        /// The certificate's margin at the state, m.
        margin: f32,
    },
}
