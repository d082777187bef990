//! The adversarial search: starts and human inputs chosen to break the certificate, within the
//! model the certificate is argued for.
//!
//! One responsibility: look for collisions and certificate losses the sampled campaign does not
//! draw. The campaign samples starts and humans; this module *searches*:
//! - **Starts** ([`StartKind`]): on and near the certified boundary (either half's margin in
//!   `[0, 0.2]` m, found by bisection on its gap), at the domain's edges (each speed near 0 and
//!   near `max_speed`, a follower or a leader at exactly `max_speed`), engaged at any acceleration
//!   in the band, and at standstill. Every start is certified at the true state, with the engaged
//!   acceleration held through the actuator's dead time and lag. With two authorities it is
//!   engaged from a period in standby, as a driver engages; a start the firmware refuses is
//!   drawn again and counted apart ([`MethodSummary::refused_starts`]), so every episode the
//!   search counts is one the firmware drove.
//! - **Humans** ([`Method`]), every input within the model (the leader's acceleration in its
//!   bounds, the follower an IDM whose time gap is anywhere in its range at every instant):
//!   structured cases (hard stops, stop-and-go at many frequencies, time-gap switches timed to
//!   the override's), random piecewise-constant schedules, cross-entropy over schedules,
//!   hill climbing on the smallest margin, and greedy rollouts that choose the next inputs to
//!   minimise the margin a few seconds ahead (on a clone of the loop).
//! - **Sensors and actuator**: exact measurements whose ages differ per channel (0-100 ms, the
//!   firmware's stale limit), the actuator's dead time and lag at or below the firmware's
//!   declared limits.
//!
//! Every case is a value ([`Case`]): deterministic for its seed, written to the findings file,
//! and replayed to a trace by `host-tests replay`.

use firmware::Config;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use table_format::rear::ReactingFollower;
use table_format::Table;

use crate::humans::{follower_speed_gradient, HumanModel};
use crate::sim::{ActuatorModel, Car, SensorModel};
use crate::world::{state_of, Half, ModeName, Score, Start, Tolerances, Trace, World};

/// How the humans' inputs were chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Hard stops, stop-and-go at many frequencies, time-gap switches timed to the override.
    Structured,
    /// Random piecewise-constant schedules.
    Random,
    /// Cross-entropy over piecewise-constant schedules.
    CrossEntropy,
    /// Hill climbing on the smallest margin.
    HillClimbing,
    /// Greedy rollouts: the next inputs that minimise the margin a few seconds ahead.
    Greedy,
}

impl Method {
    /// Every method, in report order.
    pub const ALL: [Method; 5] = [
        Method::Structured,
        Method::Random,
        Method::CrossEntropy,
        Method::HillClimbing,
        Method::Greedy,
    ];
}

/// Where a start was drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StartKind {
    /// Anywhere in the certified set.
    Anywhere,
    /// The front half's margin in `[0, 0.2]` m.
    FrontBoundary,
    /// The rear half's margin in `[0, 0.2]` m.
    RearBoundary,
    /// The ego at 33-35 m/s, accelerating.
    FastEgo,
    /// The follower at 34-35 m/s, half the time at exactly `max_speed`.
    FastFollower,
    /// The leader at 34-35 m/s, half the time at exactly `max_speed`.
    FastLeader,
    /// Every speed near zero.
    Slow,
    /// Everyone at standstill.
    Standstill,
}

const START_KINDS: [StartKind; 8] = [
    StartKind::Anywhere,
    StartKind::FrontBoundary,
    StartKind::RearBoundary,
    StartKind::FastEgo,
    StartKind::FastFollower,
    StartKind::FastLeader,
    StartKind::Slow,
    StartKind::Standstill,
];

/// How the follower's time gap is chosen at each period.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FollowerRule {
    /// The schedule's time gap.
    Schedule,
    /// The rear game's worst case: `T_max` where `dW/dv_follower > 0`, else `T_min`.
    WorstCase,
    /// `T_max` while the firmware overrides, `T_min` otherwise (or the reverse).
    WithOverride {
        /// `T_min` while it overrides instead.
        inverted: bool,
    },
}

/// How long a leader of [`Case::leader_brakes_at_authority_change`] brakes at its hardest
/// after the firmware's braking in force changes, s.
pub const AT_AUTHORITY_CHANGE: f32 = 2.0;

/// The humans' inputs, piecewise constant over segments: the leader's in `[-1, 1]` (-1 its
/// hardest braking, 1 its largest acceleration), the follower's time gap in `[0, 1]` of its
/// range. Past the last segment the last one holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Schedule {
    /// Segment length, s.
    pub segment_s: f32,
    /// The leader's input per segment.
    pub leader: Vec<f32>,
    /// The follower's time gap per segment.
    pub time_gap: Vec<f32>,
}

impl Schedule {
    fn at(&self, t: f32) -> (f32, f32) {
        let i = if self.segment_s > 0.0 {
            (t / self.segment_s).floor().max(0.0) as usize
        } else {
            0
        };
        let pick = |v: &Vec<f32>, default: f32| {
            v.get(i.min(v.len().saturating_sub(1)))
                .copied()
                .unwrap_or(default)
        };
        (pick(&self.leader, 0.0), pick(&self.time_gap, 0.5))
    }

    fn random(segments: usize, segment_s: f32, rng: &mut impl Rng) -> Self {
        Schedule {
            segment_s,
            leader: (0..segments)
                .map(|_| rng.random_range(-1.0..=1.0))
                .collect(),
            time_gap: (0..segments).map(|_| rng.random_range(0.0..=1.0)).collect(),
        }
    }
}

