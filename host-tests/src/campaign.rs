//! Episodes and campaigns: the firmware's `Controller` at its real period against the humans,
//! from initial states sampled over the whole certified set of the firmware's table, standstill
//! included.
//!
//! What an episode judges, on the *true* state (not the measured one), is
//! [`crate::world`]'s: collisions, certificate losses (each part of the certificate against its
//! own tolerance, [`crate::world::Tolerances`]) by the firmware's mode and the part lost, and
//! whether the humans alone had made a collision unavoidable first. From a certified start,
//! with humans that keep to the model, collisions and losses must both be zero, or the
//! certificate is wrong.

use firmware::{Authorities, Certificate, Certifier, Config};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;
use table_format::Table;

use crate::humans::{within_speed_limit, Follower, HumanModel, Humans, Leader};
use crate::sim::{ActuatorModel, Car, SensorModel};
use crate::world::{r157_least_gap, EmergencyCauses, Start, Tolerances, World};
pub use crate::world::{
    state_of, CutInKind, CutInScore, Half, ModeName, Needless, Trace, TracePoint, FREE_ROAD,
    NEEDLESS_REPORTED_S,
};

/// The sensors of an episode.
#[derive(Debug, Clone, Copy, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Sensing {
    /// The same sensors in every episode.
    Fixed(SensorModel),
    /// The datasheets' radars ([`SensorModel::datasheet`]) at the firmware's declared error
    /// bounds, drawn per episode, with bursts of losses up to the covered track age.
    Datasheet,
    /// The datasheets' radars as [`Sensing::Datasheet`] draws them, none of their refreshes
    /// lost: what the control does with the radars' noise, cycles and latencies alone (the
    /// emergencies the losses make are [`crate::world::EmergencyCauses::dropout`]).
    DatasheetLossless,
}

/// One episode's setting.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Episode {
    /// Leader behaviour.
    pub leader: Leader,
    /// Follower behaviour.
    pub follower: Follower,
    /// Simulated seconds.
    pub seconds: f32,
    /// Sensors.
    pub sensors: Sensing,
    /// A vehicle that cuts in during the episode (outside the model), at a random time in the
    /// first 30 s: a new leader 8-30 m ahead at -5..0 m/s relative that drives by the leader's
    /// model; a new leader that keeps its speed, seen 0.72 s before it enters the lane
    /// ([`World::cut_in_seen`]), closing at up to 15 m/s (no faster than the ego drives), that
    /// enters from UN R157's least gap for avoiding it ([`r157_least_gap`], at least 2 m) to
    /// 10 m past it if the ego keeps its speed; or a new follower 3-10 m behind closing at
    /// 0..5 m/s.
    pub cut_in: Option<CutInKind>,
    /// The ego's actuator.
    pub actuator: ActuatorModel,
    /// The firmware's configuration.
    #[serde(skip)]
    pub config: Config,
    /// Seed of the episode's random numbers.
    pub seed: u64,
}

/// What happened.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Outcome {
    /// A gap reached zero (inside an interval or at a sample).
    pub collided: bool,
    /// Time of the first collision, s.
    pub collision_time: Option<f32>,
    /// The first time the humans alone made a collision unavoidable, s.
    pub unavoidable_from: Option<f32>,
    /// The first time the true state was not certified, s, the firmware's mode then, and the
    /// part lost.
    pub certificate_lost: Option<(f32, ModeName, Half)>,
    /// The smallest certificate margin over the episode, m.
    pub min_margin: f32,
    /// The smallest front and rear margins over the episode, m (each half on its own).
    pub min_half_margins: (f32, f32),
    /// The smallest speed headroom over the episode, m/s.
    pub min_speed_headroom: f32,
    /// Smallest gap to the leader, m.
    pub min_gap_leader: f32,
    /// Smallest gap to the follower, m.
    pub min_gap_follower: f32,
    /// Share of the time the firmware braked at the certificate's level (override).
    pub override_share: f32,
    /// Share of the time in the minimum-risk manoeuvre.
    pub minimum_risk_share: f32,
    /// Share of the time outside the table's domain (uncertified).
    pub uncertified_share: f32,
    /// Largest |jerk| of the ego's command, m/s^3.
    pub max_jerk: f32,
    /// Times the leader came to a standstill.
    pub leader_stops: u32,
    /// ISO 15622's checks on the realised motion, from 1 s after engagement.
    pub iso: crate::iso::IsoWorst,
    /// The leader's hardest braking, m/s^2.
    pub leader_hardest_braking: f32,
    /// Periods whose command broke the jerk limit because the certificate needed it.
    pub emergency_periods: u64,
    /// Those periods by cause.
    pub emergencies: EmergencyCauses,
    /// The engagement itself was an emergency ([`crate::world::Score::engaged_in_emergency`]).
    pub engaged_in_emergency: bool,
    /// The comfort band alone certified the start
    /// ([`crate::world::Score::started_comfort_certified`]): no emergency was needed from it.
    pub started_comfort_certified: bool,
    /// The initial state `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`.
    pub initial: [f32; 5],
    /// The certificate margin at the start, m.
    pub initial_margin: f32,
    /// Periods of the minimum-risk manoeuvre without a certificate.
    pub uncertified_minimum_risk: u64,
    /// Periods of the certified fallback (a track beyond its covered age).
    pub fallback_periods: u64,
    /// Periods braked harder than the band (the emergency authority).
    pub below_band_periods: u64,
    /// The largest track ages the firmware read, s (leader, follower).
    pub max_track_age: [f32; 2],
    /// Braking and standing the road did not ask for.
    pub needless: Needless,
    /// The cut-in, if any, and how it was answered.
    pub cut_in: Option<CutInScore>,
    /// After a cut-in that ended in a collision: whether braking at beta from the period the
    /// radar first delivered the new vehicle's track (the earliest any controller reading it can
    /// know; the same commands before it, the same actuator, the same humans) collides too, so
    /// that the humans alone had made it unavoidable.
    pub cut_in_unavoidable: Option<bool>,
    /// The same at the emergency authority the episode's configuration declares
    /// ([`firmware::EmergencyDeclaration::braking`]): whether a car that brakes from the first
    /// track at the band's floor at once and then builds up to the authority's level at its
    /// declared jerk (through the same actuator) hits the car ahead too.
    pub cut_in_unavoidable_at_emergency: Option<bool>,
    /// Whether that braking, clear of the car ahead, was hit from behind: the follower driving
    /// as it did in the episode (its recorded accelerations), which did not answer the harder
    /// braking. What the emergency authority must buy from the follower.
    pub cut_in_hit_from_behind_at_emergency: Option<bool>,
    /// The same with a follower in the certificate's model that answers the harder braking:
    /// the IDM at its closest time gap, at once; and the follower the two-authority certificate
    /// argues with ([`firmware::Certifier::reacting_follower`]), at its largest acceleration
    /// while the ego's brake lights are off and until its reaction time has passed after they
    /// come on, then the IDM at its closest time gap braking at least at the model's level
    /// while they stay on.
    pub cut_in_hit_from_behind_at_emergency_answered: Option<[bool; 2]>,
    /// The same three followers (as it drove, the IDM at once, the reacting one) started at the
    /// worst corner of the declared error box around the follower's true state at the cut-in
    /// (the least gap and the fastest follower that an exact measurement's box holds): whether
    /// any hits that braking from behind. A controller that knows the follower only through
    /// its measurement cannot rule that follower out, so a braking it hits is not one the
    /// certificate can buy.
    pub cut_in_hit_from_behind_at_emergency_box: Option<bool>,
}

