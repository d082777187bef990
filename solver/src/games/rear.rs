//! The rear game: a follower, by its model ([`FollowerModel`]: the IDM with an adversarial
//! time gap), behind an ego whose braking is bounded.
//!
//! # Why this game exists
//! The three-car game in absolute speeds has the state
//! `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`. Its stationary value is
//! at most the follower's jam distance `s0` everywhere (all three cars can stop, and the IDM
//! follower then closes to `s0` behind the ego), so a certificate needs the value resolved to a
//! fraction of `s0` over five axes: far beyond a table that fits a microcontroller. The ego's one
//! input couples the two gaps only through *how hard it brakes*: braking protects the front gap
//! and endangers the rear one. Fix a braking level `beta` and split the game:
//!
//! - **front** (`gap_leader, leader_speed, ego_speed`): the ego, braking at most `beta`, keeps
//!   the front gap against a leader that may brake at up to `b_L`. Its value has a closed form
//!   ([`table_format::front`]): both cars braking as hard as they may is a saddle point.
//! - **rear** (this game, `gap_follower, follower_speed, ego_speed`): every ego acceleration in
//!   `[-beta, a_max]` is *adversarial*, like the follower's time gap. Its value `W_beta` bounds
//!   the rear gap from below whatever the ego does within that band.
//!
//! If `V_front,beta(z) >= 0` and `W_beta(z) >= 0`, the ego keeps both gaps for ever by braking
//! at `beta` whenever the front demands it (and doing anything within `[-beta, a_max]`
//! otherwise): the front value never decreases along its own braking, and the rear value never
//! decreases along *any* trajectory whose ego acceleration stays in the band. So
//! `min(V_front,beta, W_beta)` is a lower bound of the five-dimensional value, and the union
//! over a few `beta` of these product sets is a controlled-invariant inner approximation of the
//! five-dimensional safe set, computed on three axes where a grid can resolve `s0`.
//!
//! # Dynamics and Hamiltonian
//! `x' = v_e - v_f`, `v_f' = u_f`, `v_e' = u_e`, with `z = (x, v_f, v_e)` and
//! `p = (p1, p2, p3)`: `p . f = p1 (v_e - v_f) + p2 u_f + p3 u_e`. Nobody maximises:
//! - ego (adversarial here): `u_e = -beta` where `p3 > 0`, else `a_max`, within its speed limits;
//! - follower: `u_f = clip(g(v_f, v_f - v_e, x, T))`, its model's parameter `T` (the IDM's
//!   time gap) adversarial in `[T_min, T_max]`; `g` is non-increasing in `T` (every model's
//!   contract), so `T = T_max` where `p2 > 0` and `T_min` otherwise.
//!
//! Speeds stay in `[0, v_max]` through the input sets (a car at rest cannot brake, one at
//! `v_max` cannot speed up), so nothing leaves through a speed face.

use table_format::FollowerModel;

use super::{Accel, Dynamics, Game, OptimalInputs, Vector};
use crate::engine::semi_lagrangian::SampledGame;

/// The rear game of one braking level `beta` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RearGame {
    /// The ego's acceleration band `[-beta, a_max]`, adversarial in this game.
    pub ego: Accel,
    /// The follower's model, its clip and its adversarial parameter's range.
    pub follower: FollowerModel,
    /// The largest speed of any vehicle, m/s.
    pub max_speed: f32,
    /// `l(z) = gap_follower - min_gap`.
    pub min_gap: f32,
    /// The sampled-data iteration's follower accelerates this much more than its model
    /// (m/s^2, >= 0): a stronger adversary than the model, so that the model's own trajectories
    /// gain on the value and `verify` finds slack at the level set (0: the model itself).
    pub follower_robustness: f32,
}

impl RearGame {
    /// The follower's clip.
    #[inline(always)]
    fn follower_clip(&self) -> Accel {
        Accel::from(self.follower.clip())
    }

    /// The range of the follower model's adversarial parameter.
    #[inline(always)]
    fn parameter_range(&self) -> Accel {
        Accel::from(self.follower.parameter_range())
    }

    /// The follower's clipped acceleration for the parameter `t`, within its speed limits.
    #[inline(always)]
    pub fn follower_acceleration(&self, vf: f32, ve: f32, gap: f32, t: f32) -> f32 {
        let g = self.follower.acceleration(vf.max(0.0), vf - ve, gap, t);
        let clip = self.follower_clip().at_speed(vf, self.max_speed);
        g.clamp(clip.min, clip.max)
    }

    /// The adversary's parameter for co-state component `p2` (on `v_f`): the acceleration is
    /// non-increasing in it, so its largest value where `p2 > 0` and its smallest otherwise.
    #[inline(always)]
    pub fn adversarial_time_gap(&self, p2: f32) -> f32 {
        super::idm::time_gap_against(self.parameter_range(), p2)
    }
}

impl Dynamics for RearGame {
    fn dims(&self) -> usize {
        3
    }

    fn constraint(&self, z: &Vector) -> f32 {
        z[0] - self.min_gap
    }

