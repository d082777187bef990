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

use crate::grid::MAX_DIMS;

mod rear_idm;
pub use rear_idm::RearIdm;

/// A state or co-state with room for every supported dimension.
pub type Vector = [f32; MAX_DIMS];

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

/// A differential game the level-set engine can solve.
pub trait Dynamics: Sync {
    /// The number of state axes.
    fn dims(&self) -> usize;
    /// The constraint `l(z)`; `l >= 0` is the allowed set.
    fn constraint(&self, z: &Vector) -> f32;
    /// `H(z, p) = max_u min_d p . f(z, u, d)`.
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32;
    /// Per axis a bound `alpha_i(z) >= max_{u,d} |f_i(z, u, d)|` for the Lax-Friedrichs
    /// dissipation.
    fn dissipation(&self, z: &Vector, alpha: &mut Vector);
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
    /// Whether `V` is non-decreasing along `axis`, so that the pessimistic and optimistic ghost
    /// values of [`crate::hji::Boundary`] bound the true ones there. Axes where it is not (or
    /// where nothing leaves the grid) take extrapolated ghosts. Default: every axis.
    fn monotone_axis(&self, _axis: usize) -> bool {
        true
    }

    /// The Lax-Friedrichs numerical Hamiltonian `H(z, pbar) + sum_k alpha_k(z) half_jump_k` along a row
    /// of the last axis: `z` holds the row's fixed coordinates, `last[c]` the last one, and
    /// `pbar[k][c]`, `half_jump[k][c]` the central gradient and `(p+ - p-)/2`. `alpha` is the
    /// global dissipation, used unless `local`. The games override it with straight-line code
    /// that the compiler vectorises; this default is the scalar reference.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn lax_friedrichs_row(
        &self,
        z: &Vector,
        last: &[f32],
        pbar: &[&[f32]],
        half_jump: &[&[f32]],
        local: bool,
        alpha: &Vector,
        rate: &mut [f32],
    ) {
        let d = self.dims();
        for (c, r) in rate.iter_mut().enumerate() {
            let mut zz = *z;
            zz[d - 1] = last[c];
            let mut a = *alpha;
            if local {
                self.dissipation(&zz, &mut a);
            }
            let mut p = [0f32; MAX_DIMS];
            let mut diss = 0.0;
            for k in 0..d {
                p[k] = pbar[k][c];
                diss += a[k] * half_jump[k][c];
            }
            *r = self.hamiltonian(&zz, &p) + diss;
        }
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
}

/// The two-car game (paper Fig. 1a).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoCar {
    /// Ego acceleration bounds.
    pub ego: Accel,
    /// Leader acceleration bounds.
    pub leader: Accel,
    /// `l(z) = x - min_gap`.
    pub min_gap: f32,
}

impl Dynamics for TwoCar {
    fn dims(&self) -> usize {
        2
    }

    fn constraint(&self, z: &Vector) -> f32 {
        z[0] - self.min_gap
    }

    #[inline(always)]
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32 {
        let u2 = self.ego.argmax(-p[1]);
        let u1 = self.leader.argmin(p[1]);
        p[0] * z[1] + p[1] * (u1 - u2)
    }

    #[inline(always)]
    fn dissipation(&self, z: &Vector, alpha: &mut Vector) {
        alpha[0] = z[1].abs();
        alpha[1] = (self.leader.max - self.ego.min).max(self.ego.max - self.leader.min);
    }

    fn optimal_inputs(&self, _z: &Vector, p: &Vector) -> OptimalInputs {
        OptimalInputs {
            ego: self.ego.argmax(-p[1]),
            leader: self.leader.argmin(p[1]),
            follower: None,
            time_gap: None,
            follower_speed: None,
        }
    }

    fn ego_switching(&self, p: &Vector) -> f32 {
        -p[1]
    }

