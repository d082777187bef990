//! The control step: one set of inputs in, one acceleration command out.
//!
//! # The certificate: a split of the three-car game at one braking level
//! The table is a [`Game::ThreeCarSplit`] table. For the ego's braking level `beta` (the
//! table's `-ego.min`) a state `(gap_leader, leader_speed, gap_follower, follower_speed,
//! ego_speed)` is **certified** when
//! - the *front value* `F(z) = front_value(gap_leader, leader_speed, ego_speed)`, the smallest
//!   gap to a leader braking as hard as its model allows while the ego brakes at `beta`, in
//!   closed form ([`table_format::front`]), exceeds `front_margin`, and
//! - the *rear value* `W(z)`, the table's value at `(gap_follower, follower_speed, ego_speed)`
//!   less its error bound, exceeds `rear_margin`. `W` is the stationary (infinite-horizon)
//!   value of the rear game in which the ego's acceleration anywhere in the band
//!   `[-beta, a_max]` is adversarial: it bounds the rear gap from below for as long as the
//!   ego keeps its command in the band, whatever the command is.
//!
//! # The law, and why it keeps a certified state certified
//! Every command is in the band `[-beta, a_max]`, in every mode, so the rear half needs no
//! decision: it is a property of the band, proven for the table itself, cell by cell, by
//! `solver verify` (below). The front half decides the command. The nominal ACC law's command `u`
//! is held for one period `h`; the look-ahead computes `front_value` with a *response* of `u`
//! for `h` before the braking at `beta` (plus the delays, see below). That is the smallest
//! front gap over every leader
//! behaviour, the period included, and every state the period can reach has a front value at
//! least as large (the reached state's worst case is one of the behaviours the look-ahead
//! took the minimum over). So if the look-ahead exceeds `front_margin` the nominal command is
//! applied ([`Mode::Nominal`]); otherwise ([`Mode::Override`]) a gentler braking the
//! look-ahead passes (a secant step between the refused command and `beta`), or braking at
//! `beta` itself, along which the front value never decreases (checked by property tests in
//! `table_format::front`). Either way a certified state's front value stays above
//! `front_margin`. No monotonicity of
//! the table is used: the rear value is a property of the band, and the front value is exact.
//!
//! # Delays: the measurements' age, the actuator's dead time and lag
//! The configuration declares the actuator's dead time `D` (a command acts `D` after it is
//! issued, at most 100 ms) and the time constant `tau` of its first-order lag (at most 0.3 s);
//! a track of any age is argued from its time (below: aging and lost tracks), the ego's speed
//! up to `stale_periods` periods old. The front is argued from the
//! leader track's measurement time `t_m`, not from now: the front value is a minimum over
//! every leader behaviour from `t_m` on, so what the leader did since is covered. The ego's
//! speed at `t_m` comes from its own measurement, moved to `t_m` within the accelerations the
//! ego can have had in between (the highest speed for the ego, the lowest for the leader).
//!
//! The ego's acceleration is bounded through the commands the controller has issued, which it
//! keeps (a sliding-window maximum back to the oldest kept measurement, less `D` and `5 tau`).
//! Until braking at
//! beta takes full effect, the acceleration is at most `pending`: the largest command issued
//! since `t_m - D - 5 tau`, plus what older commands can still pass through the lag (at most
//! `e^-5` of the band's width); before the controller's first command it is the band's
//! largest. A braking command issued at `t_b` takes full effect, in the sense that matters
//! here, at `t_b + D + tau`: a first-order lag's speed never exceeds that of the step delayed
//! by `tau` (see `table_format::front`). So the **certified front value** is
//! `front_value` at the state of `t_m` with a response of `pending` until `t_b + D + tau`,
//! where `t_b` is when the current run of commands at beta began, or now. The **look-ahead**
//! of a command `u` uses a response of `max(pending, u + tail)` until `now + h + D + tau`, with
//! `tail` the lag's `e^-5` of the band's width: the next step's `pending` is `u + tail` when `u`
//! is the largest command (before issue 20's review the look-ahead took `max(pending, u)`,
//! which under-stated it by up to the tail, 0.037 m/s^2). Why it is
//! invariant: at the next step the certified value's response ends at the same instant (either
//! the braking run goes on from the same `t_b`, or `u` was held and the run starts at
//! `now + h`), with a `pending` no larger, from a later state that one of the behaviours the
//! look-ahead took the minimum over has reached; so it is at least the look-ahead's value.
//!
//! # The ego's speed: kept in the domain, not assumed
//! The rear value is the rear game's value over speeds in `[0, max_speed]`, so a certified
//! state must stay inside that range, and the ego's speed is the firmware's to keep there: no
//! human model bounds it. The **speed headroom** of a state is `max_ego_speed` less the
//! highest speed the ego can reach before braking at beta takes full effect: from its
//! measurement at `t_e`, `ego_speed + max(pending, 0) (t_b + D + tau - t_e)` (the response's
//! end as in the front value; a first-order lag's speed never exceeds the step's). A certified
//! state has a headroom of zero or more ([`Certificate::is_certified`]). The look-ahead of a
//! command `u` caps it so that `ego_speed + max(pending, u + tail, 0) (now + h + D + tau - t_e)`
//! stays within `max_ego_speed` (`ego_speed` at its measurement's highest):
//! the cap is `(max_ego_speed - ego_speed) / (now + h + D + tau - t_e) - tail`,
//! and when even `pending` alone breaks it, nothing passes and the command is beta. Why it is
//! invariant: braking at beta keeps the response's end where it was and `pending` no larger, as
//! for the front value, and a capped command ends its response at `now + h + D + tau`, which the
//! next step's headroom uses. Before (issue 19), the front value held the ego at `max_speed`
//! during its response, which the dynamics do not: a start 0.05 m above the margin, engaged at
//! 34.8 m/s and +0.8 m/s^2, collided.
//!
//! # The domain
//! The rear table covers `gap_follower` up to its last breakpoint, and speeds in
//! `[0, max_speed]`. A follower farther back than the grid (or none: a gap of `+inf`) is safe
//! until it crosses the grid's last gap, where its value is at least the smallest value on that
//! face of the grid, computed once when the table is loaded: that is its rear value. A leader
//! farther than any gap (or none) has an infinite front value. A measured speed of a human
//! slightly below zero is taken as zero (a slower follower and a faster leader are never
//! worse).
//!
//! **The rear state at one time.** The rear value is argued at the follower track's time
//! `t_f`: from a certified state at `t_f` the rear is safe for ever while every command is in
//! the band, whatever came after. The follower's speed is `ego_speed - rel_speed` with the
//! ego's speed *at `t_f`*, which its own measurement at `t_e` gives only within the
//! accelerations possible in between: `[ego - pending dt, ego + beta dt]` for an older track,
//! `[ego - beta dt, ego + pending dt]` for a newer one. So the rear value is the table's least
//! value over the box of those ego speeds and the follower speeds that go with them, held in
//! the human's `[0, max_speed]` ([`Table::least_over_box`]: exact for the multilinear interpolation, one
//! lookup when the times agree, at most `8^3` points with [`table_format::BOX_INTERIOR`] breakpoints
//! inside). Before (issue 19), the two were subtracted as if taken at once: a follower at
//! exactly 35 m/s read 35.05 m/s behind an accelerating ego, and the firmware ran uncertified.
//!
//! An ego or follower faster than `max_speed` at that time, or a follower gap below the grid,
//! is outside the domain: [`Fault::OutsideDomain`], [`Mode::Uncertified`]. Only the rear half
//! is unknown there: the command is the nominal law under the same speed cap and front
//! look-ahead as in the domain, so the front override still acts (before issue 19 the nominal
//! law ran unchecked, and an ego at 35.14 m/s braked at -1.5 m/s^2 into a stopped leader). The
//! nominal law's set speed (30 m/s by default, below the table's 35) and the cap bring a fast
//! ego back into the domain, and its braking, like every command's, is at most `beta`, which
//! spares the follower: a rear table certifies nothing unless the follower can out-brake the
//! band (measured: with the follower's braking equal to `beta` the rear value's plateau is
//! -0.99 m, README).
//!
//! # Measurement error, aging and lost tracks, cut-ins (issue 20)
//! The sensors' error is bounded and declared in [`Config::sensors`] ([`crate::sensing`]): every
//! measurement stands for the box of true values its error allows.
//! - **Front**: the front value is evaluated at the box's worst corner: the least gap, the
//!   slowest leader (the ego's lowest speed at `t_m` plus the least range rate) and the fastest
//!   ego. It is non-decreasing in the gap and the leader's speed and non-increasing in the ego's
//!   speed ([`table_format::front`]'s property test `the_error_boxs_worst_corner_is_its_least_value`),
//!   so that corner is the least value over the box; the leader's speed is `ego + range_rate`,
//!   and taking each at its own worst end covers the pair (conservative by the ego's error
//!   twice). The speed headroom and cap take the ego at its highest.
//! - **Rear**: the table's exact least value over the box (gap interval, the ego's speed at
//!   `t_f` within its error and its possible change since, the follower's with it and the
//!   range-rate error), [`Table::least_over_box`], the multilinear interpolant's minimum over the
//!   candidates (box ends and breakpoints inside), at most [`table_format::BOX_INTERIOR`]
//!   breakpoints per axis. Why at run time and not in a table eroded at compile time: the box
//!   depends on the track's age, known only at run time (an eroded table must take its worst);
//!   one table serves every declared sensor; the minimum is exact, not a second bound; and it is
//!   computed once per follower measurement (below). Measured on the deployed table
//!   (`solver verify`, `solver::robust`): 74.8% of the measured rear states pass with the
//!   default error against 77.1% with exact sensors; every passing measurement's box lies in
//!   cells the proof covers. Cost: the worst control step on the Cortex-M4F is 12,916
//!   instructions (QEMU, README), against a budget of 20,000 (0.12 ms at one instruction per
//!   cycle, 0.71 ms at six: 3.6% of the 20 ms period at 168 MHz).
//! - **Aging**: a measurement is argued from its own time, so its age is inside the argument.
//!   The last plausible leader measurement is kept with the interval of the ego's speed at its
//!   time (from the kept ego measurement nearest it); its look-ahead's response runs from then,
//!   so it grows with the age and the car slows as the track ages. The follower's rear value is
//!   computed once per measurement and kept: from a certified rear state at `t_f` the rear is
//!   safe for ever while every command is in the band, whatever the track's age. An invalid or
//!   implausible measurement is a missed refresh: the last good one goes on aging. The command
//!   history is kept back to the oldest kept measurement (merged, never under-stated, when it
//!   fills), so `pending` is known at any age.
//! - **Lost**: beyond `sensors.max_track_age_us` (1 s by default), the certified fallback: the
//!   minimum-risk deceleration under the front half of the last good leader measurement
//!   (braking harder, up to beta, when the leader's worst case since then needs it), the rear
//!   kept by the band; [`Mode::MinimumRisk`] with the fault and a margin. A track that comes back
//!   is a new measurement: its certificate is evaluated and its look-ahead decides before the
//!   nominal law resumes. Each command reports the tracks' states ([`TrackState`]), on CAN too.
//! - **Cut-ins**: a leader measurement whose range is below the least the last track's vehicle
//!   can have closed to is a new vehicle ([`TrackState::New`], [`Event::NewLeader`]). It is used in
//!   the period it arrives; where its front value is below the margin no command passes the
//!   look-ahead (it is non-increasing in the command) and the command is beta, with the
//!   takeover request ([`Command::takeover`]). A cut-in is outside the model: the certificate
//!   cannot promise what follows, only the best answer.
//!
//! # Faults and the minimum-risk manoeuvre
//! A table that does not parse, is not a split table, whose band does not fit the vehicle's
//! [`Envelope`] or that carries no complete `solver verify` record for the configured
//! `rear_margin`, a configuration outside its limits, a measurement the sensor flags invalid, a
//! non-finite or physically impossible ego speed, one older than `stale_periods`
//! periods, no plausible track yet, a track beyond its covered age (the certified fallback,
//! above), or a clock that jumps (backwards, or forwards by more than
//! [`MAX_STEP_GAP_PERIODS`] periods): each is a [`Fault`], reported in the command and logged,
//! and the command is the minimum-risk manoeuvre: a controlled deceleration of
//! `mrm_deceleration` (default 2 m/s^2, at most 4), softened to `mrm_gentle_deceleration` when
//! the follower is known, close and closing, so as not to provoke a rear-end collision. Where
//! the table is loaded and the leader track and the ego's speed are good (the fault is
//! elsewhere: the follower track, the clock), the front half still applies to that
//! deceleration exactly as to the nominal law: the speed cap and the look-ahead, so the
//! manoeuvre brakes harder, up to beta, when the leader needs it (after a clock jump the
//! forgotten history makes the look-ahead assume the band's top). A clock
//! jump is never latched: the new time is adopted, the command history forgotten, and the
//! manoeuvre ends after [`CLOCK_RECOVERY_PERIODS`] good periods. A board that restarted after
//! a fault of its own (watchdog, HardFault, panic) latches the manoeuvre until power-on
//! ([`Controller::latch_minimum_risk`], [`Fault::RestartedAfterFault`]). Every command, in
//! every mode, is clamped into the envelope, and (with a table) into the band.
//!
//! # What `solver verify` proves of the rear table
//! `cargo run -p solver --release -- verify firmware/tables/default.bin` proves, by interval
//! bounds over every cell of the table and every admissible input (not by sampling), that every
//! state with `W > error_bound + rear_margin` (the firmware's rear test, `rear_margin` 0) is
//! safe from the follower for ever while the ego's acceleration stays in the band: for each
//! such state one of the periods 20, 100, 200 or 300 ms (chosen by the state) takes it, whatever
//! the ego does in the band and whatever time gap the IDM follower holds, to a state that passes
//! the test again, with the gap above zero in between; at standstill, below the gap where the
//! IDM brakes at its clip (0.756 m), a closed-form lemma does the same. Measured: 537,280 of
//! 537,280 certified cells, 26 s on two cores (`solver::verify` has the method and why the
//! deployment table is solved with the follower pushed 0.2 m/s^2 beyond its model). The actuator's
//! dead time and lag do not enter: whatever they do, the realised acceleration stays in the
//! band when every command is in it. Between those periods the value may dip below the level:
//! by at most [`REAR_SAMPLE_TOLERANCE`] (10 cm; 8.3 cm measured by verify's bounds on the
//! deployed table) at every 20 ms sample, which verify proves from its version 2 on. What it
//! does not claim: anything about `f32` rounding beyond `solver::verify::TOLERANCE`.
//!
//! # The tolerances, per part
//! Each part of a certified state's certificate is claimed to stay above its own stated
//! tolerance at every control period: the front half above `-CERTIFICATE_TOLERANCE` (1 cm,
//! `f32` rounding of the closed form), the rear half above `-REAR_SAMPLE_TOLERANCE` (10 cm,
//! proven by verify; above zero at its proof periods), the speed headroom above
//! `-SPEED_TOLERANCE` (1 mm/s, `f32` rounding near 35 m/s).
//!
//! # What is assumed
//! The humans keep to the table's model (the leader brakes at most `-leader.min` and keeps its
//! speed in `[0, max_speed]`, the follower drives by the IDM with its time gap in range and
//! keeps its speed there too), and no vehicle cuts in; the measurements are within their
//! declared error bounds ([`Config::sensors`]) and time-stamped on the controller's clock (a
//! track of any age is argued from its time; the ego's speed at most `stale_periods` old; each
//! channel may have its own age); the actuator is a
//! dead time and a first-order lag no slower than the configuration declares, and brakes at
//! beta when told to. Nothing is assumed of the ego's speed: the firmware keeps it in the
//! domain (above). The front value is exact, and its look-ahead over the
//! delays is argued above and checked by property tests; its `f32` evaluation is within about
//! 1.4 mm (measured), inside [`CERTIFICATE_TOLERANCE`].