/// What a follower that reacts late ([`Case::follower_reacts`]) does once it has reacted,
/// while the ego's brake lights stay on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum AfterReaction {
    /// Brakes at least as the certificate's follower does
    /// (`ReactingFollower::most_acceleration`: its whole level, harder where its IDM asks):
    /// within the two-authority certificate's model.
    #[default]
    AtItsLevel,
    /// Drives by its IDM, which answers the lights only through the gap it sees: beyond the
    /// certificate's model (docs/certificate.md), searched to measure what that costs.
    ByItsIdm,
}

/// One searched episode, replayable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Case {
    /// How the inputs were chosen.
    pub method: Method,
    /// Where the start was drawn.
    pub start_kind: StartKind,
    /// The start.
    pub start: Start,
    /// The humans' inputs.
    pub schedule: Schedule,
    /// The follower's time-gap rule.
    pub follower_rule: FollowerRule,
    /// The follower sees the ego's brake lights only after its reaction time
    /// ([`Setting::reacting`]): until then it accelerates at its largest acceleration.
    #[serde(default)]
    pub follower_reacts: bool,
    /// What a follower that reacts late does once it has reacted, while the lights stay on.
    #[serde(default)]
    pub follower_after_reaction: AfterReaction,
    /// The leader brakes at its hardest for [`AT_AUTHORITY_CHANGE`] seconds from every
    /// change of the braking the firmware argues with (with two authorities), whatever the
    /// schedule says.
    #[serde(default)]
    pub leader_brakes_at_authority_change: bool,
    /// Sensors.
    pub sensors: SensorModel,
    /// The ego's actuator.
    pub actuator: ActuatorModel,
    /// Simulated seconds.
    pub seconds: f32,
    /// The seed of the sensors' random numbers.
    pub seed: u64,
    /// With two authorities, how many starts the firmware refused to engage before this one
    /// was drawn (each drawn afresh, delays included): the search counts engaged episodes.
    #[serde(default)]
    pub refused_starts: u32,
}

/// The search's fixed setting: the table, its model and the firmware's configuration.
#[derive(Clone, Copy)]
pub struct Setting<'t> {
    /// The table's bytes.
    pub bytes: &'t [u8],
    /// The table.
    pub table: &'t Table<'t>,
    /// Its model of the humans.
    pub model: HumanModel,
    /// The firmware's configuration.
    pub config: Config,
    /// What counts as a loss.
    pub tolerances: Tolerances,
    /// The slowest actuator the search draws: the configuration's declared dead time and lag
    /// for a search within the model ([`Setting::within_model`]); slower for a planted hole.
    pub plant: ActuatorModel,
    /// The follower that reacts to the brake lights late, as the two-authority certificate
    /// has it ([`firmware::Certifier::reacting_follower`]), for the cases that draw it
    /// ([`Case::follower_reacts`]); `None`: every follower sees the ego at once (the table's
    /// IDM, which the comfort band's rear half argues with).
    pub reacting: Option<ReactingFollower>,
    /// What the reacting followers do once they have reacted ([`Case::follower_after_reaction`]).
    pub after_reaction: AfterReaction,
}

impl<'t> Setting<'t> {
    /// The search within the model: the firmware's `config`, the stated tolerances, an actuator
    /// no slower than `config` declares.
    pub fn within_model(
        bytes: &'t [u8],
        table: &'t Table<'t>,
        model: HumanModel,
        config: Config,
    ) -> Self {
        Setting {
            bytes,
            table,
            model,
            config,
            tolerances: Tolerances::for_config(&config),
            plant: ActuatorModel {
                dead_time: config.plant.actuator_dead_time_us as f32 * 1e-6,
                lag: config.plant.actuator_lag_us as f32 * 1e-6,
            },
            reacting: None,
            after_reaction: AfterReaction::AtItsLevel,
        }
    }

    /// The same search with followers that react to the brake lights after the configured
    /// reaction time (the two-authority certificate's follower), doing `after` once they have
    /// reacted: with [`AfterReaction::AtItsLevel`] the model its rear half argues with,
    /// searched at the edge (the largest acceleration until the reaction, the least braking
    /// the model allows after it, the table's IDM where that brakes harder). `None` if the
    /// table is not accepted.
    pub fn with_reacting_follower(self, after: AfterReaction) -> Option<Self> {
        let certifier = firmware::Certifier::new(self.table.clone(), &self.config).ok()?;
        Some(Setting {
            reacting: Some(certifier.reacting_follower()),
            after_reaction: after,
            ..self
        })
    }

