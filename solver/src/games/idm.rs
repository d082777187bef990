//! The Intelligent Driver Model as the IDM games use it: the reading of the follower's speed,
//! its clipped acceleration, and the adversary's choice of time gap. The model itself is
//! written once, in [`table_format::idm`].

use super::Accel;

/// The Intelligent Driver Model: [`table_format::IdmParameters`], whose point and interval
/// forms ([`table_format::idm`]) the games, the proof and the simulations share.
pub use table_format::IdmParameters as Idm;

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

/// The IDM follower's acceleration at speed `v3` behind an ego at `ve`, `gap` metres ahead,
/// for time gap `t`: clipped to `clip`, within the speed limits `[0, max_speed]`. Shared by
/// every game in absolute speeds.
#[inline(always)]
pub(super) fn clipped_idm(
    idm: &Idm,
    clip: Accel,
    max_speed: f32,
    v3: f32,
    ve: f32,
    gap: f32,
    t: f32,
) -> f32 {
    let g = idm.acceleration(v3.max(0.0), v3 - ve, gap, t);
    let clip = clip.at_speed(v3, max_speed);
    g.clamp(clip.min, clip.max)
}

/// The time gap an adversary minimising `p u3` picks: the IDM acceleration is non-increasing
/// in `T`, so `T_max` where `p > 0` and `T_min` otherwise.
#[inline(always)]
pub(super) fn time_gap_against(time_gap: Accel, p: f32) -> f32 {
    if p > 0.0 {
        time_gap.max
    } else {
        time_gap.min
    }
}
