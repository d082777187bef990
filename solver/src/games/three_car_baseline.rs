//! The three-car game with a follower that may apply any acceleration in its bounds (the
//! paper's baseline).

use super::{three_car_row, Accel, Dynamics, Game, OptimalInputs, Vector};

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

impl Game for ThreeCarBaseline {
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
}