use heapless::Deque;
use table_format::front::{front_value, FrontModel};
use table_format::{Bounds, Game, Table};

use crate::fmt::{log_info, log_warn};
use crate::inputs::{Inputs, Measurement, Track};
use crate::math;
use crate::sensing::{SensorBounds, TrackState};

/// Tuning of the controller. Units: SI.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Control period, microseconds (default 20 ms).
    pub period_us: u32,
    /// An ego-speed measurement older than this many periods is stale (the radar tracks' age
    /// is covered up to `sensors.max_track_age_us`).
    pub stale_periods: u32,
    /// Speed set-point, m/s.
    pub set_speed: f32,
    /// Nominal ACC time gap, s.
    pub time_gap: f32,
    /// Nominal ACC gap at standstill, m.
    pub standstill_gap: f32,
    /// Nominal law: acceleration per metre of gap error.
    pub gap_gain: f32,
    /// Nominal law: acceleration per m/s of relative speed.
    pub rel_speed_gain: f32,
    /// Nominal law: acceleration per m/s of speed error.
    pub speed_gain: f32,
    /// The front value (m) a certified state keeps, and the look-ahead demands of the nominal
    /// command.
    pub front_margin: f32,
    /// The rear value (m, after the table's error bound) a certified state has.
    pub rear_margin: f32,
    /// Minimum-risk deceleration, m/s^2 (positive, at most 4).
    pub mrm_deceleration: f32,
    /// Minimum-risk deceleration when the follower is close and closing, m/s^2 (positive).
    pub mrm_gentle_deceleration: f32,
    /// "Close" for the follower in the minimum-risk manoeuvre, m.
    pub follower_close_gap: f32,
    /// The actuator's dead time the certificate covers, microseconds (at most
    /// [`MAX_DEAD_TIME_US`]): a command acts this long after it is issued.
    pub actuator_dead_time_us: u32,
    /// The time constant of the actuator's first-order lag the certificate covers,
    /// microseconds (at most [`MAX_ACTUATOR_LAG_US`]): `a' = (command - a) / lag`.
    pub actuator_lag_us: u32,
    /// The vehicle's own limits, whatever the table says.
    pub envelope: Envelope,
    /// The sensors' error bounds and timing the certificate covers ([`crate::sensing`]).
    pub sensors: SensorBounds,
}