    fn world(&self, case: &Case) -> World<'t> {
        World::new(
            self.bytes,
            self.config,
            self.model,
            case.start,
            case.sensors,
            case.actuator,
            self.tolerances,
            case.seed,
        )
    }

    /// The humans' accelerations for the next period of `world` under `case` (within the
    /// model: the leader's bounds, the IDM with a time gap in range, speeds in `[0, v_max]`).
    ///
    /// `case` says whether the follower reacts late ([`Case::follower_reacts`], with
    /// [`Setting::reacting`]: its largest acceleration from when the ego's brake lights come on
    /// ([`World::lights_on_at_the_earliest`]) until its reaction time has passed, the
    /// certificate's worst case before the reaction, then what [`Case::follower_after_reaction`]
    /// says while the lights stay on, the IDM once they are off) and whether the leader brakes
    /// at authority changes.
    fn humans(
        &self,
        world: &World<'_>,
        schedule: &Schedule,
        rule: FollowerRule,
        case: &Case,
    ) -> (f32, f32) {
        let m = &self.model;
        let t = world.time();
        let h = world.period_seconds();
        let [leader, ego, follower] = world.cars();
        let (u, tau) = schedule.at(t);
        let changed = world
            .braking_in_force_changed_at()
            .is_some_and(|at| t - at < AT_AUTHORITY_CHANGE);
        let u = if case.leader_brakes_at_authority_change && changed {
            -1.0
        } else {
            u.clamp(-1.0, 1.0)
        };
        let a_leader = if u < 0.0 {
            -u * m.leader.0
        } else {
            u * m.leader.1
        };
        let (tmin, tmax) = m.parameter_range();
        let time_gap = match rule {
            FollowerRule::Schedule => tmin + tau.clamp(0.0, 1.0) * (tmax - tmin),
            FollowerRule::WorstCase => {
                let gap_max = self.table.axis_bounds(0).map_or(f32::INFINITY, |b| b.max);
                let z = [(ego.x - follower.x).min(gap_max), follower.v, ego.v];
                match follower_speed_gradient(self.table, z) {
                    Some(p) if p > 0.0 => tmax,
                    _ => tmin,
                }
            }
            FollowerRule::WithOverride { inverted } => {
                let overriding = world
                    .last()
                    .is_some_and(|(c, _)| c.mode == firmware::Mode::Override);
                if overriding != inverted {
                    tmax
                } else {
                    tmin
                }
            }
        };
        let idm = m.follower_acceleration(follower.v, ego.v, ego.x - follower.x, time_gap);
        let a_follower = match (
            self.reacting.filter(|_| case.follower_reacts),
            world.lights_on_at_the_earliest(),
        ) {
            (Some(r), Some(on)) if t - on < r.reaction_time => r.reaction_acceleration,
            (Some(r), Some(on)) if case.follower_after_reaction == AfterReaction::AtItsLevel => {
                idm.min(r.most_acceleration(t - on))
            }
            _ => idm,
        };
        let limit = |a: f32, v: f32| {
            if a > 0.0 {
                a.min(((m.max_speed - v) / h).max(0.0))
            } else {
                a
            }
        };
        (limit(a_leader, leader.v), limit(a_follower, follower.v))
    }

    /// Runs `case` to its end (or its collision); with `trace`, records it. With two
    /// authorities the episode starts as a driver's engagement does (a period in standby, then
    /// a resume the firmware may refuse: then nothing more happens).
    pub fn run(&self, case: &Case, trace: Option<&mut Trace>) -> Score {
        let mut world = self.world(case);
        let humans =
            |world: &World<'_>| self.humans(world, &case.schedule, case.follower_rule, case);
        if self.config.certificate.authorities == firmware::Authorities::Two {
            let (a, b) = humans(&world);
            if world.engage_from_standby(a, b).is_err() {
                return *world.score();
            }
        }
        let steps = (case.seconds / world.period_seconds()).round() as u64;
        let mut trace = trace;
        for _ in 0..steps {
            let (a, b) = humans(&world);
            if !world.step(a, b, trace.as_deref_mut()) {
                break;
            }
        }
        *world.score()
    }

    /// Whether `start` is certified at the true state, the engaged acceleration held through
    /// the actuator's dead time and lag; with two authorities, for an ego at rest in its
    /// actuator ([`firmware::Certifier::certificate_two_authorities`]; the firmware judges the
    /// engagement itself, from standby).
    fn certified(&self, start: &Start, actuator: &ActuatorModel) -> Option<firmware::Certificate> {
        let certifier = firmware::Certifier::new(self.table.clone(), &self.config).ok()?;
        let c = match self.config.certificate.authorities {
            firmware::Authorities::ComfortBand => certifier.certificate_with_response(
                state_of(start.cars),
                actuator.dead_time + actuator.lag,
                start.engaged_acceleration,
            )?,
            firmware::Authorities::Two => certifier.certificate_two_authorities(
                state_of(start.cars),
                actuator.dead_time,
                actuator.lag,
            )?,
        };
        c.is_certified().then_some(c)
    }

    /// Draws a certified start of `kind` (`None` after 2,000 rejected draws).
    pub fn draw_start(
        &self,
        kind: StartKind,
        actuator: &ActuatorModel,
        rng: &mut impl Rng,
    ) -> Option<Start> {
        let m = &self.model;
        let vmax = m.max_speed;
        let band = (
            m.band_min,
            self.config.plant.envelope.max_acceleration.min(2.0),
        );
        let gap_max = self.table.axis_bounds(0).map_or(150.0, |b| b.max);
        for _ in 0..2_000 {
            let mut speed = || rng.random_range(0.0..=vmax);
            let (mut vl, mut ve, mut vf) = (speed(), speed(), speed());
            let mut a0 = rng.random_range(band.0..=band.1);
            let mut gap_leader = rng.random_range(0.0..=150.0f32);
            let mut gap_follower = rng.random_range(0.0..=gap_max);
            match kind {
                StartKind::FastEgo => {
                    ve = rng.random_range(33.0..=vmax);
                    a0 = rng.random_range(0.0..=band.1);
                }
                StartKind::FastFollower => {
                    vf = near_top_speed(vmax, rng);
                    gap_follower = rng.random_range(0.0..=60.0);
                }
                StartKind::FastLeader => {
                    vl = near_top_speed(vmax, rng);
                    gap_leader = rng.random_range(0.0..=80.0);
                }
                StartKind::Slow => {
                    let mut slow = || rng.random_range(0.0..=1.0f32);
                    (vl, ve, vf) = (slow(), slow(), slow());
                    gap_leader = rng.random_range(0.0..=20.0);
                    gap_follower = rng.random_range(0.0..=20.0);
                }
                StartKind::Standstill => {
                    (vl, ve, vf) = (0.0, 0.0, 0.0);
                    a0 = rng.random_range(band.0..=0.0);
                    gap_leader = rng.random_range(0.0..=10.0);
                    gap_follower = rng.random_range(0.0..=10.0);
                }
                _ => {}
            }
            let cars = |gl: f32, gf: f32| {
                [
                    Car { x: gl, v: vl },
                    Car { x: 0.0, v: ve },
                    Car { x: -gf, v: vf },
                ]
            };
            let start = |gl: f32, gf: f32| Start {
                cars: cars(gl, gf),
                engaged_acceleration: a0,
            };
            match kind {
                StartKind::FrontBoundary | StartKind::RearBoundary => {
                    // Bisection on the half's own gap: certified far out, not at zero.
                    let front = kind == StartKind::FrontBoundary;
                    let with = |g: f32| {
                        if front {
                            start(g, gap_follower)
                        } else {
                            start(gap_leader, g)
                        }
                    };
                    let (mut lo, mut hi) = (0.0f32, if front { 400.0 } else { gap_max });
                    if self.certified(&with(hi), actuator).is_none() {
                        continue;
                    }
                    if self.certified(&with(lo), actuator).is_some() {
                        continue;
                    }
                    let target = rng.random_range(0.0..=0.2f32);
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        match self.certified(&with(mid), actuator) {
                            Some(c) if (if front { c.front } else { c.rear }) <= target => {
                                return Some(with(mid));
                            }
                            Some(_) => hi = mid,
                            None => lo = mid,
                        }
                    }
                    let s = with(hi);
                    if self.certified(&s, actuator).is_some() {
                        return Some(s);
                    }
                }
                _ => {
                    let s = start(gap_leader, gap_follower);
                    if self.certified(&s, actuator).is_some() {
                        return Some(s);
                    }
                }
            }
        }
        None
    }

    /// A fresh case's sensors and actuator: three times in four the datasheets' radars
    /// ([`SensorModel::datasheet`], the firmware's declared error bounds, bursts of losses up to
    /// the covered track age), else exact measurements aged 0-5 periods per channel; the dead
    /// time at 0, half or all of the plant's limit and the lag anywhere up to it (half the time
    /// at it).
    fn draw_delays(&self, rng: &mut impl Rng) -> (SensorModel, ActuatorModel) {
        let c = &self.config;
        let sensors = if rng.random::<f32>() < 0.75 {
            SensorModel::datasheet(c.sensors, c.sensors.max_track_age_us, rng)
        } else {
            SensorModel::exact_with_latencies([
                rng.random_range(0..=5),
                rng.random_range(0..=5),
                rng.random_range(0..=5),
            ])
        };
        let actuator = ActuatorModel {
            dead_time: self.plant.dead_time * [0.0, 0.5, 1.0, 1.0][rng.random_range(0..4)],
            lag: if rng.random::<bool>() {
                self.plant.lag
            } else {
                rng.random_range(0.0..=self.plant.lag)
            },
        };
        (sensors, actuator)
    }

    /// A case with a fresh start of `kind` and `schedule` (`None`: no start found).
    fn case(
        &self,
        method: Method,
        kind: StartKind,
        schedule: Schedule,
        rule: FollowerRule,
        seconds: f32,
        rng: &mut impl Rng,
    ) -> Option<Case> {
        let two = self.config.certificate.authorities == firmware::Authorities::Two;
        // With two authorities a start the firmware refuses to engage is drawn again (the
        // campaign does the same), so that every episode the search counts is the firmware's.
        for refused_starts in 0..MAX_REFUSED_STARTS {
            let (sensors, actuator) = self.draw_delays(rng);
            let start = self.draw_start(kind, &actuator, rng)?;
            let case = Case {
                method,
                start_kind: kind,
                start,
                schedule: schedule.clone(),
                follower_rule: rule,
                follower_reacts: self.reacting.is_some(),
                follower_after_reaction: self.after_reaction,
                // With two authorities a third of the cases' leaders brake at every change of
                // the braking in force.
                leader_brakes_at_authority_change: two && rng.random_bool(1.0 / 3.0),
                sensors,
                actuator,
                seconds,
                seed: rng.random(),
                refused_starts,
            };
            if !two || self.engages(&case) {
                return Some(case);
            }
        }
        None
    }

    /// Whether the firmware takes `case`'s engagement from standby (two authorities).
    fn engages(&self, case: &Case) -> bool {
        let mut world = self.world(case);
        let (a, b) = self.humans(&world, &case.schedule, case.follower_rule, case);
        world.engage_from_standby(a, b).is_ok()
    }
}

