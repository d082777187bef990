//! The human drivers: leaders and followers that play by the game's model, and a follower that
//! does not.

use rand::Rng;
use serde::Serialize;
use table_format::{Game, IdmParameters, Table};

use crate::sim::Car;

/// What the leader does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Leader {
    /// Cruises, then brakes as hard as the model allows until it stops.
    HardBrake,
    /// Stop-and-go waves: braking and accelerating at the model's limits, period 12 s.
    StopAndGo,
    /// A new random acceleration within the bounds every second.
    Random,
    /// The game's worst case `d1*`: brake where `dV/dv_g1 > 0`, accelerate elsewhere.
    WorstCase,
}

/// What the follower does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Follower {
    /// IDM with the middle of the time-gap range.
    IdmFixed,
    /// IDM with a time gap drawn once per episode in the range.
    IdmRandom,
    /// IDM whose time gap jumps between the range's ends every 3 s.
    IdmSwitching,
    /// IDM with the game's worst-case time gap: `T_min` where `dV/dv_g2 > 0`, else `T_max`.
    IdmWorstCase,
    /// Breaks the model: any acceleration within the bounds, chosen adversarially: the paper's
    /// baseline follower playing its worst case `u3* = a_max` where `dV/dv_g2 > 0` (eq. 8).
    /// The baseline value is non-decreasing in `v_g2` (an ego faster than its follower is
    /// never worse off), so `dV/dv_g2 >= 0` and the worst case is full acceleration throughout:
    /// the follower closes in on the ego as hard as the bounds allow.
    Unbounded,
}

/// The follower's IDM when the table's game has none (baseline and two-car tables): Treiber &
/// Kesting's highway values with the paper's zero jam distance.
const FALLBACK_IDM: IdmParameters = IdmParameters {
    max_acceleration: 1.0,
    comfortable_deceleration: 1.5,
    desired_speed: 33.3,
    exponent: 4,
    jam_distance: 0.0,
};

/// The two human accelerations per period.
pub struct Humans<'t> {
    table: &'t Table<'t>,
    leader: Leader,
    follower: Follower,
    leader_bounds: (f32, f32),
    follower_bounds: (f32, f32),
    idm: IdmParameters,
    time_gap_range: (f32, f32),
    episode_time_gap: f32,
    random_accel: f32,
    next_random: f32,
}

/// `dV/dv_g1` and `dV/dv_g2` of the table at `z` by central differences over half a cell.
pub fn speed_gradient(table: &Table<'_>, z: [f32; 4]) -> Option<(f32, f32)> {
    let axes = &table.header().axes;
    let diff = |k: usize| -> Option<f32> {
        let a = axes.get(k)?;
        let h = 0.5 * a.uniform_spacing();
        let (mut lo, mut hi) = (z, z);
        lo[k] = (z[k] - h).max(a.min);
        hi[k] = (z[k] + h).min(a.max);
        let span = hi[k] - lo[k];
        if span <= 0.0 {
            return None;
        }
        Some((table.value_at(&hi).ok()? - table.value_at(&lo).ok()?) / span)
    };
    Some((diff(1)?, diff(3)?))
}

/// The IDM acceleration (Treiber et al. 2000) of a vehicle at `speed` behind a vehicle at
/// `leader_speed`, `gap` metres ahead, with desired time gap `time_gap`.
pub fn idm(p: &IdmParameters, speed: f32, leader_speed: f32, gap: f32, time_gap: f32) -> f32 {
    let approach = speed - leader_speed;
    let desired = p.jam_distance
        + (speed * time_gap
            + speed * approach / (2.0 * (p.max_acceleration * p.comfortable_deceleration).sqrt()))
        .max(0.0);
    let interaction = if gap > 0.0 {
        (desired / gap).powi(2)
    } else {
        f32::INFINITY
    };
    p.max_acceleration * (1.0 - (speed / p.desired_speed).powi(i32::from(p.exponent)) - interaction)
}

impl<'t> Humans<'t> {
    /// The hardest braking the model allows the leader and the follower (positive, m/s^2).
    pub fn hardest_braking(&self) -> (f32, f32) {
        (-self.leader_bounds.0, -self.follower_bounds.0)
    }

