//! The three-car game with an IDM follower in relative speeds (the paper's alternative).

use super::{three_car_row, Accel, Dynamics, FollowerSpeedModel, Game, Idm, OptimalInputs, Vector};

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

impl Game for ThreeCarIdm {
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
}