    fn monotone_axis(&self, axis: usize) -> bool {
        axis == 0
    }

    #[inline(always)]
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32 {
        let uf = self.follower_acceleration(z[1], z[2], z[0], self.adversarial_time_gap(p[1]));
        let ue = self.ego.at_speed(z[2], self.max_speed).argmin(p[2]);
        p[0] * (z[2] - z[1]) + p[1] * uf + p[2] * ue
    }

    #[inline(always)]
    fn dissipation(&self, z: &Vector, alpha: &mut Vector) {
        alpha[0] = (z[2] - z[1]).abs();
        alpha[1] = self
            .follower_clip()
            .at_speed(z[1], self.max_speed)
            .magnitude();
        alpha[2] = self.ego.at_speed(z[2], self.max_speed).magnitude();
    }

    /// Local-local Lax-Friedrichs (Osher & Shu 1991): with `local`, `alpha_k` is the largest
    /// `|dH/dp_k|` over the co-states between `p-` and `p+` only, not over every input.
    ///
    /// Why: at a rest point (both cars stopped, the follower `s0` behind) the flow is zero for
    /// the inputs the co-state selects, while the input *set* still allows 2 m/s^2. Plain local
    /// LF adds `alpha |p+ - p-| / 2` there with `alpha = 2`, a viscosity no transport balances:
    /// on a 1 m, 1 m/s grid it lowered the whole plateau `W = s0` by 0.002 m/s of backward time
    /// without end (0.63 m at 170 s, 0.39 m at 290 s). With `alpha` from the selected inputs
    /// the erosion is only a little slower (0.69 m at 170 s, 0.46 m at 290 s, measured the same
    /// way): the co-states in a WENO stencil near the rest point still straddle both inputs.
    /// Kept because it is the smaller consistent dissipation; the rear table comes from the
    /// sampled-data iteration instead ([`crate::engine::semi_lagrangian`]).
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
        let (x, vf) = (z[0], z[1]);
        for (c, r) in rate.iter_mut().enumerate() {
            let ve = last[c];
            let ego = self.ego.at_speed(ve, self.max_speed);
            let (p1, p2, p3) = (pbar[0][c], pbar[1][c], pbar[2][c]);
            let uf = self.follower_acceleration(vf, ve, x, self.adversarial_time_gap(p2));
            let ue = ego.argmin(p3);
            let h = p1 * (ve - vf) + p2 * uf + p3 * ue;
            let (a1, a2, a3) = if local {
                let (j2, j3) = (half_jump[1][c].abs(), half_jump[2][c].abs());
                // Follower: the time gaps the co-states in [p2 - j2, p2 + j2] select.
                let mut a2 = 0f32;
                if p2 + j2 > 0.0 {
                    a2 = a2.max(
                        self.follower_acceleration(vf, ve, x, self.parameter_range().max)
                            .abs(),
                    );
                }
                if p2 - j2 <= 0.0 {
                    a2 = a2.max(
                        self.follower_acceleration(vf, ve, x, self.parameter_range().min)
                            .abs(),
                    );
                }
                let mut a3 = 0f32;
                if p3 + j3 > 0.0 {
                    a3 = a3.max(ego.min.abs());
                }
                if p3 - j3 <= 0.0 {
                    a3 = a3.max(ego.max.abs());
                }
                ((ve - vf).abs(), a2, a3)
            } else {
                (alpha[0], alpha[1], alpha[2])
            };
            *r = h + a1 * half_jump[0][c] + a2 * half_jump[1][c] + a3 * half_jump[2][c];
        }
    }
}

impl Game for RearGame {
    fn optimal_inputs(&self, z: &Vector, p: &Vector) -> OptimalInputs {
        let t = self.adversarial_time_gap(p[1]);
        OptimalInputs {
            ego: self.ego.at_speed(z[2], self.max_speed).argmin(p[2]),
            leader: 0.0,
            follower: Some(self.follower_acceleration(z[1], z[2], z[0], t)),
            time_gap: Some(t),
            follower_speed: Some(z[1]),
        }
    }

    /// The ego is adversarial here: the switching function is the one of its worst case.
    fn ego_switching(&self, p: &Vector) -> f32 {
        -p[2]
    }

    /// The bit says whether the ego's worst case is to accelerate (a tie accelerates).
    fn ego_accelerates(&self, p: &Vector) -> bool {
        p[2] <= 0.0
    }
}

/// The sampled-data rear game: the ego's acceleration (one of `-beta`, `0`, `a_max`) and the
/// follower's time gap (`T_min` or `T_max`) are held for a period; the follower's IDM is
/// integrated in sub-steps of at most 50 ms within it (it reacts continuously).
impl SampledGame for RearGame {
    fn dims(&self) -> usize {
        Dynamics::dims(self)
    }

    fn constraint(&self, z: &Vector) -> f32 {
        Dynamics::constraint(self, z)
    }

    fn input_count(&self) -> usize {
        6
    }