    /// The humans of one episode, with the bounds and IDM of the table's game.
    pub fn new(
        table: &'t Table<'t>,
        leader: Leader,
        follower: Follower,
        rng: &mut impl Rng,
    ) -> Self {
        let (leader_bounds, follower_bounds, idm, time_gap) = match table.header().game {
            Game::ThreeCarIdm {
                leader,
                follower_clip,
                idm,
                time_gap,
                ..
            }
            // (5-D tables are refused by the campaign; their humans have the same bounds.)
            | Game::ThreeCarIdmSpeeds {
                leader,
                follower_clip,
                idm,
                time_gap,
                ..
            } => (leader, follower_clip, idm, time_gap),
            Game::ThreeCarBaseline {
                leader, follower, ..
            } => (
                leader,
                follower,
                FALLBACK_IDM,
                table_format::Bounds::new(1.0, 2.0),
            ),
            // Rear tables have no leader; the campaign refuses them like two-car tables.
            Game::RearIdm { ego: leader, .. } | Game::TwoCar { leader, .. } => (
                leader,
                leader,
                FALLBACK_IDM,
                table_format::Bounds::new(1.0, 2.0),
            ),
        };
        let episode_time_gap = match follower {
            Follower::IdmRandom => rng.random_range(time_gap.min..=time_gap.max),
            _ => 0.5 * (time_gap.min + time_gap.max),
        };
        Humans {
            table,
            leader,
            follower,
            leader_bounds: (leader_bounds.min, leader_bounds.max),
            follower_bounds: (follower_bounds.min, follower_bounds.max),
            idm,
            time_gap_range: (time_gap.min, time_gap.max),
            episode_time_gap,
            random_accel: 0.0,
            next_random: 0.0,
        }
    }

    /// The leader's and the follower's accelerations at time `t` (held for one period).
    pub fn accelerations(&mut self, t: f32, cars: [Car; 3], rng: &mut impl Rng) -> (f32, f32) {
        let [leader, ego, follower] = cars;
        let z = [
            leader.x - ego.x,
            leader.v - ego.v,
            ego.x - follower.x,
            ego.v - follower.v,
        ];
        // The table's gradient, four lookups, computed once and only when a worst case needs it.
        let mut cached: Option<Option<(f32, f32)>> = None;
        let mut gradient = || {
            *cached.get_or_insert_with(|| {
                clamp_into(self.table, z).and_then(|z| speed_gradient(self.table, z))
            })
        };
        let (lmin, lmax) = self.leader_bounds;
        let a_leader = match self.leader {
            Leader::HardBrake => {
                if t < 2.0 {
                    0.0
                } else {
                    lmin
                }
            }
            Leader::StopAndGo => {
                let phase = (t / 12.0).fract();
                if phase < 0.35 {
                    lmin
                } else if phase < 0.7 {
                    lmax
                } else {
                    0.0
                }
            }
            Leader::Random => {
                if t >= self.next_random {
                    self.random_accel = rng.random_range(lmin..=lmax);
                    self.next_random += 1.0;
                }
                self.random_accel
            }
            Leader::WorstCase => match gradient() {
                Some((p2, _)) if p2 > 0.0 => lmin,
                Some(_) => lmax,
                None => lmin,
            },
        };
        let (fmin, fmax) = self.follower_bounds;
        let (tmin, tmax) = self.time_gap_range;
        let idm_with = |time_gap: f32| {
            idm(&self.idm, follower.v, ego.v, ego.x - follower.x, time_gap).clamp(fmin, fmax)
        };
        let a_follower = match self.follower {
            Follower::IdmFixed | Follower::IdmRandom => idm_with(self.episode_time_gap),
            Follower::IdmSwitching => idm_with(if (t / 6.0).fract() < 0.5 { tmin } else { tmax }),
            Follower::IdmWorstCase => match gradient() {
                Some((_, p4)) if p4 > 0.0 => idm_with(tmin),
                _ => idm_with(tmax),
            },
            Follower::Unbounded => fmax,
        };
        (a_leader, a_follower)
    }
}

/// `z` clamped onto the table's grid (`None` if not finite).
pub fn clamp_into(table: &Table<'_>, z: [f32; 4]) -> Option<[f32; 4]> {
    let mut out = z;
    for (x, a) in out.iter_mut().zip(table.header().axes.iter()) {
        if !x.is_finite() {
            return None;
        }
        *x = x.clamp(a.min, a.max);
    }
    Some(out)
}