impl Outcome {
    /// Whether the episode ended in a collision that was preventable and was not prevented
    /// (after `cut_in`): one that braking at the emergency authority from the first track
    /// would not have turned into a collision from behind (by the follower as it drove, or by
    /// either follower of the certificate's model answering the braking), and that was with
    /// the car ahead after a cut-in UN R157 requires avoiding, or that braking avoids ahead.
    /// A collision with the car ahead that braking harder only moves behind the ego is not
    /// preventable by the ego's braking, whatever the rule asks.
    pub fn preventable_not_prevented(&self, cut_in: &CutInScore) -> bool {
        let ahead = self.collided && self.min_gap_follower > 0.0;
        // Braking at the emergency authority is not hit from behind, by the follower as it
        // drove or by the certificate's followers answering it.
        let clear_behind = self.cut_in_hit_from_behind_at_emergency == Some(false)
            && self.cut_in_hit_from_behind_at_emergency_answered == Some([false, false]);
        let at_emergency = self.cut_in_unavoidable_at_emergency == Some(false);
        clear_behind && ((ahead && cut_in.r157_requires_avoiding()) || at_emergency)
    }

    /// [`Outcome::preventable_not_prevented`] for a controller that knows the cars through
    /// the declared sensors: braking at the emergency authority from the first delivered
    /// track of the new vehicle avoids the car ahead (UN R157's rule alone does not count: it
    /// takes the cut-in as seen, and the declared radar may deliver it late, or its actuator
    /// be slower than the rule's 0.35 s), and is not hit from behind either by the followers
    /// at the worst corner of the error box around the follower's true state
    /// ([`Outcome::cut_in_hit_from_behind_at_emergency_box`]). Where the two differ the
    /// sensors, not the controller's choice, held the answer back.
    pub fn preventable_through_the_sensors_not_prevented(&self, cut_in: &CutInScore) -> bool {
        self.preventable_not_prevented(cut_in)
            && self.cut_in_unavoidable_at_emergency == Some(false)
            && self.cut_in_hit_from_behind_at_emergency_box == Some(false)
    }

    /// The outcome of an episode from its score.
    pub fn of(world: &World<'_>, initial: [f32; 5], initial_margin: f32) -> Self {
        let s = world.score();
        let n = s.periods.max(1) as f32;
        Outcome {
            collided: s.collision_time.is_some(),
            collision_time: s.collision_time,
            unavoidable_from: s.unavoidable_from,
            certificate_lost: s.certificate_lost,
            min_margin: s.min_margin(),
            min_half_margins: (s.min_front, s.min_rear),
            min_speed_headroom: s.min_speed,
            min_gap_leader: s.min_gap_leader,
            min_gap_follower: s.min_gap_follower,
            override_share: s.periods_by_mode[1] as f32 / n,
            minimum_risk_share: s.periods_by_mode[2] as f32 / n,
            uncertified_share: s.periods_by_mode[3] as f32 / n,
            max_jerk: s.max_jerk,
            leader_stops: s.leader_stops,
            iso: s.iso,
            leader_hardest_braking: s.leader_hardest_braking,
            emergency_periods: s.emergencies.total(),
            emergencies: s.emergencies,
            engaged_in_emergency: s.engaged_in_emergency,
            started_comfort_certified: s.started_comfort_certified.unwrap_or(false),
            initial,
            initial_margin,
            uncertified_minimum_risk: s.uncertified_minimum_risk,
            fallback_periods: s.fallback_periods,
            below_band_periods: s.below_band_periods,
            max_track_age: s.max_track_age,
            needless: s.needless,
            cut_in: s.cut_in,
            cut_in_unavoidable: None,
            cut_in_unavoidable_at_emergency: None,
            cut_in_hit_from_behind_at_emergency: None,
            cut_in_hit_from_behind_at_emergency_answered: None,
            cut_in_hit_from_behind_at_emergency_box: None,
        }
    }
}

/// Whether ISO 15622's limits are required of an episode: its leader braked no harder than the
/// ACC's comfort braking, and its engagement was not an emergency.
pub fn in_iso_scope(o: &Outcome) -> bool {
    o.leader_hardest_braking <= crate::humans::COMFORT_BRAKING + 1e-3 && !o.engaged_in_emergency
}

/// Draws an initial state over the whole certified set (`margin > 0` by `judge`, the
/// certificate of a true state for an actuator at rest): each speed is zero with probability
/// 0.15 and uniform in `[0, max_speed]` otherwise; gaps are uniform in `[0, 150]` m ahead and
/// over the rear grid behind. `None` after 10,000 rejected draws.
pub fn sample_start(
    judge: &impl Fn([f32; 5]) -> Option<Certificate>,
    model: &HumanModel,
    gap_max: f32,
    rng: &mut impl Rng,
) -> Option<([Car; 3], f32)> {
    let vmax = model.max_speed;
    let speed = |rng: &mut dyn rand::RngCore| {
        if rng.random::<f32>() < 0.15 {
            0.0
        } else {
            rng.random_range(0.0..=vmax)
        }
    };
    for _ in 0..10_000 {
        let (vl, vf, ve) = (speed(rng), speed(rng), speed(rng));
        let gap_leader = rng.random_range(0.0..=150.0f32);
        let gap_follower = rng.random_range(0.0..=gap_max);
        let state = [gap_leader, vl, gap_follower, vf, ve];
        if let Some(certificate) = judge(state) {
            let margin = certificate.margin();
            if certificate.is_certified() {
                let ego = Car { x: 0.0, v: ve };
                let leader = Car {
                    x: gap_leader,
                    v: vl,
                };
                let follower = Car {
                    x: -gap_follower,
                    v: vf,
                };
                return Some(([leader, ego, follower], margin));
            }
        }
    }
    None
}