    fn advance(&self, z: &Vector, input: usize, h: f32) -> Vector {
        let ue = [self.ego.min, 0.0, self.ego.max][input % 3];
        let range = self.parameter_range();
        let t = if input < 3 { range.min } else { range.max };
        let steps = (h / 0.05).ceil().max(1.0);
        let ds = h / steps;
        let vm = self.max_speed;
        let (mut x, mut vf, mut ve) = (z[0], z[1], z[2]);
        for _ in 0..steps as usize {
            let uf = if self.follower_robustness > 0.0 {
                // The model's clipped acceleration, pushed; `travel` holds the speed in [0, v_max] (a
                // follower at rest whose IDM brakes harder than the push stays at rest).
                let c = self.follower_clip();
                self.follower
                    .acceleration(vf.max(0.0), vf - ve, x, t)
                    .clamp(c.min, c.max)
                    + self.follower_robustness
            } else {
                self.follower_acceleration(vf, ve, x, t)
            };
            // Each car's speed is clamped to [0, v_max] exactly within the sub-step.
            let (dve, nve) = travel(ve, ue, ds, vm);
            let (dvf, nvf) = travel(vf, uf, ds, vm);
            x += dve - dvf;
            ve = nve;
            vf = nvf;
        }
        let mut out = *z;
        out[0] = x;
        out[1] = vf;
        out[2] = ve;
        out
    }
}

/// The distance a car at speed `v` covers in `dt` at acceleration `a`, its speed held in
/// `[0, v_max]`, and its speed at the end.
#[inline(always)]
pub fn travel(v: f32, a: f32, dt: f32, v_max: f32) -> (f32, f32) {
    let limit = if a < 0.0 { 0.0 } else { v_max };
    if a == 0.0 {
        return (v * dt, v);
    }
    let t_hit = ((limit - v) / a).max(0.0);
    if t_hit >= dt {
        (v * dt + 0.5 * a * dt * dt, v + a * dt)
    } else {
        (
            v * t_hit + 0.5 * a * t_hit * t_hit + limit * (dt - t_hit),
            limit,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn game() -> RearGame {
        RearGame {
            ego: Accel {
                min: -3.5,
                max: 2.0,
            },
            follower: FollowerModel::Idm {
                clip: table_format::Bounds::new(-6.0, 2.0),
                idm: table_format::IdmParameters::HIGHWAY,
                time_gap: table_format::Bounds::new(1.0, 2.0),
            },
            max_speed: 35.0,
            min_gap: 0.0,
            follower_robustness: 0.0,
        }
    }

    #[test]
    fn travel_is_exact_and_stops_at_the_speed_limits() {
        assert_eq!(travel(10.0, -4.0, 1.0, 35.0), (8.0, 6.0));
        // Stops after 0.5 s having covered 0.5 m, then stands.
        assert_eq!(travel(2.0, -4.0, 1.0, 35.0), (0.5, 0.0));
        // Reaches 35 m/s after 0.5 s, then cruises.
        let (d, v) = travel(34.0, 2.0, 1.0, 35.0);
        assert_eq!(v, 35.0);
        assert!((d - (34.0 * 0.5 + 0.25 + 35.0 * 0.5)).abs() < 1e-5);
    }

    #[test]
    fn a_rest_point_maps_onto_itself() {
        // Both stopped, the follower exactly s0 behind: the IDM asks for nothing, the ego at
        // rest cannot brake, so the state does not move under (0 acceleration, any T).
        let g = game();
        let mut z = [0f32; crate::engine::grid::MAX_DIMS];
        z[0] = 2.0;
        for input in [1, 4] {
            assert_eq!(g.advance(&z, input, 0.5), z);
        }
        // Braking at rest is no braking.
        assert_eq!(g.advance(&z, 0, 0.5), z);
    }

    #[test]
    fn the_hamiltonian_takes_the_least_rate_over_every_input() {
        let g = game();
        let mut z = [0f32; crate::engine::grid::MAX_DIMS];
        let mut p = [0f32; crate::engine::grid::MAX_DIMS];
        for (x, vf, ve) in [(5.0, 10.0, 8.0), (30.0, 20.0, 25.0), (3.0, 0.0, 0.0)] {
            z[..3].copy_from_slice(&[x, vf, ve]);
            for (p1, p2, p3) in [(1.0, -0.5, 0.3), (0.2, 0.7, -0.4), (0.0, 0.0, 1.0)] {
                p[..3].copy_from_slice(&[p1, p2, p3]);
                let mut least = f32::INFINITY;
                for k in 0..=20 {
                    let t = 1.0 + k as f32 / 20.0;
                    let uf = g.follower_acceleration(vf, ve, x, t);
                    for j in 0..=20 {
                        let band = g.ego.at_speed(ve, g.max_speed);
                        let ue = band.min + (band.max - band.min) * j as f32 / 20.0;
                        least = least.min(p1 * (ve - vf) + p2 * uf + p3 * ue);
                    }
                }
                let h = g.hamiltonian(&z, &p);
                assert!((h - least).abs() < 1e-4, "H {h} vs brute force {least}");
            }
        }
    }
}