    #[inline(always)]
    fn lax_friedrichs_row(
        &self,
        _z: &Vector,
        last: &[f32],
        pbar: &[&[f32]],
        half_jump: &[&[f32]],
        local: bool,
        alpha: &Vector,
        rate: &mut [f32],
    ) {
        // The last axis is the relative speed v; the row's fixed coordinate is the gap.
        let n = rate.len();
        let (v, p0, p1, h0, h1) = (
            &last[..n],
            &pbar[0][..n],
            &pbar[1][..n],
            &half_jump[0][..n],
            &half_jump[1][..n],
        );
        let a1 = alpha[1];
        for c in 0..n {
            let u2 = self.ego.argmax(-p1[c]);
            let u1 = self.leader.argmin(p1[c]);
            let a0 = if local { v[c].abs() } else { alpha[0] };
            let h = p0[c] * v[c] + p1[c] * (u1 - u2) + a0 * h0[c] + a1 * h1[c];
            rate[c] = h;
        }
    }
}

/// The three-car game where the follower's acceleration is any value within bounds (the
/// paper's baseline).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreeCarBaseline {
    /// Ego acceleration bounds.
    pub ego: Accel,
    /// Leader acceleration bounds.
    pub leader: Accel,
    /// Follower acceleration bounds.
    pub follower: Accel,
    /// `l(z) = min(x_g1, x_g2) - min_gap`.
    pub min_gap: f32,
}

impl Dynamics for ThreeCarBaseline {
    fn dims(&self) -> usize {
        4
    }

    fn constraint(&self, z: &Vector) -> f32 {
        z[0].min(z[2]) - self.min_gap
    }

    #[inline(always)]
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32 {
        let u2 = self.ego.argmax(p[3] - p[1]);
        let u1 = self.leader.argmin(p[1]);
        let u3 = self.follower.argmin(-p[3]);
        p[0] * z[1] + p[2] * z[3] + p[1] * (u1 - u2) + p[3] * (u2 - u3)
    }

    #[inline(always)]
    fn dissipation(&self, z: &Vector, alpha: &mut Vector) {
        alpha[0] = z[1].abs();
        alpha[1] = (self.leader.max - self.ego.min).max(self.ego.max - self.leader.min);
        alpha[2] = z[3].abs();
        alpha[3] = (self.ego.max - self.follower.min).max(self.follower.max - self.ego.min);
    }

    fn optimal_inputs(&self, _z: &Vector, p: &Vector) -> OptimalInputs {
        OptimalInputs {
            ego: self.ego.argmax(p[3] - p[1]),
            leader: self.leader.argmin(p[1]),
            follower: Some(self.follower.argmin(-p[3])),
            time_gap: None,
            follower_speed: None,
        }
    }

    fn ego_switching(&self, p: &Vector) -> f32 {
        p[3] - p[1]
    }
    #[inline(always)]
    fn lax_friedrichs_row(
        &self,
        z: &Vector,
        last: &[f32],
        pbar: &[&[f32]],
        half_jump: &[&[f32]],
        local: bool,
        alpha: &Vector,
        rate: &mut [f32],
    ) {
        // The last axis is v_g2; x_g1, v_g1 and x_g2 are fixed along the row.
        let follower = self.follower;
        three_car_row(
            self.ego,
            self.leader,
            z,
            last,
            pbar,
            half_jump,
            local,
            alpha,
            rate,
            |_, p4| follower.argmin(-p4),
        );
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

/// The Intelligent Driver Model (Treiber, Hennecke & Helbing, 2000).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Idm {
    /// `a`, m/s^2.
    pub max_acceleration: f32,
    /// `b`, m/s^2 (positive).
    pub comfortable_deceleration: f32,
    /// `v0`, m/s.
    pub desired_speed: f32,
    /// `delta`.
    pub exponent: i32,
    /// `s0`, m.
    pub jam_distance: f32,
}

impl Idm {
    /// Treiber & Kesting's highway parameters (*Traffic Flow Dynamics*, Table 11.2), the
    /// config defaults: `a` 1.0 m/s^2, `b` 1.5 m/s^2, `v0` 33.3 m/s, `delta` 4, `s0` 2 m.
    pub const HIGHWAY: Idm = Idm {
        max_acceleration: 1.0,
        comfortable_deceleration: 1.5,
        desired_speed: 33.3,
        exponent: 4,
        jam_distance: 2.0,
    };