/// One period after a cut-in: the leader's and follower's accelerations and the firmware's
/// command.
type Period = (f32, f32, f32);

/// Runs one episode on `bytes` (a split table); with `trace`, records the trajectory. `None`
/// if the table is not a split table or no certified start was found.
pub fn run_episode(
    table: &Table<'_>,
    bytes: &[u8],
    episode: &Episode,
    trace: Option<&mut Trace>,
) -> Option<Outcome> {
    let mut rng = StdRng::seed_from_u64(episode.seed);
    let config = episode.config;
    let certifier = Certifier::new(table.clone(), &config).ok()?;
    let model = HumanModel::of(table)?;
    let gap_max = table.axis_bounds(0)?.max;
    let response_time = episode.actuator.dead_time + episode.actuator.lag;
    let judge = |state: [f32; 5]| match config.certificate.authorities {
        Authorities::ComfortBand => certifier.certificate_with_response(state, response_time, 0.0),
        Authorities::Two => certifier.certificate_two_authorities(
            state,
            episode.actuator.dead_time,
            episode.actuator.lag,
        ),
    };
    // With two authorities the braking the certificate argues with is the firmware's choice,
    // from its measurements: the episode starts as a driver's engagement does, from a period in
    // standby, and only where the firmware accepts it (its own certificate positive); a refused
    // one draws another start.
    let two = config.certificate.authorities == Authorities::Two;
    let mut attempts = 0;
    let (initial, initial_margin, mut humans, mut world) = loop {
        attempts += 1;
        let (cars, initial_margin) = sample_start(&judge, &model, gap_max, &mut rng)?;
        let humans = Humans::new(
            table,
            episode.leader,
            episode.follower,
            certifier.reacting_follower(),
            &mut rng,
        )?;
        let start = Start {
            cars,
            engaged_acceleration: 0.0,
        };
        let sensors = match episode.sensors {
            Sensing::Fixed(m) => m,
            Sensing::Datasheet | Sensing::DatasheetLossless => {
                let drawn = SensorModel::datasheet(
                    config.sensors,
                    config.sensors.max_track_age_us,
                    &mut rng,
                );
                match episode.sensors {
                    Sensing::DatasheetLossless => drawn.lossless(),
                    _ => drawn,
                }
            }
        };
        let mut world = World::new(
            bytes,
            config,
            model,
            start,
            sensors,
            episode.actuator,
            Tolerances::for_config(&config),
            rng.random(),
        );
        if !two || world.engage_from_standby(0.0, 0.0).is_ok() {
            break (state_of(cars), initial_margin, humans, world);
        }
        if attempts >= 1_000 {
            return None;
        }
    };
    let h = world.period_seconds();
    let steps = (episode.seconds / h).round() as u64;
    let cut_in_at = episode
        .cut_in
        .map(|kind| (kind, (rng.random_range(1.0..30.0f32) / h) as u64));
    // The world at the cut-in and the humans' accelerations from then on, for the
    // counterfactual.
    let mut snapshot: Option<(World<'_>, Vec<Period>)> = None;
    let mut trace = trace;
    for k in 0..steps {
        if let Some((kind, at)) = cut_in_at {
            if k >= at && snapshot.is_none() {
                let [leader, ego, follower] = world.cars();
                let (gap, rel) = match kind {
                    // At R157's edge: closing at up to 15 m/s (no faster than the ego
                    // drives), from the rule's least gap (at least 2 m) to 10 m past it.
                    CutInKind::SteadyLeader => {
                        let closing = rng.random_range(0.0..=ego.v.min(R157_CLOSING_SPEED));
                        let least = r157_least_gap(closing).max(2.0);
                        (rng.random_range(least..least + 10.0), -closing)
                    }
                    CutInKind::Leader => (
                        rng.random_range(8.0..30.0f32),
                        rng.random_range(-5.0..0.0f32),
                    ),
                    CutInKind::Follower => (
                        rng.random_range(3.0..10.0f32),
                        rng.random_range(-5.0..0.0f32),
                    ),
                };
                // Only between the ego and the vehicle it replaces, with room to spare.
                let room = if kind.ahead() {
                    leader.x - ego.x
                } else {
                    ego.x - follower.x
                };
                // A steady leader is seen from the next lane first, where the gap is larger by
                // what the ego closes until it enters.
                let seen = kind == CutInKind::SteadyLeader;
                let lateral = if seen { R157_LATERAL_VISIBILITY } else { 0.0 };
                if gap - rel * lateral + 3.0 < room {
                    if seen {
                        world.cut_in_seen(gap, rel, lateral);
                    } else {
                        world.cut_in(kind, gap, rel);
                    }
                    snapshot = Some((world.clone(), Vec::new()));
                }
            }
        }
        let (mut a_leader, a_follower) = humans.accelerations(
            world.time(),
            h,
            world.cars(),
            world.lights_on_at_the_earliest(),
            &mut rng,
        );
        if snapshot.is_some() && episode.cut_in == Some(CutInKind::SteadyLeader) {
            a_leader = 0.0;
        }
        let running = world.step(a_leader, a_follower, trace.as_deref_mut());
        if let (Some((_, record)), Some((command, _))) = (snapshot.as_mut(), world.last()) {
            record.push((a_leader, a_follower, command.acceleration));
        }
        if !running {
            break;
        }
    }
    let mut outcome = Outcome::of(&world, initial, initial_margin);
    if let (true, Some((counterfactual, record))) = (outcome.collided, snapshot) {
        let delivered = outcome
            .cut_in
            .and_then(|c| c.delivered_after)
            .map_or(0, |s| (s / h).round() as usize);
        // The same world from the cut-in, the same commands until the first track, then
        // `braking` (a command for each period from the first track on): whether it collides
        // too, and with the car ahead or behind.
        let tmin = model.parameter_range().0;
        let reacting = certifier.reacting_follower();
        // The worst corner of the declared error box around the follower's true state at the
        // cut-in: the least gap and the fastest follower of an exact measurement's box, as
        // the firmware's rear check takes it (`MeasurementError::rear_box`).
        let box_corner = {
            let [_, e, f] = counterfactual.cars();
            let error = &config.sensors.error;
            let gap = e.x - f.x;
            let (lo, hi) = error.rear_box(gap, e.v - f.v, error.ego_speed(e.v));
            (gap - lo[0], hi[1] - f.v)
        };
        let collides_braking_with = |braking: &dyn Fn(usize) -> f32,
                                     behind: Behind,
                                     corner: bool| {
            let mut world = counterfactual.clone();
            if corner {
                world.move_follower(box_corner.0, box_corner.1);
            }
            // The record ends where the episode did (at its collision): past it, the humans
            // keep their last accelerations (a braking leader brakes on to a stop) for
            // `AFTER_RECORD` more, so that a braking that only delays the collision past the
            // record's end is not scored as avoiding it.
            let extra = record
                .last()
                .map(|last| std::iter::repeat_n(*last, (AFTER_RECORD / h).round() as usize));
            let collided = record
                .iter()
                .copied()
                .chain(extra.into_iter().flatten())
                .enumerate()
                .any(|(k, (a_leader, recorded, command))| {
                    let command = if k < delivered {
                        command
                    } else {
                        braking(k - delivered)
                    };
                    let [_, e, f] = world.cars();
                    let idm = || {
                        let a = model.follower_acceleration(f.v, e.v, e.x - f.x, tmin);
                        within_speed_limit(a, f.v, model.max_speed, h)
                    };
                    let a_follower = match (behind, world.lights_on_at_the_earliest()) {
                        (Behind::Replayed, _) => recorded,
                        (Behind::Reacting, on)
                            if on.is_none_or(|on| world.time() - on < reacting.reaction_time) =>
                        {
                            within_speed_limit(
                                reacting.reaction_acceleration,
                                f.v,
                                model.max_speed,
                                h,
                            )
                        }
                        (Behind::Reacting, Some(on)) => {
                            idm().min(reacting.most_acceleration(world.time() - on))
                        }
                        (Behind::AtOnce | Behind::Reacting, _) => idm(),
                    };
                    !world.step_with(a_leader, a_follower, Some(command), None)
                });
            let hit_behind = collided && world.score().min_gap_follower <= 0.0;
            (collided, collided && !hit_behind, hit_behind)
        };
        outcome.cut_in_unavoidable =
            Some(collides_braking_with(&|_| model.band_min, Behind::Replayed, false).0);
        // The emergency authority as declared: the band's floor at once (the comfort
        // authority's step), then the build-up at its jerk to its level.
        let emergency = config.certificate.emergency.braking;
        let before = delivered
            .checked_sub(1)
            .and_then(|k| record.get(k))
            .map_or(model.band_min, |r| r.2);
        let start = before.min(model.band_min);
        let at_emergency = |k: usize| (start - emergency.jerk * h * k as f32).max(-emergency.level);
        let (_, ahead, behind) = collides_braking_with(&at_emergency, Behind::Replayed, false);
        outcome.cut_in_unavoidable_at_emergency = Some(ahead);
        outcome.cut_in_hit_from_behind_at_emergency = Some(behind);
        outcome.cut_in_hit_from_behind_at_emergency_answered = Some([
            collides_braking_with(&at_emergency, Behind::AtOnce, false).2,
            collides_braking_with(&at_emergency, Behind::Reacting, false).2,
        ]);
        outcome.cut_in_hit_from_behind_at_emergency_box = Some(
            [Behind::Replayed, Behind::AtOnce, Behind::Reacting]
                .into_iter()
                .any(|behind| collides_braking_with(&at_emergency, behind, true).2),
        );
    }
    Some(outcome)
}

/// The fastest a steady leader's cut-in closes on the ego, m/s.
const R157_CLOSING_SPEED: f32 = 15.0;

/// How long a steady leader's lateral motion is visible before it enters the ego's lane, s:
/// UN R157's cut-in rule asks for 0.72 s ([`World::cut_in_seen`]).
const R157_LATERAL_VISIBILITY: f32 = 0.72;

/// How long a cut-in counterfactual runs past the end of the episode's record, s.
const AFTER_RECORD: f32 = 10.0;

/// The follower of a cut-in counterfactual.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Behind {
    /// It replays its accelerations of the episode (it does not answer another braking).
    Replayed,
    /// The IDM at the range's closest time gap, answering the ego at once.
    AtOnce,
    /// The follower the two-authority certificate argues with: its largest acceleration while
    /// the ego's brake lights are off and until its reaction time has passed after they come
    /// on, then the same IDM braking at least at the model's level while they stay on
    /// ([`table_format::rear::ReactingFollower::most_acceleration`]).
    Reacting,
}

