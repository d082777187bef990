//! The Intelligent Driver Model (Treiber, Hennecke & Helbing, 2000), written once: the point
//! form the games solve with and the simulations drive, and the interval form the proof
//! bounds a box with, side by side, so that a change to the model is one change.
//!
//! `g = a (1 - (v / v0)^delta - (s* / s)^2)`, `s* = s0 + max(0, v T + v dv / (2 sqrt(a b)))`,
//! for a vehicle at speed `v >= 0`, `s` metres behind its leader, approaching it at
//! `dv = v - v_leader`, with desired time gap `T`.
//!
//! For `v >= 0`, `g` is non-increasing in `T` (`s*` grows with `T` at rate `v >= 0` where the
//! max is active, and `(s*/s)^2` grows with `s* >= 0`) and non-increasing in `v` at a fixed
//! approach rate (`(v/v0)^delta` grows, and `s* - s0 = max(0, v (T + dv / (2 sqrt(ab))))` is
//! non-decreasing in `v`). The exponent is applied by squaring, exact for integers (and the
//! same sequence of products as `powi`).

use crate::IdmParameters;

/// Outward widening of every bound the interval form computes (relative and absolute), so that
/// it stays sound under `f64` rounding.
pub const WIDEN: f64 = 1e-9;

/// `x` lowered by [`WIDEN`] (relative and absolute).
#[inline(always)]
pub fn widen_down(x: f64) -> f64 {
    x - WIDEN * (1.0 + x.abs())
}

/// `x` raised by [`WIDEN`] (relative and absolute).
#[inline(always)]
pub fn widen_up(x: f64) -> f64 {
    x + WIDEN * (1.0 + x.abs())
}

macro_rules! power {
    ($name:ident, $squaring:ident, $t:ty) => {
        /// `x^n` by squaring (`n >= 0`): the products `powi` makes with an exponent known only
        /// at run time (compiler-rt's `__powisf2`, the same products in the same order; the
        /// test `the_point_forms_agree_and_match_the_formula` checks it), for targets without
        /// `std`.
        #[cfg_attr(feature = "std", allow(dead_code))]
        #[inline(always)]
        fn $squaring(x: $t, n: u8) -> $t {
            let (mut base, mut e, mut out): ($t, u8, $t) = (x, n, 1.0);
            while e > 0 {
                if e & 1 == 1 {
                    out *= base;
                }
                e >>= 1;
                if e > 0 {
                    base *= base;
                }
            }
            out
        }

        /// `x^n`: `powi` with `std`, by squaring without; the same result either way.
        #[inline(always)]
        fn $name(x: $t, n: u8) -> $t {
            #[cfg(feature = "std")]
            {
                x.powi(i32::from(n))
            }
            #[cfg(not(feature = "std"))]
            {
                $squaring(x, n)
            }
        }
    };
}
power!(power_f32, squaring_f32, f32);
power!(power_f64, squaring_f64, f64);

/// The square root, correctly rounded either way: the instruction (which the solver's loops
/// vectorise) with `std`, [`crate::math::sqrt`] without.
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    #[cfg(feature = "std")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "std"))]
    {
        crate::math::sqrt(x)
    }
}

/// [`sqrt_f32`] in `f64`.
#[inline(always)]
fn sqrt_f64(x: f64) -> f64 {
    #[cfg(feature = "std")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "std"))]
    {
        libm::sqrt(x)
    }
}

/// The point form, once, for each float type.
macro_rules! point_form {
    ($t:ty, $power:ident, $sqrt:path, $a:expr, $b:expr, $v0:expr, $s0:expr, $delta:expr,
     $speed:ident, $approach:ident, $gap:ident, $time_gap:ident) => {{
        let a: $t = $a;
        let ab2 = 2.0 * $sqrt(a * $b);
        let desired = $s0 + ($speed * $time_gap + $speed * $approach / ab2).max(0.0);
        let interaction = if $gap > 0.0 {
            let r = desired / $gap;
            r * r
        } else if desired > 0.0 {
            <$t>::INFINITY
        } else {
            0.0
        };
        a * (1.0 - $power($speed / $v0, $delta) - interaction)
    }};
}

impl IdmParameters {
    /// Treiber & Kesting's highway parameters (*Traffic Flow Dynamics*, Table 11.2): `a`
    /// 1.0 m/s^2, `b` 1.5 m/s^2, `v0` 33.3 m/s, `delta` 4, `s0` 2 m.
    pub const HIGHWAY: IdmParameters = IdmParameters {
        max_acceleration: 1.0,
        comfortable_deceleration: 1.5,
        desired_speed: 33.3,
        exponent: 4,
        jam_distance: 2.0,
    };

