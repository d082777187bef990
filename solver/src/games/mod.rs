//! The car-following games: dynamics, constraint, Hamiltonian and the players' optimal inputs.
//!
//! # Conventions
//! The value `V(z)` is the smallest constraint value `l` a trajectory from `z` ever reaches when
//! the ego maximises and the humans minimise (the paper's eq. 4). Its Hamiltonian is
//! `H(z, p) = max_u min_d p . f(z, u, d)`. Every game here is *separable*: the inputs enter `p . f`
//! in separate terms, so max-min equals min-max (Isaacs' condition holds) and each player's
//! optimum is found term by term, exactly, over its real input set.
//!
//! # Three-car games, state `z = (x_g1, v_g1, x_g2, v_g2)`
//! `x_g1' = v_g1`, `v_g1' = u1 - u2`, `x_g2' = v_g2`, `v_g2' = u2 - u3`, so with
//! `p = (p1, p2, p3, p4)`:
//!
//! `p . f = p1 v_g1 + p3 v_g2 + (p4 - p2) u2 + p2 u1 - p4 u3`.
//!
//! - Ego (maximises `(p4 - p2) u2`): `u2* = a_max` if `p4 - p2 > 0`, else `a_min` (paper eq. 6).
//! - Leader (minimises `p2 u1`): `u1* = a_min` if `p2 > 0`, else `a_max` (paper eq. 7).
//! - Baseline follower (minimises `-p4 u3`): `u3* = a_max` if `p4 > 0`, else `a_min` (eq. 8).
//! - IDM follower: `u3 = clip(g(z, T, v3))` with the time gap `T` (and, in the sound reading,
//!   the follower speed `v3`) adversarial. The adversary minimises `-p4 u3`, i.e. it *maximises*
//!   the follower's acceleration where `p4 > 0` and *minimises* it where `p4 < 0`. The IDM
//!   acceleration is non-increasing in `T` and in `v3` (see [`Idm::acceleration`]), so the
//!   optimum is exact and sits at a corner: `(T_min, v3_min)` where `p4 > 0` and
//!   `(T_max, v3_max)` where `p4 < 0`.
//!
//!   The paper's eq. 9 instead sets `T = clip(-v_g2 / (2 sqrt(ab)))` where `p4 > 0`: the `T`
//!   that zeroes the bracket `v3 T + v3 dv / (2 sqrt(ab))` if the approach rate were
//!   `dv = +v_g2`. With the paper's own convention `v_g2 = v_ego - v3`, the approach rate is
//!   `dv = v3 - v_ego = -v_g2`, and in any case the bracket enters `s*` through `max(0, .)`
//!   with slope `v3 >= 0` in `T`: `s*` is smallest (the follower's acceleration largest) at
//!   `T_min`, whatever `v_g2` is, and no interior `T` is ever strictly better. Likewise
//!   `max_T |2 sqrt(ab) T + v_g2|` in the other branch is not the minimiser of the acceleration
//!   when `v_g2 > 0` (the bracket is then negative and clipped to zero for small `T`). We use
//!   the derived corner solution; a unit test checks it against a brute-force sweep.
//!
//! # Two-car game, state `z = (x, v)`
//! `x' = v`, `v' = u1 - u2`: `p . f = p1 v - p2 u2 + p2 u1`, so `u2* = a_max` if `p2 < 0`.

pub use crate::engine::dynamics::{Dynamics, Vector};

mod idm;
mod rear;
mod three_car_baseline;
mod three_car_idm;
mod three_car_idm_speeds;
mod two_car;

pub use idm::{FollowerSpeedModel, Idm};
pub use rear::RearGame;
pub use three_car_baseline::ThreeCarBaseline;
pub use three_car_idm::ThreeCarIdm;
pub use three_car_idm_speeds::ThreeCarIdmSpeeds;
pub use two_car::TwoCar;

