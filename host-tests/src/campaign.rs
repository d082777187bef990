//! Episodes and campaigns: the firmware's `Controller` at its real period against the humans,
//! from initial states sampled inside the table's certified safe set or just outside it.

use firmware::{Config, Controller, Mode};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;
use table_format::Table;

use crate::humans::{Follower, Humans, Leader};
use crate::sim::{humans_make_a_collision_unavoidable, lowest_gap, Car, SensorModel, Sensors};

/// Where episodes start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Start {
    /// Inside the trusted box, certified: `V_table - error_bound > 0.5 m`.
    Certified,
    /// Inside the trusted box, just outside the safe set: `V_table` in `[-2, 0)` m.
    JustOutside,
}

/// One episode's setting.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Episode {
    /// Start set.
    pub start: Start,
    /// Leader behaviour.
    pub leader: Leader,
    /// Follower behaviour.
    pub follower: Follower,
    /// Simulated seconds.
    pub seconds: f32,
    /// Sensors.
    pub sensors: SensorModel,
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
    /// The first time the humans alone made a collision unavoidable (see
    /// [`crate::sim::humans_make_a_collision_unavoidable`]), s.
    pub unavoidable_from: Option<f32>,
    /// Smallest gap to the leader, m.
    pub min_gap_leader: f32,
    /// Smallest gap to the follower, m.
    pub min_gap_follower: f32,
    /// Share of the time the table's input overrode the nominal law.
    pub override_share: f32,
    /// Share of the time in the minimum-risk manoeuvre.
    pub minimum_risk_share: f32,
    /// Share of the time the ego was slower than the table assumes (nominal law, uncertified).
    pub uncertified_share: f32,
    /// Largest |jerk| of the ego's command, m/s^3.
    pub max_jerk: f32,
    /// The initial state `(gap_leader, rel_speed_leader, gap_follower, rel_speed_follower)`
    /// and ego speed.
    pub initial: [f32; 5],
    /// The table value at the start, m.
    pub initial_value: f32,
}

/// A recorded trajectory: per period `(t, gap_leader, gap_follower, ego accel, mode)`.
pub type Trace = Vec<(f32, f32, f32, f32, u8)>;

/// Draws an initial state of the wanted kind: relative speeds and gaps inside the trusted box,
/// an ego speed in [20, 35] m/s, and absolute speeds of the humans in [0, 40] m/s.
pub fn sample_start(
    table: &Table<'_>,
    start: Start,
    rng: &mut impl Rng,
) -> Option<([Car; 3], f32)> {
    let header = table.header();
    let error = header.error_bound.total();
    for _ in 0..10_000 {
        let z: Vec<f32> = header
            .trusted_box
            .iter()
            .map(|b| rng.random_range(b.min..=b.max))
            .collect();
        let ego_v: f32 = rng.random_range(20.0..=35.0);
        let leader_v = ego_v + z[1];
        let follower_v = ego_v - z[3];
        if !(0.0..=40.0).contains(&leader_v) || !(0.0..=40.0).contains(&follower_v) {
            continue;
        }
        if z[0] <= 0.5 || z[2] <= 0.5 {
            continue;
        }
        let Ok(value) = table.value_at(&z) else {
            continue;
        };
        let wanted = match start {
            Start::Certified => value - error > 0.5,
            Start::JustOutside => (-2.0..0.0).contains(&value),
        };
        if wanted {
            let ego = Car { x: 0.0, v: ego_v };
            let leader = Car {
                x: z[0],
                v: leader_v,
            };
            let follower = Car {
                x: -z[2],
                v: follower_v,
            };
            return Some(([leader, ego, follower], value));
        }
    }
    None
}