/// The vehicle's envelope: what the firmware may command and the speeds it may certify, set by
/// the integrator for the car, not by the table. Every command, in every mode, is clamped into
/// it, and a table whose band does not fit inside it is refused at load
/// ([`Fault::TableOutsideEnvelope`]): clamping the table's braking level instead would void
/// the certificate, which assumes the ego brakes at `beta` when told to.
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
    /// ISO 15622's limits for an ACC at speed (-3.5 and 2 m/s^2), up to 35 m/s.
    fn default() -> Self {
        Envelope {
            min_acceleration: ISO_15622_LIMITS.0,
            max_acceleration: ISO_15622_LIMITS.1,
            max_speed: 35.0,
        }
    }
}

impl Envelope {
    fn is_valid(&self) -> bool {
        math::is_finite(self.min_acceleration)
            && math::is_finite(self.max_acceleration)
            && math::is_finite(self.max_speed)
            && self.min_acceleration < 0.0
            && self.max_acceleration > 0.0
            && self.max_speed > 0.0
    }

    /// `a` within the envelope (NaN becomes the hardest braking).
    fn clamp(&self, a: f32) -> f32 {
        if a.is_nan() {
            return self.min_acceleration;
        }
        math::clamp(a, self.min_acceleration, self.max_acceleration)
    }
}

impl Config {
    /// Whether the configuration lies within the limits the certificate is argued for: a period
    /// of 10 to 100 ms, a stale limit of 1 to [`MAX_STALE_PERIODS`] periods, a dead time and a
    /// lag within their limits, finite non-negative margins and gains.
    pub fn is_valid(&self) -> bool {
        let finite_non_negative = [
            self.set_speed,
            self.time_gap,
            self.standstill_gap,
            self.gap_gain,
            self.rel_speed_gain,
            self.speed_gain,
            self.front_margin,
            self.rear_margin,
            self.mrm_deceleration,
            self.mrm_gentle_deceleration,
            self.follower_close_gap,
        ]
        .iter()
        .all(|x| math::is_finite(*x) && *x >= 0.0);
        finite_non_negative
            && (MIN_PERIOD_US..=MAX_PERIOD_US).contains(&self.period_us)
            && (1..=MAX_STALE_PERIODS).contains(&self.stale_periods)
            && self.actuator_dead_time_us <= MAX_DEAD_TIME_US
            && self.actuator_lag_us <= MAX_ACTUATOR_LAG_US
            && self.envelope.is_valid()
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

impl Default for Config {
    fn default() -> Self {
        Config {
            period_us: 20_000,
            stale_periods: 5,
            set_speed: 30.0,
            time_gap: 1.8,
            standstill_gap: 5.0,
            gap_gain: 0.23,
            rel_speed_gain: 0.7,
            speed_gain: 0.3,
            front_margin: 0.5,
            rear_margin: 0.0,
            mrm_deceleration: 2.0,
            mrm_gentle_deceleration: 1.0,
            follower_close_gap: 15.0,
            actuator_dead_time_us: MAX_DEAD_TIME_US,
            actuator_lag_us: MAX_ACTUATOR_LAG_US,
            envelope: Envelope::default(),
            sensors: SensorBounds::default(),
        }
    }
}

/// A gap between two steps longer than this many periods is a clock jump.
pub const MAX_STEP_GAP_PERIODS: u64 = 10;
/// After a clock jump, the minimum-risk manoeuvre lasts for the step of the jump and this many
/// good periods after it; the command history is forgotten (the actuator's state is then
/// assumed unknown until it is known again, see the module docs).
pub const CLOCK_RECOVERY_PERIODS: u32 = 5;

/// e^-5: what a first-order lag still passes on, after five time constants, of a command older
/// than that.
const LAG_TAIL: f32 = 0.006_737_947;

/// ISO 15622 acceleration limits for ACC, m/s^2.
pub const ISO_15622_LIMITS: (f32, f32) = (-3.5, 2.0);

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
    /// The nominal law (in the band) without a certificate: the state is outside the table's
    /// domain ([`Fault::OutsideDomain`]).
    Uncertified,
}

/// Why the controller is in the minimum-risk manoeuvre or uncertified.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Fault {
    /// The table did not pass `Table::parse`.
    Table(table_format::Error),
    /// The table is not a split three-car table ([`Game::ThreeCarSplit`]).
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
    /// ([`Mode::Uncertified`]), as a conventional ACC would outside its certified range,
    /// rather than braking hard into the follower.
    OutsideDomain {
        /// The axis.
        axis: u8,
    },
    /// The measurements' times are so far apart that the box of rear states they leave holds
    /// more than [`table_format::BOX_INTERIOR`] of the table's breakpoints on this axis: the
    /// step does not evaluate the rear half ([`Mode::Uncertified`], the front still enforced).
    RearBoxTooWide {
        /// The axis.
        axis: u8,
    },
    /// The clock went backwards. Recovers after [`CLOCK_RECOVERY_PERIODS`] good periods.
    ClockWentBackwards,
    /// The configuration is outside the limits the certificate is argued for (period, stale
    /// limit, dead time or lag above their limits, a negative or non-finite value, an envelope
    /// without braking or acceleration).
    InvalidConfig,
    /// The table's band of ego accelerations does not fit inside the vehicle's envelope.
    TableOutsideEnvelope,
    /// The clock jumped forward by more than [`MAX_STEP_GAP_PERIODS`] periods since the last
    /// step. Recovers after [`CLOCK_RECOVERY_PERIODS`] good periods.
    ClockJumped,
    /// The table carries no record of `solver verify`, a record of a proof that left cells
    /// unproven, one for another `rear_margin` than the configuration's (a proof at one level
    /// says nothing about another), or one of a `verify` older than
    /// [`table_format::REAR_SAMPLE_VERIFIER`] (which did not bound the samples in between).
    TableNotVerified,
    /// The board restarted after a fault of its own: the watchdog expired, or a HardFault
    /// (a stack overflow among them) or a panic ended the last run. The minimum-risk manoeuvre
    /// until the next power-on reset (see [`Controller::latch_minimum_risk`]).
    RestartedAfterFault,
}

/// One control step's output.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Command {
    /// Requested acceleration, m/s^2 (negative: braking). Always finite, always in the
    /// vehicle's envelope, and in the table's band when a table was accepted.
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
            leader: TrackState::Missing,
            follower: TrackState::Missing,
        }
    }
}

/// The certificate at a state: its two halves, each as a margin over its level (m), and the
/// ego's speed headroom (m/s). The state is certified when both halves are positive and the
/// headroom is not negative ([`Certificate::is_certified`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Certificate {
    /// The front value less `front_margin`, m.
    pub front: f32,
    /// The rear value less the table's error bound and `rear_margin`, m.
    pub rear: f32,
    /// The ego's speed headroom, m/s: the domain's largest ego speed less the highest speed
    /// the ego can reach before braking at beta takes full effect. The ego's speed is the
    /// firmware's to keep in the domain, not an assumption: a negative headroom means the
    /// commands already issued can take it out.
    pub speed: f32,
}

