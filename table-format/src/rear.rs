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
//! # The reaction clock, and why a certificate built on it is invariant
//! The follower reacts to a braking that it has seen for `reaction_time`: [`rear_gap_after`]
//! takes how long the ego has been braking (`braking_for`, from the moment its braking took
//! effect: its brake lights, so a command's dead time is not part of it) and evaluates the
//! model from the middle of the follower's reaction, or from inside its build-up. Write
//! `G(t) = rear_gap_after(state(t), b, t - t_0)` for an ego that has braked at most at `b` since
//! `t_0`, and `X` for the model's extremal pair from `state(t_0)` (the ego braking at `b` at
//! once, the follower at its model's bound). Then, for every `t >= t_0`:
//! - `X`'s continuation from `X(t)`, evaluated with the clock at `t - t_0`, is `X` itself (the
//!   model is written in absolute time from `t_0`), so `G` evaluated at `X(t)` is the least gap
//!   of `X` after `t`, which is at least its least gap after `t_0`: `G(t_0)`;
//! - the true state at `t` has a gap at least `X(t)`'s, an ego at least as fast and a follower
//!   no faster (each car covered, and kept, at least the extremal's margin at every instant),
//!   and the closed form is non-decreasing in the gap and the ego's speed and non-increasing in
//!   the follower's;
//!
//! so `G(t) >= G(t_0)` along every admissible episode while the braking lasts: a state
//! certified by `G` stays certified, and its gap stays above `G(t_0)`. The property test
//! `never_decreases_along_an_admissible_braking` checks it by integrating random admissible
//! episodes.
//!
//! A **release** ends the braking, and the model then assumes nothing of the follower but its
//! `reaction_acceleration`: the clock restarts at zero with the next braking (a fresh reaction,
//! the least the follower can be credited with), and nothing makes `G` invariant across the
//! release. A controller built on it may release only into a state that the fresh clock
//! certifies at the braking it will need next: an authority is kept until a lower one
//! certifies. The property test `a_release_restarts_the_clock` checks that the restarted
//! clock still bounds the gap from below after a release in which the follower accelerated.

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
    rear_gap_after(gap, ego_speed, follower_speed, ego_braking, 0.0, follower)
}

