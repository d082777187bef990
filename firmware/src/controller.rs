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
//! decision: it is a property of the band (proven for the game's exact value; the table is its
//! sampled-data approximation, see `solver::semi_lagrangian`, and what that leaves unproven is
//! issue 11's verify). The front half decides the command. The nominal ACC law's command `u`
//! is held for one period `h`; the look-ahead computes `front_value` with a *response* of `u`
//! for `h` before the braking at `beta`. That is the smallest front gap over every leader
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
//! # The domain
//! The rear table covers `gap_follower` up to its last breakpoint, and speeds in
//! `[0, max_speed]`. A follower farther back than the grid (or none: a gap of `+inf`) is safe
//! until it crosses the grid's last gap, where its value is at least the smallest value on that
//! face of the grid, computed once when the table is loaded: that is its rear value. A leader
//! farther than any gap (or none) has an infinite front value. A measured speed of a human
//! slightly below zero is taken as zero (a slower follower and a faster leader are never
//! worse). An ego or follower faster than `max_speed`, or a follower gap below the grid, is
//! outside the domain: [`Fault::OutsideDomain`], [`Mode::Uncertified`], with the nominal law as
//! the minimum-risk behaviour: its set speed (30 m/s by default, below the table's 35) slows
//! an ego that is too fast back into the domain, and its braking, like every command's, is at
//! most `beta`, which spares the follower: a rear table certifies nothing unless the follower
//! can out-brake the band (measured: with the follower's braking equal to `beta` the rear
//! value's plateau is -0.99 m, README).
//!
//! # Faults and the minimum-risk manoeuvre
//! A table that does not parse or is not a split table, a measurement the sensor flags
//! invalid, a non-finite or physically impossible value, a measurement older than
//! `stale_periods` periods, or a clock that went backwards: each is a [`Fault`], reported in
//! the command and logged, and the command is the minimum-risk manoeuvre: a controlled
//! deceleration of `mrm_deceleration` (default 2 m/s^2, at most 4), softened to
//! `mrm_gentle_deceleration` when the follower is known, close and closing, so as not to provoke
//! a rear-end collision. Clamped into the band, like every other command.
//!
//! # What is assumed
//! The humans keep to the table's model (the leader brakes at most `-leader.min`, the follower
//! drives by the IDM with its time gap in range); the measurements are exact and current, and
//! the ego's acceleration is its command (delays and actuator lag are issue 11).

use heapless::Deque;
use table_format::front::{front_value, FrontModel};
use table_format::{Bounds, Game, Table};

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
            front_margin: 0.5,
            rear_margin: 0.0,
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
    /// The state is outside the table's domain on this axis of the rear table (0:
    /// gap_follower below the grid, 1: follower_speed above `max_speed`, 2: ego_speed above
    /// `max_speed`). Not a sensor fault: the controller runs the nominal law uncertified
    /// ([`Mode::Uncertified`]), as a conventional ACC would outside its certified range,
    /// rather than braking hard into the follower.
    OutsideDomain {
        /// The axis.
        axis: u8,
    },
    /// The clock went backwards.
    ClockWentBackwards,
}

/// One control step's output.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Command {
    /// Requested acceleration, m/s^2 (negative: braking). Always finite, always in the band.
    pub acceleration: f32,
    /// Which law produced it.
    pub mode: Mode,
    /// The fault behind a minimum-risk manoeuvre or an uncertified command.
    pub fault: Option<Fault>,
    /// The certificate's margin at the measured state (m): the smaller of the front value
    /// less `front_margin` and the rear value less its error bound and `rear_margin`. The state
    /// is certified when it is positive. `None` when no certificate was evaluated.
    pub margin: Option<f32>,
}

/// The two halves of the certificate at a state, each as a margin over its level (m): the
/// state is certified when both are positive.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Certificate {
    /// The front value less `front_margin`.
    pub front: f32,
    /// The rear value less the table's error bound and `rear_margin`.
    pub rear: f32,
}

impl Certificate {
    /// The smaller of the two margins.
    pub fn margin(&self) -> f32 {
        math::min(self.front, self.rear)
    }
}

