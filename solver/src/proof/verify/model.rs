//! The rear game's model as a table's header states it, and sound bounds of what one period
//! can do from a box of states (the module docs of [`crate::proof::verify`] derive them).

use table_format::Game;

use super::interval::{widen_down, widen_up, Interval, StateBox};

/// The rear game's model as the table's header states it: the claim is checked against it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RearModel {
    /// `-beta`, m/s^2.
    pub ego_min: f64,
    /// `a_max`, m/s^2.
    pub ego_max: f64,
    /// The follower's clip, m/s^2.
    pub clip_min: f64,
    /// The follower's clip, m/s^2.
    pub clip_max: f64,
    /// IDM `a`, m/s^2.
    pub idm_a: f64,
    /// IDM `b`, m/s^2.
    pub idm_b: f64,
    /// IDM `v0`, m/s.
    pub idm_v0: f64,
    /// IDM `delta`.
    pub idm_delta: i32,
    /// IDM `s0`, m.
    pub idm_s0: f64,
    /// The time gap's range, s.
    pub time_gap: Interval,
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
                follower_clip,
                idm,
                time_gap,
                max_speed,
                ..
            } => Some(RearModel {
                ego_min: f64::from(ego.min),
                ego_max: f64::from(ego.max),
                clip_min: f64::from(follower_clip.min),
                clip_max: f64::from(follower_clip.max),
                idm_a: f64::from(idm.max_acceleration),
                idm_b: f64::from(idm.comfortable_deceleration),
                idm_v0: f64::from(idm.desired_speed),
                idm_delta: i32::from(idm.exponent),
                idm_s0: f64::from(idm.jam_distance),
                time_gap: Interval::new(f64::from(time_gap.min), f64::from(time_gap.max)),
                max_speed: f64::from(max_speed),
                min_gap: f64::from(min_gap),
            }),
            _ => None,
        }
    }

    /// Bounds of the follower's clipped IDM acceleration over a box of gaps and speeds and
    /// every time gap in range (module docs).
    pub fn follower_acceleration(&self, b: &StateBox) -> Interval {
        let (p, q) = (b.follower_speed.lo.max(0.0), b.follower_speed.hi.max(0.0));
        let (r, s) = (b.ego_speed.lo, b.ego_speed.hi);
        let c = 2.0 * (self.idm_a * self.idm_b).sqrt();
        // z(v) = v T + v (v - v_e) / c is non-increasing in v_e and non-decreasing in T
        // (v >= 0), convex in v: its least value at T_min, v_e = s, at the vertex clamped into
        // [p, q]; its largest at T_max, v_e = r, at an end.
        let z = |v: f64, t: f64, ve: f64| v * t + v * (v - ve) / c;
        let vertex = (0.5 * (s - c * self.time_gap.lo)).clamp(p, q);
        let z_lo = z(p, self.time_gap.lo, s)
            .min(z(q, self.time_gap.lo, s))
            .min(z(vertex, self.time_gap.lo, s));
        let z_hi = z(p, self.time_gap.hi, r).max(z(q, self.time_gap.hi, r));
        let desired_lo = widen_down(self.idm_s0 + z_lo.max(0.0));
        let desired_hi = widen_up(self.idm_s0 + z_hi.max(0.0));
        let speed_term = |v: f64| power(v / self.idm_v0, self.idm_delta);
        let (speed_lo, speed_hi) = (speed_term(p), speed_term(q));
        // (s*/g)^2 with s* >= s0 > 0: decreasing in g > 0; infinite at g <= 0.
        let (g1, g2) = (b.gap.lo, b.gap.hi);
        let interaction_hi = if g1 > 0.0 {
            (desired_hi / g1).powi(2)
        } else {
            f64::INFINITY
        };
        let interaction_lo = if g2 > 0.0 {
            (desired_lo / g2).powi(2)
        } else {
            f64::INFINITY
        };
        let lo = widen_down(self.idm_a * (1.0 - speed_hi - interaction_hi));
        let hi = widen_up(self.idm_a * (1.0 - speed_lo - interaction_lo));
        let clamp = |x: f64| {
            if x.is_nan() {
                self.clip_min
            } else {
                x.clamp(self.clip_min, self.clip_max)
            }
        };
        Interval::new(clamp(lo), clamp(hi))
    }

    /// Every state the box can reach over `[0, period]`, bounded (module docs).
    pub fn reach(&self, b: &StateBox, period: f64) -> Reach {
        self.reach_within(b, period, Interval::new(self.clip_min, self.clip_max), 3)
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

/// `x^n` by squaring, for the IDM's small integer exponent: `f64::powi` with an exponent known
/// only at run time is a library call (`__powidf2`) on the proof's hottest path. The exponent
/// is at least 1 (`Idm` refuses others); a bound computed from it is widened like any other.
#[inline(always)]
fn power(x: f64, n: i32) -> f64 {
    let (mut base, mut e, mut out) = (x, n.unsigned_abs(), 1.0);
    while e > 0 {
        if e & 1 == 1 {
            out *= base;
        }
        base *= base;
        e >>= 1;
    }
    if n < 0 {
        1.0 / out
    } else {
        out
    }
}
