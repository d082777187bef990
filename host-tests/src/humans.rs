//! The human drivers: leaders and followers that play by the table's model, and a follower that
//! does not. Their bounds, IDM and speed limit come from the table's header
//! ([`Game::ThreeCarSplit`]), so the campaign tests the model the certificate was made for.

use rand::Rng;
use serde::Serialize;
use table_format::rear::ReactingFollower;
use table_format::{FollowerModel, Game, Table};

use crate::sim::Car;

/// What the leader does. Every leader keeps its speed in `[0, max_speed]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Leader {
    /// Cruises for 2 s, then brakes as hard as the model allows until it stops, and stays.
    /// (The front game's worst case: hardest braking is the leader's saddle-point strategy.)
    HardBrake,
    /// Stop-and-go: brakes as hard as the model allows to standstill, waits 1-5 s, pulls away
    /// at 50-100 % of its largest acceleration to a speed drawn in [5, 30] m/s, cruises 2-8 s,
    /// and again; several stops per minute.
    StopAndGo,
    /// A new random acceleration within the bounds every second.
    Random,
    /// A new random acceleration every second within `[-3.5, 2]` m/s^2, the ACC's comfort
    /// braking at most: the campaign's group where ISO 15622's limits must hold.
    Comfortable,
}

/// The ACC's comfort braking, m/s^2: ISO 15622's limits are required where the leader brakes
/// no harder.
pub const COMFORT_BRAKING: f32 = 3.5;

/// What the follower does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Follower {
    /// IDM with the middle of the time-gap range.
    IdmFixed,
    /// IDM with a time gap drawn once per episode in the range.
    IdmRandom,
    /// IDM whose time gap jumps between the range's ends after random holds of 0.2-4 s.
    IdmSwitching,
    /// IDM with the rear game's worst-case time gap: `T_max` where `dW/dv_follower > 0`, else
    /// `T_min` (the IDM's acceleration is non-increasing in `T`).
    IdmWorstCase,
    /// Breaks the model: the largest acceleration the bounds allow, always (the paper's
    /// baseline follower's worst case).
    Unbounded,
    /// Breaks the table's model, keeps the two-authority certificate's: the IDM at the range's
    /// closest time gap, seeing the ego's brake lights only after its reaction time
    /// ([`table_format::rear::ReactingFollower`], the firmware's
    /// [`firmware::Certifier::reacting_follower`]). From when the lights come on (the ego's
    /// actual acceleration below the declared lights' deceleration's negative, at the earliest
    /// the loop's samples allow: [`crate::world::World::lights_on_at_the_earliest`]) it keeps
    /// the acceleration it had for its reaction time, then brakes at least as the model's
    /// follower does ([`table_format::rear::ReactingFollower::most_acceleration`]: its whole
    /// level, 6 m/s^2, while the lights stay on; harder where its IDM asks); lights that go
    /// off end it, and it drives by its IDM again. The follower that reacts like a person of
    /// `table_format::rear`.
    IdmReacting,
    /// Breaks both models: [`Follower::IdmReacting`] until it reacts, then the IDM at the
    /// range's closest time gap, which answers the lights only through the gap it sees (far
    /// enough back, it keeps accelerating behind an ego that brakes). Beyond the certificate's
    /// follower, which brakes at its whole level once it has reacted
    /// (`host-tests/cases/idm-after-reaction-collision.json` is what that costs).
    IdmAfterReacting,
}

impl Follower {
    /// Whether the follower keeps to the table's model.
    pub fn in_model(self) -> bool {
        !matches!(
            self,
            Follower::Unbounded | Follower::IdmReacting | Follower::IdmAfterReacting
        )
    }

    /// Whether the follower keeps to the model the certificate argues with: the table's in the
    /// comfort band; with two authorities the follower that reacts to the brake lights after
    /// its reaction time, at most at its IDM's top before and braking at its whole level after
    /// while the lights stay on (docs/certificate.md), which every IDM follower that sees the
    /// ego at once and [`Follower::IdmReacting`] keep to.
    pub fn in_model_for(self, authorities: firmware::Authorities) -> bool {
        match authorities {
            firmware::Authorities::ComfortBand => self.in_model(),
            firmware::Authorities::Two => {
                !matches!(self, Follower::Unbounded | Follower::IdmAfterReacting)
            }
        }
    }
}

/// The table's model of the humans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HumanModel {
    /// The leader's acceleration bounds, m/s^2.
    pub leader: (f32, f32),
    /// The follower's model ([`FollowerModel`]: the IDM with its time gap in range).
    pub follower: FollowerModel,
    /// Every speed lies in `[0, max_speed]`, m/s.
    pub max_speed: f32,
    /// The ego's band's lowest command, `-beta`, m/s^2.
    pub band_min: f32,
}