    /// The IDM acceleration of a vehicle at speed `speed` (>= 0), `gap` metres behind its
    /// leader, approaching it at `approach_rate = speed - leader_speed`, with desired time gap
    /// `time_gap`:
    ///
    /// `g = a (1 - (v / v0)^delta - (s* / s)^2)`,
    /// `s* = s0 + max(0, v T + v dv / (2 sqrt(a b)))`.
    ///
    /// For `v >= 0`, `g` is non-increasing in `T` (`s*` grows with `T` at rate `v >= 0` where the
    /// max is active, and `(s*/s)^2` grows with `s* >= 0`) and non-increasing in `v` at a fixed
    /// approach rate (`(v/v0)^delta` grows, and `s* - s0 = max(0, v (T + dv / (2 sqrt(ab))))`
    /// is non-decreasing in `v`). The exponent is applied with `powi`, exact for integers.
    /// A gap of zero or less with a positive desired gap gives `-inf` (the caller clips).
    #[inline(always)]
    pub fn acceleration(&self, speed: f32, approach_rate: f32, gap: f32, time_gap: f32) -> f32 {
        let a = self.max_acceleration;
        let ab2 = 2.0 * (a * self.comfortable_deceleration).sqrt();
        let desired = self.jam_distance + (speed * time_gap + speed * approach_rate / ab2).max(0.0);
        let interaction = if gap > 0.0 {
            let r = desired / gap;
            r * r
        } else if desired > 0.0 {
            f32::INFINITY
        } else {
            0.0
        };
        a * (1.0 - (speed / self.desired_speed).powi(self.exponent) - interaction)
    }
}

impl From<table_format::IdmParameters> for Idm {
    fn from(idm: table_format::IdmParameters) -> Self {
        Idm {
            max_acceleration: idm.max_acceleration,
            comfortable_deceleration: idm.comfortable_deceleration,
            desired_speed: idm.desired_speed,
            exponent: i32::from(idm.exponent),
            jam_distance: idm.jam_distance,
        }
    }
}

/// How the IDM game gets the follower's absolute speed `v3 = v_ego - v_g2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FollowerSpeedModel {
    /// The paper's reading: the ego drives at `ego_speed`, so `v3 = max(0, ego_speed - v_g2)`.
    NominalEgoSpeed {
        /// Assumed ego speed, m/s.
        ego_speed: f32,
    },
    /// The sound reading: `v3` is adversarial over all speeds consistent with the state and an
    /// ego speed in `[min_ego_speed, max_speed]`: `v3 >= 0`, `v3 <= max_speed`, and the ego's
    /// speed `v3 + v_g2` in that band, i.e.
    /// `max(0, min_ego_speed - v_g2) <= v3 <= min(max_speed, max_speed - v_g2)`.
    /// `min_ego_speed = 0` assumes nothing; a positive value is an operating-range assumption.
    Adversarial {
        /// Lowest ego speed assumed, m/s.
        min_ego_speed: f32,
        /// Largest speed of any vehicle, m/s.
        max_speed: f32,
    },
}

impl FollowerSpeedModel {
    /// The range of follower speeds consistent with `v_g2`.
    #[inline(always)]
    pub fn range(&self, v_g2: f32) -> (f32, f32) {
        match *self {
            FollowerSpeedModel::NominalEgoSpeed { ego_speed } => {
                let v3 = (ego_speed - v_g2).max(0.0);
                (v3, v3)
            }
            FollowerSpeedModel::Adversarial {
                min_ego_speed,
                max_speed,
            } => {
                let lo = (min_ego_speed - v_g2).max(0.0).min(max_speed);
                let hi = max_speed.min(max_speed - v_g2).max(lo);
                (lo, hi)
            }
        }
    }
}

/// The three-car game with an IDM follower whose desired time gap (the paper's "safe reaction
/// time") is adversarial in `[T_min, T_max]` (the paper's alternative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreeCarIdm {
    /// Ego acceleration bounds.
    pub ego: Accel,
    /// Leader acceleration bounds.
    pub leader: Accel,
    /// The follower's IDM output is clipped to these bounds.
    pub follower_clip: Accel,
    /// The follower's IDM.
    pub idm: Idm,
    /// `[T_min, T_max]`, s.
    pub time_gap: Accel,
    /// How `v3` is obtained.
    pub follower_speed: FollowerSpeedModel,
    /// `l(z) = min(x_g1, x_g2) - min_gap`.
    pub min_gap: f32,
}