/// The optimal inputs of all players at one state for one co-state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimalInputs {
    /// The ego's acceleration `u2*`.
    pub ego: f32,
    /// The leader's acceleration `u1*` (the adversary's).
    pub leader: f32,
    /// The follower's acceleration `u3*` (absent in the two-car game).
    pub follower: Option<f32>,
    /// The IDM time gap the adversary picks (IDM game only).
    pub time_gap: Option<f32>,
    /// The follower speed the adversary picks or the nominal reading implies (IDM game only).
    pub follower_speed: Option<f32>,
}

/// Below this magnitude (s: metres of value per m/s of speed) the ego's switching function
/// is a tie: both inputs change `V` by less than 1 mm per m/s, under the table's quantization
/// on every grid here. The plots show ties apart; the policy bit still follows the sign (and
/// brakes at exactly zero).
pub const TIE_TOLERANCE: f32 = 1e-3;

/// What a car-following game adds to its [`Dynamics`]: the players' optimal inputs, and the
/// ego's switching function (the table's policy bit).
pub trait Game: Dynamics {
    /// All players' optimal inputs at `z` for co-state `p`.
    fn optimal_inputs(&self, z: &Vector, p: &Vector) -> OptimalInputs;
    /// The ego's switching function: the coefficient of its acceleration in `p . f` (the
    /// derivative of `V` along the ego's input, s). The ego accelerates where it is positive
    /// and brakes where it is negative; where it is zero (within [`TIE_TOLERANCE`]) both inputs
    /// are equally good to first order, a tie.
    fn ego_switching(&self, p: &Vector) -> f32;
    /// Whether the ego's optimal input is its maximum acceleration (the table's policy bit). A
    /// tie brakes.
    fn ego_accelerates(&self, p: &Vector) -> bool {
        self.ego_switching(p) > 0.0
    }
}

/// Bounds of one player's acceleration, m/s^2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accel {
    /// Lower bound (braking, negative).
    pub min: f32,
    /// Upper bound.
    pub max: f32,
}

impl Accel {
    /// The extreme that maximises `c * a`.
    #[inline(always)]
    fn argmax(self, c: f32) -> f32 {
        if c > 0.0 {
            self.max
        } else {
            self.min
        }
    }

    /// The extreme that minimises `c * a`.
    #[inline(always)]
    fn argmin(self, c: f32) -> f32 {
        if c > 0.0 {
            self.min
        } else {
            self.max
        }
    }

    fn from(b: table_format::Bounds) -> Self {
        Accel {
            min: b.min,
            max: b.max,
        }
    }

    /// The bounds a car at `speed` can really apply inside `[0, max_speed]`.
    #[inline(always)]
    fn at_speed(self, speed: f32, max_speed: f32) -> Accel {
        Accel {
            min: if speed <= 0.0 {
                self.min.max(0.0)
            } else {
                self.min
            },
            max: if speed >= max_speed {
                self.max.min(0.0)
            } else {
                self.max
            },
        }
    }

    /// The largest magnitude in the bounds.
    #[inline(always)]
    fn magnitude(self) -> f32 {
        self.min.abs().max(self.max.abs())
    }
}

/// The row form of the three-car Lax-Friedrichs rate, shared by both follower models:
/// `follower(v_g2, p4)` is the follower's worst-case acceleration.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn three_car_row(
    ego: Accel,
    leader: Accel,
    z: &Vector,
    last: &[f32],
    pbar: &[&[f32]],
    half_jump: &[&[f32]],
    local: bool,
    alpha: &Vector,
    rate: &mut [f32],
    follower: impl Fn(f32, f32) -> f32,
) {
    let n = rate.len();
    let v1 = z[1];
    let v2 = &last[..n];
    let [p0, p1, p2, p3] = [0, 1, 2, 3].map(|k| &pbar[k][..n]);
    let [h0, h1, h2, h3] = [0, 1, 2, 3].map(|k| &half_jump[k][..n]);
    let a0 = if local { v1.abs() } else { alpha[0] };
    let (a1, a3) = (alpha[1], alpha[3]);
    for c in 0..n {
        let u2 = ego.argmax(p3[c] - p1[c]);
        let u1 = leader.argmin(p1[c]);
        let u3 = follower(v2[c], p3[c]);
        let a2 = if local { v2[c].abs() } else { alpha[2] };
        let h = p0[c] * v1
            + p2[c] * v2[c]
            + p1[c] * (u1 - u2)
            + p3[c] * (u2 - u3)
            + a0 * h0[c]
            + a1 * h1[c]
            + a2 * h2[c]
            + a3 * h3[c];
        rate[c] = h;
    }
}