/// Certificate losses by the firmware's mode at the moment of loss.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct LossesByMode {
    /// In [`firmware::Mode::Nominal`].
    pub nominal: usize,
    /// In [`firmware::Mode::Override`].
    pub r#override: usize,
    /// In [`firmware::Mode::MinimumRisk`].
    pub minimum_risk: usize,
    /// In [`firmware::Mode::Uncertified`].
    pub uncertified: usize,
    /// Of all, those where the front value was lost.
    pub front: usize,
    /// Of all, those where the rear value was lost.
    pub rear: usize,
    /// Of all, those where the ego's speed headroom was lost.
    pub speed: usize,
    /// Of all, those where the state left the domain.
    pub domain: usize,
}

/// Per (leader, follower) group: counts and extremes.
#[derive(Debug, Clone, Serialize)]
pub struct GroupSummary {
    /// Leader behaviour.
    pub leader: Leader,
    /// Follower behaviour.
    pub follower: Follower,
    /// Whether the humans keep to the table's model (no cut-in, a follower within the IDM).
    pub in_model: bool,
    /// Episodes run.
    pub episodes: usize,
    /// Episodes with a collision.
    pub collisions: usize,
    /// Of those, collisions the humans alone had made unavoidable beforehand.
    pub collisions_unavoidable: usize,
    /// Episodes in which the true state left the certified set.
    pub certificate_losses: usize,
    /// The same, by the firmware's mode at the moment of loss.
    pub certificate_losses_by_mode: LossesByMode,
    /// Episodes in which the humans alone made a collision unavoidable at some point.
    pub humans_made_unavoidable: usize,
    /// The smallest certificate margin over the group, m.
    pub min_margin: f32,
    /// The smallest front margin over the group, m.
    pub min_front_margin: f32,
    /// The smallest rear margin over the group, m.
    pub min_rear_margin: f32,
    /// Smallest gap to the leader over the group, m.
    pub min_gap_leader: f32,
    /// Smallest gap to the follower over the group, m.
    pub min_gap_follower: f32,
    /// Mean share of time under override.
    pub mean_override_share: f32,
    /// Mean share of time in the minimum-risk manoeuvre.
    pub mean_minimum_risk_share: f32,
    /// Mean share of time outside the table's domain.
    pub mean_uncertified_share: f32,
    /// Largest |jerk|, m/s^3.
    pub max_jerk: f32,
    /// Episodes whose leader braked no harder than 3.5 m/s^2 and whose engagement was not an
    /// emergency (ISO 15622's scope), and of them those where every ISO 15622 check held from
    /// 1 s after engagement.
    pub iso_scope: (usize, usize),
    /// Of the scope's episodes, those that started where the comfort band alone certified the
    /// truth ([`Outcome::started_comfort_certified`]: the leader was not closer than comfort
    /// allows from the start, as a late one is), those of them where ISO 15622 held, and their
    /// emergency periods by cause.
    pub iso_scope_comfort_start: (usize, usize, EmergencyCauses),
    /// Episodes whose engagement was an emergency (left out of the scope above).
    pub engaged_in_emergency: usize,
    /// The worst ISO 15622 ratio (to its limit) over the scope's episodes.
    pub iso_worst_in_scope: f32,
    /// Periods whose command broke the jerk limit because the certificate needed it
    /// (emergencies), over the group.
    pub emergency_periods: u64,
    /// Those periods by cause.
    pub emergencies: EmergencyCauses,
    /// Mean number of leader stops to standstill per episode.
    pub mean_leader_stops: f32,
    /// Starts at standstill (ego speed zero).
    pub standstill_starts: usize,
    /// Seed of the episode with the smallest margin (to replay it).
    pub worst_seed: u64,
    /// Periods of the minimum-risk manoeuvre without a certificate, over the group.
    pub uncertified_minimum_risk_periods: u64,
    /// Periods of the certified fallback over the group, and the episodes that ran it.
    pub fallback_periods: u64,
    /// See `fallback_periods`.
    pub fallback_episodes: usize,
    /// Periods braked harder than the band (the emergency authority) over the group, and the
    /// episodes that did.
    pub below_band_periods: u64,
    /// See `below_band_periods`.
    pub below_band_episodes: usize,
    /// The largest track age the firmware read, s (leader, follower).
    pub max_track_age: [f32; 2],
    /// Braking and standing the road did not ask for ([`Needless`]): the episodes with a
    /// stretch longer than [`NEEDLESS_REPORTED_S`] (braking, standstill), and the longest
    /// stretch of each with its episode's seed (s).
    pub needless: NeedlessSummary,
    /// Cut-ins, if the group has them.
    pub cut_ins: Option<CutInSummary>,
}