/// How many refused starts a case draws again before it gives up (two authorities).
const MAX_REFUSED_STARTS: u32 = 1_000;

/// A human's speed at the domain's top: exactly `vmax` half the time, else in `[34, vmax]`.
fn near_top_speed(vmax: f32, rng: &mut impl Rng) -> f32 {
    if rng.random::<bool>() {
        vmax
    } else {
        rng.random_range(34.0..=vmax)
    }
}

/// What the search aims at: the smallest margin, with failures below every margin.
fn objective(score: &Score) -> f32 {
    if score.collision_time.is_some() {
        -1e6
    } else if score.certificate_lost.is_some() {
        -1e3 + score.min_margin().max(-100.0)
    } else {
        score.min_margin()
    }
}

/// The search's size.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Budget {
    /// Structured cases.
    pub structured: usize,
    /// Random-schedule episodes.
    pub random: usize,
    /// Cross-entropy runs (each `ce_population x ce_iterations` episodes).
    pub ce_runs: usize,
    /// Episodes per cross-entropy generation.
    pub ce_population: usize,
    /// Cross-entropy generations.
    pub ce_iterations: usize,
    /// Hill-climbing runs.
    pub hill_runs: usize,
    /// Steps per hill-climbing run (one episode each).
    pub hill_steps: usize,
    /// Greedy episodes.
    pub greedy: usize,
    /// Seconds per episode.
    pub seconds: f32,
}

