//! The controller's configuration: the period, the law's tuning, the margins, the delays the
//! certificate covers, the vehicle's envelope and the sensors' bounds, with their limits.

use crate::math;
use crate::sensing::SensorBounds;
use table_format::authority::DRY_ROAD_EMERGENCY;
use table_format::EmergencyDeclaration;

/// Tuning of the controller, grouped by what each part is for: the nominal law, the
/// certificate, the plant it covers, the fallback. Units: SI.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Control period, microseconds (default 20 ms).
    pub period_us: u32,
    /// An ego-speed measurement older than this many periods is stale (the radar tracks' age
    /// is covered up to `sensors.max_track_age_us`).
    pub stale_periods: u32,
    /// The nominal ACC law's settings and gains.
    pub law: LawConfig,
    /// What the certificate demands: its margins and the braking ramp.
    pub certificate: CertificateConfig,
    /// The vehicle the certificate covers: the actuator's delays and the envelope.
    pub plant: PlantConfig,
    /// The minimum-risk manoeuvre.
    pub fallback: FallbackConfig,
    /// The sensors' error bounds and timing the certificate covers ([`crate::sensing`]).
    pub sensors: SensorBounds,
}

/// The nominal ACC law: the driver's settings at start, the gap policy and the gains.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LawConfig {
    /// The speed set-point at start, m/s (the driver changes it at run time:
    /// [`DriverRequest`](crate::DriverRequest)).
    pub set_speed: f32,
    /// The time gaps the driver may select, s, shortest first; the shortest no shorter than
    /// ISO 15622's minimum ([`crate::iso15622::MIN_TIME_GAP`]).
    pub time_gaps: [f32; TIME_GAP_SETTINGS],
    /// The time-gap setting at start (an index into `time_gaps`).
    pub time_gap_setting: u8,
    /// Nominal ACC gap at standstill, m: where the car stops behind a stopped one.
    pub standstill_gap: f32,
    /// The gap policy's room over the certificate as a closing speed, m/s: the law's desired
    /// gap is at least the gap the certificate needs while the ego closes on its leader at
    /// this speed, plus `gap_room`, so that following, with the speed differences its own
    /// transients make, does not touch the override. The room in metres is what the
    /// certificate's braking makes of it: 7.3 m
    /// at 30 m/s in the comfort band (3.5 m/s^2 against a leader's 6), 4.5 m with 8 m/s^2
    /// against 9.8.
    pub gap_room_speed: f32,
    /// The gap policy's room over the certificate beyond the closing speed's, m.
    pub gap_room: f32,
    /// Nominal law: acceleration per metre of gap error.
    pub gap_gain: f32,
    /// Nominal law: acceleration per m/s of relative speed.
    pub rel_speed_gain: f32,
    /// Nominal law: acceleration per m/s of speed error.
    pub speed_gain: f32,
    /// Nominal law: the speed error's integral gain, m/s^2 per m/s per s (anti-windup: it
    /// integrates only while the speed law is the command).
    pub speed_integral_gain: f32,
    /// Nominal law: the share of the leader's estimated acceleration fed forward.
    pub feedforward_gain: f32,
    /// Nominal law: the constant deceleration a stop behind a stopped car aims at, at least,
    /// m/s^2 (positive): the approach keeps its speed until that braking stops it at the
    /// standstill gap, so that the last metres do not crawl. With two authorities and a
    /// follower behind, the stop is planned harder than the lights' command by a margin
    /// instead, where this is gentler (a lit run the follower does not let end would cut a
    /// gentler stop short: `Controller::stop_deceleration`).
    pub stop_deceleration: f32,
    /// After a stop, the car moves off by itself when its leader does within this time,
    /// microseconds; later it waits for the driver's resume (ISO 15622's full-speed-range
    /// type).
    pub auto_resume_us: u32,
}