    /// The IDM acceleration of a vehicle at speed `speed` (>= 0), `gap` metres behind its
    /// leader, approaching it at `approach_rate = speed - leader_speed`, with desired time gap
    /// `time_gap` (module docs). A gap of zero or less with a positive desired gap gives
    /// `-inf` (the caller clips).
    #[inline(always)]
    pub fn acceleration(&self, speed: f32, approach_rate: f32, gap: f32, time_gap: f32) -> f32 {
        point_form!(
            f32,
            power_f32,
            sqrt_f32,
            self.max_acceleration,
            self.comfortable_deceleration,
            self.desired_speed,
            self.jam_distance,
            self.exponent,
            speed,
            approach_rate,
            gap,
            time_gap
        )
    }

    /// [`IdmParameters::acceleration`] in `f64`, the proof's arithmetic.
    pub fn acceleration_f64(&self, speed: f64, approach_rate: f64, gap: f64, time_gap: f64) -> f64 {
        point_form!(
            f64,
            power_f64,
            sqrt_f64,
            f64::from(self.max_acceleration),
            f64::from(self.comfortable_deceleration),
            f64::from(self.desired_speed),
            f64::from(self.jam_distance),
            self.exponent,
            speed,
            approach_rate,
            gap,
            time_gap
        )
    }

    /// The fastest an IDM vehicle can make itself (m/s) while its gap stays at most
    /// `gap_bound` (m) and the car ahead drives at most at `leader_speed_bound` (m/s), its
    /// desired time gap anywhere at or above `min_time_gap` (s) at every instant, if it may
    /// hold an acceleration it once had for up to `hold` seconds (zero: it drives by its IDM
    /// at every instant; a driver who keeps the acceleration it had when it sees brake lights
    /// for its reaction time, as `table_format::rear`'s late follower, holds): the vehicle's
    /// speed stays at most the larger of its speed at the start and this, where the gap has
    /// been at most `gap_bound` from `hold` seconds before the start on. `+inf` where anything
    /// is NaN or infinite, or `hold` is negative.
    ///
    /// **Derivation.** With `c = 2 sqrt(a b)`, `v >= 0`, `T >= T_min` and `v_l <= V` (the
    /// leader's speed bound), the desired gap is `s* = s0 + max(0, v T + v (v - v_l) / c)`,
    /// at least `s0 + k v + v^2 / c` with `k = T_min - V / c`. A positive IDM acceleration
    /// needs `(s*/s)^2 < 1 - (v / v0)^delta <= 1`, so `s* < s <= S` (the gap bound), so
    /// `v^2 / c + k v < S - s0`: `v` is below the quadratic's positive root,
    /// `v_cap = c (sqrt(k^2 + 4 (S - s0) / c) - k) / 2`, and no positive acceleration comes at
    /// all where `S <= s0`.
    /// At or above `v_cap` the acceleration is at most zero, and the clip keeps it so. So along
    /// any motion with the gap at most `S` the speed cannot rise above `max(v(0), v_cap)`:
    /// after the last time it was at or below that, it is above `v_cap` and does not grow. A
    /// held acceleration was the IDM's at the hold's start: positive only where the speed was
    /// below `v_cap` then, and at most `a (1 - (s0 / S)^2)` (`s* >= s0`, the gap at most `S`),
    /// so a hold of at most `hold` seconds ends at most `v_cap + a (1 - (s0 / S)^2) hold`; the
    /// IDM takes over above `v_cap` without a positive acceleration, and a hold that starts
    /// above `v_cap` holds no positive one. The property test
    /// `a_positive_idm_acceleration_comes_only_below_the_cap` checks the root where it is
    /// tight; `an_idm_follower_keeps_under_its_speed_cap` integrates IDM followers whose time
    /// gap switches at random against the whole bound.
    pub fn speed_cap(
        &self,
        min_time_gap: f32,
        gap_bound: f32,
        leader_speed_bound: f32,
        hold: f32,
    ) -> f32 {
        let c = 2.0 * sqrt_f32(self.max_acceleration * self.comfortable_deceleration);
        let finite = [min_time_gap, gap_bound, leader_speed_bound, hold, c]
            .iter()
            .all(|x| x.is_finite());
        if !(finite && hold >= 0.0) {
            return f32::INFINITY;
        }
        let room = gap_bound - self.jam_distance;
        let cap = if room > 0.0 {
            let k = min_time_gap - leader_speed_bound.max(0.0) / c;
            0.5 * c * (sqrt_f32(k * k + 4.0 * room / c) - k)
        } else {
            0.0
        };
        cap + self.acceleration_within(gap_bound) * hold
    }

