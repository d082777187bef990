//! The front part of the three-car game in closed form: the smallest gap to the leader when
//! the ego brakes at a bounded rate after a response time and the leader brakes as hard as it
//! may, both down to standstill.
//!
//! # Why a closed form is the front game's value
//! The front gap is `gap(t) = gap + p_L(t) - p_E(t)`, with `p_L`, `p_E` the distances the two
//! cars cover from now. A leader braking at `b_L` until it stops covers the least distance
//! *at every instant* among all its admissible behaviours (speeds stay at or above zero), and
//! an ego braking at `beta` covers the least among all of its own. So the pair is a saddle point
//! of `min_t gap(t)` for every `t` at once, and the game's value (`sup` over the ego, `inf` over
//! the leader, of the smallest gap ever) is that pair's smallest gap. The solver uses the same
//! function as the firmware, so the two agree to the bit.
//!
//! # The response time
//! With a response time `rho` the ego keeps an acceleration `a_r` for `rho`, then brakes at
//! `beta`: the ego's dead time plus actuator lag, bounded above by a hold of the largest
//! acceleration still in the actuator's pipeline. Why a hold bounds a first-order lag: with
//! `a(t) = c + (a_0 - c) e^(-t/tau)` towards the braking command `c = -beta`, `a_0 <= a_r`, and
//! `v_s` the speed of the step "`a_r` until `tau`, then `c`",
//! - for `t < tau`: `v_s(t) - v(t) >= (a_0 - c) (t - tau (1 - e^(-t/tau))) >= 0`, since
//!   `1 - e^(-x) <= x`;
//! - for `t >= tau`: `v_s(t) - v(t) >= (a_0 - c) tau e^(-t/tau) >= 0`;
//!
//! so the lagged ego is never faster, and never farther, than the step: a dead time `D` before
//! the braking command takes force adds `D` to the hold. The property test
//! `bounds_a_dead_time_and_a_first_order_lag` checks it against brute-force integration of the
//! real actuator.
//!
//! During the response the ego's speed is **not** held at `max_speed`: nothing in the dynamics
//! stops an accelerating actuator at the domain's edge (an ego at 34.8 m/s accelerating at
//! 0.8 m/s^2 with 0.4 s of response reaches 35.12 m/s, and braking from there takes 1.2 m more
//! than from 35). Keeping the ego inside `[0, max_speed]` is the controller's job, not an
//! assumption of this function. Only the leader's speed is held in `[0, max_speed]`, by the
//! model of the human, and a measured leader speed above it is taken at `max_speed` (a slower
//! leader is never better for the ego).
//!
//! # The braking ramp
//! A controller that limits its jerk cannot brake at `beta` at once: from the response's end
//! its acceleration ramps down, `max(r - j s, -beta)` at `s` seconds into the ramp, from
//! `ramp_from = r` at the jerk `j`. The ramp is in the model exactly (not bounded by a later
//! step), because a later step is not invariant: a controller re-evaluating mid-ramp would move
//! the step later by half of every period. The firmware's argument (`controller`'s module docs)
//! uses the ramp's start and reference, which stay fixed while it runs. Why a dead time and a
//! lag before a ramp are still bounded by a hold for `D + tau`: the commands form a
//! non-increasing profile `c` (the hold, then the ramp), so its integral `C` (the speed it
//! gives) is concave; a first-order lag averages the speed over an exponential delay of mean
//! `tau`, and by Jensen's inequality the average of a concave function is at most its value at
//! the mean delay. So the lagged ego is never faster than the profile delayed by `tau`; the
//! dead time delays it by `D` more. The property test `bounds_a_ramp_through_the_delays`
//! checks it by brute force, ramp started before the measurement included.
//!
//! # Evaluation
//! Between events (the response ends, the ramp ends, a car stops) the leader's acceleration is
//! constant and the ego's constant or falling at the jerk: the gap is a parabola or a cubic in
//! time. Its relative speed is then a convex quadratic, so its smallest value on a segment is
//! at an end or where the relative speed crosses zero upwards (the larger root). There are at
//! most five segments (the response ends, the ramp ends, the leader stops, the ego stops, then
//! nothing moves). f32 throughout; no panics, no loops without a bound.

