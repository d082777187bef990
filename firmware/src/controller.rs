//! The control step: one set of inputs in, one acceleration command out.
//!
//! # Policy: a least-restrictive safety filter
//! A nominal ACC law (constant time gap with a speed set-point) drives while the table certifies
//! that the state stays safe through the next control period under it; otherwise the table's
//! bang-bang input `u2*` takes over ([`Mode::Override`]). Faults lead to a minimum-risk manoeuvre
//! ([`Mode::MinimumRisk`]).
//!
//! # Why a one-step look-ahead, and why it is sound
//! The command is held for a period `h`. In that time the state moves, under the ego's held
//! command `u` and any admissible human inputs, within a box whose *lowest* corner is
//!
//! `x_g1 + v_g1 h + (l_min - u) h^2/2`, `v_g1 + (l_min - u) h`,
//! `x_g2 + v_g2 h + (u - f_max) h^2/2`, `v_g2 + (u - f_max) h`,
//!
//! with `l_min` the leader's hardest braking and `f_max` the follower's largest acceleration;
//! the corner used is the lower of that and the current state, per coordinate. Relative speeds
//! are affine in time, so their lowest value is at an end of the period. A gap is a parabola
//! in time: its lowest value is at an end too, except when the relative speed changes sign
//! inside the period, where it dips below both ends by at most `|a| h^2 / 2` (4 m/s^2, 20 ms:
//! under 1 mm), which the switch margin covers. The value function never decreases with more
//! gap or more relative speed (the property the solver's boundary bounds rest on), so its
//! minimum over the reachable box is at that corner, and the table's value is at most
//! `error_bound.total()` above the solver's. Hence if `V_table(corner) - error_bound > margin`,
//! the solver's value stays positive through the period whatever the humans do, and the
//! nominal command is safe to apply. A plain `V(z) > eps` test ignores the motion during the
//! period and lets the state cross the boundary between two samples.
//!
//! # Faults and the minimum-risk manoeuvre
//! A table that does not parse or is not a three-car table, a measurement the sensor flags
//! invalid, a non-finite or physically impossible value, a measurement older than
//! `stale_periods` periods, a state below the grid (a gap below the grid's lowest gap or a
//! closing speed beyond it), or a clock that went backwards: each is a [`Fault`], reported in
//! the command and logged, and the
//! command is the minimum-risk manoeuvre: a controlled deceleration of
//! `mrm_deceleration` (default 2 m/s^2, at most 4), softened to `mrm_gentle_deceleration`
//! when the follower is known, close and closing, so as not to provoke a rear-end collision.
//! States above the grid (more gap, more opening speed) are clamped onto it, which is
//! conservative; so is clamping them onto the table's trusted box from above. Below the trusted
//! box the table is still a lower bound of the value (it is compiled from the pessimistic
//! solve), but how close a bound is not established there: the look-ahead then demands a
//! further `untrusted_margin` (default 2 m) before the nominal law may drive. An ego slower than the
//! table assumes is not a fault of the inputs: the controller runs the nominal law uncertified
//! ([`Mode::Uncertified`]), braking no harder than the follower can unless the leader's
//! stopping point demands it (`spare_the_follower`): at low speed the sandwich is lost by
//! rear-end collisions.

use heapless::Deque;
use table_format::{Bounds, EgoAction, FollowerSpeed, Game, Table};

use crate::fmt::{log_info, log_warn};
use crate::inputs::{Inputs, Measurement, Track};
use crate::math;

/// Tuning of the controller. Units: SI.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Control period, microseconds (default 20 ms).
    pub period_us: u32,
    /// A measurement older than this many periods is stale.
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
    /// Extra value margin (m) the look-ahead must keep before the nominal law may drive.
    pub switch_margin: f32,
    /// Further margin (m) below the table's trusted box, where the table is a sound lower
    /// bound but its accuracy is not established.
    pub untrusted_margin: f32,
    /// Minimum-risk deceleration, m/s^2 (positive, at most 4).
    pub mrm_deceleration: f32,
    /// Minimum-risk deceleration when the follower is close and closing, m/s^2 (positive).
    pub mrm_gentle_deceleration: f32,
    /// "Close" for the follower in the minimum-risk manoeuvre, m.
    pub follower_close_gap: f32,
}

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
            switch_margin: 0.5,
            untrusted_margin: 2.0,
            mrm_deceleration: 2.0,
            mrm_gentle_deceleration: 1.0,
            follower_close_gap: 15.0,
        }
    }
}

/// ISO 15622 acceleration limits for ACC, m/s^2.
pub const ISO_15622_LIMITS: (f32, f32) = (-3.5, 2.0);