impl Budget {
    /// Episodes over every method.
    pub fn episodes(&self) -> usize {
        self.structured
            + self.random
            + self.ce_runs * self.ce_population * self.ce_iterations
            + self.hill_runs * self.hill_steps
            + self.greedy
    }

    /// About `episodes` episodes in the proportions the long search uses (greedy episodes cost
    /// about twenty plain ones).
    pub fn scaled(episodes: usize, seconds: f32) -> Self {
        let share = |f: f64| ((episodes as f64 * f).round() as usize).max(1);
        let ce_population = 24;
        let ce_iterations = 6;
        let hill_steps = 50;
        Budget {
            structured: share(0.24),
            random: share(0.36),
            ce_runs: share(0.2 / (ce_population * ce_iterations) as f64),
            ce_population,
            ce_iterations,
            hill_runs: share(0.16 / hill_steps as f64),
            hill_steps,
            greedy: share(0.04),
            seconds,
        }
    }
}

/// One method's figures.
#[derive(Debug, Clone, Serialize)]
pub struct MethodSummary {
    /// The method.
    pub method: Method,
    /// Episodes run.
    pub episodes: usize,
    /// Episodes with a collision.
    pub collisions: usize,
    /// Of those, collisions the humans alone had made unavoidable first.
    pub collisions_unavoidable: usize,
    /// Episodes with a certificate loss.
    pub certificate_losses: usize,
    /// Losses by the firmware's mode then: nominal, override, minimum risk, uncertified.
    pub losses_by_mode: [usize; 4],
    /// Losses by the part lost: front, rear, speed, domain.
    pub losses_by_part: [usize; 4],
    /// Periods the firmware spent uncertified.
    pub uncertified_periods: u64,
    /// The smallest front margin, m.
    pub min_front_m: f32,
    /// The smallest rear margin, m.
    pub min_rear_m: f32,
    /// The smallest speed headroom, m/s.
    pub min_speed_headroom_m_per_s: f32,
    /// The smallest gap to the leader, m.
    pub min_gap_leader_m: f32,
    /// The smallest gap to the follower, m.
    pub min_gap_follower_m: f32,
    /// The largest ego speed while the firmware drove (engaged), m/s.
    pub max_ego_speed_m_per_s: f32,
    /// Engaged starts accelerating at 34-35 m/s.
    pub fast_accelerating_starts: usize,
    /// Starts with the follower at exactly `max_speed`.
    pub follower_at_max_speed_starts: usize,
    /// Starts the firmware refused to engage, drawn again (two authorities; not episodes).
    pub refused_starts: usize,
    /// Episodes whose engagement the firmware refused (a mutated case's humans in its standby
    /// period; not counted in `episodes`).
    pub refused_episodes: usize,
}

/// A case and what it did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Finding {
    /// The case.
    pub case: Case,
    /// Time of its collision, s.
    pub collision_time_s: Option<f32>,
    /// Its first loss: time (s), mode, part.
    pub certificate_lost: Option<(f32, ModeName, Half)>,
    /// When the humans alone made a collision unavoidable, s.
    pub unavoidable_from_s: Option<f32>,
    /// Its smallest margin, m.
    pub min_margin_m: f32,
}

impl Finding {
    fn of(case: Case, s: &Score) -> Self {
        Finding {
            case,
            collision_time_s: s.collision_time,
            certificate_lost: s.certificate_lost,
            unavoidable_from_s: s.unavoidable_from,
            min_margin_m: s.min_margin(),
        }
    }
}

/// Everything the search found.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The budget.
    pub budget: Budget,
    /// The first seed.
    pub seed: u64,
    /// Per method.
    pub methods: Vec<MethodSummary>,
    /// Every collision or loss (the first 200).
    pub findings: Vec<Finding>,
    /// Per method, the case with the smallest margin.
    pub worst: Vec<Finding>,
    /// Wall time, s.
    pub seconds: f64,
}

impl Report {
    /// Episodes over every method.
    pub fn episodes(&self) -> usize {
        self.methods.iter().map(|m| m.episodes).sum()
    }

    /// Collisions and losses over every method.
    pub fn failures(&self) -> (usize, usize) {
        (
            self.methods.iter().map(|m| m.collisions).sum(),
            self.methods.iter().map(|m| m.certificate_losses).sum(),
        )
    }
}

struct Tally {
    summary: MethodSummary,
    findings: Vec<Finding>,
    worst: Option<Finding>,
}

