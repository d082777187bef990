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
//! # Evaluation
//! Between events (the response ends, a car stops) both accelerations are constant and the gap
//! is a parabola in time: its smallest value on a segment is at an end or at the vertex, where
//! the relative speed changes sign from closing to opening. There are at most four segments
//! (the response ends, the leader stops, the ego stops, then nothing moves). f32 throughout; no
//! panics, no loops without a bound.

/// The front model: the leader's hardest braking, and the ego's braking level, response time,
/// acceleration during the response and speed limit. All in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrontModel {
    /// The leader's hardest braking `b_L`, m/s^2 (positive).
    pub leader_braking: f32,
    /// The ego's braking level `beta`, m/s^2 (positive).
    pub ego_braking: f32,
    /// How long the ego keeps `response_acceleration` before braking, s (zero or positive).
    pub response_time: f32,
    /// The ego's acceleration during the response, m/s^2.
    pub response_acceleration: f32,
    /// The leader's largest speed, m/s (the human's model; the ego's speed is not held by it).
    pub max_speed: f32,
}

/// The smallest gap (m) to a leader `gap` metres ahead at `leader_speed`, for an ego at
/// `ego_speed`, under [`FrontModel`]: the front game's value with constraint `l = gap`.
/// The leader's speed is taken in `[0, max_speed]`, the ego's at or above zero (module docs:
/// no speed limit holds the ego). Non-decreasing in `gap` and `leader_speed`, non-increasing
/// in `ego_speed`, `response_time` and `response_acceleration`. NaN in, NaN out.
pub fn front_value(gap: f32, leader_speed: f32, ego_speed: f32, model: &FrontModel) -> f32 {
    let vmax = model.max_speed;
    let (bl, beta) = (model.leader_braking, model.ego_braking);
    let mut g = gap;
    // (Not `f32::clamp`: it asserts its bounds are ordered, a panic path.)
    let mut vl = leader_speed.max(0.0).min(vmax);
    let mut ve = ego_speed.max(0.0);
    let mut response = model.response_time.max(0.0);
    let mut least = g;
    // Each pass ends at an event that does not recur: the response ends, the leader stops, the
    // ego stops. Five passes cover them all with one to spare.
    for _ in 0..5 {
        let al = if vl > 0.0 { -bl } else { 0.0 };
        let ae = if response > 0.0 {
            let a = model.response_acceleration;
            if a < 0.0 && ve <= 0.0 {
                0.0
            } else {
                a
            }
        } else if ve > 0.0 {
            -beta
        } else {
            0.0
        };
        // Time to each event; the segment ends at the first, and the cars whose event it is
        // are set exactly to their limit (no rounding remainder to start a spurious segment).
        let t_leader = if al < 0.0 { vl / bl } else { f32::INFINITY };
        let t_response = if response > 0.0 {
            response
        } else {
            f32::INFINITY
        };
        let t_ego = if ae < 0.0 { ve / -ae } else { f32::INFINITY };
        let len = t_leader.min(t_response).min(t_ego);
        let dv = vl - ve;
        let da = al - ae;
        // The vertex of a closing-then-opening parabola inside the segment.
        if dv < 0.0 && da > 0.0 {
            let s = -dv / da;
            if s < len {
                least = least.min(g + 0.5 * dv * s);
            }
        }
        if !len.is_finite() {
            // Nothing changes any more: both at constant speed, the ego no faster (it stops
            // or brakes whenever it moves outside the response).
            if dv < 0.0 {
                return f32::NEG_INFINITY;
            }
            break;
        }
        g += dv * len + 0.5 * da * len * len;
        vl = if len >= t_leader {
            0.0
        } else {
            (vl + al * len).max(0.0).min(vmax)
        };
        ve = if len >= t_ego {
            0.0
        } else {
            (ve + ae * len).max(0.0)
        };
        response = if len >= t_response {
            0.0
        } else {
            response - len
        };
        least = least.min(g);
    }
    if gap.is_nan() || leader_speed.is_nan() || ego_speed.is_nan() {
        return f32::NAN;
    }
    least
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
        while vl > 0.0 || ve > 0.0 {
            let ae = if t < f64::from(m.response_time) {
                f64::from(m.response_acceleration)
            } else {
                -f64::from(m.ego_braking)
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
        FrontModel {
            leader_braking: bl,
            ego_braking: beta,
            response_time: rho,
            response_acceleration: ar,
            max_speed: 35.0,
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

    /// Issue 19 (A): an ego at 34.8 m/s with 0.4 s of response at +0.8 m/s^2 reaches
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
            let m = FrontModel {
                leader_braking: bl,
                ego_braking: beta,
                response_time: dead + tau,
                response_acceleration: hold,
                max_speed: 35.0,
            };
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