/// Which law produced the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// The nominal ACC law, certified safe through the next period.
    Nominal,
    /// The table's bang-bang input `u2*`.
    Override,
    /// The minimum-risk manoeuvre after a fault.
    MinimumRisk,
    /// The nominal law without a certificate, braking no harder than the follower can unless
    /// the leader demands it: the ego is slower than the speed the table assumes for the
    /// follower, so the table cannot speak (see [`Fault::BelowAssumedSpeed`]).
    Uncertified,
}

/// Why the controller is in the minimum-risk manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Fault {
    /// The table did not pass `Table::parse`.
    Table(table_format::Error),
    /// The table is not a three-car table.
    WrongGame,
    /// The leader track is flagged invalid, non-finite or impossible.
    LeaderInvalid,
    /// The leader track is older than `stale_periods` periods.
    LeaderStale,
    /// The follower track is flagged invalid, non-finite or impossible.
    FollowerInvalid,
    /// The follower track is older than `stale_periods` periods.
    FollowerStale,
    /// The ego speed is flagged invalid, non-finite, negative or above 100 m/s.
    EgoSpeedInvalid,
    /// The ego speed is older than `stale_periods` periods.
    EgoSpeedStale,
    /// The state lies below the table's grid on this axis (0: gap_leader, 1: rel_speed_leader,
    /// 2: gap_follower, 3: rel_speed_follower).
    OutsideGrid {
        /// The axis.
        axis: u8,
    },
    /// The ego is slower than the speed the table assumes for the follower's IDM. Not a sensor
    /// fault: the controller runs the nominal law uncertified ([`Mode::Uncertified`]), as a
    /// conventional ACC would below its certified range, rather than braking (a hard
    /// minimum-risk braking there invites the follower into the ego's rear).
    BelowAssumedSpeed,
    /// The clock went backwards.
    ClockWentBackwards,
}

/// One control step's output.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Command {
    /// Requested acceleration, m/s^2 (negative: braking). Always finite.
    pub acceleration: f32,
    /// Which law produced it.
    pub mode: Mode,
    /// The fault behind a minimum-risk manoeuvre.
    pub fault: Option<Fault>,
    /// The table's value at the state (m), when it was looked up.
    pub value: Option<f32>,
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
    /// The state is no longer certified safe (its table value is within the error bound of
    /// zero, or below): logged once per episode.
    MarginLost {
        /// Time, microseconds.
        at_us: u64,
        /// The table's value at the state, m.
        value: f32,
    },
}

/// What the controller takes from the table's header once.
#[derive(Debug, Clone, Copy)]
struct Model {
    ego: Bounds,
    leader_min: f32,
    follower_min: f32,
    follower_max: f32,
    min_ego_speed: f32,
    error_bound: f32,
}

/// The ACC safety controller. It owns the table and a log of recent events; it never allocates
/// and never panics.
pub struct Controller<'t> {
    table: Result<(Table<'t>, Model), Fault>,
    config: Config,
    mode: Mode,
    last_now_us: u64,
    margin_lost: bool,
    events: Deque<Event, 32>,
}

fn model_of(table: &Table<'_>) -> Result<Model, Fault> {
    let header = table.header();
    let (ego, leader, follower, min_ego_speed) = match header.game {
        Game::ThreeCarBaseline {
            ego,
            leader,
            follower,
        } => (ego, leader, follower, 0.0),
        Game::ThreeCarIdm {
            ego,
            leader,
            follower_clip,
            follower_speed,
            ..
        } => {
            let min_speed = match follower_speed {
                FollowerSpeed::NominalEgoSpeed { ego_speed } => ego_speed,
                FollowerSpeed::Adversarial { min_ego_speed, .. } => min_ego_speed,
            };
            (ego, leader, follower_clip, min_speed)
        }
        _ => return Err(Fault::WrongGame),
    };
    if table.dims() != 4 {
        return Err(Fault::WrongGame);
    }
    Ok(Model {
        ego,
        leader_min: leader.min,
        follower_min: follower.min,
        follower_max: follower.max,
        min_ego_speed,
        error_bound: header.error_bound.total(),
    })
}

impl<'t> Controller<'t> {
    /// A controller running `table_bytes`. A table that does not parse, or is not a three-car
    /// table, leaves the controller in the minimum-risk manoeuvre for good, with the reason in
    /// every command.
    pub fn new(table_bytes: &'t [u8], config: Config) -> Self {
        let table = Table::parse(table_bytes)
            .map_err(Fault::Table)
            .and_then(|t| model_of(&t).map(|m| (t, m)));
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
            last_now_us: 0,
            margin_lost: false,
            events: Deque::new(),
        }
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

