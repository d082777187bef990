//! Why the controller is not in certified nominal control: every bad input and refused table
//! is one variant, with its reaction documented in the controller's module docs.

/// Why the controller is in the minimum-risk manoeuvre or uncertified.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Fault {
    /// The table did not pass `Table::parse`.
    Table(table_format::Error),
    /// The table is not a split three-car table
    /// ([`Game::ThreeCarSplit`](table_format::Game::ThreeCarSplit)).
    WrongGame,
    /// The leader track is flagged invalid, non-finite or impossible.
    LeaderInvalid,
    /// The leader track is older than the covered age (`sensors.max_track_age_us`): the
    /// certified fallback on its last good measurement.
    LeaderStale,
    /// The follower track is flagged invalid, non-finite or impossible.
    FollowerInvalid,
    /// The follower track is older than the covered age: the certified fallback, the rear kept
    /// by the band from its last good measurement.
    FollowerStale,
    /// The ego speed is flagged invalid, non-finite, negative or above 100 m/s.
    EgoSpeedInvalid,
    /// The ego speed is older than `stale_periods` periods.
    EgoSpeedStale,
    /// The state is outside the table's domain on this axis of the rear table (0:
    /// gap_follower below the grid, 1: follower_speed above `max_speed`, 2: ego_speed above
    /// `max_speed`). Not a sensor fault: the controller runs the nominal law uncertified
    /// ([`Mode::Uncertified`](super::Mode::Uncertified)), as a conventional ACC would outside its
    /// certified range, rather than braking hard into the follower.
    OutsideDomain {
        /// The axis.
        axis: u8,
    },
    /// The measurements' times are so far apart that the box of rear states they leave holds
    /// more than [`table_format::BOX_INTERIOR`] of the table's breakpoints on this axis: the
    /// step does not evaluate the rear half ([`Mode::Uncertified`](super::Mode::Uncertified), the
    /// front still enforced).
    RearBoxTooWide {
        /// The axis.
        axis: u8,
    },
    /// The clock went backwards. Recovers after
    /// [`CLOCK_RECOVERY_PERIODS`](super::CLOCK_RECOVERY_PERIODS) good periods.
    ClockWentBackwards,
    /// The configuration is outside the limits the certificate is argued for (period, stale
    /// limit, dead time or lag above their limits, a negative or non-finite value, an envelope
    /// without braking or acceleration, a lights' command harder than the table's band).
    InvalidConfig,
    /// The table's band of ego accelerations does not fit inside the vehicle's envelope.
    TableOutsideEnvelope,
    /// The table declares another emergency authority, follower reaction or lights' command
    /// ([`table_format::EmergencyDeclaration`]) than the configuration
    /// ([`CertificateConfig::emergency`](crate::CertificateConfig)): it certifies for another
    /// vehicle or another follower.
    EmergencyDeclarationDiffers,
    /// The clock jumped forward by more than [`MAX_STEP_GAP_PERIODS`](super::MAX_STEP_GAP_PERIODS)
    /// periods since the last step. Recovers after
    /// [`CLOCK_RECOVERY_PERIODS`](super::CLOCK_RECOVERY_PERIODS) good periods.
    ClockJumped,
    /// The table carries no record of `solver verify`, a record of a proof that left cells
    /// unproven, one for another `rear_margin` than the configuration's (a proof at one level
    /// says nothing about another), or one of a `verify` older than
    /// [`table_format::REAR_SAMPLE_VERIFIER`] (which did not bound the samples in between).
    TableNotVerified,
    /// The table was checked under less measurement error than the configuration declares
    /// (`sensors.error`): some bound of its record
    /// ([`table_format::Verification::measurement_error`]) is below the declared one.
    TableCheckedForLessError,
    /// The ego braked below the band (the emergency authority) after the follower's kept
    /// measurement was taken, or too recently for the actuator to be back in the band: the
    /// rear table's value holds only while the ego's acceleration stays in the band, so the
    /// rear half is unknown until a follower measurement taken after the braking's effect (a
    /// period, the dead time and ten lag time constants after the last such command). The
    /// front is still enforced ([`Mode::Uncertified`](super::Mode::Uncertified)).
    AfterEmergencyBraking,
    /// The board restarted after a fault of its own: the watchdog expired, or a HardFault
    /// (a stack overflow among them) or a panic ended the last run. The minimum-risk manoeuvre
    /// until the next power-on reset (see
    /// [`Controller::latch_minimum_risk`](super::Controller::latch_minimum_risk)).
    RestartedAfterFault,
}

impl core::fmt::Display for Fault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Fault::Table(e) => write!(f, "the table is refused: {e}"),
            Fault::WrongGame => f.write_str("the table is not a split three-car table"),
            Fault::LeaderInvalid => f.write_str("the leader track is invalid"),
            Fault::LeaderStale => f.write_str("the leader track is older than its covered age"),
            Fault::FollowerInvalid => f.write_str("the follower track is invalid"),
            Fault::FollowerStale => f.write_str("the follower track is older than its covered age"),
            Fault::EgoSpeedInvalid => f.write_str("the ego speed is invalid"),
            Fault::EgoSpeedStale => f.write_str("the ego speed is stale"),
            Fault::OutsideDomain { axis } => {
                write!(
                    f,
                    "the state is outside the rear table's domain on axis {axis}"
                )
            }
            Fault::RearBoxTooWide { axis } => write!(
                f,
                "the measurements leave a box of rear states too wide on axis {axis}"
            ),
            Fault::ClockWentBackwards => f.write_str("the clock went backwards"),
            Fault::InvalidConfig => {
                f.write_str("the configuration is outside the certificate's limits")
            }
            Fault::TableOutsideEnvelope => {
                f.write_str("the table's band does not fit the vehicle's envelope")
            }
            Fault::EmergencyDeclarationDiffers => f.write_str(
                "the table declares another emergency authority, follower or lights' command",
            ),
            Fault::ClockJumped => f.write_str("the clock jumped forward"),
            Fault::TableNotVerified => {
                f.write_str("the table carries no complete proof for this configuration")
            }
            Fault::TableCheckedForLessError => {
                f.write_str("the table was checked for less measurement error than declared")
            }
            Fault::AfterEmergencyBraking => {
                f.write_str("the rear is unknown until a follower measurement after the braking")
            }
            Fault::RestartedAfterFault => f.write_str("the board restarted after a fault"),
        }
    }
}

impl core::error::Error for Fault {}