/// Braking and standing the road did not ask for over episodes ([`Needless`]).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct NeedlessSummary {
    /// The episodes with a stretch of braking, and of standstill, longer than
    /// [`NEEDLESS_REPORTED_S`].
    pub episodes: [usize; 2],
    /// The longest stretch of braking, s, and its episode's seed.
    pub braking: (f32, u64),
    /// The longest stretch at a standstill, s, and its episode's seed.
    pub standstill: (f32, u64),
}

impl NeedlessSummary {
    /// The summary of one episode's figures.
    fn of(seed: u64, n: &Needless) -> NeedlessSummary {
        NeedlessSummary {
            episodes: n.reported().map(usize::from),
            braking: (n.braking, seed),
            standstill: (n.standstill, seed),
        }
    }

    /// Two summaries as one.
    fn add(self, other: NeedlessSummary) -> NeedlessSummary {
        let longer = |a: (f32, u64), b: (f32, u64)| if b.0 > a.0 { b } else { a };
        NeedlessSummary {
            episodes: [0, 1].map(|i| self.episodes[i] + other.episodes[i]),
            braking: longer(self.braking, other.braking),
            standstill: longer(self.standstill, other.standstill),
        }
    }
}

/// How a group's cut-ins were answered.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CutInSummary {
    /// Episodes with a cut-in.
    pub episodes: usize,
    /// The mean and largest time from the cut-in to the first track of the new vehicle, s
    /// (the radar's cycle and latency).
    pub delivered_after_mean: f32,
    /// See `delivered_after_mean`.
    pub delivered_after_max: f32,
    /// Cut-ins the firmware reported as a new vehicle in the period of the first track.
    pub recognised_at_once: usize,
    /// Cut-ins whose front was not certified at the first track.
    pub front_uncertified: usize,
    /// Of those, the ones answered (the emergency answer, or a braking at beta) within one
    /// period of the first track.
    pub answered_within_one_period: usize,
    /// The mean of those answers' first command, m/s^2: as hard as the leader's worst case
    /// needs.
    pub mean_first_answer: f32,
    /// The mean hardest command in the 5 s after a cut-in, m/s^2.
    pub mean_hardest_command: f32,
    /// Collisions after a cut-in.
    pub collisions: usize,
    /// Of those, the ones with the follower (the ego hit from behind).
    pub collisions_behind: usize,
    /// Of those, the ones that braking at beta from the cut-in on would not have avoided
    /// either: the humans alone had made them unavoidable.
    pub unavoidable: usize,
    /// Leader cut-ins UN R157 requires avoiding ([`CutInScore::r157_requires_avoiding`]: the
    /// rule's conditions met at the intrusion, the new car keeping its speed afterwards).
    pub r157_requires_avoiding: usize,
    /// Collisions that the emergency authority from the first track would not have avoided
    /// either ([`Outcome::cut_in_unavoidable_at_emergency`]): the car ahead hit all the same.
    pub unavoidable_at_emergency: usize,
    /// Collisions that the emergency authority would have avoided ahead, but would have been
    /// hit from behind by the follower driving as it did.
    pub hit_from_behind_at_emergency: usize,
    /// The same with a follower in the certificate's model that answers the braking: the IDM
    /// at its closest time gap at once, and the certificate's reacting follower
    /// ([`Outcome::cut_in_hit_from_behind_at_emergency_answered`]).
    pub hit_from_behind_at_emergency_answered: [usize; 2],
    /// Collisions that were preventable and were not prevented
    /// ([`Outcome::preventable_not_prevented`]). The aim is none.
    pub preventable_not_prevented: usize,
    /// Of those, the ones preventable through the declared sensors as well
    /// ([`Outcome::preventable_through_the_sensors_not_prevented`]): the others the sensors
    /// held back (a track delivered too late for the emergency authority, or the rear
    /// measurement's error box).
    pub preventable_through_the_sensors_not_prevented: usize,
}