impl Certificate {
    /// The smaller of the two halves' margins (m); when the speed headroom is negative, the
    /// headroom (m/s) if it is smaller still. Positive exactly when the state is certified (the
    /// units differ only on the uncertified side).
    pub fn margin(&self) -> f32 {
        let halves = math::min(self.front, self.rear);
        if self.speed < 0.0 {
            math::min(halves, self.speed)
        } else {
            halves
        }
    }

    /// Both halves positive and the speed headroom not negative.
    pub fn is_certified(&self) -> bool {
        self.front > 0.0 && self.rear > 0.0 && self.speed >= 0.0
    }
}

/// f32 rounding can lower a computed margin along a trajectory on which the exact one never
/// decreases (the front value's closed form and the plant are evaluated in f32; the property
/// test `never_decreases_along_the_ego_braking` in `table_format::front` allows
/// `1e-3 (1 + |F|)`, 1.5 mm at `F = 0.5 m`). A certified state (margin above zero) is claimed
/// to keep its margin above `-CERTIFICATE_TOLERANCE`, 1 cm.
pub const CERTIFICATE_TOLERANCE: f32 = 0.01;

/// How far below its level the rear value may read at a control period between the periods
/// `solver verify` proves it over, m ([`table_format::REAR_SAMPLE_TOLERANCE`]). `verify` (from
/// its version [`table_format::REAR_SAMPLE_VERIFIER`]) proves, for every certified cell, that
/// at every multiple of its shortest period inside the period that closes the cell's proof the
/// table's value stays above `level - REAR_SAMPLE_TOLERANCE` (measured on the deployed table:
/// at most 8.3 cm by its interval bounds); the firmware refuses a table with an older record.
/// So the rear half's claim at every 20 ms sample is `rear > -REAR_SAMPLE_TOLERANCE`, at the
/// proof's own periods `rear > 0`, and the gap to the follower stays above zero throughout.
pub const REAR_SAMPLE_TOLERANCE: f32 = table_format::REAR_SAMPLE_TOLERANCE;

/// How far below zero the ego's speed headroom may read, m/s: `f32` rounding of a speed near
/// 35 m/s (its spacing there is 3.8e-6 m/s) over a few operations.
pub const SPEED_TOLERANCE: f32 = 1e-3;

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
    /// The state is no longer certified (its margin is zero or below): logged once per
    /// excursion.
    MarginLost {
        /// Time, microseconds.
        at_us: u64,
        /// The certificate's margin at the state, m.
        margin: f32,
    },
}

/// What the controller takes from the table's header once.
#[derive(Debug, Clone, Copy)]
struct Model {
    /// The band `[-beta, a_max]`.
    ego: Bounds,
    /// The leader's hardest braking, positive.
    leader_braking: f32,
    max_speed: f32,
    /// The fastest ego the controller certifies: the table's and the envelope's limit.
    max_ego_speed: f32,
    /// The rear grid's lowest and highest gap, m.
    gap_min: f32,
    gap_max: f32,
    /// The smallest value on the rear grid's last gap face: the rear value beyond the grid.
    beyond_grid: f32,
    error_bound: f32,
}

impl Model {
    fn front(&self, response_time: f32, response_acceleration: f32) -> FrontModel {
        FrontModel {
            leader_braking: self.leader_braking,
            ego_braking: -self.ego.min,
            response_time,
            response_acceleration,
            max_speed: self.max_speed,
        }
    }
}

/// The ACC safety controller. It owns the table and a log of recent events; it never allocates
/// and never panics. A clone is an independent controller in the same state (host-side
/// searches look ahead with one).
#[derive(Clone)]
pub struct Controller<'t> {
    table: Result<(Table<'t>, Model), Fault>,
    config: Config,
    mode: Mode,
    /// The last command's takeover request.
    takeover: bool,
    /// The time of the last step (`None` before the first).
    last_now_us: Option<u64>,
    /// Periods of the minimum-risk manoeuvre left after a clock jump, and its fault.
    clock_recovery: (u32, Fault),
    margin_lost: bool,
    events: Deque<Event, 32>,
    issued: IssuedCommands,
    /// When the current run of commands braking at beta began (`None`: the last command was
    /// not braking at beta): the braking is under way since then, not only from now.
    braking_since_us: Option<u64>,
    /// The last plausible leader measurement, with the ego's speed interval at its time.
    leader: Option<LeaderMemo>,
    /// Since when (the ego measurement's time of the first of an unbroken run of steps) every
    /// step's speed headroom was zero or more: from then on the ego's true speed has stayed
    /// within the domain.
    speed_kept_from_us: Option<u64>,
    /// The last plausible follower measurement, with its rear value at its time.
    rear: Option<RearMemo>,
    /// The latest ego-speed measurements `(time, speed)`, oldest first: the one nearest a
    /// track's time gives the ego's speed there.
    ego_history: Deque<(u64, f32), EGO_HISTORY>,
}

/// Ego-speed measurements kept to find the one nearest a track's time: 16 periods, 320 ms at
/// the default period, more than the radar's latency and cycle.
const EGO_HISTORY: usize = 16;

/// The last plausible leader measurement (module docs: aging and lost tracks).
#[derive(Debug, Clone, Copy)]
struct LeaderMemo {
    /// When it was measured, microseconds.
    at_us: u64,
    track: Track,
    /// The interval of the ego's speed at `at_us`, measurement error included, m/s.
    ego: (f32, f32),
}

/// The last plausible follower measurement and its rear value at its time: it holds for ever
/// while every command is in the band (module docs), so it is computed once per measurement.
#[derive(Debug, Clone, Copy)]
struct RearMemo {
    at_us: u64,
    track: Track,
    value: Result<f32, Fault>,
}

/// One command the controller issued.
#[derive(Debug, Clone, Copy)]
struct Issued {
    at_us: u64,
    acceleration: f32,
}

/// The commands issued since the oldest time a later query can ask about, kept as a
/// sliding-window maximum (each entry larger than every later one), so that the largest is the
/// front entry: O(1) per step. A track may be old (the certified fallback argues from its last
/// measurement, whatever its age), so the window is bounded by its capacity, not by a time:
/// when it is full, the two oldest entries merge into one at the later one's time with the
/// earlier's (larger) value, which over-states the commands between them and so stays an upper
/// bound.
#[derive(Clone)]
struct IssuedCommands {
    window: Deque<Issued, 272>,
    /// Every command issued at or after this time is in the window (`None` before the first
    /// command): before it, what the actuator did is unknown.
    first_at_us: Option<u64>,
}

impl IssuedCommands {
    /// No command issued yet.
    fn new() -> Self {
        IssuedCommands {
            window: Deque::new(),
            first_at_us: None,
        }
    }

    /// Records `acceleration` issued at `at_us`; entries older than `keep_from_us` are no
    /// longer asked about and go.
    fn push(&mut self, at_us: u64, acceleration: f32, keep_from_us: u64) {
        while let Some(e) = self.window.front().copied() {
            if e.at_us >= keep_from_us {
                break;
            }
            self.window.pop_front();
            // A query reaching back before this entry's time no longer finds it.
            self.first_at_us = self.first_at_us.map(|t| t.max(e.at_us + 1));
        }
        while self
            .window
            .back()
            .is_some_and(|e| e.acceleration <= acceleration)
        {
            self.window.pop_back();
        }
        if self.window.is_full() {
            if let (Some(oldest), Some(next)) = (self.window.pop_front(), self.window.pop_front()) {
                let merged = Issued {
                    at_us: next.at_us,
                    acceleration: math::max(oldest.acceleration, next.acceleration),
                };
                let _ = self.window.push_front(merged);
            }
        }
        if self
            .window
            .push_back(Issued {
                at_us,
                acceleration,
            })
            .is_err()
        {
            // Cannot happen (a slot was freed above); if it did, forget and start again (the
            // largest acceleration is then assumed until the window refills).
            self.window.clear();
            self.first_at_us = None;
        }
        if self.first_at_us.is_none() {
            self.first_at_us = Some(at_us);
        }
    }

    /// Forgets every command: what the actuator was told is unknown from here on.
    fn forget(&mut self) {
        self.window.clear();
        self.first_at_us = None;
    }

    /// An upper bound of every command issued since `span_us` before `at_us`: the window's
    /// largest, or `unknown` if the first command recorded is later than that (before it, what
    /// the actuator did is not known).
    fn largest_since(&self, at_us: u64, span_us: u64, unknown: f32) -> f32 {
        let known = self
            .first_at_us
            .is_some_and(|t| t.saturating_add(span_us) <= at_us);
        let largest = self
            .window
            .front()
            .map_or(f32::NEG_INFINITY, |e| e.acceleration);
        if known {
            largest
        } else {
            math::max(largest, unknown)
        }
    }
}