/// What the certificate demands of a state and of the override.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CertificateConfig {
    /// The jerk of the braking ramp the certificate's actuator model assumes, m/s^3: the
    /// override ramps its braking down at this rate, never faster, and the look-ahead accounts
    /// for the ramp. At most ISO 15622's limit at speed (2.5 m/s^3, the default), every
    /// certified command keeps to ISO 15622's jerk limit at every speed. `f32::INFINITY`: no
    /// ramp (braking at `beta` at once, the paper's policy).
    pub brake_jerk: f32,
    /// How the override chooses its braking ([`OverridePolicy`]).
    pub override_policy: OverridePolicy,
    /// The front value (m) a certified state keeps, and the look-ahead demands of the nominal
    /// command.
    pub front_margin: f32,
    /// The rear value (m, after the table's error bound) a certified state has.
    pub rear_margin: f32,
    /// The vehicle's emergency authority, the follower's reaction and the lights' command
    /// (default [`EmergencyDeclaration::DEFAULT`]), as the table declares them: a table that
    /// declares others is refused ([`Fault::EmergencyDeclarationDiffers`](crate::Fault)).
    /// - `braking`: the vehicle's full braking and its build-up (8 m/s^2 at 12 m/s^3: a dry
    ///   road). Used only where braking at the band's floor at once cannot keep the leader's
    ///   worst case off the car, and only as far as the follower allows (the controller's
    ///   module docs: emergencies). Its level is at most the envelope's hardest braking; a
    ///   level no harder than the table's band leaves the band's floor as the hardest command.
    /// - `follower_reaction_time`: how long the follower behind keeps its acceleration after
    ///   the ego's brake lights come on, s (1.15 s: UN R157's careful driver), at most 5 s:
    ///   what the emergency authority's rear check waits for.
    /// - `lights_deceleration`: the deceleration beyond which the brake lights are on for
    ///   sure, m/s^2 (1.3: UN R13-H's threshold for braking that is not the driver's pedal).
    /// - `lights_command`: the command (m/s^2) at or below which the brake lights are on once
    ///   the actuator delivers it (-1.5, below `-lights_deceleration`): the follower's
    ///   reaction is counted only from a run of such commands
    ///   ([`lights_on_within`](table_format::EmergencyDeclaration::lights_on_within) after it
    ///   began). At least -3.5, and no harder than the table's band.
    pub emergency: EmergencyDeclaration,
    /// Which brakings the certificate argues with ([`Authorities`]).
    pub authorities: Authorities,
}

/// Which brakings the certificate argues with, and so which follower its rear half holds
/// against (the controller's module docs: the certificate).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Authorities {
    /// The comfort band alone: every command in `[-beta, a_max]` but the emergency answer,
    /// the front argued with the braking ramp to `beta`, the rear half the table's (the
    /// paper's IDM follower, proven cell by cell by `solver verify`). The default.
    ComfortBand,
    /// Two authorities: the law and the graded override in the comfort band, and the
    /// certificate argued with the emergency authority's build-up at the hardest level the
    /// follower allows (`table_format::authority`'s rule through the delays and the error
    /// boxes); the rear half in closed form against a follower that reacts after
    /// the declared `follower_reaction_time` ([`CertificateConfig::emergency`]) to the brake lights
    /// (`table_format::rear`). The table gives the models, not the rear value.
    Two,
}

/// The vehicle the certificate covers: the actuator's dead time and lag, and the envelope.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlantConfig {
    /// The actuator's dead time the certificate covers, microseconds (at most
    /// [`MAX_DEAD_TIME_US`]): a command acts this long after it is issued.
    pub actuator_dead_time_us: u32,
    /// The time constant of the actuator's first-order lag the certificate covers,
    /// microseconds (at most [`MAX_ACTUATOR_LAG_US`]): `a' = (command - a) / lag`.
    pub actuator_lag_us: u32,
    /// The vehicle's own limits, whatever the table says.
    pub envelope: Envelope,
}

/// The minimum-risk manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FallbackConfig {
    /// Minimum-risk deceleration, m/s^2 (positive, at most 4).
    pub mrm_deceleration: f32,
    /// Minimum-risk deceleration when the follower is close and closing, m/s^2 (positive).
    pub mrm_gentle_deceleration: f32,
    /// "Close" for the follower in the minimum-risk manoeuvre, m.
    pub follower_close_gap: f32,
}

/// How many time-gap settings a driver chooses from.
pub const TIME_GAP_SETTINGS: usize = 4;

/// How the override brakes when the look-ahead refuses the law's command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OverridePolicy {
    /// As little braking as passes the look-ahead, down to the ramp (the default).
    Graded,
    /// The paper's bang-bang `u2*`: the hardest braking the ramp allows (`beta` at once with
    /// `brake_jerk = f32::INFINITY`).
    BangBang,
}