/// The front value a certified state keeps, m, unless a configuration declares another: the
/// firmware's default `front_margin`, and the level the solver measures a table's certified
/// volume at.
pub const DEFAULT_FRONT_MARGIN: f32 = 0.5;

/// The front model: the leader's hardest braking, and the ego's braking level, response, braking
/// ramp and the leader's speed limit. All in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrontModel {
    /// The leader's hardest braking `b_L`, m/s^2 (positive).
    pub leader_braking: f32,
    /// The ego's braking level `beta`, m/s^2 (positive).
    pub ego_braking: f32,
    /// How long the ego keeps `response_acceleration` before its braking ramp, s (zero or
    /// positive).
    pub response_time: f32,
    /// The ego's acceleration during the response, m/s^2.
    pub response_acceleration: f32,
    /// Where the ego's braking ramp starts, m/s^2: after the response its acceleration is
    /// `max(ramp_from - jerk s, -beta)`, `s` seconds into the ramp (module docs: the ramp).
    pub ramp_from: f32,
    /// The ramp's jerk, m/s^3 (positive; `f32::INFINITY`: no ramp, the braking at `beta` takes
    /// effect at once, as before the ramp entered the model).
    pub jerk: f32,
    /// The leader's largest speed, m/s (the human's model; the ego's speed is not held by it).
    pub max_speed: f32,
}

impl FrontModel {
    /// The model without a braking ramp: a response, then `beta` at once.
    pub const fn step(
        leader_braking: f32,
        ego_braking: f32,
        response_time: f32,
        response_acceleration: f32,
        max_speed: f32,
    ) -> Self {
        FrontModel {
            leader_braking,
            ego_braking,
            response_time,
            response_acceleration,
            ramp_from: 0.0,
            jerk: f32::INFINITY,
            max_speed,
        }
    }

    /// Whether the model has a ramp to run (a finite positive jerk, a start above `-beta`).
    fn has_ramp(&self) -> bool {
        self.jerk.is_finite() && self.jerk > 0.0 && self.ramp_from > -self.ego_braking
    }
}

/// The ego's phase in [`front_value`]'s evaluation.
#[derive(Clone, Copy)]
enum Phase {
    /// The response, with its time left.
    Hold(f32),
    /// The braking ramp, with its acceleration now.
    Ramp(f32),
    /// Braking at `beta` (or stopped).
    Brake,
}