fn model_of(table: &Table<'_>, config: &Config) -> Result<Model, Fault> {
    let envelope = &config.envelope;
    let header = table.header();
    let Game::ThreeCarSplit {
        ego,
        leader,
        max_speed,
        ..
    } = header.game
    else {
        return Err(Fault::WrongGame);
    };
    let (Some(gaps), Some(follower_speeds), Some(ego_speeds)) = (
        table.axis_bounds(0),
        table.axis_bounds(1),
        table.axis_bounds(2),
    ) else {
        return Err(Fault::WrongGame);
    };
    if ego.min < envelope.min_acceleration || ego.max > envelope.max_acceleration {
        return Err(Fault::TableOutsideEnvelope);
    }
    match header.verification {
        Some(v)
            if v.is_complete()
                && v.rear_margin == config.rear_margin
                && v.verifier >= table_format::REAR_SAMPLE_VERIFIER => {}
        _ => return Err(Fault::TableNotVerified),
    }
    // The rear table must cover every speed the game allows: the domain check below relies on
    // it.
    let covers = |b: Bounds| b.min <= 0.0 && b.max >= max_speed;
    if table.dims() != 3 || !covers(follower_speeds) || !covers(ego_speeds) {
        return Err(Fault::WrongGame);
    }
    // The last gap face is the last `points(1) * points(2)` nodes (C order).
    let nodes = table.node_count();
    let face = header
        .axes
        .get(1)
        .zip(header.axes.get(2))
        .map_or(0, |(a, b)| a.points as usize * b.points as usize);
    let beyond_grid = (nodes.saturating_sub(face)..nodes)
        .filter_map(|n| table.value_at_node(n))
        .fold(f32::INFINITY, math::min);
    Ok(Model {
        ego,
        leader_braking: -leader.min,
        max_speed,
        max_ego_speed: math::min(max_speed, envelope.max_speed),
        gap_min: gaps.min,
        gap_max: gaps.max,
        beyond_grid,
        error_bound: header.error_bound.total(),
    })
}

impl<'t> Controller<'t> {
    /// A controller running `table_bytes`. A table that does not parse, or is not a split
    /// three-car table, leaves the controller in the minimum-risk manoeuvre for good, with the
    /// reason in every command.
    pub fn new(table_bytes: &'t [u8], config: Config) -> Self {
        let table = if config.is_valid() {
            Table::parse(table_bytes)
                .map_err(Fault::Table)
                .and_then(|t| model_of(&t, &config).map(|m| (t, m)))
        } else {
            Err(Fault::InvalidConfig)
        };
        if let Err(fault) = &table {
            log_warn!("table refused: {}", fault);
        }
        let mut config = config;
        config.mrm_deceleration = math::clamp(config.mrm_deceleration, 0.5, 4.0);
        config.mrm_gentle_deceleration =
            math::clamp(config.mrm_gentle_deceleration, 0.5, config.mrm_deceleration);
        Controller {
            table,
            config,
            mode: Mode::MinimumRisk,
            takeover: true,
            last_now_us: None,
            clock_recovery: (0, Fault::ClockJumped),
            margin_lost: false,
            events: Deque::new(),
            issued: IssuedCommands::new(),
            braking_since_us: None,
            leader: None,
            speed_kept_from_us: None,
            rear: None,
            ego_history: Deque::new(),
        }
    }

    /// How far before a measurement's time the issued commands matter: the dead time and five
    /// lag time constants, microseconds.
    fn command_span_us(&self) -> u64 {
        let c = &self.config;
        u64::from(c.actuator_dead_time_us) + 5 * u64::from(c.actuator_lag_us)
    }

    /// The oldest time a later step's `pending` can ask about: the kept measurements' times
    /// (a new one is never older than the last of its channel), less the command span; with
    /// none kept, the covered age and the stale limit before now.
    fn keep_commands_from(&self, now: u64) -> u64 {
        let c = &self.config;
        let oldest = [
            self.leader.map(|l| l.at_us),
            self.rear.map(|r| r.at_us),
            self.ego_history.front().map(|e| e.0),
        ]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or_else(|| {
            now.saturating_sub(
                u64::from(c.sensors.max_track_age_us)
                    + u64::from(c.period_us) * u64::from(c.stale_periods),
            )
        });
        oldest.saturating_sub(self.command_span_us())
    }

    /// Ends certified control for good: every later step is the minimum-risk manoeuvre, with
    /// `fault` as its reason. For a board that restarted after a fault of its own (watchdog,
    /// HardFault, panic): software that failed once in a drive is not trusted again in that
    /// drive, so a restart brings the car to a stop instead of resuming control. The
    /// manoeuvre is the usual one (softened for a close, closing follower); nothing but a new
    /// controller ends it.
    pub fn latch_minimum_risk(&mut self, fault: Fault) {
        log_warn!("minimum-risk manoeuvre latched: {}", fault);
        self.table = Err(fault);
    }