impl Tally {
    fn new(method: Method) -> Self {
        Tally {
            summary: MethodSummary {
                method,
                episodes: 0,
                collisions: 0,
                collisions_unavoidable: 0,
                certificate_losses: 0,
                losses_by_mode: [0; 4],
                losses_by_part: [0; 4],
                uncertified_periods: 0,
                min_front_m: f32::INFINITY,
                min_rear_m: f32::INFINITY,
                min_speed_headroom_m_per_s: f32::INFINITY,
                min_gap_leader_m: f32::INFINITY,
                min_gap_follower_m: f32::INFINITY,
                max_ego_speed_m_per_s: 0.0,
                fast_accelerating_starts: 0,
                follower_at_max_speed_starts: 0,
                refused_starts: 0,
                refused_episodes: 0,
            },
            findings: Vec::new(),
            worst: None,
        }
    }

    fn add(&mut self, case: &Case, s: &Score, vmax: f32) {
        let m = &mut self.summary;
        m.refused_starts += case.refused_starts as usize;
        if s.engagement_refused {
            m.refused_episodes += 1;
            return;
        }
        m.episodes += 1;
        let [_, ego, follower] = case.start.cars;
        if ego.v >= vmax - 1.0 && case.start.engaged_acceleration > 0.0 {
            m.fast_accelerating_starts += 1;
        }
        if follower.v == vmax {
            m.follower_at_max_speed_starts += 1;
        }
        if s.collision_time.is_some() {
            m.collisions += 1;
            if s.unavoidable_from.is_some() {
                m.collisions_unavoidable += 1;
            }
        }
        if let Some((_, mode, half)) = s.certificate_lost {
            m.certificate_losses += 1;
            m.losses_by_mode[mode as usize] += 1;
            m.losses_by_part[half as usize] += 1;
        }
        m.uncertified_periods += s.periods_by_mode[3];
        m.min_front_m = m.min_front_m.min(s.min_front);
        m.min_rear_m = m.min_rear_m.min(s.min_rear);
        m.min_speed_headroom_m_per_s = m.min_speed_headroom_m_per_s.min(s.min_speed);
        m.min_gap_leader_m = m.min_gap_leader_m.min(s.min_gap_leader);
        m.min_gap_follower_m = m.min_gap_follower_m.min(s.min_gap_follower);
        m.max_ego_speed_m_per_s = m.max_ego_speed_m_per_s.max(s.max_ego_speed);
        if s.failed() && self.findings.len() < 200 {
            self.findings.push(Finding::of(case.clone(), s));
        }
        if self
            .worst
            .as_ref()
            .is_none_or(|w| s.min_margin() < w.min_margin_m)
        {
            self.worst = Some(Finding::of(case.clone(), s));
        }
    }
}

/// The tally of `method`.
fn tally_of(tallies: &mut [Tally], method: Method) -> Option<&mut Tally> {
    tallies.iter_mut().find(|t| t.summary.method == method)
}

/// Runs `cases` in parallel, in order.
fn run_all(setting: &Setting<'_>, cases: Vec<Case>) -> Vec<(Case, Score)> {
    cases
        .into_par_iter()
        .map(|c| {
            let s = setting.run(&c, None);
            (c, s)
        })
        .collect()
}

/// A structured leader: a hard stop at `t0`, or stop-and-go with period `p` (braking for half,
/// accelerating for half); the time gap switching every `switch` seconds (0: fixed at `tau`).
fn structured_schedule(kind: usize, rng: &mut impl Rng, seconds: f32) -> (Schedule, FollowerRule) {
    let segment_s = 0.1;
    let n = (seconds / segment_s).ceil() as usize;
    let t0 = rng.random_range(0.0..10.0f32);
    let period = [4.0f32, 6.0, 8.0, 12.0, 16.0, 24.0, 40.0][rng.random_range(0..7)];
    let phase = rng.random_range(0.0..period);
    let switch = [0.0f32, 0.3, 1.0, 2.0, 5.0][rng.random_range(0..5)];
    let tau = if rng.random::<bool>() { 0.0 } else { 1.0 };
    let leader: Vec<f32> = (0..n)
        .map(|i| {
            let t = i as f32 * segment_s;
            match kind % 3 {
                0 => {
                    if t < t0 {
                        0.0
                    } else {
                        -1.0
                    }
                }
                _ => {
                    if ((t + phase) % period) < 0.5 * period {
                        -1.0
                    } else {
                        1.0
                    }
                }
            }
        })
        .collect();
    let time_gap: Vec<f32> = (0..n)
        .map(|i| {
            let t = i as f32 * segment_s;
            if switch > 0.0 && ((t / switch) as u32) % 2 == 1 {
                1.0 - tau
            } else {
                tau
            }
        })
        .collect();
    let rule = match kind % 4 {
        0 | 1 => FollowerRule::Schedule,
        2 => FollowerRule::WorstCase,
        _ => FollowerRule::WithOverride {
            inverted: rng.random::<bool>(),
        },
    };
    (
        Schedule {
            segment_s,
            leader,
            time_gap,
        },
        rule,
    )
}