/// Evaluates `$body` with `$g` bound to the concrete game inside `$game` (an [`AnyGame`]),
/// so that generic engine code is monomorphised for each game. The one place, with
/// [`AnyGame`] itself, that lists the games: a new game is added here and nowhere else.
macro_rules! with_game {
    ($game:expr, $g:ident => $body:expr) => {
        match $game {
            $crate::games::AnyGame::TwoCar($g) => $body,
            $crate::games::AnyGame::Baseline($g) => $body,
            $crate::games::AnyGame::Idm($g) => $body,
            $crate::games::AnyGame::IdmSpeeds($g) => $body,
            $crate::games::AnyGame::Rear($g) => $body,
        }
    };
}
pub(crate) use with_game;

/// Builds the engine's dynamics from a table header's game description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AnyGame {
    /// See [`TwoCar`].
    TwoCar(TwoCar),
    /// See [`ThreeCarBaseline`].
    Baseline(ThreeCarBaseline),
    /// See [`ThreeCarIdm`].
    Idm(ThreeCarIdm),
    /// See [`ThreeCarIdmSpeeds`].
    IdmSpeeds(ThreeCarIdmSpeeds),
    /// See [`RearGame`].
    Rear(RearGame),
}

impl AnyGame {
    /// The solver's model of `game` with constraint `l = min(gaps) - min_gap`.
    pub fn from_description(game: &table_format::Game, min_gap: f32) -> Self {
        use table_format::Game as G;
        match *game {
            G::TwoCar { ego, leader } => AnyGame::TwoCar(TwoCar {
                ego: Accel::from(ego),
                leader: Accel::from(leader),
                min_gap,
            }),
            G::ThreeCarBaseline {
                ego,
                leader,
                follower,
            } => AnyGame::Baseline(ThreeCarBaseline {
                ego: Accel::from(ego),
                leader: Accel::from(leader),
                follower: Accel::from(follower),
                min_gap,
            }),
            G::ThreeCarIdm {
                ego,
                leader,
                follower_clip,
                idm,
                time_gap,
                follower_speed,
            } => AnyGame::Idm(ThreeCarIdm {
                ego: Accel::from(ego),
                leader: Accel::from(leader),
                follower_clip: Accel::from(follower_clip),
                idm,
                time_gap: Accel::from(time_gap),
                follower_speed: match follower_speed {
                    table_format::FollowerSpeed::NominalEgoSpeed { ego_speed } => {
                        FollowerSpeedModel::NominalEgoSpeed { ego_speed }
                    }
                    table_format::FollowerSpeed::Adversarial {
                        min_ego_speed,
                        max_speed,
                    } => FollowerSpeedModel::Adversarial {
                        min_ego_speed,
                        max_speed,
                    },
                },
                min_gap,
            }),
            G::ThreeCarIdmSpeeds {
                ego,
                leader,
                follower_clip,
                idm,
                time_gap,
                max_speed,
            } => AnyGame::IdmSpeeds(ThreeCarIdmSpeeds {
                ego: Accel::from(ego),
                leader: Accel::from(leader),
                follower_clip: Accel::from(follower_clip),
                idm,
                time_gap: Accel::from(time_gap),
                max_speed,
                min_gap,
            }),
            G::ThreeCarSplit {
                ego,
                follower,
                max_speed,
                ..
            } => AnyGame::Rear(RearGame {
                ego: Accel::from(ego),
                follower,
                max_speed,
                min_gap,
                follower_robustness: 0.0,
            }),
        }
    }