    /// The table, if it was accepted.
    pub fn table(&self) -> Option<&Table<'t>> {
        self.table.as_ref().ok().map(|(t, _)| t)
    }

    /// The configuration in force (decelerations clamped to their limits).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The mode of the last command.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The last command's takeover request ([`Command::takeover`]; true before the first
    /// command).
    pub fn takeover_requested(&self) -> bool {
        self.takeover
    }

    /// Recent events (the last 32), oldest first.
    pub fn events(&self) -> impl Iterator<Item = &Event> {
        self.events.iter()
    }

    /// The certificate at the true state `(gap_leader, leader_speed, gap_follower,
    /// follower_speed, ego_speed)`, with the same domain rules as the control step: `None`
    /// outside the domain or without a table. For tests and campaigns, which judge the
    /// certificate on the state the firmware cannot see exactly.
    pub fn certificate(&self, state: [f32; 5]) -> Option<Certificate> {
        self.certificate_with_response(state, 0.0, 0.0)
    }

    /// [`Controller::certificate`] for an ego whose acceleration is at most
    /// `response_acceleration` for `response_time` seconds before braking at beta takes effect
    /// (its actuator's dead time and lag, with the commands still in its pipeline).
    pub fn certificate_with_response(
        &self,
        state: [f32; 5],
        response_time: f32,
        response_acceleration: f32,
    ) -> Option<Certificate> {
        let (table, model) = self.table.as_ref().ok()?;
        let [gap_leader, leader_speed, gap_follower, follower_speed, ego_speed] = state;
        let rear = rear_value(
            table,
            model,
            (gap_follower, gap_follower),
            (follower_speed, follower_speed),
            (ego_speed, ego_speed),
        )
        .ok()?;
        let front = front_value(
            gap_leader,
            leader_speed,
            ego_speed,
            &model.front(response_time, response_acceleration),
        );
        let peak =
            ego_speed + math::max(response_acceleration, 0.0) * math::max(response_time, 0.0);
        Some(self.certificate_of(front, rear, model.max_ego_speed - peak, model))
    }

    fn certificate_of(&self, front: f32, rear: f32, speed: f32, model: &Model) -> Certificate {
        Certificate {
            front: front - self.config.front_margin,
            rear: rear - model.error_bound - self.config.rear_margin,
            speed,
        }
    }

    /// Appends to the event log, dropping the oldest entry when it is full. (`heapless::Deque`
    /// rather than `HistoryBuf`: its ring arithmetic has no bounds check the optimiser cannot
    /// remove, so the control step keeps no panic path; see the `no-panic` binary.)
    fn log(&mut self, event: Event) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(event);
    }

    /// One control step. Never inlined: it is the unit the target's cost figures (stack,
    /// instructions per step) are measured on.
    #[inline(never)]
    pub fn step(&mut self, inputs: &Inputs) -> Command {
        let now = inputs.now_us;
        // The clock: a step earlier than the last, or more than MAX_STEP_GAP_PERIODS periods
        // after it, is a jump. The new time is adopted (so a jump never latches), the command
        // history is forgotten (its time stamps belong to the old time line), and the
        // minimum-risk manoeuvre lasts CLOCK_RECOVERY_PERIODS good periods more.
        let max_gap = MAX_STEP_GAP_PERIODS * u64::from(self.config.period_us);
        let jump = match self.last_now_us {
            Some(last) if now < last => Some(Fault::ClockWentBackwards),
            Some(last) if now - last > max_gap => Some(Fault::ClockJumped),
            _ => None,
        };
        self.last_now_us = Some(now);
        let command = if let Some(fault) = jump {
            self.issued.forget();
            self.braking_since_us = None;
            // The kept measurements' times belong to the old time line.
            self.leader = None;
            self.speed_kept_from_us = None;
            self.rear = None;
            self.ego_history.clear();
            self.clock_recovery = (CLOCK_RECOVERY_PERIODS, fault);
            self.minimum_risk(inputs, fault)
        } else if self.clock_recovery.0 > 0 {
            self.clock_recovery.0 -= 1;
            self.minimum_risk(inputs, self.clock_recovery.1)
        } else {
            self.decide(inputs)
        };
        let command = Command {
            acceleration: self.config.envelope.clamp(command.acceleration),
            ..command
        };
        if command.mode != self.mode {
            self.log(Event::ModeChanged {
                at_us: now,
                to: command.mode,
                fault: command.fault,
            });
            log_info!("mode {} (fault {})", command.mode, command.fault);
        }
        self.mode = command.mode;
        self.takeover = command.takeover;
        // Every command goes to the actuator: the look-ahead of later steps must know it.
        let keep_from = self.keep_commands_from(now);
        self.issued.push(now, command.acceleration, keep_from);
        let at_beta = self
            .table
            .as_ref()
            .is_ok_and(|(_, m)| command.acceleration <= m.ego.min);
        self.braking_since_us = match (at_beta, self.braking_since_us) {
            (true, Some(since)) => Some(since),
            (true, None) => Some(now),
            (false, _) => None,
        };
        command
    }

    fn minimum_risk(&self, inputs: &Inputs, fault: Fault) -> Command {
        let deceleration = self.mrm_deceleration(inputs);
        let mut command = Command::bare(-deceleration, Mode::MinimumRisk, Some(fault));
        command.takeover = true;
        let Ok((_, model)) = &self.table else {
            return command;
        };
        let planned = math::clamp(-deceleration, model.ego.min, model.ego.max);
        command.acceleration = planned;
        // The front half still applies where its inputs are good (module docs): the manoeuvre
        // brakes harder when the leader needs it, never more than beta.
        let now = inputs.now_us;
        if let (Some(leader), Ok(ego_speed)) =
            (self.leader, self.check_ego_speed(&inputs.ego_speed, now))
        {
            let t_e = inputs.ego_speed.timestamp_us;
            let pending = self.pending(leader.at_us.min(t_e), model);
            command.acceleration = self
                .enforce_front(model, &leader, ego_speed, t_e, now, pending, planned)
                .command;
            command.leader = self.track_state(leader.at_us, now);
        }
        command
    }

    /// The minimum-risk deceleration: `mrm_deceleration`, softened to
    /// `mrm_gentle_deceleration` when the follower is known, close and closing (by this
    /// period's plausible track, or the last one kept).
    fn mrm_deceleration(&self, inputs: &Inputs) -> f32 {
        let c = &self.config;
        let follower = if self.is_plausible(&inputs.follower, inputs.now_us) {
            Some(inputs.follower.value)
        } else {
            self.rear.map(|r| r.track)
        };
        let close_and_closing = follower.is_some_and(|t| {
            math::is_finite(t.gap) && t.gap < c.follower_close_gap && t.rel_speed < 0.0
        });
        if close_and_closing {
            c.mrm_gentle_deceleration
        } else {
            c.mrm_deceleration
        }
    }

    /// A track measurement the controller can use: flagged valid by the sensor, a gap that is
    /// not NaN and not negative (`+inf`: no vehicle), a finite relative speed within 100 m/s,
    /// taken no later than now.
    fn is_plausible(&self, m: &Measurement<Track>, now_us: u64) -> bool {
        let t = m.value;
        m.valid
            && !t.gap.is_nan()
            && t.gap >= 0.0
            && math::is_finite(t.rel_speed)
            && math::abs(t.rel_speed) <= 100.0
            && m.timestamp_us <= now_us
    }

    /// Whether `m` is plausible and newer than the measurement `kept` (its time and track): a
    /// later time stamp, or the same one with another value.
    fn is_new_measurement(
        &self,
        m: &Measurement<Track>,
        kept: Option<(u64, Track)>,
        now: u64,
    ) -> bool {
        self.is_plausible(m, now)
            && kept.is_none_or(|(at, track)| {
                m.timestamp_us > at || (m.timestamp_us == at && m.value != track)
            })
    }

    /// The state of a track kept from `at_us`, at `now`.
    fn track_state(&self, at_us: u64, now: u64) -> TrackState {
        self.config.sensors.track_state(now.saturating_sub(at_us))
    }

    /// The ego's speed, if its measurement is valid, finite, in `[0, 100]` m/s and no older than
    /// `stale_periods` periods.
    fn check_ego_speed(&self, m: &Measurement<f32>, now_us: u64) -> Result<f32, Fault> {
        let v = m.value;
        if !(m.valid && math::is_finite(v) && (0.0..=100.0).contains(&v)) {
            return Err(Fault::EgoSpeedInvalid);
        }
        let limit = u64::from(self.config.period_us) * u64::from(self.config.stale_periods);
        if !(m.timestamp_us <= now_us && now_us - m.timestamp_us <= limit) {
            return Err(Fault::EgoSpeedStale);
        }
        Ok(v)
    }

    /// Keeps the ego's speed measurement at `t_e` (a newer one than the last kept).
    fn remember_ego_speed(&mut self, t_e: u64, v: f32) {
        if self.ego_history.back().is_some_and(|e| e.0 >= t_e) {
            return;
        }
        if self.ego_history.is_full() {
            self.ego_history.pop_front();
        }
        let _ = self.ego_history.push_back((t_e, v));
    }

    /// The interval of the ego's speed at time `t` (m/s, error included): from the kept
    /// measurement nearest `t`, moved to `t` within the accelerations possible in between (at
    /// most `pending`, at least the band's lowest).
    fn ego_speed_interval_at(&self, t: u64, model: &Model) -> (f32, f32) {
        let distance = |e: &(u64, f32)| e.0.abs_diff(t);
        let Some(&(t_e, v)) = self
            .ego_history
            .iter()
            .min_by(|a, b| distance(a).cmp(&distance(b)))
        else {
            return (0.0, model.max_ego_speed.max(0.0) + 100.0);
        };
        let pending = self.pending(t.min(t_e), model);
        ego_speed_at(
            self.config.sensors.ego_speed(v),
            t_e,
            t,
            pending,
            model.ego.min,
        )
    }

    /// Takes this period's leader measurement if it is plausible and newer than the one kept,
    /// and says what the controller makes of the track.
    fn observe_leader(&mut self, m: &Measurement<Track>, now: u64, model: &Model) -> TrackState {
        let newer = self.is_new_measurement(m, self.leader.map(|l| (l.at_us, l.track)), now);
        if !newer {
            return self
                .leader
                .map_or(TrackState::Missing, |l| self.track_state(l.at_us, now));
        }
        let new_vehicle = self
            .leader
            .is_some_and(|old| self.is_another_vehicle(&old, m, model));
        let ego = self.ego_speed_interval_at(m.timestamp_us, model);
        self.leader = Some(LeaderMemo {
            at_us: m.timestamp_us,
            track: m.value,
            ego,
        });
        if new_vehicle {
            self.log(Event::NewLeader {
                at_us: now,
                gap: m.value.gap,
            });
            TrackState::New
        } else {
            self.track_state(m.timestamp_us, now)
        }
    }

    /// Whether a new leader measurement cannot be the vehicle of the last one: its range is
    /// below the least the old vehicle can have closed to (the old range's lowest, closing at
    /// the old range rate's lowest, the relative speed falling at most at the leader's hardest
    /// braking plus the ego's largest acceleration), or a vehicle appears where there was none.
    fn is_another_vehicle(
        &self,
        old: &LeaderMemo,
        new: &Measurement<Track>,
        model: &Model,
    ) -> bool {
        let sensors = &self.config.sensors;
        if !math::is_finite(old.track.gap) {
            return math::is_finite(new.value.gap);
        }
        let dt = seconds(new.timestamp_us.saturating_sub(old.at_us));
        let closing = model.leader_braking + model.ego.max;
        let least = sensors.range(old.track.gap).0 + sensors.range_rate(old.track.rel_speed).0 * dt
            - 0.5 * closing * dt * dt;
        sensors.range(new.value.gap).1 < least
    }

    /// Takes this period's follower measurement if it is plausible and newer than the one
    /// kept, computing its rear value at its time, and says what the controller makes of it.
    fn observe_follower(&mut self, m: &Measurement<Track>, now: u64, model: &Model) -> TrackState {
        let newer = self.is_new_measurement(m, self.rear.map(|r| (r.at_us, r.track)), now);
        if let (true, Ok((table, _))) = (newer, &self.table) {
            let sensors = &self.config.sensors;
            let (ego_low, ego_high) = self.ego_speed_interval_at(m.timestamp_us, model);
            // Where every step since before the track's time kept a speed headroom of zero or
            // more, the ego's true speed has stayed within the domain (module docs: the ego's
            // speed), and its interval is held there too.
            let ego_high = if self.speed_kept_from_us.is_some_and(|t| t <= m.timestamp_us) {
                math::min(ego_high, model.max_ego_speed)
            } else {
                ego_high
            };
            let gap = sensors.range(m.value.gap);
            let (rate_low, rate_high) = sensors.range_rate(m.value.rel_speed);
            // The follower's speed is `ego - rel_speed`, held in the human's `[0, max_speed]`.
            let follower_low = math::max(ego_low - rate_high, 0.0);
            let follower_high = math::min(math::max(ego_high - rate_low, 0.0), model.max_speed);
            let value = rear_value(
                table,
                model,
                gap,
                (follower_low, follower_high),
                (ego_low, ego_high),
            );
            self.rear = Some(RearMemo {
                at_us: m.timestamp_us,
                track: m.value,
                value,
            });
        }
        self.rear
            .map_or(TrackState::Missing, |r| self.track_state(r.at_us, now))
    }

    fn decide(&mut self, inputs: &Inputs) -> Command {
        let model = match &self.table {
            Ok((_, m)) => *m,
            Err(f) => return self.minimum_risk(inputs, *f),
        };
        let now = inputs.now_us;
        let ego = inputs.ego_speed;
        let ego_speed = match self.check_ego_speed(&ego, now) {
            Ok(v) => v,
            Err(f) => return self.minimum_risk(inputs, f),
        };
        let t_e = ego.timestamp_us;
        self.remember_ego_speed(t_e, ego_speed);
        let leader_state = self.observe_leader(&inputs.leader, now, &model);
        let follower_state = self.observe_follower(&inputs.follower, now, &model);
        let with_tracks = |mut c: Command| {
            c.leader = leader_state;
            c.follower = follower_state;
            c
        };
        let Some(leader) = self.leader else {
            return with_tracks(self.minimum_risk(inputs, Fault::LeaderInvalid));
        };
        let Some(rear) = self.rear else {
            return with_tracks(self.minimum_risk(inputs, Fault::FollowerInvalid));
        };
        // Beyond the covered age: the certified fallback (module docs), the minimum-risk
        // deceleration under the front half of the last good leader measurement.
        let lost = match (leader_state, follower_state) {
            (TrackState::Lost, _) => Some(Fault::LeaderStale),
            (_, TrackState::Lost) => Some(Fault::FollowerStale),
            _ => None,
        };
        let proposal = match lost {
            Some(_) => math::clamp(-self.mrm_deceleration(inputs), model.ego.min, model.ego.max),
            None => self.nominal(leader.track, ego_speed, model.ego),
        };
        let pending = self.pending(leader.at_us.min(t_e), &model);
        let front = self.enforce_front(&model, &leader, ego_speed, t_e, now, pending, proposal);
        self.speed_kept_from_us = if front.headroom >= 0.0 {
            self.speed_kept_from_us.or(Some(t_e))
        } else {
            None
        };
        let mode = match (lost, front.overridden) {
            (Some(_), _) => Mode::MinimumRisk,
            (None, true) => Mode::Override,
            (None, false) => Mode::Nominal,
        };
        let front_certified = front.value > self.config.front_margin;
        let mut command = with_tracks(Command::bare(front.command, mode, lost));
        command.takeover = lost.is_some() || !front_certified;
        // Outside the rear table's domain the front override (and the speed cap) still act:
        // only the rear half is unknown (module docs).
        let rear = match rear.value {
            Ok(w) => w,
            Err(fault) => {
                if lost.is_none() {
                    command.mode = Mode::Uncertified;
                    command.fault = Some(fault);
                }
                command.takeover = true;
                return command;
            }
        };
        let margin = self
            .certificate_of(front.value, rear, front.headroom, &model)
            .margin();
        // Diagnostics: the state itself is no longer certified (logged once per excursion).
        let outside = margin.is_nan() || margin <= 0.0;
        if outside && !self.margin_lost {
            self.log(Event::MarginLost { at_us: now, margin });
        }
        self.margin_lost = outside;
        command.margin = Some(margin);
        command
    }

    /// An upper bound of the ego's acceleration since `t_0` until braking at beta takes full
    /// effect: the largest command issued since `t_0`, less the dead time and five lag time
    /// constants, plus what older commands can still add through the lag (at most e^-5 of the
    /// band's width); the band's top before the first command.
    fn pending(&self, t_0: u64, model: &Model) -> f32 {
        self.issued
            .largest_since(t_0, self.command_span_us(), model.ego.max)
            + self.lag_tail(model)
    }

    /// What commands older than five lag time constants can still add through the lag, at
    /// most: e^-5 of the band's width (none without a lag).
    fn lag_tail(&self, model: &Model) -> f32 {
        if self.config.actuator_lag_us > 0 {
            LAG_TAIL * (model.ego.max - model.ego.min)
        } else {
            0.0
        }
    }

    /// The front half applied to a `proposal` (module docs: the delays, the measurement error,
    /// the ego's speed): the certified front value and speed headroom of the state, and the
    /// command, which is the proposal under the speed cap if its look-ahead passes, else the
    /// gentlest braking that passes, at most beta.
    #[allow(clippy::too_many_arguments)]
    fn enforce_front(
        &self,
        model: &Model,
        leader: &LeaderMemo,
        ego_speed: f32,
        t_e: u64,
        now: u64,
        pending: f32,
        proposal: f32,
    ) -> FrontCheck {
        let c = &self.config;
        let h = seconds(u64::from(c.period_us));
        let dead = seconds(u64::from(c.actuator_dead_time_us));
        let lag = seconds(u64::from(c.actuator_lag_us));
        let t_m = leader.at_us;
        // The worst point of the error box (module docs): the least gap, the slowest leader
        // (the ego's lowest speed at `t_m` plus the least range rate), the fastest ego; the
        // front value is non-decreasing in the first two and non-increasing in the third.
        let sensors = &c.sensors;
        let gap = sensors.range(leader.track.gap).0;
        let (ego_low, ego_high) = leader.ego;
        let leader_at_m = math::max(ego_low + sensors.range_rate(leader.track.rel_speed).0, 0.0);
        let age = seconds(now.saturating_sub(t_m));
        // The certified front value: braking at beta, commanded since the current run of such
        // commands began, or from now.
        let braking_from = self.braking_since_us.unwrap_or(now).min(now);
        let braking_age = seconds(braking_from.saturating_sub(t_m));
        let value = front_value(
            gap,
            leader_at_m,
            ego_high,
            &model.front(braking_age + dead + lag, pending),
        );
        // The speed headroom (module docs): until the braking takes full effect the ego's
        // speed grows at most at `pending` from its measurement's highest.
        let ego_now = sensors.ego_speed(ego_speed).1;
        let since_e = |t: u64| seconds(t.saturating_sub(t_e));
        let headroom = model.max_ego_speed
            - (ego_now + math::max(pending, 0.0) * (since_e(braking_from) + dead + lag));
        // The look-ahead (module docs): `u` held for one period before the braking at beta.
        // Its response acceleration is `max(pending, u + tail)`: the lag averages every command
        // ever issued, and the window's older ones (up to the band's top) still pass `tail` on
        // top of `u` (found in review for issue 20: with `max(pending, u)` the next step's
        // `pending`, `u + tail`, could exceed what the look-ahead had assumed).
        let tail = self.lag_tail(model);
        let response = |u: f32| math::max(pending, u + tail);
        // First the speed: the largest command whose response keeps the ego in the domain.
        let response_end = since_e(now) + h + dead + lag;
        let room = model.max_ego_speed - (ego_now + math::max(pending, 0.0) * response_end);
        let speed_cap = if room < 0.0 {
            // Nothing passes: brake at beta (which keeps a certified headroom, module docs).
            model.ego.min
        } else if response_end > 0.0 {
            math::max(
                (model.max_ego_speed - ego_now) / response_end - tail,
                model.ego.min,
            )
        } else {
            model.ego.max
        };
        let capped = math::min(proposal, speed_cap);
        let margin_front = c.front_margin;
        let ahead = |u: f32| {
            front_value(
                gap,
                leader_at_m,
                ego_high,
                &model.front(age + h + dead + lag, response(u)),
            )
        };
        let at_capped = ahead(capped);
        let passes = room >= 0.0 && at_capped > margin_front;
        let command = if room < 0.0 {
            model.ego.min
        } else if passes {
            capped
        } else {
            least_braking(capped, at_capped, model.ego.min, value, margin_front, |u| {
                ahead(u) > margin_front
            })
        };
        let command = math::clamp(command, model.ego.min, model.ego.max);
        FrontCheck {
            command,
            overridden: !passes || capped < proposal,
            value,
            headroom,
        }
    }

    /// The nominal ACC law: constant time gap with a speed set-point, limited to ISO 15622 and
    /// then to the band.
    fn nominal(&self, leader: Track, ego_speed: f32, ego: Bounds) -> f32 {
        let c = &self.config;
        let speed_law = c.speed_gain * (c.set_speed - ego_speed);
        let law = if math::is_finite(leader.gap) {
            let desired = c.standstill_gap + c.time_gap * ego_speed;
            let gap_law = c.gap_gain * (leader.gap - desired) + c.rel_speed_gain * leader.rel_speed;
            math::min(gap_law, speed_law)
        } else {
            speed_law
        };
        let law = math::clamp(law, ISO_15622_LIMITS.0, ISO_15622_LIMITS.1);
        math::clamp(law, ego.min, ego.max)
    }
}