/// The vehicle's envelope: what the firmware may command and the speeds it may certify, set by
/// the integrator for the car, not by the table. Every command, in every mode, is clamped into
/// it, and a table whose band does not fit inside it is refused at load
/// ([`Fault::TableOutsideEnvelope`](crate::Fault::TableOutsideEnvelope)): clamping the table's
/// braking level instead would void the certificate, which assumes the ego brakes at `beta` when
/// told to.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Envelope {
    /// The hardest braking the firmware may command, m/s^2 (negative).
    pub min_acceleration: f32,
    /// The largest acceleration the firmware may command, m/s^2 (positive).
    pub max_acceleration: f32,
    /// Ego speeds above this are outside the certified domain, whatever the table covers, m/s.
    pub max_speed: f32,
}

impl Default for Envelope {
    /// The car's full braking on a dry road (-8 m/s^2, the emergency authority's default
    /// level), ISO 15622's largest acceleration at speed (2 m/s^2), up to 35 m/s.
    fn default() -> Self {
        Envelope {
            min_acceleration: -DRY_ROAD_EMERGENCY.level,
            max_acceleration: ISO_15622_LIMITS.1,
            max_speed: 35.0,
        }
    }
}

impl Envelope {
    pub(crate) fn is_valid(&self) -> bool {
        math::is_finite(self.min_acceleration)
            && math::is_finite(self.max_acceleration)
            && math::is_finite(self.max_speed)
            && self.min_acceleration < 0.0
            && self.max_acceleration > 0.0
            && self.max_speed > 0.0
    }

    /// `a` within the envelope (NaN becomes the hardest braking).
    pub(crate) fn clamp(&self, a: f32) -> f32 {
        if a.is_nan() {
            return self.min_acceleration;
        }
        math::clamp(a, self.min_acceleration, self.max_acceleration)
    }
}

impl Config {
    /// Whether the configuration lies within the limits the certificate is argued for: a period
    /// of 10 to 100 ms, a stale limit of 1 to [`MAX_STALE_PERIODS`] periods, a dead time and a
    /// lag within their limits, finite non-negative margins and gains, an emergency level
    /// within the envelope built up at 0.5 m/s^3 or faster, a follower reaction of 0 to 5 s, a
    /// lights' deceleration of at least zero and a lights' command in `[-3.5, -theta)`.
    pub fn is_valid(&self) -> bool {
        let finite_non_negative = [
            self.law.set_speed,
            self.law.standstill_gap,
            self.law.gap_room_speed,
            self.law.gap_room,
            self.law.gap_gain,
            self.law.rel_speed_gain,
            self.law.speed_gain,
            self.law.speed_integral_gain,
            self.law.feedforward_gain,
            self.law.stop_deceleration,
            self.certificate.front_margin,
            self.certificate.rear_margin,
            self.fallback.mrm_deceleration,
            self.fallback.mrm_gentle_deceleration,
            self.fallback.follower_close_gap,
        ]
        .iter()
        .all(|x| math::is_finite(*x) && *x >= 0.0);
        let gaps_ordered = self
            .law
            .time_gaps
            .windows(2)
            .all(|w| w.iter().all(|g| math::is_finite(*g)) && w.first() <= w.last());
        let time_gaps = gaps_ordered
            && self
                .law
                .time_gaps
                .first()
                .is_some_and(|g| *g >= crate::iso15622::MIN_TIME_GAP)
            && self.law.time_gaps.last().is_some_and(|g| *g <= 5.0)
            && usize::from(self.law.time_gap_setting) < TIME_GAP_SETTINGS;
        // A jerk of at least 0.5 m/s^3 (a ramp of 11 s to 3.5 m/s^2 at most), or no ramp.
        let jerk = self.certificate.brake_jerk >= 0.5;
        let declared = self.certificate.emergency;
        let e = declared.braking;
        let emergency = declared.is_valid()
            && e.level <= -self.plant.envelope.min_acceleration
            && e.jerk >= 0.5;
        let lights = declared.lights_command >= ISO_15622_LIMITS.0;
        // Two authorities argue with a ramp and grade the override in the comfort band.
        let authorities = self.certificate.authorities == Authorities::ComfortBand
            || (math::is_finite(self.certificate.brake_jerk)
                && math::is_finite(e.jerk)
                && self.certificate.override_policy == OverridePolicy::Graded);
        finite_non_negative
            && authorities
            && time_gaps
            && jerk
            && emergency
            && lights
            && self.law.stop_deceleration >= 0.3
            && (MIN_PERIOD_US..=MAX_PERIOD_US).contains(&self.period_us)
            && (1..=MAX_STALE_PERIODS).contains(&self.stale_periods)
            && self.plant.actuator_dead_time_us <= MAX_DEAD_TIME_US
            && self.plant.actuator_lag_us <= MAX_ACTUATOR_LAG_US
            && self.plant.envelope.is_valid()
            && self.sensors.is_valid()
    }
}

