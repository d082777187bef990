//! Episodes and campaigns: the firmware's `Controller` at its real period against the humans,
//! from initial states sampled over the whole certified set of the firmware's table, standstill
//! included.
//!
//! What an episode judges, on the *true* state (not the measured one):
//! - a **collision**: a gap reaches zero, inside a period or at a sample;
//! - a **certificate loss**: the certificate's margin ([`firmware::Controller::certificate`])
//!   falls to `-firmware::CERTIFICATE_TOLERANCE` (f32 rounding) or below, or the state leaves
//!   the table's domain, at a sample while the firmware runs; the firmware's mode at that moment
//!   and the half of the certificate that was lost are kept. From a certified start, with humans that keep to the model, both must be zero, or
//!   the certificate is wrong;
//! - whether the **humans alone** made a collision unavoidable first (the follower can no
//!   longer stop short of where the leader stops).

use firmware::{Config, Controller, Mode, CERTIFICATE_TOLERANCE};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;
use table_format::Table;

use crate::humans::{Follower, HumanModel, Humans, Leader};
use crate::sim::{
    humans_make_a_collision_unavoidable, lowest_gap, Actuator, ActuatorModel, Car, SensorModel,
    Sensors,
};

/// Sub-steps per control period in the plant: the actuator's lag changes the ego's
/// acceleration within a period (5 ms steps against a lag of 0.3 s).
const SUB_STEPS: u32 = 4;

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
    pub sensors: SensorModel,
    /// The ego's actuator.
    pub actuator: ActuatorModel,
    /// The firmware's configuration.
    #[serde(skip)]
    pub config: Config,
    /// Seed of the episode's random numbers.
    pub seed: u64,
}

/// The firmware's mode, for reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModeName {
    /// [`Mode::Nominal`].
    Nominal,
    /// [`Mode::Override`].
    Override,
    /// [`Mode::MinimumRisk`].
    MinimumRisk,
    /// [`Mode::Uncertified`].
    Uncertified,
}

impl From<Mode> for ModeName {
    fn from(m: Mode) -> Self {
        match m {
            Mode::Nominal => ModeName::Nominal,
            Mode::Override => ModeName::Override,
            Mode::MinimumRisk => ModeName::MinimumRisk,
            Mode::Uncertified => ModeName::Uncertified,
        }
    }
}

/// Which half of the certificate was lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Half {
    /// The front value.
    Front,
    /// The rear value.
    Rear,
    /// The state left the table's domain.
    Domain,
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
    /// half lost.
    pub certificate_lost: Option<(f32, ModeName, Half)>,
    /// The smallest certificate margin over the episode, m.
    pub min_margin: f32,
    /// The smallest front and rear margins over the episode, m (each half on its own).
    pub min_half_margins: (f32, f32),
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
    /// The initial state `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`.
    pub initial: [f32; 5],
    /// The certificate margin at the start, m.
    pub initial_margin: f32,
}

/// A recorded trajectory, one entry per period.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TracePoint {
    /// Time, s.
    pub t: f32,
    /// Gap to the leader, m.
    pub gap_leader: f32,
    /// Gap to the follower, m.
    pub gap_follower: f32,
    /// Speeds of leader, ego and follower, m/s.
    pub speeds: [f32; 3],
    /// The ego's command, m/s^2.
    pub command: f32,
    /// The firmware's mode.
    pub mode: ModeName,
    /// The certificate margin at the true state, m.
    pub margin: f32,
    /// The certificate margin the firmware computed from its measurements (NaN: none), m.
    pub firmware_margin: f32,
}

/// A recorded trajectory.
pub type Trace = Vec<TracePoint>;

/// The true state `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`.
pub fn state_of([leader, ego, follower]: [Car; 3]) -> [f32; 5] {
    [
        leader.x - ego.x,
        leader.v,
        ego.x - follower.x,
        follower.v,
        ego.v,
    ]
}