/// Greedy rollouts: every `decide_s` seconds, each candidate input pair is held over a
/// look-ahead of `ahead_s` seconds on a clone of the loop, and the one with the smallest margin
/// over it is played. The played inputs are recorded as the case's schedule (so it replays).
fn greedy_case(setting: &Setting<'_>, mut case: Case) -> (Case, Score) {
    let decide_s = 0.5f32;
    let ahead_s = 2.0f32;
    let candidates: [(f32, f32); 6] = [
        (-1.0, 0.0),
        (-1.0, 1.0),
        (0.0, 0.0),
        (0.0, 1.0),
        (1.0, 0.0),
        (1.0, 1.0),
    ];
    let mut world = setting.world(&case);
    let h = world.period_seconds();
    let per_decision = (decide_s / h).round() as usize;
    let ahead = (ahead_s / h).round() as usize;
    let decisions = (case.seconds / decide_s).ceil() as usize;
    let mut schedule = Schedule {
        segment_s: decide_s,
        leader: Vec::new(),
        time_gap: Vec::new(),
    };
    'episode: for _ in 0..decisions {
        let mut best = (f32::INFINITY, candidates[0]);
        for &(u, tau) in &candidates {
            let hold = Schedule {
                segment_s: 1e9,
                leader: vec![u],
                time_gap: vec![tau],
            };
            let mut probe = world.clone();
            let mut least = f32::INFINITY;
            for _ in 0..ahead {
                let (a, b) = setting.humans(&probe, &hold, FollowerRule::Schedule, &case);
                let alive = probe.step(a, b, None);
                if let Some((_, Some(c))) = probe.last() {
                    least = least.min(c.margin());
                }
                if !alive {
                    least = f32::NEG_INFINITY;
                    break;
                }
            }
            if least < best.0 {
                best = (least, (u, tau));
            }
        }
        let (u, tau) = best.1;
        schedule.leader.push(u);
        schedule.time_gap.push(tau);
        let hold = Schedule {
            segment_s: 1e9,
            leader: vec![u],
            time_gap: vec![tau],
        };
        for _ in 0..per_decision {
            let (a, b) = setting.humans(&world, &hold, FollowerRule::Schedule, &case);
            if !world.step(a, b, None) {
                break 'episode;
            }
        }
    }
    case.schedule = schedule;
    case.follower_rule = FollowerRule::Schedule;
    // The recorded schedule, replayed from the start, is the case's verdict.
    let score = setting.run(&case, None);
    (case, score)
}