    /// Recent events (the last 32), oldest first.
    pub fn events(&self) -> impl Iterator<Item = &Event> {
        self.events.iter()
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
        let command = self.decide(inputs);
        if command.mode != self.mode {
            self.log(Event::ModeChanged {
                at_us: inputs.now_us,
                to: command.mode,
                fault: command.fault,
            });
            log_info!("mode {} (fault {})", command.mode, command.fault);
        }
        self.mode = command.mode;
        if inputs.now_us > self.last_now_us {
            self.last_now_us = inputs.now_us;
        }
        command
    }

    fn minimum_risk(&self, inputs: &Inputs, fault: Fault) -> Command {
        let c = &self.config;
        let follower = &inputs.follower;
        let follower_close_and_closing = follower.valid
            && self.is_fresh(follower, inputs.now_us)
            && math::is_finite(follower.value.gap)
            && math::is_finite(follower.value.rel_speed)
            && follower.value.gap < c.follower_close_gap
            && follower.value.rel_speed < 0.0;
        let deceleration = if follower_close_and_closing {
            c.mrm_gentle_deceleration
        } else {
            c.mrm_deceleration
        };
        Command {
            acceleration: -deceleration,
            mode: Mode::MinimumRisk,
            fault: Some(fault),
            value: None,
        }
    }

    fn is_fresh<T>(&self, m: &Measurement<T>, now_us: u64) -> bool {
        let limit = u64::from(self.config.period_us) * u64::from(self.config.stale_periods);
        m.timestamp_us <= now_us && now_us - m.timestamp_us <= limit
    }

    fn check_track(
        &self,
        m: &Measurement<Track>,
        now_us: u64,
        invalid: Fault,
        stale: Fault,
    ) -> Result<Track, Fault> {
        let t = m.value;
        // A gap may be +inf ("no vehicle"); NaN, -inf and negative gaps are not measurements.
        let plausible = m.valid
            && !t.gap.is_nan()
            && t.gap >= 0.0
            && math::is_finite(t.rel_speed)
            && math::abs(t.rel_speed) <= 100.0;
        if !plausible {
            return Err(invalid);
        }
        if !self.is_fresh(m, now_us) {
            return Err(stale);
        }
        Ok(t)
    }

    fn decide(&mut self, inputs: &Inputs) -> Command {
        let (table, model) = match &self.table {
            Ok((t, m)) => (t, *m),
            Err(f) => return self.minimum_risk(inputs, *f),
        };
        let now = inputs.now_us;
        if now < self.last_now_us {
            return self.minimum_risk(inputs, Fault::ClockWentBackwards);
        }
        let leader = match self.check_track(
            &inputs.leader,
            now,
            Fault::LeaderInvalid,
            Fault::LeaderStale,
        ) {
            Ok(t) => t,
            Err(f) => return self.minimum_risk(inputs, f),
        };
        let follower = match self.check_track(
            &inputs.follower,
            now,
            Fault::FollowerInvalid,
            Fault::FollowerStale,
        ) {
            Ok(t) => t,
            Err(f) => return self.minimum_risk(inputs, f),
        };
        let ego = inputs.ego_speed;
        if !(ego.valid && math::is_finite(ego.value) && ego.value >= 0.0 && ego.value <= 100.0) {
            return self.minimum_risk(inputs, Fault::EgoSpeedInvalid);
        }
        if !self.is_fresh(&ego, now) {
            return self.minimum_risk(inputs, Fault::EgoSpeedStale);
        }
        let ego_speed = ego.value;
        if ego_speed < model.min_ego_speed {
            return Command {
                acceleration: spare_the_follower(
                    self.nominal(leader, ego_speed, model.ego),
                    leader,
                    ego_speed,
                    &model,
                ),
                mode: Mode::Uncertified,
                fault: Some(Fault::BelowAssumedSpeed),
                value: None,
            };
        }

        let measured = [
            leader.gap,
            leader.rel_speed,
            follower.gap,
            follower.rel_speed,
        ];
        // Below the trusted box on any axis the table may be needlessly conservative there;
        // above it (more gap, more opening speed) the state is clamped onto it, conservatively.
        let trusted = (0..4).all(|k| {
            table
                .trusted_bounds(k)
                .zip(measured.get(k))
                .is_some_and(|(b, x)| *x >= b.min)
        });
        let state = match onto_grid(table, measured) {
            Ok(z) => z,
            Err(f) => return self.minimum_risk(inputs, f),
        };
        let here = match table.lookup(&state) {
            Ok(l) => l,
            Err(_) => return self.minimum_risk(inputs, Fault::OutsideGrid { axis: 0 }),
        };
        let u_star = match here.action {
            EgoAction::Accelerate => model.ego.max,
            EgoAction::Brake => model.ego.min,
        };
        let nominal = self.nominal(leader, ego_speed, model.ego);
        let h = self.config.period_us as f32 * 1e-6;
        // The look-ahead (module docs): the lowest corner reachable in one period under the
        // nominal law must keep a certified value; below the grid it cannot.
        let margin = if trusted {
            self.config.switch_margin
        } else {
            self.config.switch_margin + self.config.untrusted_margin
        };
        let certified = onto_grid(
            table,
            lowest_corner(&state, nominal, model.leader_min, model.follower_max, h),
        )
        .ok()
        .and_then(|corner| table.value_at(&corner).ok())
        .is_some_and(|v| v - model.error_bound > margin);
        let (acceleration, mode) = if certified {
            (nominal, Mode::Nominal)
        } else {
            (u_star, Mode::Override)
        };
        // Diagnostics: the state itself is no longer certified (logged once per episode).
        let outside = here.value - model.error_bound <= 0.0;
        if outside && !self.margin_lost {
            self.log(Event::MarginLost {
                at_us: now,
                value: here.value,
            });
        }
        self.margin_lost = outside;
        Command {
            acceleration: math::clamp(acceleration, model.ego.min, model.ego.max),
            mode,
            fault: None,
            value: Some(here.value),
        }
    }