impl ThreeCarIdm {
    /// The follower's clipped IDM acceleration and the adversary's `(T, v3)` when the
    /// adversary wants the follower's acceleration high (`maximise`) or low.
    #[inline(always)]
    fn follower(&self, z: &Vector, maximise: bool) -> (f32, f32, f32) {
        let (v_lo, v_hi) = self.follower_speed.range(z[3]);
        let (t, v3) = if maximise {
            (self.time_gap.min, v_lo)
        } else {
            (self.time_gap.max, v_hi)
        };
        let g = self.idm.acceleration(v3, -z[3], z[2], t);
        let u3 = g.clamp(self.follower_clip.min, self.follower_clip.max);
        (u3, t, v3)
    }
}

impl Dynamics for ThreeCarIdm {
    fn dims(&self) -> usize {
        4
    }

    fn constraint(&self, z: &Vector) -> f32 {
        z[0].min(z[2]) - self.min_gap
    }

    #[inline(always)]
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32 {
        let u2 = self.ego.argmax(p[3] - p[1]);
        let u1 = self.leader.argmin(p[1]);
        let (u3, _, _) = self.follower(z, p[3] > 0.0);
        p[0] * z[1] + p[2] * z[3] + p[1] * (u1 - u2) + p[3] * (u2 - u3)
    }

    #[inline(always)]
    fn dissipation(&self, z: &Vector, alpha: &mut Vector) {
        alpha[0] = z[1].abs();
        alpha[1] = (self.leader.max - self.ego.min).max(self.ego.max - self.leader.min);
        alpha[2] = z[3].abs();
        alpha[3] =
            (self.ego.max - self.follower_clip.min).max(self.follower_clip.max - self.ego.min);
    }

    fn optimal_inputs(&self, z: &Vector, p: &Vector) -> OptimalInputs {
        let (u3, t, v3) = self.follower(z, p[3] > 0.0);
        OptimalInputs {
            ego: self.ego.argmax(p[3] - p[1]),
            leader: self.leader.argmin(p[1]),
            follower: Some(u3),
            time_gap: Some(t),
            follower_speed: Some(v3),
        }
    }

    fn ego_switching(&self, p: &Vector) -> f32 {
        p[3] - p[1]
    }

    #[inline(always)]
    fn lax_friedrichs_row(
        &self,
        z: &Vector,
        last: &[f32],
        pbar: &[&[f32]],
        half_jump: &[&[f32]],
        local: bool,
        alpha: &Vector,
        rate: &mut [f32],
    ) {
        three_car_row(
            self.ego,
            self.leader,
            z,
            last,
            pbar,
            half_jump,
            local,
            alpha,
            rate,
            |v2, p4| {
                let mut zz = *z;
                zz[3] = v2;
                self.follower(&zz, p4 > 0.0).0
            },
        );
    }
}

