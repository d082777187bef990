//! The three-car game with an IDM follower in absolute speeds (five axes).

use super::idm::{clipped_idm, time_gap_against};
use super::{Accel, Dynamics, Game, Idm, OptimalInputs, Vector};

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

impl Game for ThreeCarIdmSpeeds {
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
}