impl HumanModel {
    /// The follower's clip, m/s^2: `(lowest, highest)`.
    pub fn follower_clip(&self) -> (f32, f32) {
        let c = self.follower.clip();
        (c.min, c.max)
    }

    /// The follower's clipped acceleration at `follower_speed`, `gap` metres behind a leader
    /// at `leader_speed`, for the model's parameter `parameter`, m/s^2.
    pub fn follower_acceleration(
        &self,
        follower_speed: f32,
        leader_speed: f32,
        gap: f32,
        parameter: f32,
    ) -> f32 {
        let (lo, hi) = self.follower_clip();
        self.follower
            .acceleration(
                follower_speed,
                follower_speed - leader_speed,
                gap,
                parameter,
            )
            .clamp(lo, hi)
    }

    /// The range of the follower model's parameter (the IDM's time gap, s).
    pub fn parameter_range(&self) -> (f32, f32) {
        let r = self.follower.parameter_range();
        (r.min, r.max)
    }

    /// The model of a split table, `None` for any other game.
    pub fn of(table: &Table<'_>) -> Option<HumanModel> {
        match table.header().game {
            Game::ThreeCarSplit {
                ego,
                leader,
                follower,
                max_speed,
                ..
            } => Some(HumanModel {
                band_min: ego.min,
                leader: (leader.min, leader.max),
                follower,
                max_speed,
            }),
            _ => None,
        }
    }
}

/// The two human accelerations per period.
pub struct Humans<'t> {
    table: &'t Table<'t>,
    model: HumanModel,
    leader: Leader,
    follower: Follower,
    episode_time_gap: f32,
    /// Random leader: the current acceleration and when it is next drawn.
    random_accel: f32,
    next_random: f32,
    /// Stop-and-go leader: the phase and when it ends (or the target speed).
    phase: Phase,
    phase_until: f32,
    target_speed: f32,
    pull_away: f32,
    /// Switching follower: the current time gap and when it next jumps.
    switching_time_gap: f32,
    next_switch: f32,
    /// Reacting follower: its model, since when the ego's lights are on, the acceleration held
    /// until the follower reacts, and its last acceleration.
    reacting: ReactingFollower,
    lights_since: Option<f32>,
    held: f32,
    last_follower: f32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Braking,
    Standing,
    PullingAway,
    Cruising,
}

/// `dW/dv_follower` of the rear table at `(gap_follower, follower_speed, ego_speed)` by a
/// difference over 0.25 m/s (one-sided at the speed limits); `None` outside the grid.
pub fn follower_speed_gradient(table: &Table<'_>, z: [f32; 3]) -> Option<f32> {
    let axis = table.axis_bounds(1)?;
    let lo = (z[1] - 0.125).max(axis.min);
    let hi = (z[1] + 0.125).min(axis.max);
    if hi <= lo {
        return None;
    }
    let at = |v: f32| table.value_at(&[z[0], v, z[2]]).ok();
    Some((at(hi)? - at(lo)?) / (hi - lo))
}

/// `a` limited so that a car at `v` stays in `[0, v_max]` over a period `h` (the plant stops
/// cars at zero by itself).
pub(crate) fn within_speed_limit(a: f32, v: f32, v_max: f32, h: f32) -> f32 {
    if a > 0.0 {
        a.min(((v_max - v) / h).max(0.0))
    } else {
        a
    }
}

impl<'t> Humans<'t> {
    /// The hardest braking the model allows the leader and the follower (positive, m/s^2).
    pub fn hardest_braking(&self) -> (f32, f32) {
        (-self.model.leader.0, -self.model.follower_clip().0)
    }

    /// The humans of one episode, with the model of the table's game (`None` for a table that
    /// is not a split table); a follower that reacts late reacts as `reacting` does (the
    /// firmware's [`firmware::Certifier::reacting_follower`]).
    pub fn new(
        table: &'t Table<'t>,
        leader: Leader,
        follower: Follower,
        reacting: ReactingFollower,
        rng: &mut impl Rng,
    ) -> Option<Self> {
        let model = HumanModel::of(table)?;
        let (tmin, tmax) = model.parameter_range();
        let episode_time_gap = match follower {
            Follower::IdmRandom => rng.random_range(tmin..=tmax),
            _ => 0.5 * (tmin + tmax),
        };
        Some(Humans {
            table,
            model,
            leader,
            follower,
            episode_time_gap,
            random_accel: 0.0,
            next_random: 0.0,
            phase: Phase::Cruising,
            phase_until: rng.random_range(0.0..4.0),
            target_speed: 0.0,
            pull_away: 0.0,
            switching_time_gap: if rng.random::<bool>() { tmin } else { tmax },
            next_switch: rng.random_range(0.2..4.0),
            reacting,
            lights_since: None,
            held: 0.0,
            last_follower: 0.0,
        })
    }