/// The three-car IDM game in absolute speeds, `z = (x_g1, v1, x_g2, v3, v_ego)` (five axes).
///
/// # Why a fifth axis
/// The IDM follower's acceleration depends on its own speed `v3`, which the paper's 4-D relative
/// state does not contain: any fixed reading of `v3` is an assumption (the table is wrong when the
/// ego's speed differs), and the sound 4-D reading (`v3` adversarial over everything consistent
/// with `v_g2`) lets `v3` jump and empties the safe set. With the three absolute speeds as
/// states, the follower's model is exact, and speeds can be kept physical: every speed lies in
/// `[0, v_max]`, so a braking leader stops instead of braking for ever. The game then has a
/// stationary value (all three cars can come to rest), which a receding-horizon controller
/// needs: a finite-horizon value certifies only as far as its horizon.
///
/// # Dynamics and Hamiltonian
/// `x_g1' = v1 - v_ego`, `v1' = u1`, `x_g2' = v_ego - v3`, `v3' = u3`, `v_ego' = u2`, so with
/// `p = (p1, p2, p3, p4, p5)`:
///
/// `p . f = p1 (v1 - v_ego) + p3 (v_ego - v3) + p2 u1 + p4 u3 + p5 u2`.
///
/// Speed limits are input constraints: a car at rest cannot brake, one at `v_max` cannot speed
/// up, so at `v = 0` the input set is `[max(0, a_min), a_max]` and at `v = v_max` it is
/// `[a_min, min(0, a_max)]` (exact at the grid faces, where these speeds live; no smoothing,
/// which would let a "stopped" leader creep backwards or forwards).
/// - Ego (maximises `p5 u2`): `u2* = a_max` if `p5 > 0`, else `a_min` (within the speed
///   limits). By the chain rule this is the paper's eq. 6: with `v_g1 = v1 - v_ego` and
///   `v_g2 = v_ego - v3`, `dV/dv_ego` at fixed `v1, v3` is `dV/dv_g2 - dV/dv_g1`.
/// - Leader (minimises `p2 u1`): `u1* = a_min` if `p2 > 0`, else `a_max`.
/// - Follower: `u3 = clip(g(v3, v3 - v_ego, x_g2, T))`, `T` adversarial in `[T_min, T_max]`.
///   The adversary minimises `p4 u3`; `g` is non-increasing in `T` and clipping is monotone,
///   so `T* = T_max` (least acceleration) where `p4 > 0` and `T_min` where `p4 <= 0`. Here
///   `v3` is the true follower speed, so no other choice is left to the adversary.
///
/// # Boundary
/// Nothing leaves the grid through a speed face (the input constraints above point the flow
/// inwards or along it), so those faces take extrapolated ghosts whatever the configured
/// boundary; the gap axes keep the configured (pessimistic or optimistic) ghosts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreeCarIdmSpeeds {
    /// Ego acceleration bounds.
    pub ego: Accel,
    /// Leader acceleration bounds.
    pub leader: Accel,
    /// The follower's IDM output is clipped to these bounds.
    pub follower_clip: Accel,
    /// The follower's IDM.
    pub idm: Idm,
    /// `[T_min, T_max]`, s.
    pub time_gap: Accel,
    /// The largest speed of any vehicle, m/s.
    pub max_speed: f32,
    /// `l(z) = min(x_g1, x_g2) - min_gap`.
    pub min_gap: f32,
}

impl Accel {
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

/// The IDM follower's acceleration at speed `v3` behind an ego at `ve`, `gap` metres ahead,
/// for time gap `t`: clipped to `clip`, within the speed limits `[0, max_speed]`. Shared by
/// every game in absolute speeds.
#[inline(always)]
fn clipped_idm(idm: &Idm, clip: Accel, max_speed: f32, v3: f32, ve: f32, gap: f32, t: f32) -> f32 {
    let g = idm.acceleration(v3.max(0.0), v3 - ve, gap, t);
    let clip = clip.at_speed(v3, max_speed);
    g.clamp(clip.min, clip.max)
}

/// The time gap an adversary minimising `p u3` picks: the IDM acceleration is non-increasing
/// in `T`, so `T_max` where `p > 0` and `T_min` otherwise.
#[inline(always)]
fn time_gap_against(time_gap: Accel, p: f32) -> f32 {
    if p > 0.0 {
        time_gap.max
    } else {
        time_gap.min
    }
}

impl ThreeCarIdmSpeeds {
    /// The follower's clipped IDM acceleration, within its speed limits, at follower speed
    /// `v3`, ego speed `ve` and gap `gap`, for time gap `t`.
    #[inline(always)]
    pub fn follower_acceleration(&self, v3: f32, ve: f32, gap: f32, t: f32) -> f32 {
        clipped_idm(
            &self.idm,
            self.follower_clip,
            self.max_speed,
            v3,
            ve,
            gap,
            t,
        )
    }

    /// The adversary's time gap for co-state component `p4` (on `v3`).
    #[inline(always)]
    pub fn adversarial_time_gap(&self, p4: f32) -> f32 {
        time_gap_against(self.time_gap, p4)
    }
}

impl Dynamics for ThreeCarIdmSpeeds {
    fn dims(&self) -> usize {
        5
    }

    fn constraint(&self, z: &Vector) -> f32 {
        z[0].min(z[2]) - self.min_gap
    }

    fn monotone_axis(&self, axis: usize) -> bool {
        axis == 0 || axis == 2
    }

    #[inline(always)]
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32 {
        let vm = self.max_speed;
        let u1 = self.leader.at_speed(z[1], vm).argmin(p[1]);
        let u2 = self.ego.at_speed(z[4], vm).argmax(p[4]);
        let u3 = self.follower_acceleration(z[3], z[4], z[2], self.adversarial_time_gap(p[3]));
        p[0] * (z[1] - z[4]) + p[2] * (z[4] - z[3]) + p[1] * u1 + p[3] * u3 + p[4] * u2
    }

