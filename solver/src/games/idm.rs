//! The Intelligent Driver Model, as the IDM games use it: the follower's acceleration, the
//! reading of its speed, and the adversary's choice of time gap.

use super::Accel;

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