/// Runs `episodes` episodes of one group in parallel, seeds `seed..seed + episodes`.
pub fn run_group(
    table: &Table<'_>,
    bytes: &[u8],
    template: Episode,
    episodes: usize,
    progress: &(dyn Fn() + Sync),
) -> (GroupSummary, Vec<(u64, Outcome)>) {
    let outcomes: Vec<(u64, Outcome)> = (0..episodes as u64)
        .into_par_iter()
        .filter_map(|i| {
            let e = Episode {
                seed: template.seed + i,
                ..template
            };
            let o = run_episode(table, bytes, &e, None);
            progress();
            o.map(|o| (e.seed, o))
        })
        .collect();
    let n = outcomes.len().max(1) as f32;
    let count = |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|(_, o)| f(o)).count();
    let mean = |f: &dyn Fn(&Outcome) -> f32| outcomes.iter().map(|(_, o)| f(o)).sum::<f32>() / n;
    let least = |f: &dyn Fn(&Outcome) -> f32| {
        outcomes
            .iter()
            .map(|(_, o)| f(o))
            .fold(f32::INFINITY, f32::min)
    };
    let comfort_start = |o: &Outcome| in_iso_scope(o) && o.started_comfort_certified;
    let mut by_mode = LossesByMode::default();
    for (_, o) in &outcomes {
        let Some((_, mode, half)) = o.certificate_lost else {
            continue;
        };
        match mode {
            ModeName::Nominal => by_mode.nominal += 1,
            ModeName::Override => by_mode.r#override += 1,
            ModeName::MinimumRisk => by_mode.minimum_risk += 1,
            ModeName::Uncertified | ModeName::Standby => by_mode.uncertified += 1,
        }
        match half {
            Half::Front => by_mode.front += 1,
            Half::Rear => by_mode.rear += 1,
            Half::Speed => by_mode.speed += 1,
            Half::Domain => by_mode.domain += 1,
        }
    }
    let worst = outcomes
        .iter()
        .min_by(|a, b| a.1.min_margin.total_cmp(&b.1.min_margin))
        .map_or(template.seed, |(s, _)| *s);
    let summary = GroupSummary {
        leader: template.leader,
        follower: template.follower,
        in_model: template
            .follower
            .in_model_for(template.config.certificate.authorities)
            && template.cut_in.is_none(),
        episodes: outcomes.len(),
        collisions: count(&|o| o.collided),
        collisions_unavoidable: count(&|o| o.collided && o.unavoidable_from.is_some()),
        certificate_losses: count(&|o| o.certificate_lost.is_some()),
        certificate_losses_by_mode: by_mode,
        humans_made_unavoidable: count(&|o| o.unavoidable_from.is_some()),
        min_margin: least(&|o| o.min_margin),
        min_front_margin: least(&|o| o.min_half_margins.0),
        min_rear_margin: least(&|o| o.min_half_margins.1),
        min_gap_leader: least(&|o| o.min_gap_leader),
        min_gap_follower: least(&|o| o.min_gap_follower),
        mean_override_share: mean(&|o| o.override_share),
        mean_minimum_risk_share: mean(&|o| o.minimum_risk_share),
        mean_uncertified_share: mean(&|o| o.uncertified_share),
        max_jerk: outcomes.iter().map(|(_, o)| o.max_jerk).fold(0.0, f32::max),
        iso_scope: (
            count(&|o| in_iso_scope(o)),
            count(&|o| in_iso_scope(o) && o.iso.holds()),
        ),
        iso_scope_comfort_start: (
            count(&|o| comfort_start(o)),
            count(&|o| comfort_start(o) && o.iso.holds()),
            outcomes
                .iter()
                .filter(|(_, o)| comfort_start(o))
                .fold(EmergencyCauses::default(), |sum, (_, o)| {
                    sum.add(&o.emergencies)
                }),
        ),
        engaged_in_emergency: count(&|o| o.engaged_in_emergency),
        iso_worst_in_scope: outcomes
            .iter()
            .filter(|(_, o)| in_iso_scope(o))
            .map(|(_, o)| o.iso.worst())
            .fold(0.0, f32::max),
        emergency_periods: outcomes.iter().map(|(_, o)| o.emergency_periods).sum(),
        emergencies: outcomes
            .iter()
            .fold(EmergencyCauses::default(), |sum, (_, o)| {
                sum.add(&o.emergencies)
            }),
        mean_leader_stops: mean(&|o| o.leader_stops as f32),
        standstill_starts: count(&|o| o.initial[4] == 0.0),
        worst_seed: worst,
        uncertified_minimum_risk_periods: outcomes
            .iter()
            .map(|(_, o)| o.uncertified_minimum_risk)
            .sum(),
        fallback_periods: outcomes.iter().map(|(_, o)| o.fallback_periods).sum(),
        below_band_periods: outcomes.iter().map(|(_, o)| o.below_band_periods).sum(),
        below_band_episodes: count(&|o| o.below_band_periods > 0),
        fallback_episodes: count(&|o| o.fallback_periods > 0),
        max_track_age: [0, 1].map(|i| {
            outcomes
                .iter()
                .map(|(_, o)| o.max_track_age[i])
                .fold(0.0, f32::max)
        }),
        needless: outcomes
            .iter()
            .map(|(seed, o)| NeedlessSummary::of(*seed, &o.needless))
            .fold(NeedlessSummary::default(), NeedlessSummary::add),
        cut_ins: template.cut_in.map(|_| cut_in_summary(&outcomes)),
    };
    (summary, outcomes)
}