/// [`rear_gap`] for an ego that has been braking for `braking_for` seconds (module docs: the
/// reaction clock): the follower's reaction already that far under way. `braking_for` at or
/// below zero, or NaN, is a braking that starts now (the least credit); at or beyond the
/// reaction and the follower's build-up, the follower is braking at its level. Non-decreasing
/// in `braking_for`.
pub fn rear_gap_after(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    ego_braking: f32,
    braking_for: f32,
    follower: &ReactingFollower,
) -> f32 {
    // (`>` is false for NaN: a NaN clock gets no credit.)
    let elapsed = if braking_for > 0.0 { braking_for } else { 0.0 };
    let mut car_behind = follower.as_car_behind(ego_braking);
    let left = follower.reaction_time - elapsed;
    if left > 0.0 {
        car_behind.response_time = left;
    } else {
        car_behind.response_time = 0.0;
        if follower.jerk.is_finite() {
            // Into the build-up by `-left` seconds; past its end the ramp's start is below
            // `-braking` and the closed form brakes at the level at once.
            car_behind.ramp_from = follower.reaction_acceleration + follower.jerk * left;
        }
    }
    front_value(gap, ego_speed, follower_speed, &car_behind)
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

    /// The extremal pair by brute force (f64, 0.1 ms steps), the ego braking at `b` at once,
    /// from `(gap, ve, vf)`: the state at `split` seconds, and the least gap from `split` on.
    fn extremal_after(
        (gap, ve, vf): (f64, f64, f64),
        b: f64,
        f: &ReactingFollower,
        split: f64,
    ) -> ((f64, f64, f64), f64) {
        let dt = 1e-4;
        let (mut g, mut ve, mut vf, mut t) = (gap, ve.clamp(0.0, f64::from(f.max_speed)), vf, 0.0);
        let (rho, ar) = (
            f64::from(f.reaction_time),
            f64::from(f.reaction_acceleration),
        );
        let (bf, jf) = (f64::from(f.braking), f64::from(f.jerk));
        let mut at_split = None;
        let mut least = f64::INFINITY;
        loop {
            if at_split.is_none() && t >= split - 0.5 * dt {
                at_split = Some((g, ve, vf));
            }
            if at_split.is_some() {
                least = least.min(g);
                if (ve <= 0.0 && vf <= 0.0 && t > rho) || t > 200.0 {
                    break;
                }
            }
            let mid = t + 0.5 * dt;
            let af = if mid < rho {
                ar
            } else {
                (ar - jf * (mid - rho)).max(-bf)
            };
            let ne = (ve - b * dt).max(0.0);
            let nf = (vf + af * dt).max(0.0);
            g += 0.5 * (ve + ne) * dt - 0.5 * (vf + nf) * dt;
            ve = ne;
            vf = nf;
            t += dt;
        }
        (at_split.unwrap_or((g, ve, vf)), least)
    }

    /// One admissible episode by integration (1 ms steps) for `seconds`: the ego's
    /// acceleration drawn in `[-b, 1]` while it brakes (`[0, 1]` while released), the
    /// follower's at most `reaction_acceleration` until `reaction_time` into each braking and
    /// at most its build-up after, at least -9 m/s^2 (it may brake harder than its model),
    /// each held for 50 ms. `released` says when the ego is not braking. Calls `visit` every
    /// 10 ms with the state and the clock; returns the least gap.
    #[allow(clippy::too_many_arguments)]
    fn admissible_episode(
        (gap, ve, vf): (f32, f32, f32),
        b: f32,
        f: &ReactingFollower,
        draws: &[(f32, f32)],
        released: impl Fn(f32) -> bool,
        seconds: f32,
        mut visit: impl FnMut(f32, (f32, f32, f32), f32),
    ) -> f32 {
        let dt = 1e-3f64;
        let (mut g, mut e, mut fv) = (f64::from(gap), f64::from(ve), f64::from(vf));
        let mut clock = 0.0f64;
        let mut least = g;
        let steps = (f64::from(seconds) / dt).round() as usize;
        for k in 0..steps {
            let t = k as f64 * dt;
            if k % 10 == 0 {
                visit(t as f32, (g as f32, e as f32, fv as f32), clock as f32);
            }
            let (ue, uf) = draws[(k / 50) % draws.len()];
            let off = released(t as f32);
            let ae = if off {
                f64::from(ue.abs())
            } else if ue < 0.0 {
                f64::from(ue * b)
            } else {
                f64::from(ue)
            };
            let bound = if off || clock < f64::from(f.reaction_time) {
                f64::from(f.reaction_acceleration)
            } else if f.jerk.is_finite() {
                (f64::from(f.reaction_acceleration)
                    - f64::from(f.jerk) * (clock - f64::from(f.reaction_time)))
                .max(-f64::from(f.braking))
            } else {
                -f64::from(f.braking)
            };
            // `uf` in [0, 1] picks between -9 and the bound.
            let af = bound - f64::from(uf) * (bound + 9.0).max(0.0);
            let ne = (e + ae * dt).clamp(0.0, f64::from(f.max_speed));
            let nf = (fv + af * dt).max(0.0);
            g += 0.5 * (e + ne) * dt - 0.5 * (fv + nf) * dt;
            e = ne;
            fv = nf;
            clock = if off { 0.0 } else { clock + dt };
            least = least.min(g);
        }
        least as f32
    }

    fn draws() -> impl Strategy<Value = Vec<(f32, f32)>> {
        proptest::collection::vec((-1.0f32..1.0, 0.0f32..1.0), 40)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The clock mid-reaction or mid-build-up against brute force: the extremal pair's state
        /// `split` seconds into the braking, evaluated with the clock at `split`, gives the
        /// extremal's least gap from then on.
        #[test]
        fn the_clock_matches_brute_force_from_inside_the_reaction(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            bf in 3.0f32..9.0, jf in 5.0f32..30.0, split in 0.0f64..3.0,
        ) {
            let f = follower(rho, ar, bf, jf);
            let (state, least) = extremal_after(
                (f64::from(gap), f64::from(ve), f64::from(vf)), f64::from(b), &f, split,
            );
            let exact = rear_gap_after(
                state.0 as f32, state.1 as f32, state.2 as f32, b, split as f32, &f,
            );
            prop_assert!(
                (f64::from(exact) - least).abs() < 0.01 * (1.0 + least.abs() * 1e-3),
                "{} vs {} at {:?}", exact, least, state
            );
        }

        /// More time braking never lowers the value.
        #[test]
        fn the_value_never_falls_as_the_clock_runs(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.0f32..2.0, t in 0.0f32..3.0, dt in 0.0f32..1.0,
        ) {
            let f = follower(rho, 0.5, 7.59, 12.65);
            let early = rear_gap_after(gap, ve, vf, b, t, &f);
            let late = rear_gap_after(gap, ve, vf, b, t + dt, &f);
            prop_assert!(late >= early - 1e-3 * (1.0 + early.abs()), "{} then {}", early, late);
        }

        /// The invariance (module docs): along every admissible episode of a braking that
        /// lasts, the value with the clock never falls below its start by more than rounding,
        /// and the gap never falls below it.
        #[test]
        fn never_decreases_along_an_admissible_braking(
            gap in 0.0f32..80.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            draws in draws(),
        ) {
            let f = follower(rho, ar, 7.59, 12.65);
            let start = rear_gap_after(gap, ve, vf, b, 0.0, &f);
            let tolerance = 2e-3 * (1.0 + start.abs());
            let mut visited = Vec::new();
            let least = admissible_episode((gap, ve, vf), b, &f, &draws, |_| false, 8.0,
                |_, (g, e, v), clock| visited.push((g, rear_gap_after(g, e, v, b, clock, &f))));
            let low = visited.iter().map(|p| p.1).fold(f32::INFINITY, f32::min);
            prop_assert!(low >= start - tolerance, "{} after {}", low, start);
            prop_assert!(least >= start - tolerance, "gap {} below {}", least, start);
            // And each value bounds the gaps after it (the clock gives no more credit than the
            // follower's reaction has earned).
            let mut after = f32::INFINITY;
            for &(g, value) in visited.iter().rev() {
                after = after.min(g);
                prop_assert!(after >= value - 2e-3 * (1.0 + value.abs()) - 0.02, "gap {} below {}", after, value);
            }
        }

        /// A release restarts the clock: after a release in which the follower accelerated at
        /// its bound, the fresh clock still bounds the rest of the episode's gap from below
        /// (a clock carried across the release would not; see the next test).
        #[test]
        fn a_release_restarts_the_clock(
            gap in 0.0f32..80.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.3f32..2.0,
            release in 0.2f32..3.0, length in 0.1f32..2.0,
            draws in draws(),
        ) {
            let f = follower(rho, 1.0, 7.59, 12.65);
            let again = release + length;
            let mut fresh = None;
            let mut after = f32::INFINITY;
            admissible_episode((gap, ve, vf), b, &f, &draws,
                |t| t >= release && t < again, 10.0,
                |t, (g, e, v), clock| {
                    if t >= again {
                        if fresh.is_none() {
                            fresh = Some(rear_gap_after(g, e, v, b, clock, &f));
                        }
                        after = after.min(g);
                    }
                });
            if let Some(fresh) = fresh {
                prop_assert!(after >= fresh - 2e-3 * (1.0 + fresh.abs()), "gap {} below {}", after, fresh);
            }
        }
    }

    /// Why the clock must restart: carried across a release, it credits the follower with a
    /// reaction to a braking it no longer sees. Both at 30 m/s, 20 m apart; the ego brakes at
    /// 6 m/s^2 for 1.5 s, releases for 2 s, then brakes again. A follower that accelerates at
    /// +1 m/s^2 while the ego does not brake, and reacts 1.15 s after the second braking,
    /// comes closer than the value with the old clock (3.5 s) promises; the fresh clock's value
    /// is below what it does.
    #[test]
    fn a_clock_carried_across_a_release_is_unsound() {
        let f = follower(1.15, 1.0, 7.59, 12.65);
        let b = 6.0;
        let (release, again) = (1.5f32, 3.5f32);
        let mut at_again = None;
        let mut after = f32::INFINITY;
        // The ego brakes at `b` while braking (draw -1) and holds its speed while released
        // (draw 0 is no acceleration); the follower at its bound (draw 0).
        let draws = [(-1.0f32, 0.0f32)];
        admissible_episode(
            (120.0, 30.0, 30.0),
            b,
            &f,
            &draws,
            |t| t >= release && t < again,
            12.0,
            |t, state, clock| {
                if t >= again {
                    at_again.get_or_insert((state, clock));
                    after = after.min(state.0);
                }
            },
        );
        let ((g, e, v), clock) = at_again.unwrap();
        assert!(clock < 0.011, "{clock}");
        let carried = rear_gap_after(g, e, v, b, again, &f);
        let fresh = rear_gap_after(g, e, v, b, clock, &f);
        assert!(after > 0.0, "{after}");
        assert!(carried > after + 1.0, "carried {carried}, gap {after}");
        assert!(fresh <= after + 0.05, "fresh {fresh}, gap {after}");
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
