//! The rear game's model as a table's header states it, and sound bounds of what one period
//! can do from a box of states (the module docs of [`crate::proof::verify`] derive them).

use table_format::{FollowerModel, Game};

use super::interval::{widen_down, widen_up, Interval, StateBox};

/// The rear game's model as the table's header states it: the claim is checked against it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RearModel {
    /// `-beta`, m/s^2.
    pub ego_min: f64,
    /// `a_max`, m/s^2.
    pub ego_max: f64,
    /// The follower's model, its clip and its parameter's range ([`FollowerModel`]: its
    /// interval form is the proof's).
    pub follower: FollowerModel,
    /// Every speed lies in `[0, max_speed]`, m/s.
    pub max_speed: f64,
    /// A collision is a gap at or below this, m.
    pub min_gap: f64,
}

impl RearModel {
    /// The model of a split table's header; `None` for any other game.
    pub fn from_game(game: &Game, min_gap: f32) -> Option<Self> {
        match *game {
            Game::ThreeCarSplit {
                ego,
                follower,
                max_speed,
                ..
            } => Some(RearModel {
                ego_min: f64::from(ego.min),
                ego_max: f64::from(ego.max),
                follower,
                max_speed: f64::from(max_speed),
                min_gap: f64::from(min_gap),
            }),
            _ => None,
        }
    }

    /// The follower's clip, lowest, m/s^2.
    pub fn clip_min(&self) -> f64 {
        f64::from(self.follower.clip().min)
    }

    /// The follower's clip, highest, m/s^2.
    pub fn clip_max(&self) -> f64 {
        f64::from(self.follower.clip().max)
    }

    /// Bounds of the follower's clipped acceleration over a box of gaps and speeds and every
    /// parameter in range ([`FollowerModel::acceleration_bounds`], the ego the follower's
    /// leader), clipped; a NaN bound is the clip's lowest.
    pub fn follower_acceleration(&self, b: &StateBox) -> Interval {
        let (lo, hi) = self.follower.acceleration_bounds(
            (b.gap.lo, b.gap.hi),
            (b.follower_speed.lo, b.follower_speed.hi),
            (b.ego_speed.lo, b.ego_speed.hi),
        );
        let clamp = |x: f64| {
            if x.is_nan() {
                self.clip_min()
            } else {
                x.clamp(self.clip_min(), self.clip_max())
            }
        };
        Interval::new(clamp(lo), clamp(hi))
    }

    /// Every state the box can reach over `[0, period]`, bounded (module docs).
    pub fn reach(&self, b: &StateBox, period: f64) -> Reach {
        self.reach_within(
            b,
            period,
            Interval::new(self.clip_min(), self.clip_max()),
            3,
        )
    }

    /// [`RearModel::reach`] from a bound `accel` already known to hold for the follower's
    /// acceleration over `[0, period]` (a longer period's holds for a shorter one), narrowed
    /// `rounds` times.
    pub fn reach_within(&self, b: &StateBox, period: f64, accel: Interval, rounds: u32) -> Reach {
        let vm = self.max_speed;
        let ve = b.ego_speed;
        let ego_tube = Interval::new(
            (ve.lo + self.ego_min * period).max(0.0),
            (ve.hi + self.ego_max * period).min(vm),
        );
        let ego_far = travel(ve.hi, self.ego_max, period, vm).0;
        let mut accel = accel;
        for _ in 0..rounds {
            let vf = b.follower_speed;
            let follower_tube = Interval::new(
                (vf.lo + accel.lo.min(0.0) * period).max(0.0),
                (vf.hi + accel.hi.max(0.0) * period).min(vm),
            );
            let follower_far = travel(vf.hi, accel.hi, period, vm).0;
            let gap_tube = Interval::new(
                widen_down(b.gap.lo - follower_far),
                widen_up(b.gap.hi + ego_far),
            );
            let tube = StateBox {
                gap: gap_tube,
                follower_speed: follower_tube,
                ego_speed: ego_tube,
            };
            let next = self.follower_acceleration(&tube);
            accel = Interval::new(next.lo.max(accel.lo), next.hi.min(accel.hi));
        }
        let vf = b.follower_speed;
        let (ego_near, ego_end_lo) = travel(ve.lo, self.ego_min, period, vm);
        let (ego_far, ego_end_hi) = travel(ve.hi, self.ego_max, period, vm);
        let (follower_near, follower_end_lo) = travel(vf.lo, accel.lo, period, vm);
        let (follower_far, follower_end_hi) = travel(vf.hi, accel.hi, period, vm);
        let end = StateBox {
            gap: Interval::new(
                widen_down(b.gap.lo + ego_near - follower_far),
                widen_up(b.gap.hi + ego_far - follower_near),
            ),
            follower_speed: Interval::new(
                widen_down(follower_end_lo).max(0.0),
                widen_up(follower_end_hi).min(vm),
            ),
            ego_speed: Interval::new(
                widen_down(ego_end_lo).max(0.0),
                widen_up(ego_end_hi).min(vm),
            ),
        };
        let least_gap = widen_down(
            b.gap.lo + least_difference(ve.lo, self.ego_min, vf.hi, accel.hi, period, vm),
        );
        // Throughout the period: the gap above its least value and below the box's largest
        // plus the ego's farthest travel (the follower never goes backwards), each speed
        // within its tube under the acceleration bound just found.
        let tube = StateBox {
            gap: Interval::new(least_gap, widen_up(b.gap.hi + ego_far)),
            follower_speed: Interval::new(
                widen_down(vf.lo + accel.lo.min(0.0) * period).max(0.0),
                widen_up(vf.hi + accel.hi.max(0.0) * period).min(vm),
            ),
            ego_speed: ego_tube,
        };
        Reach {
            end,
            tube,
            least_gap,
            follower_acceleration: accel,
        }
    }
}

