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
/// vectorise) with `std`, libm's without.
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    #[cfg(feature = "std")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "std"))]
    {
        libm::sqrtf(x)
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

    /// The point form at the corners and inside a box lies within the interval form's bounds.
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