/// Draws an initial state over the whole certified set (`margin > 0` for an actuator at rest
/// that takes `response_time` to brake): each speed is zero with probability 0.15 and uniform
/// in `[0, max_speed]` otherwise; gaps are uniform in `[0, 150]` m ahead and over the rear grid
/// behind. `None` after 10,000 rejected draws.
pub fn sample_start(
    controller: &Controller<'_>,
    model: &HumanModel,
    gap_max: f32,
    response_time: f32,
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
        if let Some(certificate) = controller.certificate_with_response(state, response_time, 0.0) {
            let margin = certificate.margin();
            if margin > 0.0 {
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
    let mut controller = Controller::new(bytes, config);
    let model = HumanModel::of(table)?;
    let gap_max = table.axis_bounds(0)?.max;
    let response_time = episode.actuator.dead_time + episode.actuator.lag;
    let ([mut leader, mut ego, mut follower], initial_margin) =
        sample_start(&controller, &model, gap_max, response_time, &mut rng)?;
    let initial = state_of([leader, ego, follower]);
    let mut humans = Humans::new(table, episode.leader, episode.follower, &mut rng)?;
    let mut sensors = Sensors::new(episode.sensors);
    let mut actuator = Actuator::new(episode.actuator);
    let h = config.period_us as f32 * 1e-6;
    let steps = (episode.seconds / h).round() as u64;
    let (mut min_front, mut min_rear) = (f32::INFINITY, f32::INFINITY);
    let (mut overrides, mut mrm, mut uncertified) = (0u64, 0u64, 0u64);
    let mut max_jerk = 0f32;
    let mut last_accel: Option<f32> = None;
    let mut collision_time = None;
    let mut unavoidable_from = None;
    let mut certificate_lost = None;
    let mut min_margin = f32::INFINITY;
    let mut min_half = (f32::INFINITY, f32::INFINITY);
    let mut leader_stops = 0u32;
    let (leader_braking, follower_braking) = humans.hardest_braking();
    let mut trace = trace;
    for k in 0..steps {
        let t = k as f32 * h;
        let now_us = k * u64::from(config.period_us);
        if unavoidable_from.is_none()
            && humans_make_a_collision_unavoidable(
                leader,
                follower,
                leader_braking,
                follower_braking,
            )
        {
            unavoidable_from = Some(t);
        }
        let inputs = sensors.measure(now_us, [leader, ego, follower], &mut rng);
        let command = controller.step(&inputs);
        // The certificate at the true state, with what the actuator has yet to do.
        let (response_time, response_acceleration) = actuator.response(t, model.band_min);
        let certificate = controller.certificate_with_response(
            state_of([leader, ego, follower]),
            response_time,
            response_acceleration,
        );
        let m = certificate.map_or(f32::NEG_INFINITY, |c| c.margin());
        min_margin = min_margin.min(m);
        if let Some(c) = certificate {
            min_half.0 = min_half.0.min(c.front);
            min_half.1 = min_half.1.min(c.rear);
        }
        if certificate_lost.is_none() && (m.is_nan() || m <= -CERTIFICATE_TOLERANCE) {
            let half = match certificate {
                None => Half::Domain,
                Some(c) if c.front <= c.rear => Half::Front,
                Some(_) => Half::Rear,
            };
            certificate_lost = Some((t, command.mode.into(), half));
        }
        match command.mode {
            Mode::Override => overrides += 1,
            Mode::MinimumRisk => mrm += 1,
            Mode::Uncertified => uncertified += 1,
            Mode::Nominal => {}
        }
        let a_ego = command.acceleration;
        if let Some(prev) = last_accel {
            max_jerk = max_jerk.max((a_ego - prev).abs() / h);
        }
        last_accel = Some(a_ego);
        actuator.request(t, a_ego);
        let (a_leader, a_follower) = humans.accelerations(t, h, [leader, ego, follower], &mut rng);
        // The period in sub-steps: the ego's acceleration follows the actuator within it.
        let before = [leader, ego, follower];
        let mut collided = false;
        for j in 0..SUB_STEPS {
            let dt = h / SUB_STEPS as f32;
            let a_actual = actuator.advance(t + j as f32 * dt, dt);
            let front = lowest_gap(leader, a_leader, ego, a_actual, dt);
            let rear = lowest_gap(ego, a_actual, follower, a_follower, dt);
            min_front = min_front.min(front);
            min_rear = min_rear.min(rear);
            if front <= 0.0 || rear <= 0.0 {
                collided = true;
                break;
            }
            leader.advance(a_leader, dt);
            ego.advance(a_actual, dt);
            follower.advance(a_follower, dt);
        }
        if let Some(tr) = trace.as_deref_mut() {
            let [l, e, f] = before;
            tr.push(TracePoint {
                t,
                gap_leader: l.x - e.x,
                gap_follower: e.x - f.x,
                speeds: [l.v, e.v, f.v],
                command: a_ego,
                mode: command.mode.into(),
                margin: m,
                firmware_margin: command.margin.unwrap_or(f32::NAN),
            });
        }
        if collided {
            collision_time = Some(t);
            break;
        }
        if before[0].v > 0.0 && leader.v <= 0.0 {
            leader_stops += 1;
        }
    }
    let n = steps.max(1) as f32;
    Some(Outcome {
        collided: collision_time.is_some(),
        collision_time,
        unavoidable_from,
        certificate_lost,
        min_margin,
        min_half_margins: min_half,
        min_gap_leader: min_front,
        min_gap_follower: min_rear,
        override_share: overrides as f32 / n,
        minimum_risk_share: mrm as f32 / n,
        uncertified_share: uncertified as f32 / n,
        max_jerk,
        leader_stops,
        initial,
        initial_margin,
    })
}

/// Certificate losses by the firmware's mode at the moment of loss.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct LossesByMode {
    /// In [`Mode::Nominal`].
    pub nominal: usize,
    /// In [`Mode::Override`].
    pub r#override: usize,
    /// In [`Mode::MinimumRisk`].
    pub minimum_risk: usize,
    /// In [`Mode::Uncertified`].
    pub uncertified: usize,
    /// Of all, those where the front value was lost.
    pub front: usize,
    /// Of all, those where the rear value was lost.
    pub rear: usize,
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
    /// Whether the humans keep to the table's model.
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
    /// Mean number of leader stops to standstill per episode.
    pub mean_leader_stops: f32,
    /// Starts at standstill (ego speed zero).
    pub standstill_starts: usize,
    /// Seed of the episode with the smallest margin (to replay it).
    pub worst_seed: u64,
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
    let mut by_mode = LossesByMode::default();
    for (_, o) in &outcomes {
        let Some((_, mode, half)) = o.certificate_lost else {
            continue;
        };
        match mode {
            ModeName::Nominal => by_mode.nominal += 1,
            ModeName::Override => by_mode.r#override += 1,
            ModeName::MinimumRisk => by_mode.minimum_risk += 1,
            ModeName::Uncertified => by_mode.uncertified += 1,
        }
        match half {
            Half::Front => by_mode.front += 1,
            Half::Rear => by_mode.rear += 1,
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
        in_model: template.follower.in_model(),
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
        mean_leader_stops: mean(&|o| o.leader_stops as f32),
        standstill_starts: count(&|o| o.initial[4] == 0.0),
        worst_seed: worst,
    };
    (summary, outcomes)
}
