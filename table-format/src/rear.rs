//! The rear gap in closed form against a follower that reacts like a person: the smallest gap
//! behind the ego when the ego brakes at a given level from now and the follower notices only
//! after its reaction time, and the hardest braking the follower therefore allows the ego.
//!
//! # Why
//! The split certificate's rear table is solved against the paper's IDM follower, which brakes
//! the instant the gap closes: it certifies a follower 0.1 m behind at equal speeds, and so lets
//! the ego brake at its whole band there. A driver needs time to see the ego's brake lights and
//! to move a foot: UN R157's careful driver takes 0.4 s to perceive and 0.75 s to brake, 1.15 s
//! in all, then reaches 0.774 g over 0.6 s. Against such a follower, how hard the ego may brake
//! depends on the gap behind it: the trade-off the paper's three-car game is about, one seat
//! further.
//!
//! # The model and why its value is [`front_value`] with the roles swapped
//! The ego brakes at `b` from now; the follower keeps an acceleration of at most
//! `reaction_acceleration` for `reaction_time`, then its braking builds up at `jerk` to
//! `braking` and stays there until it stops. The rear gap is the front gap of the pair (ego
//! ahead, follower behind), so its smallest value is the front game's closed form with the ego
//! as the car ahead braking at `b` and the follower as the car behind with a response, a ramp
//! and a braking level ([`FrontModel`]): [`rear_gap`] calls [`front_value`] so. Every ego that
//! brakes no harder than `b` covers at least the distance of the step to `b` at every instant
//! (a braking that builds up over time is one of them), and every follower that reacts no later
//! and brakes no less covers at most the distance of the model at every instant; so the closed
//! form is the least gap over all of them. The property tests check it against brute-force
//! integration, and that an ego whose braking builds up at a finite jerk keeps a larger gap.
//!
//! # What it does not claim
//! It is the gap from one moment on, for one braking started at that moment: the follower's
//! reaction clock starts when the ego's braking does. An ego that brakes, releases and brakes
//! again restarts nothing in a real driver's head, and nothing here argues invariance across
//! such a sequence; a certificate built on it must carry the braking's start in its state (as
//! the firmware's braking ramp carries its own start).

use crate::front::{front_value, FrontModel};

/// A follower that reacts after a delay, then brakes with a bounded build-up. All in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReactingFollower {
    /// How long the follower keeps its acceleration after the ego starts braking, s.
    pub reaction_time: f32,
    /// Its largest acceleration during the reaction, m/s^2 (0: it holds its speed).
    pub reaction_acceleration: f32,
    /// Its braking once it reacts, m/s^2 (positive).
    pub braking: f32,
    /// How fast its braking builds up, m/s^3 (positive; `f32::INFINITY`: at once).
    pub jerk: f32,
    /// The largest speed of any car, m/s (the ego's speed is taken in `[0, max_speed]`).
    pub max_speed: f32,
}

impl ReactingFollower {
    /// UN R157's careful driver: 0.4 s to perceive and 0.75 s to brake (1.15 s in which its
    /// speed is held), then 0.774 g (7.59 m/s^2) reached over 0.6 s (12.65 m/s^3), speeds up
    /// to `max_speed`.
    pub const fn careful_driver(max_speed: f32) -> Self {
        ReactingFollower {
            reaction_time: 1.15,
            reaction_acceleration: 0.0,
            braking: 0.774 * 9.81,
            jerk: 0.774 * 9.81 / 0.6,
            max_speed,
        }
    }

    /// The follower as the car behind in the front game's closed form.
    fn as_car_behind(&self, ego_braking: f32) -> FrontModel {
        FrontModel {
            leader_braking: ego_braking,
            ego_braking: self.braking,
            response_time: self.reaction_time,
            response_acceleration: self.reaction_acceleration,
            ramp_from: self.reaction_acceleration,
            jerk: self.jerk,
            max_speed: self.max_speed,
        }
    }
}