    /// The nominal ACC law: constant time gap with a speed set-point, limited to ISO 15622 and
    /// then to the game's ego bounds.
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

/// Below the table's speed range (uncertified): the nominal law, but never braking harder than
/// the follower can (the game's bound on its braking), unless the leader leaves no choice: the
/// deceleration that stops the ego behind the point where the leader stops if it brakes as
/// hard as its model allows (less a 2 m margin) is always allowed. A rear-end collision is the
/// typical way to lose a sandwich at low speed, and braking harder than necessary invites it.
fn spare_the_follower(nominal: f32, leader: Track, ego_speed: f32, model: &Model) -> f32 {
    let follower_braking = math::max(-model.follower_min, 0.0);
    let leader_braking = math::max(-model.leader_min, 0.1);
    let needed = if math::is_finite(leader.gap) {
        let leader_speed = math::max(ego_speed + leader.rel_speed, 0.0);
        let room = leader.gap + leader_speed * leader_speed / (2.0 * leader_braking) - 2.0;
        ego_speed * ego_speed / (2.0 * math::max(room, 0.5))
    } else {
        0.0
    };
    let allowed = math::max(needed, follower_braking);
    math::clamp(math::max(nominal, -allowed), model.ego.min, model.ego.max)
}

/// The lowest corner of the box the state can reach within `h` under the held ego input `u`
/// (see the module docs).
fn lowest_corner(z: &[f32; 4], u: f32, leader_min: f32, follower_max: f32, h: f32) -> [f32; 4] {
    let a1 = leader_min - u;
    let a2 = u - follower_max;
    let end = [
        z[0] + z[1] * h + 0.5 * a1 * h * h,
        z[1] + a1 * h,
        z[2] + z[3] * h + 0.5 * a2 * h * h,
        z[3] + a2 * h,
    ];
    // Lowest values over the period are at its ends (up to the sub-millimetre dip of a gap
    // whose relative speed changes sign, which the switch margin covers).
    [
        math::min(z[0], end[0]),
        math::min(z[1], end[1]),
        math::min(z[2], end[2]),
        math::min(z[3], end[3]),
    ]
}

/// Clamps a state from above onto the trusted box (more gap or relative speed is never worse,
/// so this is conservative) and refuses it below the grid.
fn onto_grid(table: &Table<'_>, z: [f32; 4]) -> Result<[f32; 4], Fault> {
    let mut out = z;
    for (k, x) in out.iter_mut().enumerate() {
        let axis = u8::try_from(k).unwrap_or(u8::MAX);
        let grid = table.axis_bounds(k).ok_or(Fault::OutsideGrid { axis })?;
        let trusted = table.trusted_bounds(k).ok_or(Fault::OutsideGrid { axis })?;
        if x.is_nan() || *x < grid.min {
            return Err(Fault::OutsideGrid { axis });
        }
        if *x > trusted.max {
            *x = trusted.max;
        }
    }
    Ok(out)
}