/// Runs the whole search (module docs), deterministic for `seed`; `progress` is told how many
/// episodes each batch ran.
pub fn search(
    setting: &Setting<'_>,
    budget: &Budget,
    seed: u64,
    progress: &(dyn Fn(usize) + Sync),
) -> Report {
    let t0 = std::time::Instant::now();
    let vmax = setting.model.max_speed;
    let seconds = budget.seconds;
    let segments_of = |segment_s: f32| (seconds / segment_s).ceil() as usize;
    let mut tallies: Vec<Tally> = Method::ALL.iter().map(|&m| Tally::new(m)).collect();
    let tally = |tallies: &mut Vec<Tally>, method: Method, results: &[(Case, Score)]| {
        if let Some(t) = tally_of(tallies, method) {
            for (c, s) in results {
                t.add(c, s, vmax);
            }
        }
        progress(results.len());
    };
    let kind_of = |i: usize| START_KINDS[i % START_KINDS.len()];

    // Structured and random cases: each drawn from its own seed (so the order of the parallel
    // draws does not matter), run in parallel.
    for (method, count) in [
        (Method::Structured, budget.structured),
        (Method::Random, budget.random),
    ] {
        let cases: Vec<Case> = (0..count)
            .into_par_iter()
            .filter_map(|i| {
                let mut r =
                    StdRng::seed_from_u64(seed.wrapping_add((method as u64) << 40) ^ i as u64);
                let (schedule, rule) = if method == Method::Structured {
                    structured_schedule(i, &mut r, seconds)
                } else {
                    let segment_s = [0.5f32, 1.0, 2.0, 5.0][i % 4];
                    (
                        Schedule::random(segments_of(segment_s), segment_s, &mut r),
                        FollowerRule::Schedule,
                    )
                };
                setting.case(method, kind_of(i), schedule, rule, seconds, &mut r)
            })
            .collect();
        for chunk in cases.chunks(2_000) {
            let results = run_all(setting, chunk.to_vec());
            tally(&mut tallies, method, &results);
        }
    }

    // Cross-entropy: per run one start, a Gaussian per segment input, refitted to the elites.
    let ce_segment = 2.0f32;
    let ce_n = segments_of(ce_segment);
    let mut ce_best: Vec<Case> = Vec::new();
    for run in 0..budget.ce_runs {
        let mut rng = StdRng::seed_from_u64(seed ^ 0xCE00_0000 ^ run as u64);
        let Some(base) = setting.case(
            Method::CrossEntropy,
            kind_of(run + 1),
            Schedule::random(ce_n, ce_segment, &mut rng),
            FollowerRule::Schedule,
            seconds,
            &mut rng,
        ) else {
            continue;
        };
        // The run's one start: its refused draws count once, not with every member.
        if let Some(t) = tally_of(&mut tallies, Method::CrossEntropy) {
            t.summary.refused_starts += base.refused_starts as usize;
        }
        let mut mean = vec![0.0f32; 2 * ce_n];
        let mut sd = vec![0.7f32; 2 * ce_n];
        for (k, m) in mean.iter_mut().enumerate() {
            *m = if k < ce_n { 0.0 } else { 0.5 };
        }
        let mut best: Option<(f32, Case)> = None;
        for _ in 0..budget.ce_iterations {
            let population: Vec<Case> = (0..budget.ce_population)
                .map(|_| {
                    let mut draw = |k: usize, lo: f32, hi: f32| {
                        // Box-Muller from two uniforms.
                        let (a, b): (f32, f32) = (rng.random_range(1e-6..1.0), rng.random());
                        let z = (-2.0 * a.ln()).sqrt() * (std::f32::consts::TAU * b).cos();
                        (mean[k] + sd[k] * z).clamp(lo, hi)
                    };
                    let leader: Vec<f32> = (0..ce_n).map(|k| draw(k, -1.0, 1.0)).collect();
                    let time_gap: Vec<f32> = (0..ce_n).map(|k| draw(ce_n + k, 0.0, 1.0)).collect();
                    Case {
                        schedule: Schedule {
                            segment_s: ce_segment,
                            leader,
                            time_gap,
                        },
                        refused_starts: 0,
                        ..base.clone()
                    }
                })
                .collect();
            let mut results = run_all(setting, population);
            tally(&mut tallies, Method::CrossEntropy, &results);
            results.sort_by(|a, b| objective(&a.1).total_cmp(&objective(&b.1)));
            let elites = &results[..(budget.ce_population / 4).max(2).min(results.len())];
            if let Some((c, s)) = elites.first() {
                if best.as_ref().is_none_or(|(o, _)| objective(s) < *o) {
                    best = Some((objective(s), c.clone()));
                }
            }
            for k in 0..2 * ce_n {
                let values: Vec<f32> = elites
                    .iter()
                    .map(|(c, _)| {
                        if k < ce_n {
                            c.schedule.leader[k]
                        } else {
                            c.schedule.time_gap[k - ce_n]
                        }
                    })
                    .collect();
                let mu = values.iter().sum::<f32>() / values.len() as f32;
                let var =
                    values.iter().map(|v| (v - mu).powi(2)).sum::<f32>() / values.len() as f32;
                mean[k] = mu;
                sd[k] = var.sqrt().max(0.05);
            }
        }
        if let Some((_, c)) = best {
            ce_best.push(c);
        }
    }

    // Hill climbing: from the cross-entropy's best case of the same run (or a random one),
    // perturb one to three segments, keep the change when the margin falls.
    let hill_results: Vec<(Vec<(Case, Score)>, usize)> = (0..budget.hill_runs)
        .into_par_iter()
        .map(|run| {
            let mut rng = StdRng::seed_from_u64(seed ^ 0x4111_0000 ^ run as u64);
            // A start drawn here has its refused draws counted once, with the run (the
            // cross-entropy counted its own).
            let (start, refused) = match ce_best.get(run) {
                Some(c) => (Some(c.clone()), 0),
                None => {
                    let c = setting.case(
                        Method::HillClimbing,
                        kind_of(run + 2),
                        Schedule::random(ce_n, ce_segment, &mut rng),
                        FollowerRule::Schedule,
                        seconds,
                        &mut rng,
                    );
                    let refused = c.as_ref().map_or(0, |c| c.refused_starts as usize);
                    (c, refused)
                }
            };
            let Some(mut current) = start else {
                return (Vec::new(), 0);
            };
            current.refused_starts = 0;
            current.method = Method::HillClimbing;
            let mut current_score = setting.run(&current, None);
            let mut out = Vec::with_capacity(budget.hill_steps);
            for _ in 0..budget.hill_steps {
                let mut next = current.clone();
                let n = next.schedule.leader.len().max(1);
                for _ in 0..rng.random_range(1..=3) {
                    let k = rng.random_range(0..n);
                    if let Some(u) = next.schedule.leader.get_mut(k) {
                        *u = (*u + rng.random_range(-1.0..=1.0f32)).clamp(-1.0, 1.0);
                    }
                    if let Some(tau) = next.schedule.time_gap.get_mut(k) {
                        if rng.random::<f32>() < 0.5 {
                            *tau = 1.0 - *tau;
                        }
                    }
                }
                let s = setting.run(&next, None);
                out.push((next.clone(), s));
                if objective(&s) < objective(&current_score) {
                    current = next;
                    current_score = s;
                }
            }
            (out, refused)
        })
        .collect();
    for (r, refused) in &hill_results {
        tally(&mut tallies, Method::HillClimbing, r);
        if let Some(t) = tally_of(&mut tallies, Method::HillClimbing) {
            t.summary.refused_starts += refused;
        }
    }

    // Greedy rollouts.
    let greedy_cases: Vec<Case> = (0..budget.greedy)
        .filter_map(|i| {
            let mut r = StdRng::seed_from_u64(seed ^ 0x6EED_0000 ^ i as u64);
            setting.case(
                Method::Greedy,
                kind_of(i),
                Schedule::random(1, 1.0, &mut r),
                FollowerRule::Schedule,
                seconds,
                &mut r,
            )
        })
        .collect();
    for chunk in greedy_cases.chunks(64) {
        let results: Vec<(Case, Score)> = chunk
            .par_iter()
            .map(|c| greedy_case(setting, c.clone()))
            .collect();
        tally(&mut tallies, Method::Greedy, &results);
    }

    let mut findings = Vec::new();
    let mut worst = Vec::new();
    let mut methods = Vec::new();
    for t in tallies {
        findings.extend(t.findings);
        worst.extend(t.worst);
        methods.push(t.summary);
    }
    Report {
        budget: *budget,
        seed,
        methods,
        findings,
        worst,
        seconds: t0.elapsed().as_secs_f64(),
    }
}