    #[inline(always)]
    fn dissipation(&self, z: &Vector, alpha: &mut Vector) {
        let vm = self.max_speed;
        alpha[0] = (z[1] - z[4]).abs();
        alpha[1] = self.leader.at_speed(z[1], vm).magnitude();
        alpha[2] = (z[4] - z[3]).abs();
        alpha[3] = self.follower_clip.at_speed(z[3], vm).magnitude();
        alpha[4] = self.ego.at_speed(z[4], vm).magnitude();
    }

    fn optimal_inputs(&self, z: &Vector, p: &Vector) -> OptimalInputs {
        let vm = self.max_speed;
        let t = self.adversarial_time_gap(p[3]);
        OptimalInputs {
            ego: self.ego.at_speed(z[4], vm).argmax(p[4]),
            leader: self.leader.at_speed(z[1], vm).argmin(p[1]),
            follower: Some(self.follower_acceleration(z[3], z[4], z[2], t)),
            time_gap: Some(t),
            follower_speed: Some(z[3]),
        }
    }

    fn ego_switching(&self, p: &Vector) -> f32 {
        p[4]
    }

    #[inline(always)]
    fn lax_friedrichs_row(
        &self,
        z: &Vector,
        last: &[f32],
        pbar: &[&[f32]],
        half_jump: &[&[f32]],
        local: bool,
        alpha: &Vector,
        rate: &mut [f32],
    ) {
        let n = rate.len();
        let vm = self.max_speed;
        let (x2, v1, v3) = (z[2], z[1], z[3]);
        let ve = &last[..n];
        let [p0, p1, p2, p3, p4] = [0, 1, 2, 3, 4].map(|k| &pbar[k][..n]);
        let [h0, h1, h2, h3, h4] = [0, 1, 2, 3, 4].map(|k| &half_jump[k][..n]);
        let leader = self.leader.at_speed(v1, vm);
        let (a1, a3) = if local {
            (
                leader.magnitude(),
                self.follower_clip.at_speed(v3, vm).magnitude(),
            )
        } else {
            (alpha[1], alpha[3])
        };
        for c in 0..n {
            let ego = self.ego.at_speed(ve[c], vm);
            let u2 = ego.argmax(p4[c]);
            let u1 = leader.argmin(p1[c]);
            let t = self.adversarial_time_gap(p3[c]);
            let u3 = self.follower_acceleration(v3, ve[c], x2, t);
            let (a0, a2, a4) = if local {
                ((v1 - ve[c]).abs(), (ve[c] - v3).abs(), ego.magnitude())
            } else {
                (alpha[0], alpha[2], alpha[4])
            };
            let h = p0[c] * (v1 - ve[c])
                + p2[c] * (ve[c] - v3)
                + p1[c] * u1
                + p3[c] * u3
                + p4[c] * u2
                + a0 * h0[c]
                + a1 * h1[c]
                + a2 * h2[c]
                + a3 * h3[c]
                + a4 * h4[c];
            rate[c] = h;
        }
    }
}

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
    /// See [`RearIdm`].
    Rear(RearIdm),
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
                idm: Idm::from(idm),
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
                idm: Idm::from(idm),
                time_gap: Accel::from(time_gap),
                max_speed,
                min_gap,
            }),
            G::ThreeCarSplit {
                ego,
                follower_clip,
                idm,
                time_gap,
                max_speed,
                ..
            } => AnyGame::Rear(RearIdm {
                ego: Accel::from(ego),
                follower_clip: Accel::from(follower_clip),
                idm: Idm::from(idm),
                time_gap: Accel::from(time_gap),
                max_speed,
                min_gap,
                follower_robustness: 0.0,
            }),
        }
    }

    /// The dynamics as a trait object (for code off the hot path).
    pub fn dynamics(&self) -> &dyn Dynamics {
        match self {
            AnyGame::TwoCar(g) => g,
            AnyGame::Baseline(g) => g,
            AnyGame::Idm(g) => g,
            AnyGame::IdmSpeeds(g) => g,
            AnyGame::Rear(g) => g,
        }
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
