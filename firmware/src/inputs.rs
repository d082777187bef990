//! What the control loop reads: radar tracks and the ego speed, each with its time stamp and
//! validity. The traits the hardware implements to deliver them and to take commands are in
//! [`crate::hardware`].

/// A measured value with the time it was taken and the sensor's own validity flag.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement<T> {
    /// The value.
    pub value: T,
    /// When it was measured, on the controller's monotonic clock, microseconds.
    pub timestamp_us: u64,
    /// The sensor's validity flag (false: the sensor says the value is not usable).
    pub valid: bool,
}

impl<T> Measurement<T> {
    /// A valid measurement taken at `timestamp_us`.
    pub const fn new(value: T, timestamp_us: u64) -> Self {
        Measurement {
            value,
            timestamp_us,
            valid: true,
        }
    }
}

/// A radar track of the vehicle ahead or behind.
///
/// Sign conventions are the table's: for the leader `rel_speed = v_leader - v_ego`, for the
/// follower `rel_speed = v_ego - v_follower`; positive means the gap is opening. A sensor that
/// sees no vehicle reports `gap = f32::INFINITY`, `rel_speed = 0` and `valid = true`: the
/// controller treats that as a vehicle at the edge of the table's grid, which is conservative
/// because more gap is never worse.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Track {
    /// Bumper-to-bumper gap, m.
    pub gap: f32,
    /// Relative speed, m/s (positive: the gap opens).
    pub rel_speed: f32,
}

/// One control period's inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Inputs {
    /// The vehicle ahead.
    pub leader: Measurement<Track>,
    /// The vehicle behind.
    pub follower: Measurement<Track>,
    /// The ego's own speed over ground, m/s.
    pub ego_speed: Measurement<f32>,
    /// The actuator's state, m/s^2: an upper bound, from the vehicle, of the acceleration its
    /// powertrain and brakes deliver and have been asked for (the request in force and in
    /// flight, the driver's pedal before engagement). The certificate uses it for what the
    /// car does before the controller's own commands are known (at engagement, after a
    /// cancel, after a clock jump), within `sensors.acceleration_error`; invalid or older than
    /// the ego speed's stale limit, it is not used and the band's top is assumed.
    pub ego_acceleration: Measurement<f32>,
    /// A request from the driver's controls this period, if any.
    pub driver: Option<crate::driver::DriverRequest>,
    /// The time of this control step, microseconds.
    pub now_us: u64,
}

impl Inputs {
    /// Inputs at `now_us` with every measurement invalid (NaN, flagged invalid): what a period
    /// whose sensors could not be read, or a bus that has delivered nothing yet, gives the
    /// controller.
    pub fn invalid(now_us: u64) -> Self {
        let track = Measurement {
            value: Track {
                gap: f32::NAN,
                rel_speed: f32::NAN,
            },
            timestamp_us: now_us,
            valid: false,
        };
        Inputs {
            leader: track,
            follower: track,
            ego_speed: Measurement {
                value: f32::NAN,
                timestamp_us: now_us,
                valid: false,
            },
            ego_acceleration: Measurement {
                value: f32::NAN,
                timestamp_us: now_us,
                valid: false,
            },
            driver: None,
            now_us,
        }
    }
}