    /// The leader's and the follower's accelerations at time `t`, held for a period `h`, with
    /// the ego's brake lights on since `lights_on_since` (`None`: off), the earliest they can
    /// have come on ([`crate::world::World::lights_on_at_the_earliest`]).
    pub fn accelerations(
        &mut self,
        t: f32,
        h: f32,
        cars: [Car; 3],
        lights_on_since: Option<f32>,
        rng: &mut impl Rng,
    ) -> (f32, f32) {
        let [leader, ego, follower] = cars;
        let m = self.model;
        let (lmin, lmax) = m.leader;
        let a_leader = match self.leader {
            Leader::HardBrake => {
                if t < 2.0 {
                    0.0
                } else {
                    lmin
                }
            }
            Leader::StopAndGo => self.stop_and_go(t, leader.v, rng),
            Leader::Random | Leader::Comfortable => {
                if t >= self.next_random {
                    let low = if self.leader == Leader::Comfortable {
                        lmin.max(-COMFORT_BRAKING)
                    } else {
                        lmin
                    };
                    self.random_accel = rng.random_range(low..=lmax);
                    self.next_random += 1.0;
                }
                self.random_accel
            }
        };
        let (tmin, tmax) = m.parameter_range();
        let gap = ego.x - follower.x;
        let idm_with = |time_gap: f32| m.follower_acceleration(follower.v, ego.v, gap, time_gap);
        let a_follower = match self.follower {
            Follower::IdmFixed | Follower::IdmRandom => idm_with(self.episode_time_gap),
            Follower::IdmSwitching => {
                if t >= self.next_switch {
                    self.switching_time_gap = if self.switching_time_gap == tmin {
                        tmax
                    } else {
                        tmin
                    };
                    self.next_switch = t + rng.random_range(0.2..4.0);
                }
                idm_with(self.switching_time_gap)
            }
            Follower::IdmWorstCase => {
                let z = [gap.min(self.table_gap_max()), follower.v, ego.v];
                match follower_speed_gradient(self.table, z) {
                    Some(p) if p > 0.0 => idm_with(tmax),
                    _ => idm_with(tmin),
                }
            }
            Follower::Unbounded => m.follower_clip().1,
            Follower::IdmReacting | Follower::IdmAfterReacting => {
                if lights_on_since.is_some() && self.lights_since.is_none() {
                    self.held = self.last_follower;
                }
                self.lights_since = lights_on_since;
                match self.lights_since {
                    Some(on) if t - on < self.reacting.reaction_time => self.held,
                    Some(on) if self.follower == Follower::IdmReacting => {
                        idm_with(tmin).min(self.reacting.most_acceleration(t - on))
                    }
                    _ => idm_with(tmin),
                }
            }
        };
        self.last_follower = a_follower;
        (
            within_speed_limit(a_leader, leader.v, m.max_speed, h),
            within_speed_limit(a_follower, follower.v, m.max_speed, h),
        )
    }

    fn table_gap_max(&self) -> f32 {
        self.table.axis_bounds(0).map_or(f32::INFINITY, |b| b.max)
    }

    fn stop_and_go(&mut self, t: f32, speed: f32, rng: &mut impl Rng) -> f32 {
        let (lmin, lmax) = self.model.leader;
        loop {
            match self.phase {
                Phase::Cruising if t >= self.phase_until => self.phase = Phase::Braking,
                Phase::Cruising => return 0.0,
                Phase::Braking if speed <= 0.0 => {
                    self.phase = Phase::Standing;
                    self.phase_until = t + rng.random_range(1.0..5.0);
                }
                Phase::Braking => return lmin,
                Phase::Standing if t >= self.phase_until => {
                    self.phase = Phase::PullingAway;
                    self.target_speed = rng.random_range(5.0..30.0f32).min(self.model.max_speed);
                    self.pull_away = rng.random_range(0.5..=1.0) * lmax;
                }
                Phase::Standing => return 0.0,
                Phase::PullingAway if speed >= self.target_speed => {
                    self.phase = Phase::Cruising;
                    self.phase_until = t + rng.random_range(2.0..8.0);
                }
                Phase::PullingAway => return self.pull_away,
            }
        }
    }
}