    /// The largest acceleration (m/s^2, at least zero) the IDM gives a vehicle whose gap is
    /// at most `gap_bound` (m): `a (1 - (s0 / S)^2)` where the gap bound exceeds the jam
    /// distance `s0` (`s* >= s0`), zero at or below it, `a` where NaN.
    pub fn acceleration_within(&self, gap_bound: f32) -> f32 {
        let a = self.max_acceleration;
        if gap_bound.is_nan() {
            return a;
        }
        if gap_bound <= self.jam_distance {
            return 0.0;
        }
        let r = self.jam_distance / gap_bound;
        (a * (1.0 - r * r)).max(0.0)
    }

    /// The free-road term `(v / v0)^delta` at `speed`.
    pub fn free_road_term(&self, speed: f32) -> f32 {
        power_f32(speed / self.desired_speed, self.exponent)
    }

    /// Bounds `(lowest, highest)` of the (unclipped) IDM acceleration of a follower at a speed
    /// in `follower_speed` behind a leader at a speed in `leader_speed`, `gap` metres ahead,
    /// over every time gap in `time_gap` (each `(lo, hi)`), widened outward ([`WIDEN`]): a
    /// gap at or below zero gives `-inf`. Derivation: `z(v) = v T + v (v - v_l) / c`
    /// (`c = 2 sqrt(a b)`) is non-increasing in `v_l` and non-decreasing in `T` (`v >= 0`),
    /// convex in `v`: its least value at `T_min`, `v_l` highest, at the vertex clamped into the
    /// follower's range; its largest at `T_max`, `v_l` lowest, at an end. `(s*/s)^2` with
    /// `s* >= s0 > 0` is decreasing in `s > 0`, and `(v/v0)^delta` increasing in `v >= 0`.
    pub fn acceleration_bounds(
        &self,
        gap: (f64, f64),
        follower_speed: (f64, f64),
        leader_speed: (f64, f64),
        time_gap: (f64, f64),
    ) -> (f64, f64) {
        let a = f64::from(self.max_acceleration);
        let (p, q) = (follower_speed.0.max(0.0), follower_speed.1.max(0.0));
        let (r, s) = leader_speed;
        let c = 2.0 * sqrt_f64(a * f64::from(self.comfortable_deceleration));
        let z = |v: f64, t: f64, vl: f64| v * t + v * (v - vl) / c;
        let vertex = (0.5 * (s - c * time_gap.0)).clamp(p, q);
        let z_lo = z(p, time_gap.0, s)
            .min(z(q, time_gap.0, s))
            .min(z(vertex, time_gap.0, s));
        let z_hi = z(p, time_gap.1, r).max(z(q, time_gap.1, r));
        let s0 = f64::from(self.jam_distance);
        let desired_lo = widen_down(s0 + z_lo.max(0.0));
        let desired_hi = widen_up(s0 + z_hi.max(0.0));
        let v0 = f64::from(self.desired_speed);
        let (speed_lo, speed_hi) = (
            power_f64(p / v0, self.exponent),
            power_f64(q / v0, self.exponent),
        );
        let (g1, g2) = gap;
        let square = |x: f64| x * x;
        let interaction_hi = if g1 > 0.0 {
            square(desired_hi / g1)
        } else {
            f64::INFINITY
        };
        let interaction_lo = if g2 > 0.0 {
            square(desired_lo / g2)
        } else {
            f64::INFINITY
        };
        (
            widen_down(a * (1.0 - speed_hi - interaction_hi)),
            widen_up(a * (1.0 - speed_lo - interaction_lo)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// An IDM follower behind a car that brakes at `braking` from `leader_speed` to a stop,
    /// `gap` metres ahead, by brute force (f64, 1 ms steps, 8 s): its desired time gap jumps
    /// between `[t_min, t_max]`'s ends at the steps in `switches`, and from each time in
    /// `holds` it keeps the acceleration it has for `hold` seconds (a late driver seeing brake
    /// lights). Returns the largest speed and the largest gap it reached.
    #[allow(clippy::too_many_arguments)]
    fn follow(
        p: &IdmParameters,
        (gap, follower_speed, leader_speed): (f64, f64, f64),
        braking: f64,
        (t_min, t_max): (f64, f64),
        switches: &[u32],
        holds: &[f64],
        hold: f64,
    ) -> (f64, f64) {
        let dt = 1e-3;
        let (mut s, mut v, mut vl) = (gap, follower_speed, leader_speed);
        let (mut fastest, mut widest) = (v, s);
        let mut held: Option<(f64, f64)> = None;
        let mut time_gap = t_min;
        for k in 0..8000u32 {
            let t = f64::from(k) * dt;
            if switches.contains(&(k / 100)) && k % 100 == 0 {
                time_gap = if time_gap == t_min { t_max } else { t_min };
            }
            let idm = p.acceleration_f64(v, v - vl, s, time_gap).clamp(-6.0, 2.0);
            if held.is_some_and(|(until, _)| t >= until) {
                held = None;
            }
            if held.is_none() && holds.iter().any(|h| (t - h).abs() < 0.5 * dt) {
                held = Some((t + hold, idm));
            }
            let a = held.map_or(idm, |(_, a)| a);
            let al = if vl > 0.0 { -braking } else { 0.0 };
            crate::brute::advance(&mut s, &mut vl, &mut v, (al, a), dt);
            fastest = fastest.max(v);
            widest = widest.max(s);
        }
        (fastest, widest)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        /// An IDM follower, its time gap switching at random, some seeing brake lights late
        /// and holding their acceleration for 1.15 s, never drives faster than the larger of
        /// its start and [`IdmParameters::speed_cap`] for the largest gap the run reached
        /// (the car ahead stopping, that gap is at most its start plus the car's stopping
        /// distance).
        #[test]
        fn an_idm_follower_keeps_under_its_speed_cap(
            gap in 0.5f64..30.0,
            follower_speed in 0.0f64..8.0,
            leader_speed in 0.0f64..2.0,
            braking in 1.0f64..8.0,
            switches in proptest::collection::vec(0u32..80, 0..6),
            holds in proptest::collection::vec(0.0f64..3.0, 0..3),
            late in any::<bool>(),
        ) {
            let p = IdmParameters::HIGHWAY;
            let hold = if late { 1.15 } else { 0.0 };
            let holds: Vec<f64> = holds.iter().map(|h| (h * 1000.0).round() / 1000.0).collect();
            let (fastest, widest) = follow(
                &p,
                (gap, follower_speed, leader_speed),
                braking,
                (1.0, 2.0),
                &switches,
                if late { &holds } else { &[] },
                hold,
            );
            let bound = gap + leader_speed * leader_speed / (2.0 * braking);
            prop_assert!(widest <= bound + 1e-6, "{widest} > {bound}");
            // The lemma holds for any bound of the gap over the run: the tightest is the
            // widest gap it reached.
            let cap = p.speed_cap(1.0, widest as f32, leader_speed as f32, hold as f32);
            prop_assert!(
                fastest <= follower_speed.max(f64::from(cap)) + 1e-3,
                "{fastest} above {follower_speed} and {cap}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20000))]

        /// The derivation's two steps at a point, where they are tight: a positive IDM
        /// acceleration comes only below the cap for the gap it has, and is at most
        /// [`IdmParameters::acceleration_within`] that gap (equal at rest behind a car at
        /// rest).
        #[test]
        fn a_positive_idm_acceleration_comes_only_below_the_cap(
            speed in 0.0f32..10.0,
            leader_speed in 0.0f32..2.4,
            gap in 0.1f32..20.0,
            time_gap in 1.0f32..3.0,
        ) {
            let p = IdmParameters::HIGHWAY;
            let a = p.acceleration(speed, speed - leader_speed, gap, time_gap);
            if a > 0.0 {
                let cap = p.speed_cap(1.0, gap, leader_speed, 0.0);
                prop_assert!(speed < cap * (1.0 + 1e-5) + 1e-6, "{speed} at {a} not below {cap}");
                let within = p.acceleration_within(gap);
                prop_assert!(a <= within * (1.0 + 1e-5) + 1e-6, "{a} above {within}");
            }
        }
    }

    /// The cap at the jam distance is the speed the follower has: an IDM vehicle at rest 2 m
    /// behind a stopped car does not move; one that sees its leader pull away at up to 2 m/s
    /// with at most 2.5 m between them gets no faster than the quadratic's root (0.90 m/s),
    /// and 0.36 m/s more after a hold of a second. `+inf` for a NaN.
    #[test]
    fn the_speed_cap_at_the_jam_distance() {
        let p = IdmParameters::HIGHWAY;
        assert_eq!(p.speed_cap(1.0, 2.0, 0.0, 0.0), 0.0);
        assert_eq!(p.speed_cap(1.0, 1.5, 0.0, 1.15), 0.0);
        let c = 2.0 * 1.5f32.sqrt();
        let k = 1.0 - 2.0 / c;
        let root = 0.5 * c * ((k * k + 2.0 / c).sqrt() - k);
        let cap = p.speed_cap(1.0, 2.5, 2.0, 0.0);
        assert!(
            (cap - root).abs() < 1e-4 && (cap - 0.905).abs() < 0.005,
            "{cap}"
        );
        // On the root the desired gap is the gap bound.
        let desired = 2.0 + cap * 1.0 + cap * (cap - 2.0) / c;
        assert!((desired - 2.5).abs() < 1e-4, "{desired}");
        let held = p.speed_cap(1.0, 2.5, 2.0, 1.0);
        assert!((held - cap - (1.0 - 0.64)).abs() < 1e-4, "{held}");
        assert_eq!(p.speed_cap(f32::NAN, 2.5, 0.0, 0.0), f32::INFINITY);
        assert_eq!(p.speed_cap(1.0, f32::NAN, 0.0, 0.0), f32::INFINITY);
        assert_eq!(p.speed_cap(1.0, 2.5, 0.0, -1.0), f32::INFINITY);
        assert_eq!(p.acceleration_within(f32::NAN), 1.0);
        assert_eq!(p.acceleration_within(1.0), 0.0);
    }

    #[test]
    fn the_bounds_hold_the_point_form_over_a_box() {
        let p = IdmParameters::HIGHWAY;
        let boxes = [
            ((5.0, 6.0), (10.0, 12.0), (9.0, 13.0), (1.0, 2.0)),
            ((0.5, 0.8), (0.0, 0.4), (0.0, 0.3), (1.0, 2.0)),
            ((40.0, 60.0), (25.0, 35.0), (20.0, 35.0), (0.5, 2.5)),
        ];
        for (gap, vf, vl, t) in boxes {
            let (lo, hi) = p.acceleration_bounds(gap, vf, vl, t);
            for k in 0..=4 {
                for m in 0..=4 {
                    for n in 0..=4 {
                        for o in 0..=2 {
                            let at = |(a, b): (f64, f64), i: u32, of: u32| {
                                a + (b - a) * f64::from(i) / f64::from(of)
                            };
                            let (g, v, l, tt) =
                                (at(gap, k, 4), at(vf, m, 4), at(vl, n, 4), at(t, o, 2));
                            let x = p.acceleration_f64(v, v - l, g, tt);
                            assert!(lo <= x && x <= hi, "{x} not in [{lo}, {hi}]");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_point_forms_agree_and_match_the_formula() {
        let p = IdmParameters::HIGHWAY;
        let (v, dv, s, t) = (20.0f32, 2.0f32, 30.0f32, 1.5f32);
        let desired = 2.0 + 20.0 * 1.5 + 20.0 * 2.0 / (2.0 * (1.5f64).sqrt()) as f32;
        let expect = 1.0 - (20.0f32 / 33.3).powi(4) - (desired / 30.0).powi(2);
        assert!((p.acceleration(v, dv, s, t) - expect).abs() < 1e-5);
        let wide = p.acceleration_f64(20.0, 2.0, 30.0, 1.5);
        assert!((f64::from(p.acceleration(v, dv, s, t)) - wide).abs() < 1e-5);
        // At or below zero gap: -inf with a desired gap, the free-road term without one.
        assert_eq!(p.acceleration(5.0, 0.0, 0.0, 1.0), f32::NEG_INFINITY);
        let zero = IdmParameters {
            jam_distance: 0.0,
            ..p
        };
        assert_eq!(zero.acceleration(0.0, 0.0, 0.0, 1.0), 1.0);
        // The powers are powi's with an exponent known at run time (compiler-rt's
        // `__powisf2`, the same products in the same order).
        for x in [0.3f32, 0.99, 1.0, 0.0, 0.6006006] {
            let n = core::hint::black_box(4);
            assert_eq!(squaring_f32(x, 4), core::hint::black_box(x).powi(n), "{x}");
            let three = core::hint::black_box(3);
            assert_eq!(
                squaring_f64(f64::from(x), 3),
                core::hint::black_box(f64::from(x)).powi(three),
                "{x}"
            );
            assert_eq!(squaring_f32(x, 1), x);
            assert_eq!(squaring_f32(x, 0), 1.0);
            let (x, four) = (core::hint::black_box(x), core::hint::black_box(4u8));
            assert_eq!(power_f32(x, four), squaring_f32(x, four));
        }
    }
}