/// The smallest gap (m) to a leader `gap` metres ahead at `leader_speed`, for an ego at
/// `ego_speed`, under [`FrontModel`]: the front game's value with constraint `l = gap`.
/// The leader's speed is taken in `[0, max_speed]`, the ego's at or above zero (module docs:
/// no speed limit holds the ego). Non-decreasing in `gap` and `leader_speed`, non-increasing
/// in `ego_speed`, `response_time`, `response_acceleration` and `ramp_from`, non-decreasing in
/// `jerk`. NaN in, NaN out.
pub fn front_value(gap: f32, leader_speed: f32, ego_speed: f32, model: &FrontModel) -> f32 {
    let vmax = model.max_speed;
    let (bl, beta, jerk) = (model.leader_braking, model.ego_braking, model.jerk);
    let mut g = gap;
    // (Not `f32::clamp`: it asserts its bounds are ordered, a panic path.)
    let mut vl = leader_speed.max(0.0).min(vmax);
    let mut ve = ego_speed.max(0.0);
    let after_hold = if model.has_ramp() {
        Phase::Ramp(model.ramp_from)
    } else {
        Phase::Brake
    };
    let mut phase = if model.response_time > 0.0 {
        Phase::Hold(model.response_time)
    } else {
        after_hold
    };
    let mut least = g;
    // Each pass ends at an event that does not recur: the response ends, the ramp ends, the
    // leader stops, the ego stops (once it has moved). Seven passes cover them all with two to
    // spare.
    for _ in 0..7 {
        let al = if vl > 0.0 { -bl } else { 0.0 };
        // The ego's acceleration at the segment's start and its rate of change.
        let (ae, rate) = match phase {
            Phase::Hold(_) => {
                let a = model.response_acceleration;
                (if a < 0.0 && ve <= 0.0 { 0.0 } else { a }, 0.0)
            }
            Phase::Ramp(a) => {
                if a <= 0.0 && ve <= 0.0 {
                    // Stopped with the ramp braking: it stays stopped.
                    phase = Phase::Brake;
                    (0.0, 0.0)
                } else {
                    (a, -jerk)
                }
            }
            Phase::Brake => (if ve > 0.0 { -beta } else { 0.0 }, 0.0),
        };
        // Time to each event; the segment ends at the first, and the cars whose event it is
        // are set exactly to their limit (no rounding remainder to start a spurious segment).
        let t_leader = if al < 0.0 { vl / bl } else { f32::INFINITY };
        let t_phase = match phase {
            Phase::Hold(left) => left,
            Phase::Ramp(a) => (a + beta) / jerk,
            Phase::Brake => f32::INFINITY,
        };
        // The ego stops where `ve + ae s + rate s^2 / 2` reaches zero.
        let t_ego = if rate < 0.0 {
            let j = -rate;
            (ae + crate::math::sqrt((ae * ae + 2.0 * j * ve).max(0.0))) / j
        } else if ae < 0.0 {
            ve / -ae
        } else {
            f32::INFINITY
        };
        let len = t_leader.min(t_phase).min(t_ego);
        let dv = vl - ve;
        let da = al - ae;
        // The gap is `g + dv s + da s^2 / 2 - rate s^3 / 6`; its relative speed
        // `dv + da s - rate s^2 / 2` is convex in `s`, so the gap's one local minimum is where
        // that speed crosses zero upwards: the larger root.
        let gap_at = |s: f32| g + dv * s + 0.5 * da * s * s - rate * s * s * s / 6.0;
        let vertex = if rate < 0.0 {
            let c = -0.5 * rate;
            let disc = da * da - 4.0 * c * dv;
            if disc >= 0.0 {
                (-da + crate::math::sqrt(disc)) / (2.0 * c)
            } else {
                f32::NAN
            }
        } else if dv < 0.0 && da > 0.0 {
            -dv / da
        } else {
            f32::NAN
        };
        if vertex > 0.0 && vertex < len {
            least = least.min(gap_at(vertex));
        }
        if !len.is_finite() {
            // Nothing changes any more: both at constant speed, the ego no faster (it stops
            // or brakes whenever it moves outside the response).
            if dv < 0.0 {
                return f32::NEG_INFINITY;
            }
            break;
        }
        g = gap_at(len);
        vl = if len >= t_leader {
            0.0
        } else {
            (vl + al * len).max(0.0).min(vmax)
        };
        ve = if len >= t_ego {
            0.0
        } else {
            (ve + ae * len + 0.5 * rate * len * len).max(0.0)
        };
        phase = match phase {
            Phase::Hold(_) if len >= t_phase => after_hold,
            Phase::Hold(left) => Phase::Hold(left - len),
            Phase::Ramp(_) if len >= t_phase || len >= t_ego => Phase::Brake,
            Phase::Ramp(a) => Phase::Ramp(a + rate * len),
            Phase::Brake => Phase::Brake,
        };
        least = least.min(g);
    }
    if gap.is_nan() || leader_speed.is_nan() || ego_speed.is_nan() {
        return f32::NAN;
    }
    least
}