/// The largest actuator dead time a configuration may declare, microseconds.
pub const MAX_DEAD_TIME_US: u32 = 100_000;
/// The largest actuator lag time constant a configuration may declare, microseconds.
pub const MAX_ACTUATOR_LAG_US: u32 = 300_000;
/// The smallest control period a configuration may declare, microseconds.
pub const MIN_PERIOD_US: u32 = 10_000;
/// The largest control period a configuration may declare, microseconds.
pub const MAX_PERIOD_US: u32 = 100_000;
/// The largest `stale_periods` a configuration may declare.
pub const MAX_STALE_PERIODS: u32 = 10;

impl Config {
    /// The paper's policy: the override brakes at `beta` at once (bang-bang `u2*`, no ramp),
    /// the rest of the configuration the default.
    pub fn bang_bang() -> Self {
        Config {
            certificate: CertificateConfig {
                brake_jerk: f32::INFINITY,
                override_policy: OverridePolicy::BangBang,
                ..CertificateConfig::default()
            },
            ..Config::default()
        }
    }

    /// The time gap of `setting`, s (the last one for a setting past the end).
    pub fn time_gap(&self, setting: u8) -> f32 {
        let last = self
            .law
            .time_gaps
            .last()
            .copied()
            .unwrap_or(crate::iso15622::MIN_TIME_GAP);
        self.law
            .time_gaps
            .get(usize::from(setting))
            .copied()
            .unwrap_or(last)
    }
}

impl Default for Config {
    fn default() -> Self {
        Config {
            period_us: 20_000,
            stale_periods: 5,
            law: LawConfig::default(),
            certificate: CertificateConfig::default(),
            plant: PlantConfig::default(),
            fallback: FallbackConfig::default(),
            sensors: SensorBounds::default(),
        }
    }
}

impl Default for LawConfig {
    fn default() -> Self {
        LawConfig {
            set_speed: 30.0,
            time_gaps: [1.0, 1.4, 1.8, 2.2],
            time_gap_setting: 2,
            standstill_gap: 4.0,
            gap_room_speed: 1.5,
            gap_room: 1.0,
            gap_gain: 0.23,
            rel_speed_gain: 0.7,
            speed_gain: 0.6,
            speed_integral_gain: 0.25,
            feedforward_gain: 0.5,
            stop_deceleration: 1.0,
            auto_resume_us: 3_000_000,
        }
    }
}

impl Default for CertificateConfig {
    fn default() -> Self {
        CertificateConfig {
            brake_jerk: crate::iso15622::jerk_limit(f32::INFINITY),
            override_policy: OverridePolicy::Graded,
            front_margin: table_format::front::DEFAULT_FRONT_MARGIN,
            rear_margin: 0.0,
            emergency: EmergencyDeclaration::DEFAULT,
            authorities: Authorities::ComfortBand,
        }
    }
}

impl Default for PlantConfig {
    fn default() -> Self {
        PlantConfig {
            actuator_dead_time_us: MAX_DEAD_TIME_US,
            actuator_lag_us: MAX_ACTUATOR_LAG_US,
            envelope: Envelope::default(),
        }
    }
}

impl Default for FallbackConfig {
    fn default() -> Self {
        FallbackConfig {
            mrm_deceleration: 2.0,
            mrm_gentle_deceleration: 1.0,
            follower_close_gap: 15.0,
        }
    }
}

/// A gap between two steps longer than this many periods is a clock jump.
pub const MAX_STEP_GAP_PERIODS: u64 = 10;
/// After a clock jump, the minimum-risk manoeuvre lasts for the step of the jump and this many
/// good periods after it; the command history is forgotten (the actuator's state is then
/// assumed unknown until it is known again, see the module docs).
pub const CLOCK_RECOVERY_PERIODS: u32 = 5;

/// ISO 15622 acceleration limits for ACC, m/s^2.
pub const ISO_15622_LIMITS: (f32, f32) = (-3.5, 2.0);