/// What the front half made of a proposed command ([`Controller::enforce_front`]).
struct FrontCheck {
    /// The command, at most the proposal.
    command: f32,
    /// The speed cap lowered the proposal, or its look-ahead failed.
    overridden: bool,
    /// The state's certified front value, m.
    value: f32,
    /// The state's speed headroom, m/s.
    headroom: f32,
}

/// The ego's speed at time `t` from its measurement's interval `(low, high)` at `t_e`, within
/// the accelerations it can have had in between (at most `pending`, at least `band_min`):
/// `(lowest, highest)`, both at or above zero.
fn ego_speed_at(
    (low, high): (f32, f32),
    t_e: u64,
    t: u64,
    pending: f32,
    band_min: f32,
) -> (f32, f32) {
    let (low, high) = if t_e <= t {
        let dt = seconds(t - t_e);
        (low + band_min * dt, high + pending * dt)
    } else {
        let dt = seconds(t_e - t);
        (low - pending * dt, high - band_min * dt)
    };
    (math::max(low, 0.0), math::max(high, 0.0))
}

/// Microseconds to seconds. The step's time differences are bounded by the covered age and the
/// delays (seconds at most), so they go through `u32`, which the Cortex-M4F converts in one
/// instruction (`u64` takes a library routine); a difference beyond `u32` (71 minutes) is
/// taken at `u32::MAX`.
fn seconds(us: u64) -> f32 {
    u32::try_from(us).unwrap_or(u32::MAX) as f32 * 1e-6
}