/// What one period can do from a box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// Every state at the end of the period lies in this box.
    pub end: StateBox,
    /// Every state at every time of the period lies in this box.
    pub tube: StateBox,
    /// The gap stays at or above this throughout the period, m.
    pub least_gap: f64,
    /// The follower's acceleration throughout the period lies here, m/s^2.
    pub follower_acceleration: Interval,
}

/// The distance a car at speed `v` covers in `t` at constant acceleration `a`, its speed held in
/// `[0, v_max]`, and its speed at the end. Non-decreasing in `v` and in `a`.
pub fn travel(v: f64, a: f64, t: f64, v_max: f64) -> (f64, f64) {
    if a == 0.0 || t <= 0.0 {
        return (v * t.max(0.0), v);
    }
    let limit = if a < 0.0 { 0.0 } else { v_max };
    let t_hit = ((limit - v) / a).max(0.0);
    if t_hit >= t {
        (v * t + 0.5 * a * t * t, v + a * t)
    } else {
        (
            v * t_hit + 0.5 * a * t_hit * t_hit + limit * (t - t_hit),
            limit,
        )
    }
}

/// The least over `t` in `[0, period]` of `travel(ve, ae, t) - travel(vf, af, t)`: the gap's
/// least change when the ego brakes from `ve` at `ae` and the follower goes from `vf` at `af`.
/// The difference is continuous with a piecewise-linear derivative, so its least value is at an
/// end, a kink (a car stopping or saturating) or a zero of the derivative on a piece.
pub(super) fn least_difference(ve: f64, ae: f64, vf: f64, af: f64, period: f64, v_max: f64) -> f64 {
    let hit = |v: f64, a: f64| -> Option<f64> {
        if a == 0.0 {
            return None;
        }
        let limit = if a < 0.0 { 0.0 } else { v_max };
        let t = (limit - v) / a;
        (t > 0.0 && t < period).then_some(t)
    };
    let mut candidates = vec![0.0, period];
    candidates.extend(hit(ve, ae));
    candidates.extend(hit(vf, af));
    // On each piece each speed is either moving (v + a t) or held (a constant); the
    // derivative's zero for each combination.
    let moving = |v: f64, a: f64| (v, a);
    let held = |v: f64, a: f64| {
        let limit = if a < 0.0 { 0.0 } else { v_max };
        (if a == 0.0 { v } else { limit }, 0.0)
    };
    for (e0, e1) in [moving(ve, ae), held(ve, ae)] {
        for (f0, f1) in [moving(vf, af), held(vf, af)] {
            let slope = e1 - f1;
            if slope != 0.0 {
                let t = (f0 - e0) / slope;
                if t > 0.0 && t < period {
                    candidates.push(t);
                }
            }
        }
    }
    candidates
        .into_iter()
        .map(|t| travel(ve, ae, t, v_max).0 - travel(vf, af, t, v_max).0)
        .fold(f64::INFINITY, f64::min)
}