/// The override's graded command: a braking between the ramp's `floor` and the `refused`
/// command that passes the look-ahead, if one is found (the firmware's override, and
/// `crate::authority`'s rule with the comfort level as the floor).
///
/// The look-ahead's front value `F(u)` (the command `u` held for a period, then the ramp from
/// `u`) is non-increasing in `u`: a harder-accelerating ego is ahead of a gentler one at every
/// instant. It is known at the refused command (`F(refused) <= margin`), and the certified
/// value `front` (the ramp from now) stands in for `F(floor)`. Over one period `F` is nearly
/// affine in `u`, so the secant's root, pulled 10% towards the floor, is a candidate; it is
/// used only if the look-ahead passes it, else the midpoint between it and the floor, else
/// nothing (the caller follows the ramp). Two evaluations at most (the control step's budget).
/// Whatever is returned passed the look-ahead. Braking no harder than needed spares the
/// follower and the jerk.
pub fn least_braking(
    refused: f32,
    at_refused: f32,
    floor: f32,
    front: f32,
    margin: f32,
    passes: impl Fn(f32) -> bool,
) -> Option<f32> {
    let drop = front - at_refused;
    if !(front > margin && drop > 0.0) {
        return None;
    }
    // In `[0, 1]`, a NaN share at 0 (not `f32::clamp`: it passes NaN on).
    let share = 0.9 * (front - margin) / drop;
    let share = if share >= 0.0 { share.min(1.0) } else { 0.0 };
    let candidate = floor + share * (refused - floor);
    if passes(candidate) {
        return Some(candidate);
    }
    let halfway = 0.5 * (floor + candidate);
    passes(halfway).then_some(halfway)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The smallest gap by brute-force integration (f64, 0.1 ms steps). The ego's speed is
    /// held at or above zero only: nothing holds it at `max_speed`.
    fn simulated(gap: f64, vl: f64, ve: f64, m: &FrontModel) -> f64 {
        let dt = 1e-4;
        let (mut g, mut vl, mut ve, mut t) = (gap, vl, ve, 0.0);
        let mut least = g;
        // Both cars at rest end it only once the ego's acceleration can no longer be positive:
        // after the response, and after the ramp has fallen through zero (a ramp from a positive
        // reference moves an ego at rest).
        let ramp_up = if m.jerk.is_finite() {
            f64::from(m.ramp_from.max(0.0)) / f64::from(m.jerk)
        } else {
            0.0
        };
        let moving_until = f64::from(m.response_time) + ramp_up;
        while vl > 0.0 || ve > 0.0 || t <= moving_until {
            let beta = f64::from(m.ego_braking);
            // The acceleration at the step's middle: exact over a step of the ramp.
            let mid = t + 0.5 * dt;
            let ae = if mid < f64::from(m.response_time) {
                f64::from(m.response_acceleration)
            } else if m.jerk.is_finite() {
                let s = mid - f64::from(m.response_time);
                (f64::from(m.ramp_from) - f64::from(m.jerk) * s).max(-beta)
            } else {
                -beta
            };
            let nl = (vl - f64::from(m.leader_braking) * dt).max(0.0);
            let ne = (ve + ae * dt).max(0.0);
            g += 0.5 * (vl + nl) * dt - 0.5 * (ve + ne) * dt;
            vl = nl;
            ve = ne;
            t += dt;
            least = least.min(g);
            if t > 200.0 {
                break;
            }
        }
        least
    }

    fn model(bl: f32, beta: f32, rho: f32, ar: f32) -> FrontModel {
        FrontModel::step(bl, beta, rho, ar, 35.0)
    }

    fn ramped(bl: f32, beta: f32, rho: f32, ar: f32, r: f32, j: f32) -> FrontModel {
        FrontModel {
            ramp_from: r,
            jerk: j,
            ..model(bl, beta, rho, ar)
        }
    }

    #[test]
    fn known_cases() {
        // Equal braking, no response: the gap never shrinks below min(gap, final gap).
        let m = model(6.0, 6.0, 0.0, 0.0);
        assert_eq!(front_value(20.0, 20.0, 20.0, &m), 20.0);
        // A stopped leader: the ego stops v^2 / (2 beta) = 50 m later.
        let m = model(6.0, 4.0, 0.0, 0.0);
        assert!((front_value(60.0, 0.0, 20.0, &m) - 10.0).abs() < 1e-4);
        // The ego out-brakes the leader and is faster: the smallest gap is where the speeds
        // meet, gap - dv^2 / (2 (beta - b_L)) = 30 - 100 / 4 = 5 m.
        let m = model(2.0, 4.0, 0.0, 0.0);
        assert!((front_value(30.0, 20.0, 30.0, &m) - 5.0).abs() < 1e-3);
        // A response of 1 s at +2 m/s^2 from 20 m/s: 21 m, then 22^2 / 8 = 60.5 m.
        let m = model(6.0, 4.0, 1.0, 2.0);
        assert!((front_value(100.0, 0.0, 20.0, &m) - 18.5).abs() < 1e-3);
        assert!(front_value(f32::NAN, 0.0, 20.0, &m).is_nan());
    }

    /// An ego at 34.8 m/s with 0.4 s of response at +0.8 m/s^2 reaches
    /// 35.12 m/s before it brakes. Held at 35 m/s, the value was 1.2 m too high, and a start
    /// that collides at 9.9 s was certified.
    #[test]
    fn the_response_is_not_held_at_the_speed_limit() {
        let m = model(6.0, 3.5, 0.4, 0.8);
        let during = 34.8 * 0.4 + 0.5 * 0.8 * 0.4 * 0.4;
        let braking = 35.12f32 * 35.12 / (2.0 * 3.5);
        let exact = 300.0 - during - braking;
        let v = front_value(300.0, 0.0, 34.8, &m);
        assert!((v - exact).abs() < 2e-3, "{v} against {exact}");
        // An ego measured above the speed limit is not taken at it.
        let m = model(6.0, 3.5, 0.0, 0.0);
        let v = front_value(300.0, 0.0, 36.0, &m);
        assert!((v - (300.0 - 36.0 * 36.0 / 7.0)).abs() < 2e-3, "{v}");
    }

    proptest! {
        #[test]
        fn matches_brute_force_integration(
            gap in -5.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            bl in 1.0f32..9.0, beta in 1.0f32..9.0, rho in 0.0f32..1.0, ar in -4.0f32..2.0,
        ) {
            let m = model(bl, beta, rho, ar);
            let exact = front_value(gap, vl, ve, &m);
            let brute = simulated(f64::from(gap), f64::from(vl), f64::from(ve), &m);
            prop_assert!((f64::from(exact) - brute).abs() < 0.01, "{} vs {}", exact, brute);
        }

        /// The response bounds the real actuator: the braking command takes force after a dead
        /// time `D`, and the acceleration follows it through a first-order lag `tau` from
        /// wherever it was (`a_0`, with the command in force `c_0`). The closed form with a hold
        /// of `max(a_0, c_0)` for `D + tau` is never above the smallest gap of brute-force
        /// integration (f64, 0.1 ms steps), and within the integration's error of it when there
        /// is no lag to gain on.
        #[test]
        fn bounds_a_dead_time_and_a_first_order_lag(
            gap in 0.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            bl in 1.0f32..9.0, beta in 1.0f32..6.0,
            dead in 0.0f32..0.1, tau in 0.0f32..0.3,
            a0 in -1.0f32..1.0, c0 in -1.0f32..1.0,
        ) {
            let (a0, c0) = (if a0 < 0.0 { a0 * beta } else { 2.0 * a0 }, if c0 < 0.0 { c0 * beta } else { 2.0 * c0 });
            let hold = a0.max(c0);
            let m = model(bl, beta, dead + tau, hold);
            let bound = f64::from(front_value(gap, vl, ve, &m));
            // The real actuator.
            let dt = 1e-4f64;
            let (mut g, mut l, mut e, mut a, mut t) =
                (f64::from(gap), f64::from(vl), f64::from(ve), f64::from(a0), 0.0f64);
            let mut least = g;
            while (l > 0.0 || e > 0.0) && t < 200.0 {
                let command = if t < f64::from(dead) { f64::from(c0) } else { -f64::from(beta) };
                // The lag's exact step, then the speed with the step's mean acceleration.
                let mean = if tau > 0.0 {
                    let k = (-dt / f64::from(tau)).exp();
                    let next = command + (a - command) * k;
                    let mean = command + (a - command) * f64::from(tau) * (1.0 - k) / dt;
                    a = next;
                    mean
                } else {
                    a = command;
                    command
                };
                let nl = (l - f64::from(bl) * dt).max(0.0);
                let ne = (e + mean * dt).max(0.0);
                g += 0.5 * (l + nl) * dt - 0.5 * (e + ne) * dt;
                l = nl;
                e = ne;
                t += dt;
                least = least.min(g);
            }
            prop_assert!(bound <= least + 0.01, "closed form {} above the real {}", bound, least);
        }

        /// The ramp's closed form against brute force: a response, then the acceleration
        /// falling at the jerk from `ramp_from` to `-beta`, with stops on the way.
        #[test]
        fn the_ramp_matches_brute_force_integration(
            gap in -5.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            bl in 1.0f32..9.0, beta in 1.0f32..6.0, rho in 0.0f32..1.0, ar in -4.0f32..2.0,
            r in -4.0f32..2.0, j in 0.5f32..10.0,
        ) {
            let m = ramped(bl, beta, rho, ar, r, j);
            let exact = front_value(gap, vl, ve, &m);
            let brute = simulated(f64::from(gap), f64::from(vl), f64::from(ve), &m);
            prop_assert!((f64::from(exact) - brute).abs() < 0.01, "{} vs {} {:?}", exact, brute, m);
        }

        /// The value is non-increasing in the ramp's start and non-decreasing in its jerk (a
        /// ramp that starts lower or falls faster is behind at every instant), and the step is
        /// the ramp's limit as the jerk grows.
        #[test]
        fn the_ramp_is_monotone_and_tends_to_the_step(
            gap in 0.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            rho in 0.0f32..1.0, ar in -3.5f32..2.0, r in -3.5f32..2.0, dr in 0.0f32..2.0,
            j in 0.5f32..10.0, dj in 0.0f32..10.0,
        ) {
            let v = |r: f32, j: f32| front_value(gap, vl, ve, &ramped(6.0, 3.5, rho, ar, r, j));
            let tol = |x: f32| 1e-3 * (1.0 + x.abs());
            let base = v(r, j);
            prop_assert!(v(r + dr, j) <= base + tol(base), "higher start {} above {}", v(r + dr, j), base);
            prop_assert!(v(r, j + dj) >= base - tol(base), "more jerk {} below {}", v(r, j + dj), base);
            let step = front_value(gap, vl, ve, &model(6.0, 3.5, rho, ar));
            let steep = v(r, 1e5);
            prop_assert!((steep - step).abs() < 0.01, "jerk 1e5 {} against the step {}", steep, step);
        }

        /// The ramp bounds the real actuator: commands held per period (a staircase below the
        /// ramp from `r`, started `t_b` before the measurement, at or before it), taking force
        /// after a dead time `D` and passing a first-order lag `tau` from wherever the lag was
        /// (`a_0`), with the commands in force before the ramp at most `c_0`. The closed form
        /// with a hold of `max(a_0, c_0, ramp start)` for `max(D - t_b, 0) + tau` and the ramp
        /// from `r - j max(t_b - D, 0)` (the firmware's formula, `controller`'s module docs) is
        /// never above the smallest gap of brute-force integration (f64, 0.1 ms steps).
        #[test]
        fn bounds_a_ramp_through_the_delays(
            gap in 0.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            bl in 1.0f32..9.0, beta in 1.0f32..6.0,
            dead in 0.0f32..0.1, tau in 0.0f32..0.3,
            a0 in -1.0f32..1.0, c0 in -1.0f32..1.0, r in -1.0f32..1.0,
            j in 1.0f32..10.0, since in 0.0f32..2.0,
        ) {
            let scale = |x: f32| if x < 0.0 { x * beta } else { 2.0 * x };
            let (a0, c0, r) = (scale(a0), scale(c0), scale(r));
            let h = 0.02f64;
            let ramp_from = r - j * (since - dead).max(0.0);
            let hold = a0.max(c0).max(ramp_from.max(-beta));
            let m = ramped(bl, beta, (dead - since).max(0.0) + tau, hold, ramp_from, j);
            let bound = f64::from(front_value(gap, vl, ve, &m));
            // The real actuator; time 0 is the measurement, the ramp began at `-since`.
            let (dt, tb) = (1e-4f64, -f64::from(since));
            let (jj, bb, rr) = (f64::from(j), f64::from(beta), f64::from(r));
            let issued = |t: f64| -> f64 {
                if t < tb {
                    f64::from(c0)
                } else {
                    let k = ((t - tb) / h).floor();
                    (rr - jj * (k + 1.0) * h).max(-bb)
                }
            };
            let (mut g, mut l, mut e, mut a, mut t) =
                (f64::from(gap), f64::from(vl), f64::from(ve), f64::from(a0), 0.0f64);
            let mut least = g;
            while (l > 0.0 || e > 0.0) && t < 200.0 {
                let command = issued(t - f64::from(dead));
                let mean = if tau > 0.0 {
                    let k = (-dt / f64::from(tau)).exp();
                    let next = command + (a - command) * k;
                    let mean = command + (a - command) * f64::from(tau) * (1.0 - k) / dt;
                    a = next;
                    mean
                } else {
                    a = command;
                    command
                };
                let nl = (l - f64::from(bl) * dt).max(0.0);
                let ne = (e + mean * dt).max(0.0);
                g += 0.5 * (l + nl) * dt - 0.5 * (e + ne) * dt;
                l = nl;
                e = ne;
                t += dt;
                least = least.min(g);
            }
            prop_assert!(bound <= least + 0.01, "closed form {} above the real {} ({:?})", bound, least, m);
        }

        /// Why the firmware evaluates the front at one corner of a measurement's error box:
        /// the value is non-decreasing in the gap and the leader's speed and non-increasing in
        /// the ego's speed, so the corner (least gap, slowest leader, fastest ego) is never
        /// above the value at any point of the box.
        #[test]
        fn the_error_boxs_worst_corner_is_its_least_value(
            gap in -5.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            dg in 0.0f32..3.0, dl in 0.0f32..1.0, de in 0.0f32..1.0,
            sg in 0.0f32..1.0, sl in 0.0f32..1.0, se in 0.0f32..1.0,
            rho in 0.0f32..1.5, ar in -3.5f32..2.0,
        ) {
            let m = model(6.0, 3.5, rho, ar);
            let corner = front_value(gap, vl, ve + de, &m);
            let inside = front_value(gap + sg * dg, vl + sl * dl, ve + se * de, &m);
            prop_assert!(corner <= inside + 1e-3 * (1.0 + inside.abs()), "{} above {}", corner, inside);
        }

        /// The property a safety filter rests on: braking at beta (no response time), the
        /// value never decreases, whatever the leader does within its bounds.
        #[test]
        fn never_decreases_along_the_ego_braking(
            gap in 0.0f32..150.0, vl in 0.0f32..35.0, ve in 0.0f32..35.0,
            bl in 1.0f32..9.0, beta in 1.0f32..9.0,
            leader in proptest::collection::vec(-1.0f32..1.0, 50),
        ) {
            let m = model(bl, beta, 0.0, 0.0);
            let (mut g, mut l, mut e) = (gap, vl, ve);
            let start = front_value(g, l, e, &m);
            let h = 0.02f32;
            for &u in &leader {
                // The leader's acceleration in [-b_L, 2], held for 20 ms (speeds >= 0).
                let al = if u < 0.0 { u * bl } else { 2.0 * u };
                let nl = (l + al * h).clamp(0.0, 35.0);
                let ne = (e - beta * h).max(0.0);
                // Exact distances for the held accelerations, stopping at zero speed.
                let dl = if l + al * h < 0.0 { l * l / (2.0 * -al) } else { 0.5 * (l + nl) * h };
                let de = if e - beta * h < 0.0 { e * e / (2.0 * beta) } else { 0.5 * (e + ne) * h };
                g += dl - de;
                l = nl;
                e = ne;
                let now = front_value(g, l, e, &m);
                prop_assert!(now >= start - 1e-3 * (1.0 + start.abs()), "{} after {} at {:?} from {:?} m {:?}", now, start, (g, l, e), (gap, vl, ve), m);
            }
        }
    }
}
