//! The two-car game: the ego behind a leader (paper Fig. 1a).

use super::{Accel, Dynamics, Game, OptimalInputs, Vector};

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

impl Game for TwoCar {
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
}