/// Runs one episode; with `trace`, records the trajectory.
pub fn run_episode(
    table: &Table<'_>,
    bytes: &[u8],
    episode: &Episode,
    trace: Option<&mut Trace>,
) -> Option<Outcome> {
    let mut rng = StdRng::seed_from_u64(episode.seed);
    let ([mut leader, mut ego, mut follower], initial_value) =
        sample_start(table, episode.start, &mut rng)?;
    let initial = [
        leader.x - ego.x,
        leader.v - ego.v,
        ego.x - follower.x,
        ego.v - follower.v,
        ego.v,
    ];
    let config = Config::default();
    let mut controller = Controller::new(bytes, config);
    let mut humans = Humans::new(table, episode.leader, episode.follower, &mut rng);
    let mut sensors = Sensors::new(episode.sensors);
    let h = config.period_us as f32 * 1e-6;
    let steps = (episode.seconds / h).round() as u64;
    let (mut min_front, mut min_rear) = (f32::INFINITY, f32::INFINITY);
    let (mut overrides, mut mrm, mut uncertified) = (0u64, 0u64, 0u64);
    let mut max_jerk = 0f32;
    let mut last_accel: Option<f32> = None;
    let mut collision_time = None;
    let mut unavoidable_from = None;
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
        let (a_leader, a_follower) = humans.accelerations(t, [leader, ego, follower], &mut rng);
        let front = lowest_gap(leader, a_leader, ego, a_ego, h);
        let rear = lowest_gap(ego, a_ego, follower, a_follower, h);
        min_front = min_front.min(front);
        min_rear = min_rear.min(rear);
        if let Some(tr) = trace.as_deref_mut() {
            let mode = match command.mode {
                Mode::Nominal => 0,
                Mode::Override => 1,
                Mode::MinimumRisk => 2,
                Mode::Uncertified => 3,
            };
            tr.push((t, leader.x - ego.x, ego.x - follower.x, a_ego, mode));
        }
        if front <= 0.0 || rear <= 0.0 {
            collision_time = Some(t);
            break;
        }
        leader.advance(a_leader, h);
        ego.advance(a_ego, h);
        follower.advance(a_follower, h);
    }
    let n = steps.max(1) as f32;
    Some(Outcome {
        collided: collision_time.is_some(),
        collision_time,
        unavoidable_from,
        min_gap_leader: min_front,
        min_gap_follower: min_rear,
        override_share: overrides as f32 / n,
        minimum_risk_share: mrm as f32 / n,
        uncertified_share: uncertified as f32 / n,
        max_jerk,
        initial,
        initial_value,
    })
}

/// Per (start, leader, follower) group: counts and extremes.
#[derive(Debug, Clone, Serialize)]
pub struct GroupSummary {
    /// Start set.
    pub start: Start,
    /// Leader behaviour.
    pub leader: Leader,
    /// Follower behaviour.
    pub follower: Follower,
    /// Episodes run.
    pub episodes: usize,
    /// Episodes with a collision.
    pub collisions: usize,
    /// Of those, collisions the humans alone had made unavoidable beforehand (the follower could
    /// no longer stop short of the leader's stopping point).
    pub collisions_unavoidable: usize,
    /// `collisions / episodes`.
    pub collision_fraction: f64,
    /// Smallest gap to the leader over the group, m.
    pub min_gap_leader: f32,
    /// Smallest gap to the follower over the group, m.
    pub min_gap_follower: f32,
    /// Mean share of time under override.
    pub mean_override_share: f32,
    /// Mean share of time in the minimum-risk manoeuvre.
    pub mean_minimum_risk_share: f32,
    /// Share of episodes in which the ego ran uncertified (slower than the table assumes) at
    /// some point.
    pub uncertified_episodes: f64,
    /// Largest |jerk|, m/s^3.
    pub max_jerk: f32,
    /// Seed of the episode with the smallest gap (to replay it).
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
    let n = outcomes.len().max(1);
    let collisions = outcomes.iter().filter(|(_, o)| o.collided).count();
    let collisions_unavoidable = outcomes
        .iter()
        .filter(|(_, o)| o.collided && o.unavoidable_from.is_some())
        .count();
    let worst = outcomes
        .iter()
        .min_by(|a, b| {
            let ga = a.1.min_gap_leader.min(a.1.min_gap_follower);
            let gb = b.1.min_gap_leader.min(b.1.min_gap_follower);
            ga.total_cmp(&gb)
        })
        .map_or(template.seed, |(s, _)| *s);
    let summary = GroupSummary {
        start: template.start,
        leader: template.leader,
        follower: template.follower,
        episodes: outcomes.len(),
        collisions,
        collisions_unavoidable,
        collision_fraction: collisions as f64 / n as f64,
        min_gap_leader: outcomes
            .iter()
            .map(|(_, o)| o.min_gap_leader)
            .fold(f32::INFINITY, f32::min),
        min_gap_follower: outcomes
            .iter()
            .map(|(_, o)| o.min_gap_follower)
            .fold(f32::INFINITY, f32::min),
        mean_override_share: outcomes.iter().map(|(_, o)| o.override_share).sum::<f32>() / n as f32,
        mean_minimum_risk_share: outcomes
            .iter()
            .map(|(_, o)| o.minimum_risk_share)
            .sum::<f32>()
            / n as f32,
        uncertified_episodes: outcomes
            .iter()
            .filter(|(_, o)| o.uncertified_share > 0.0)
            .count() as f64
            / n as f64,
        max_jerk: outcomes.iter().map(|(_, o)| o.max_jerk).fold(0.0, f32::max),
        worst_seed: worst,
    };
    (summary, outcomes)
}