/// f32 rounding can lower a computed margin along a trajectory on which the exact one never
/// decreases (the front value's closed form and the plant are evaluated in f32; the property
/// test `never_decreases_along_the_ego_braking` in `table_format::front` allows
/// `1e-3 (1 + |F|)`, 1.5 mm at `F = 0.5 m`). A certified state (margin above zero) is claimed
/// to keep its margin above `-CERTIFICATE_TOLERANCE`, 1 cm.
pub const CERTIFICATE_TOLERANCE: f32 = 0.01;

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

    /// The certificate at the true state `(gap_leader, leader_speed, gap_follower,
    /// follower_speed, ego_speed)`, with the same domain rules as the control step: `None`
    /// outside the domain or without a table. For tests and campaigns, which judge the
    /// certificate on the state the firmware cannot see exactly.
    pub fn certificate(&self, state: [f32; 5]) -> Option<Certificate> {
        let (table, model) = self.table.as_ref().ok()?;
        let [gap_leader, leader_speed, gap_follower, follower_speed, ego_speed] = state;
        let rear = rear_value(table, model, gap_follower, follower_speed, ego_speed).ok()?;
        let front = front_value(gap_leader, leader_speed, ego_speed, &model.front(0.0, 0.0));
        Some(self.certificate_of(front, rear, model))
    }

    fn certificate_of(&self, front: f32, rear: f32, model: &Model) -> Certificate {
        Certificate {
            front: front - self.config.front_margin,
            rear: rear - model.error_bound - self.config.rear_margin,
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
        let acceleration = match &self.table {
            Ok((_, model)) => math::clamp(-deceleration, model.ego.min, model.ego.max),
            Err(_) => -deceleration,
        };
        Command {
            acceleration,
            mode: Mode::MinimumRisk,
            fault: Some(fault),
            margin: None,
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
        let nominal = self.nominal(leader, ego_speed, model.ego);
        // Absolute speeds; a human measured slightly below zero is taken at rest (a slower
        // follower and a faster leader are never worse).
        let leader_speed = math::max(ego_speed + leader.rel_speed, 0.0);
        let follower_speed = math::max(ego_speed - follower.rel_speed, 0.0);
        let rear = match rear_value(table, &model, follower.gap, follower_speed, ego_speed) {
            Ok(w) => w,
            Err(fault) => {
                return Command {
                    acceleration: nominal,
                    mode: Mode::Uncertified,
                    fault: Some(fault),
                    margin: None,
                }
            }
        };
        let h = self.config.period_us as f32 * 1e-6;
        // The look-ahead (module docs): the front value with a command held for one period
        // before braking at beta.
        let margin_front = self.config.front_margin;
        let ahead = |u: f32| front_value(leader.gap, leader_speed, ego_speed, &model.front(h, u));
        // Braking at beta from now is the front value itself (no response needed).
        let front = front_value(leader.gap, leader_speed, ego_speed, &model.front(0.0, 0.0));
        let at_nominal = ahead(nominal);
        let (acceleration, mode) = if at_nominal > margin_front {
            (nominal, Mode::Nominal)
        } else {
            (
                least_braking(
                    nominal,
                    at_nominal,
                    model.ego.min,
                    front,
                    margin_front,
                    |u| ahead(u) > margin_front,
                ),
                Mode::Override,
            )
        };
        let margin = self.certificate_of(front, rear, &model).margin();
        // Diagnostics: the state itself is no longer certified (logged once per excursion).
        let outside = margin.is_nan() || margin <= 0.0;
        if outside && !self.margin_lost {
            self.log(Event::MarginLost { at_us: now, margin });
        }
        self.margin_lost = outside;
        Command {
            acceleration: math::clamp(acceleration, model.ego.min, model.ego.max),
            mode,
            fault: None,
            margin: Some(margin),
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

/// The rear value at `(gap_follower, follower_speed, ego_speed)`: the table's interpolation
/// inside the grid, the last gap face's smallest value beyond it (module docs), and
/// [`Fault::OutsideDomain`] below the grid or above the speed range.
fn rear_value(
    table: &Table<'_>,
    model: &Model,
    gap_follower: f32,
    follower_speed: f32,
    ego_speed: f32,
) -> Result<f32, Fault> {
    if gap_follower.is_nan() || gap_follower < model.gap_min {
        return Err(Fault::OutsideDomain { axis: 0 });
    }
    if !(follower_speed >= 0.0 && follower_speed <= model.max_speed) {
        return Err(Fault::OutsideDomain { axis: 1 });
    }
    if !(ego_speed >= 0.0 && ego_speed <= model.max_speed) {
        return Err(Fault::OutsideDomain { axis: 2 });
    }
    if gap_follower > model.gap_max {
        return Ok(model.beyond_grid);
    }
    table
        .value_at(&[gap_follower, follower_speed, ego_speed])
        .map_err(|_| Fault::OutsideDomain { axis: 0 })
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