/// The cut-ins of a group's outcomes.
fn cut_in_summary(outcomes: &[(u64, Outcome)]) -> CutInSummary {
    let cuts: Vec<(&Outcome, &CutInScore)> = outcomes
        .iter()
        .filter_map(|(_, o)| o.cut_in.as_ref().map(|c| (o, c)))
        .collect();
    let n = cuts.len().max(1) as f32;
    let answers: Vec<f32> = cuts
        .iter()
        .filter(|(_, c)| c.answered_periods.is_some_and(|p| p <= 1))
        .filter_map(|(_, c)| c.first_answer)
        .collect();
    let delivered: Vec<f32> = cuts.iter().filter_map(|(_, c)| c.delivered_after).collect();
    CutInSummary {
        episodes: cuts.len(),
        delivered_after_mean: delivered.iter().sum::<f32>() / delivered.len().max(1) as f32,
        delivered_after_max: delivered.iter().copied().fold(0.0, f32::max),
        recognised_at_once: cuts
            .iter()
            .filter(|(_, c)| c.recognised_periods == Some(0))
            .count(),
        front_uncertified: cuts
            .iter()
            .filter(|(_, c)| c.front_certified_at_delivery == Some(false))
            .count(),
        answered_within_one_period: answers.len(),
        mean_first_answer: answers.iter().sum::<f32>() / answers.len().max(1) as f32,
        mean_hardest_command: cuts
            .iter()
            .map(|(_, c)| c.hardest_command.min(2.0))
            .sum::<f32>()
            / n,
        collisions: cuts.iter().filter(|(o, _)| o.collided).count(),
        collisions_behind: cuts
            .iter()
            .filter(|(o, _)| o.collided && o.min_gap_follower <= 0.0)
            .count(),
        unavoidable: cuts
            .iter()
            .filter(|(o, _)| o.cut_in_unavoidable == Some(true))
            .count(),
        r157_requires_avoiding: cuts
            .iter()
            .filter(|(_, c)| c.r157_requires_avoiding())
            .count(),
        unavoidable_at_emergency: cuts
            .iter()
            .filter(|(o, _)| o.cut_in_unavoidable_at_emergency == Some(true))
            .count(),
        hit_from_behind_at_emergency: cuts
            .iter()
            .filter(|(o, _)| o.collided && o.cut_in_hit_from_behind_at_emergency == Some(true))
            .count(),
        hit_from_behind_at_emergency_answered: [0, 1].map(|i| {
            cuts.iter()
                .filter(|(o, _)| {
                    o.collided
                        && o.cut_in_hit_from_behind_at_emergency_answered
                            .is_some_and(|a| a[i])
                })
                .count()
        }),
        preventable_not_prevented: cuts
            .iter()
            .filter(|(o, c)| o.preventable_not_prevented(c))
            .count(),
        preventable_through_the_sensors_not_prevented: cuts
            .iter()
            .filter(|(o, c)| o.preventable_through_the_sensors_not_prevented(c))
            .count(),
    }
}

/// The groups a campaign runs: every leader against every follower.
pub const GROUPS: [(Leader, Follower); 24] = {
    let leaders = [
        Leader::HardBrake,
        Leader::StopAndGo,
        Leader::Random,
        Leader::Comfortable,
    ];
    let followers = [
        Follower::IdmFixed,
        Follower::IdmRandom,
        Follower::IdmSwitching,
        Follower::IdmWorstCase,
        Follower::Unbounded,
        Follower::IdmReacting,
    ];
    let mut out = [(Leader::HardBrake, Follower::IdmFixed); 24];
    let mut i = 0;
    while i < 24 {
        out[i] = (leaders[i / 6], followers[i % 6]);
        i += 1;
    }
    out
};

/// A campaign's settings: every group ([`GROUPS`]) runs `episodes` episodes of `seconds`.
#[derive(Debug, Clone, Copy)]
pub struct CampaignSettings {
    /// Episodes per group.
    pub episodes: usize,
    /// Simulated seconds per episode.
    pub seconds: f32,
    /// The first seed (group `i` starts at `seed + i * 1,000,000`).
    pub seed: u64,
    /// The sensors.
    pub sensing: Sensing,
    /// A cut-in in every episode, if any (outside the model).
    pub cut_in: Option<CutInKind>,
    /// The ego's actuator.
    pub actuator: ActuatorModel,
    /// The firmware's configuration.
    pub config: Config,
}

/// A setting that means nothing: which one, and why (the command line and the Python module
/// each name it their way).
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// The setting (`episodes`, `seconds`, `latency`, `dead_time_ms`, `lag`).
    pub field: &'static str,
    /// Why.
    pub reason: String,
}

impl CampaignSettings {
    /// Refuses settings that would test nothing or mean nothing: no episodes, a duration that
    /// is not a positive number of seconds, a latency beyond the covered track age, an
    /// actuator with a negative or non-finite delay.
    pub fn check(&self) -> Result<(), Invalid> {
        let fail = |field, reason: String| Err(Invalid { field, reason });
        if self.episodes == 0 {
            return fail(
                "episodes",
                "must be at least 1 (got 0): nothing would be tested".into(),
            );
        }
        if !(self.seconds.is_finite() && self.seconds > 0.0) {
            return fail(
                "seconds",
                format!(
                    "must be a finite number of seconds above 0 (got {})",
                    self.seconds
                ),
            );
        }
        if let Sensing::Fixed(s) = self.sensing {
            let oldest = s.channels.iter().map(|c| c.latency_us).max().unwrap_or(0);
            if oldest > 1_000_000 {
                return fail(
                    "latency",
                    format!(
                        "must be at most 50 periods (1 s, the covered track age; got {} ms)",
                        oldest / 1000
                    ),
                );
            }
        }
        let dead = self.actuator.dead_time * 1e3;
        if !(dead.is_finite() && dead >= 0.0) {
            return fail(
                "dead_time_ms",
                format!("must be a finite number of milliseconds of at least 0 (got {dead})"),
            );
        }
        if !(self.actuator.lag.is_finite() && self.actuator.lag >= 0.0) {
            return fail(
                "lag",
                format!(
                    "must be a finite time constant of at least 0 s (got {})",
                    self.actuator.lag
                ),
            );
        }
        Ok(())
    }

    /// Whether the certificate covers the campaign: measurements within the declared error and
    /// track age (both sensor settings), an actuator within the declared dead time and lag, no
    /// cut-in.
    pub fn covered(&self) -> bool {
        self.cut_in.is_none()
            && self.actuator.dead_time * 1e6 <= self.config.plant.actuator_dead_time_us as f32 + 0.5
            && self.actuator.lag * 1e6 <= self.config.plant.actuator_lag_us as f32 + 0.5
    }
}

/// The totals over a campaign's groups whose humans keep to the model.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct CampaignTotals {
    /// Episodes in the model's groups.
    pub in_model_episodes: usize,
    /// Their collisions.
    pub collisions: usize,
    /// Of those, collisions the humans alone had made unavoidable.
    pub collisions_unavoidable: usize,
    /// Their certificate losses.
    pub certificate_losses: usize,
    /// Their periods of the minimum-risk manoeuvre without a certificate.
    pub uncertified_minimum_risk_periods: u64,
    /// Their periods of the certified fallback.
    pub fallback_periods: u64,
    /// Their periods braked harder than the band, and the episodes that did.
    pub below_band_periods: u64,
    /// See `below_band_periods`.
    pub below_band_episodes: usize,
    /// Their braking and standing the road did not ask for.
    pub needless: NeedlessSummary,
    /// Their emergency periods by cause.
    pub emergencies: EmergencyCauses,
    /// Cut-ins over every group.
    pub cut_ins: usize,
    /// Cut-ins with an uncertified front not answered within one period.
    pub cut_ins_answered_late: usize,
    /// Collisions after a cut-in that braking at beta from the first track would have avoided.
    pub cut_in_collisions_avoidable: usize,
    /// Collisions after a cut-in with the follower (the ego hit from behind).
    pub cut_in_collisions_behind: usize,
    /// Collisions after a cut-in that the emergency authority would not have avoided.
    pub cut_in_collisions_unavoidable_at_emergency: usize,
    /// Collisions after a cut-in that the emergency authority would have turned into a
    /// collision from behind (the follower driving as it did).
    pub cut_in_collisions_hit_from_behind_at_emergency: usize,
    /// The same with the certificate's followers answering the braking: at once, and after
    /// its reaction time.
    pub cut_in_collisions_hit_from_behind_at_emergency_answered: [usize; 2],
    /// Leader cut-ins UN R157 requires avoiding ([`CutInSummary::r157_requires_avoiding`]).
    pub cut_ins_r157: usize,
    /// Collisions after a cut-in that were preventable and were not prevented
    /// ([`Outcome::preventable_not_prevented`]).
    pub cut_in_collisions_preventable: usize,
    /// Of those, the ones preventable through the declared sensors as well
    /// ([`Outcome::preventable_through_the_sensors_not_prevented`]).
    pub cut_in_collisions_preventable_through_the_sensors: usize,
}