/// The smallest gap (m) behind an ego at `ego_speed` braking at `ego_braking` (m/s^2, positive)
/// from now, to a `follower` `gap` metres behind at `follower_speed`, both down to standstill
/// (module docs). Non-decreasing in `gap` and `ego_speed`, non-increasing in `ego_braking` and
/// `follower_speed`. NaN in, NaN out.
pub fn rear_gap(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    ego_braking: f32,
    follower: &ReactingFollower,
) -> f32 {
    front_value(
        gap,
        ego_speed,
        follower_speed,
        &follower.as_car_behind(ego_braking),
    )
}

/// The hardest braking in `[0, ceiling]` (m/s^2) the `follower` allows the ego: the largest
/// found whose [`rear_gap`] stays above `margin` (m), within 1e-3 m/s^2 of the largest there is;
/// `None` when not even holding the ego's speed (braking 0) keeps the gap above `margin`.
/// Whatever is returned passed [`rear_gap`] itself.
pub fn allowed_braking(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    follower: &ReactingFollower,
    margin: f32,
    ceiling: f32,
) -> Option<f32> {
    let keeps = |b: f32| rear_gap(gap, ego_speed, follower_speed, b, follower) > margin;
    if !keeps(0.0) {
        return None;
    }
    if keeps(ceiling) {
        return Some(ceiling);
    }
    let (mut lo, mut hi) = (0.0f32, ceiling);
    // 2^-14 of a ceiling of at most a few g: below 1e-3 m/s^2.
    for _ in 0..14 {
        let mid = 0.5 * (lo + hi);
        if keeps(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The smallest rear gap by brute-force integration (f64, 0.1 ms steps), the ego's braking
    /// building up at `ego_jerk` (infinite: at once) to `ego_braking` from now, the follower
    /// holding `reaction_acceleration` for its reaction, then ramping at its jerk to its
    /// braking; both to standstill.
    fn simulated(
        gap: f64,
        ve: f64,
        vf: f64,
        ego_braking: f64,
        ego_jerk: f64,
        f: &ReactingFollower,
    ) -> f64 {
        let dt = 1e-4;
        let (mut g, mut ve, mut vf, mut t) = (gap, ve.clamp(0.0, f64::from(f.max_speed)), vf, 0.0);
        let mut least = g;
        let (rho, ar) = (
            f64::from(f.reaction_time),
            f64::from(f.reaction_acceleration),
        );
        let (bf, jf) = (f64::from(f.braking), f64::from(f.jerk));
        while ve > 0.0 || vf > 0.0 || t <= rho + ar.max(0.0) / jf {
            let mid = t + 0.5 * dt;
            let ae = -(ego_jerk * mid).min(ego_braking);
            let af = if mid < rho {
                ar
            } else {
                (ar - jf * (mid - rho)).max(-bf)
            };
            let ne = (ve + ae * dt).max(0.0);
            let nf = (vf + af * dt).max(0.0);
            g += 0.5 * (ve + ne) * dt - 0.5 * (vf + nf) * dt;
            ve = ne;
            vf = nf;
            t += dt;
            least = least.min(g);
            if t > 200.0 {
                break;
            }
        }
        least
    }

    fn follower(rho: f32, ar: f32, bf: f32, jf: f32) -> ReactingFollower {
        ReactingFollower {
            reaction_time: rho,
            reaction_acceleration: ar,
            braking: bf,
            jerk: jf,
            max_speed: 35.0,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// The closed form against brute force, the ego braking at once.
        #[test]
        fn matches_brute_force_integration(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.0f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            bf in 3.0f32..9.0, jf in 5.0f32..30.0,
        ) {
            let f = follower(rho, ar, bf, jf);
            let exact = rear_gap(gap, ve, vf, b, &f);
            let brute = simulated(
                f64::from(gap), f64::from(ve), f64::from(vf), f64::from(b), f64::INFINITY, &f,
            );
            prop_assert!(
                (f64::from(exact) - brute).abs() < 0.01 * (1.0 + brute.abs() * 1e-3),
                "{} vs {}", exact, brute
            );
        }

        /// An ego whose braking builds up at a finite jerk keeps at least the closed form's gap
        /// (the step is the hardest braking the level allows).
        #[test]
        fn bounds_an_ego_whose_braking_builds_up(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, ego_jerk in 2.0f64..40.0, rho in 0.0f32..2.0,
        ) {
            let f = follower(rho, 0.0, 7.0, 12.0);
            let exact = rear_gap(gap, ve, vf, b, &f);
            let brute = simulated(
                f64::from(gap), f64::from(ve), f64::from(vf), f64::from(b), ego_jerk, &f,
            );
            prop_assert!(brute >= f64::from(exact) - 0.01, "{} vs {}", exact, brute);
        }

        /// What `allowed_braking` returns keeps the margin, and a braking 0.01 m/s^2 harder
        /// does not (unless it is the ceiling).
        #[test]
        fn the_allowed_braking_is_the_largest_that_keeps_the_margin(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            rho in 0.0f32..2.0, margin in 0.0f32..2.0,
        ) {
            let f = follower(rho, 0.0, 7.59, 12.65);
            match allowed_braking(gap, ve, vf, &f, margin, 10.0) {
                None => prop_assert!(rear_gap(gap, ve, vf, 0.0, &f) <= margin),
                Some(b) => {
                    prop_assert!(rear_gap(gap, ve, vf, b, &f) > margin);
                    if b < 10.0 {
                        prop_assert!(rear_gap(gap, ve, vf, b + 0.01, &f) <= margin + 1e-3);
                    }
                }
            }
        }
    }

    /// A follower at the IDM's closest time gap (1 s: 30 m + 2 m at 30 m/s), both at 30 m/s.
    /// By hand: the follower gains on the ego until it stops, so the smallest gap is at the end,
    /// `32 + 900 / (2 b) - d_f`, with `d_f` the follower's distance to standstill.
    /// - Holding its speed 1.15 s, then braking at 6 m/s^2 at once: `d_f = 34.5 + 75 = 109.5` m,
    ///   so `b < 450 / 77.5 = 5.806` m/s^2.
    /// - R157's careful driver (then 7.59 m/s^2 reached over 0.6 s): `d_f = 34.5 + 17.545 +
    ///   27.723^2 / 15.18 = 102.67` m, so `b < 450 / 70.67 = 6.368` m/s^2.
    ///
    /// Either is far below a car's 8 m/s^2.
    #[test]
    fn a_follower_one_second_behind_allows_the_braking_worked_out_by_hand() {
        let at_once = follower(1.15, 0.0, 6.0, f32::INFINITY);
        let b = allowed_braking(32.0, 30.0, 30.0, &at_once, 0.0, 12.0).unwrap();
        assert!((b - 5.806).abs() < 0.005, "{b}");
        let careful = ReactingFollower::careful_driver(35.0);
        let b = allowed_braking(32.0, 30.0, 30.0, &careful, 0.0, 12.0).unwrap();
        assert!((b - 6.368).abs() < 0.005, "{b}");
        // An instant follower (the paper's IDM at its clip) allows the whole band 0.1 m behind;
        // one that reacts after 1.15 s allows only what loses less than 0.1 m: `b 1.15^2 / 2`
        // in the reaction, then `(1.15 b)^2 / (2 (6 - b))` until the speeds are equal, so
        // `b = 0.1472`.
        let instant = follower(0.0, 0.0, 6.0, f32::INFINITY);
        assert_eq!(
            allowed_braking(0.1, 30.0, 30.0, &instant, 0.0, 6.0),
            Some(6.0)
        );
        let b = allowed_braking(0.1, 30.0, 30.0, &at_once, 0.0, 12.0).unwrap();
        assert!((b - 0.1472).abs() < 0.0005, "{b}");
        // A faster follower that reacts late is hit even by an ego holding its speed.
        assert_eq!(allowed_braking(1.0, 20.0, 25.0, &at_once, 0.0, 12.0), None);
    }
}