    /// The game as a trait object (for code off the hot path).
    pub fn dynamics(&self) -> &dyn Game {
        with_game!(self, g => g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn idm() -> Idm {
        Idm {
            max_acceleration: 1.0,
            comfortable_deceleration: 1.5,
            desired_speed: 33.3,
            exponent: 4,
            jam_distance: 2.0,
        }
    }

    #[test]
    fn idm_is_non_increasing_in_time_gap_and_speed() {
        let m = idm();
        for &gap in &[1.0f32, 5.0, 20.0, 60.0] {
            for &dv in &[-5.0f32, 0.0, 3.0, 8.0] {
                for iv in 0..30 {
                    let v = iv as f32;
                    let mut prev = f32::INFINITY;
                    for it in 0..=20 {
                        let t = 0.5 + 0.1 * it as f32;
                        let g = m.acceleration(v, dv, gap, t);
                        assert!(g <= prev + 1e-5, "T monotonicity at v={v} dv={dv} s={gap}");
                        prev = g;
                    }
                    let g_here = m.acceleration(v, dv, gap, 1.5);
                    let g_faster = m.acceleration(v + 1.0, dv, gap, 1.5);
                    assert!(g_faster <= g_here + 1e-5, "v monotonicity");
                }
            }
        }
    }

    #[test]
    fn idm_free_road_and_equilibrium() {
        let m = idm();
        // Standing still, far from anything: full acceleration.
        assert!((m.acceleration(0.0, 0.0, 1e9, 1.5) - 1.0).abs() < 1e-6);
        // At the desired speed on a free road: zero.
        assert!(m.acceleration(33.3, 0.0, 1e9, 1.5).abs() < 1e-5);
        // Standing exactly at the jam distance: equilibrium, zero.
        assert!(m.acceleration(0.0, 0.0, 2.0, 1.5).abs() < 1e-6);
        // Standing at half the jam distance: 1 - 4 = -3 a.
        assert!((m.acceleration(0.0, 0.0, 1.0, 1.5) + 3.0).abs() < 1e-6);
    }

    #[test]
    fn the_idm_adversary_is_optimal_over_a_fine_sweep() {
        let game = ThreeCarIdm {
            ego: Accel {
                min: -2.0,
                max: 2.0,
            },
            leader: Accel {
                min: -1.5,
                max: 1.5,
            },
            follower_clip: Accel {
                min: -1.5,
                max: 1.5,
            },
            idm: idm(),
            time_gap: Accel { min: 1.0, max: 2.0 },
            follower_speed: FollowerSpeedModel::Adversarial {
                min_ego_speed: 0.0,
                max_speed: 40.0,
            },
            min_gap: 0.0,
        };
        for &(x2, v2) in &[(3.0f32, -4.0f32), (10.0, 2.0), (25.0, -8.0), (40.0, 5.0)] {
            for &p4 in &[-1.0f32, 0.7] {
                let z = [20.0, 0.0, x2, v2, 0.0];
                let p = [0.1, 0.2, 0.3, p4, 0.0];
                let h = game.hamiltonian(&z, &p);
                // Brute force: the adversary minimises over a fine (T, v3) grid.
                let (lo, hi) = game.follower_speed.range(v2);
                let mut best = f32::INFINITY;
                for it in 0..=50 {
                    let t = 1.0 + it as f32 / 50.0;
                    for iv in 0..=50 {
                        let v3 = lo + (hi - lo) * iv as f32 / 50.0;
                        let u3 = game.idm.acceleration(v3, -v2, x2, t).clamp(-1.5, 1.5);
                        let u2 = game.ego.argmax(p[3] - p[1]);
                        let u1 = game.leader.argmin(p[1]);
                        let val = p[0] * z[1] + p[2] * z[3] + p[1] * (u1 - u2) + p[3] * (u2 - u3);
                        best = best.min(val);
                    }
                }
                assert!((h - best).abs() < 1e-4, "H {h} vs brute force {best}");
            }
        }
    }

    #[test]
    fn the_five_d_game_is_exact_over_a_brute_force_sweep_and_keeps_speeds_physical() {
        let human = Accel {
            min: -1.5,
            max: 1.5,
        };
        let game = ThreeCarIdmSpeeds {
            ego: Accel {
                min: -2.0,
                max: 2.0,
            },
            leader: human,
            follower_clip: human,
            idm: Idm {
                jam_distance: 2.0,
                ..idm()
            },
            time_gap: Accel { min: 1.0, max: 2.0 },
            max_speed: 35.0,
            min_gap: 0.0,
        };
        // (x_g1, v1, x_g2, v3, v_ego), including speeds at both faces and states where the
        // follower's IDM is not clipped, so that the time gap matters.
        let states = [
            [30.0f32, 20.0, 60.0, 20.0, 20.0],
            [25.0, 15.0, 45.0, 12.0, 14.0],
            [20.0, 10.0, 12.0, 14.0, 10.0],
            [5.0, 0.0, 30.0, 0.0, 3.0],
            [40.0, 35.0, 8.0, 20.0, 0.0],
            [15.0, 12.0, 25.0, 35.0, 35.0],
        ];
        for z in states {
            for p in [[0.1f32, 0.2, 0.3, -0.8, 0.5], [0.4, -0.2, 0.1, 0.7, -0.5]] {
                let h = game.hamiltonian(&z, &p);
                // Brute force over every player's real input set: the ego maximises, the
                // humans minimise, inputs that would push a speed out of [0, 35] excluded.
                let feasible = |a: f32, v: f32| (v > 0.0 || a >= 0.0) && (v < 35.0 || a <= 0.0);
                let sweep =
                    |b: Accel| (0..=60).map(move |i| b.min + (b.max - b.min) * i as f32 / 60.0);
                let ego_best = sweep(game.ego)
                    .filter(|&u| feasible(u, z[4]))
                    .map(|u| p[4] * u)
                    .fold(f32::NEG_INFINITY, f32::max);
                let leader_worst = sweep(human)
                    .filter(|&u| feasible(u, z[1]))
                    .map(|u| p[1] * u)
                    .fold(f32::INFINITY, f32::min);
                let follower_worst = (0..=100)
                    .map(|i| {
                        let t = 1.0 + i as f32 / 100.0;
                        let g = game.idm.acceleration(z[3], z[3] - z[4], z[2], t);
                        let g = g.clamp(-1.5, 1.5);
                        let g = if z[3] <= 0.0 { g.max(0.0) } else { g };
                        let g = if z[3] >= 35.0 { g.min(0.0) } else { g };
                        p[3] * g
                    })
                    .fold(f32::INFINITY, f32::min);
                let brute = p[0] * (z[1] - z[4])
                    + p[2] * (z[4] - z[3])
                    + ego_best
                    + leader_worst
                    + follower_worst;
                assert!((h - brute).abs() < 1e-4, "z {z:?} p {p:?}: {h} vs {brute}");
                let inputs = game.optimal_inputs(&z, &p);
                assert!(
                    z[1] > 0.0 || inputs.leader >= 0.0,
                    "a stopped leader brakes"
                );
                assert!(z[4] > 0.0 || inputs.ego >= 0.0, "a stopped ego brakes");
                assert!(
                    z[4] < 35.0 || inputs.ego <= 0.0,
                    "the ego speeds up past v_max"
                );
            }
        }
    }
}