/// What a campaign found: `campaign.json`.
#[derive(Debug, Clone, Serialize)]
pub struct CampaignReport {
    /// Episodes per group.
    pub episodes_per_group: usize,
    /// Simulated seconds per episode.
    pub seconds: f32,
    /// The sensors.
    pub sensors: Sensing,
    /// The firmware's declared sensor bounds.
    pub declared_sensor_bounds: firmware::SensorBounds,
    /// The track age the firmware covers, s.
    pub covered_track_age_s: f32,
    /// The cut-in, if any.
    pub cut_in: Option<CutInKind>,
    /// The ego's actuator.
    pub actuator: ActuatorModel,
    /// Whether the certificate covers the campaign ([`CampaignSettings::covered`]).
    pub covered_by_the_certificate: bool,
    /// Every group.
    pub groups: Vec<GroupSummary>,
    /// The totals.
    pub totals: CampaignTotals,
    /// Wall time, s.
    pub wall_s: f64,
}

impl CampaignReport {
    /// Why the campaign fails, if it does: a group that drew no certified start (nothing was
    /// tested), or, where the certificate covers the campaign, a collision, a certificate loss
    /// or an uncertified minimum-risk period with humans within the model.
    pub fn failure(&self) -> Option<String> {
        let empty: Vec<String> = self
            .groups
            .iter()
            .filter(|s| s.episodes == 0)
            .map(|s| format!("{:?}/{:?}", s.leader, s.follower))
            .collect();
        if !empty.is_empty() {
            return Some(format!(
                "no certified start could be drawn for {}: nothing was tested",
                empty.join(", ")
            ));
        }
        let t = &self.totals;
        (self.covered_by_the_certificate
            && (t.collisions > 0
                || t.certificate_losses > 0
                || t.uncertified_minimum_risk_periods > 0))
            .then(|| {
                format!(
                    "the certificate failed: {} collisions, {} certificate losses and {} \
                     uncertified minimum-risk periods with humans within the model, sensors and \
                     actuator within its limits",
                    t.collisions, t.certificate_losses, t.uncertified_minimum_risk_periods
                )
            })
    }
}

/// Runs a campaign on `table` (its `bytes`): every group of [`GROUPS`] in turn, its episodes
/// in parallel. `group_done` sees each group's summary and the episode with its smallest
/// margin as it finishes; `episode_done` is called after every episode.
pub fn run_campaign(
    table: &Table<'_>,
    bytes: &[u8],
    settings: &CampaignSettings,
    group_done: &mut dyn FnMut(&GroupSummary, &Episode),
    episode_done: &(dyn Fn() + Sync),
) -> CampaignReport {
    let t0 = std::time::Instant::now();
    let mut groups = Vec::new();
    for (i, (leader, follower)) in GROUPS.iter().enumerate() {
        let template = Episode {
            leader: *leader,
            follower: *follower,
            seconds: settings.seconds,
            sensors: settings.sensing,
            cut_in: settings.cut_in,
            actuator: settings.actuator,
            config: settings.config,
            seed: settings.seed + (i as u64) * 1_000_000,
        };
        let (summary, _) = run_group(table, bytes, template, settings.episodes, episode_done);
        group_done(
            &summary,
            &Episode {
                seed: summary.worst_seed,
                ..template
            },
        );
        groups.push(summary);
    }
    let mut totals = CampaignTotals::default();
    for s in groups.iter().filter(|s| s.in_model) {
        totals.in_model_episodes += s.episodes;
        totals.collisions += s.collisions;
        totals.collisions_unavoidable += s.collisions_unavoidable;
        totals.certificate_losses += s.certificate_losses;
        totals.uncertified_minimum_risk_periods += s.uncertified_minimum_risk_periods;
        totals.fallback_periods += s.fallback_periods;
        totals.below_band_periods += s.below_band_periods;
        totals.below_band_episodes += s.below_band_episodes;
        totals.needless = totals.needless.add(s.needless);
        totals.emergencies = totals.emergencies.add(&s.emergencies);
    }
    for c in groups.iter().filter_map(|s| s.cut_ins) {
        totals.cut_ins += c.episodes;
        totals.cut_ins_answered_late += c.front_uncertified - c.answered_within_one_period;
        totals.cut_in_collisions_avoidable += c.collisions - c.unavoidable;
        totals.cut_in_collisions_behind += c.collisions_behind;
        totals.cut_in_collisions_unavoidable_at_emergency += c.unavoidable_at_emergency;
        totals.cut_in_collisions_hit_from_behind_at_emergency += c.hit_from_behind_at_emergency;
        for i in 0..2 {
            totals.cut_in_collisions_hit_from_behind_at_emergency_answered[i] +=
                c.hit_from_behind_at_emergency_answered[i];
        }
        totals.cut_ins_r157 += c.r157_requires_avoiding;
        totals.cut_in_collisions_preventable += c.preventable_not_prevented;
        totals.cut_in_collisions_preventable_through_the_sensors +=
            c.preventable_through_the_sensors_not_prevented;
    }
    CampaignReport {
        episodes_per_group: settings.episodes,
        seconds: settings.seconds,
        sensors: settings.sensing,
        declared_sensor_bounds: settings.config.sensors,
        covered_track_age_s: settings.config.sensors.max_track_age_us as f32 * 1e-6,
        cut_in: settings.cut_in,
        actuator: settings.actuator,
        covered_by_the_certificate: settings.covered(),
        groups,
        totals,
        wall_s: t0.elapsed().as_secs_f64(),
    }
}