/// The rear value over a box of rear states: the intervals of `gap_follower`, the follower's
/// speed and the ego's speed (`(lowest, highest)`). The table's least value over the box
/// inside the grid ([`Table::least_over_box`]: exact for the multilinear interpolation, one
/// lookup for a point), the last gap face's smallest value beyond it (module docs), and
/// [`Fault::OutsideDomain`] below the grid or above the speed range; [`Fault::RearBoxTooWide`]
/// for a box the step does not evaluate.
fn rear_value(
    table: &Table<'_>,
    model: &Model,
    (gap_low, gap_high): (f32, f32),
    follower_speed: (f32, f32),
    ego_speed: (f32, f32),
) -> Result<f32, Fault> {
    if gap_low.is_nan() || gap_high.is_nan() || gap_low < model.gap_min {
        return Err(Fault::OutsideDomain { axis: 0 });
    }
    let within = |(low, high): (f32, f32), max: f32| low >= 0.0 && high <= max && low <= high;
    if !within(follower_speed, model.max_speed) {
        return Err(Fault::OutsideDomain { axis: 1 });
    }
    if !within(ego_speed, model.max_ego_speed) {
        return Err(Fault::OutsideDomain { axis: 2 });
    }
    if gap_low > model.gap_max {
        return Ok(model.beyond_grid);
    }
    // Beyond the grid's last gap the value is at least the last face's smallest.
    let beyond = if gap_high > model.gap_max {
        model.beyond_grid
    } else {
        f32::INFINITY
    };
    let gap_high = math::min(gap_high, model.gap_max);
    let lo = [gap_low, follower_speed.0, ego_speed.0];
    let hi = [gap_high, follower_speed.1, ego_speed.1];
    // Measurements of one time and exact sensors leave a point: one lookup.
    let inside = if lo == hi {
        table.value_at(&lo)
    } else {
        table.least_over_box(&lo, &hi)
    };
    inside.map(|w| math::min(w, beyond)).map_err(|e| match e {
        table_format::Error::BoxTooWide { axis } => Fault::RearBoxTooWide {
            axis: u8::try_from(axis).unwrap_or(u8::MAX),
        },
        table_format::Error::OutOfDomain { axis }
        | table_format::Error::NonFiniteState { axis } => Fault::OutsideDomain {
            axis: u8::try_from(axis).unwrap_or(u8::MAX),
        },
        _ => Fault::OutsideDomain { axis: 0 },
    })
}

/// The override's command: a gentler braking than `beta_command` where one passes the
/// look-ahead, else `beta_command` itself.
///
/// The look-ahead's front value `F(u)` (the command `u` held for a period, then braking at
/// beta) is non-increasing in `u`: a harder-accelerating ego is ahead of a gentler one at every
/// instant. It is known at the refused command (`F(refused) <= margin`) and at `beta_command`
/// (`F(beta) = front`, braking from now). Over one period it is nearly affine in `u` (the
/// extra speed `(u + beta) h` is what matters), so the secant's root, pulled 10% towards
/// `beta`, is a candidate; it is used only if the look-ahead passes it, else the midpoint
/// between it and `beta`, else `beta`. Two evaluations at most (the control step's budget:
/// each costs about 560 instructions on the Cortex-M4F). Whatever is returned either passed the
/// look-ahead or is the braking at beta, which keeps a certified front value (module docs).
/// Braking no harder than needed spares the follower and the jerk.
fn least_braking(
    refused: f32,
    at_refused: f32,
    beta_command: f32,
    front: f32,
    margin: f32,
    passes: impl Fn(f32) -> bool,
) -> f32 {
    let drop = front - at_refused;
    if !(front > margin && drop > 0.0) {
        return beta_command;
    }
    let share = 0.9 * (front - margin) / drop;
    let candidate = beta_command + math::clamp(share, 0.0, 1.0) * (refused - beta_command);
    if passes(candidate) {
        return candidate;
    }
    let halfway = 0.5 * (beta_command + candidate);
    if passes(halfway) {
        halfway
    } else {
        beta_command
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The command window never under-states: after far more strictly falling commands than
    /// it holds (each push merges its two oldest entries), and with entries dropped before a
    /// horizon, `largest_since` is at least the true largest command since any time, and the
    /// band's top where the window no longer knows.
    #[test]
    fn the_command_window_merges_and_forgets_without_under_stating() {
        let mut w = IssuedCommands::new();
        let commands: Vec<(u64, f32)> = (0..1_000u64)
            .map(|k| (k * 10_000, 2.0 - 0.005 * k as f32))
            .collect();
        for &(t, a) in &commands {
            w.push(t, a, 0);
        }
        assert!(w.window.len() <= 272);
        for &(t0, _) in commands.iter().step_by(7) {
            let truth = commands
                .iter()
                .filter(|(t, _)| *t >= t0)
                .map(|(_, a)| *a)
                .fold(f32::NEG_INFINITY, f32::max);
            let got = w.largest_since(t0, 0, 9.0);
            assert!(got >= truth, "since {t0}: {got} below {truth}");
        }
        // Dropped before a horizon: asked about, the window answers with the band's top.
        let mut w = IssuedCommands::new();
        for k in 0..10u64 {
            w.push(k * 10_000, 1.0 - 0.1 * k as f32, 0);
        }
        assert_eq!(w.largest_since(0, 0, 9.0), 1.0);
        w.push(200_000, -3.0, 55_000);
        assert_eq!(w.largest_since(20_000, 0, 9.0), 9.0);
        assert_eq!(w.largest_since(60_000, 0, 9.0), 1.0 - 0.1 * 6.0);
    }
}
