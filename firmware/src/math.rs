//! The firmware's float arithmetic, in one place, so that host tests run exactly the code the
//! target runs. On a host, `x.abs()` or `x.sqrt()` would silently pick std's methods over
//! micromath's; everything here calls micromath (or plain IEEE operations) explicitly.
//!
//! The controller needs comparisons, products and sums, `abs`, and one square root (the law's
//! approach speed to a stopped car), which is correctly rounded ([`sqrt`]); nothing here
//! uses micromath's approximate `powf` or `sqrt`.

use micromath::F32Ext;

/// `|x|` (exact: micromath clears the sign bit).
#[inline]
pub fn abs(x: f32) -> f32 {
    F32Ext::abs(x)
}

/// `x` limited to `[lo, hi]`; NaN maps to `lo` (the callers pass finite values; this keeps a
/// slip from becoming a NaN command).
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x >= lo {
        if x <= hi {
            x
        } else {
            hi
        }
    } else {
        lo
    }
}

/// The smaller of two values (the first if either is NaN).
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

/// The larger of two values (the first if either is NaN).
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// `sqrt(x)`, correctly rounded; NaN below zero ([`table_format::math::sqrt`]: the FPU's
/// instruction on the target, libm's on a host, the same bits).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    table_format::math::sqrt(x)
}

/// Whether `x` is neither NaN nor infinite.
#[inline]
pub fn is_finite(x: f32) -> bool {
    x.is_finite()
}

/// `seconds` as whole microseconds, rounded up (a bound on a time stays a bound); `None`
/// unless it is finite and within `0..=4,000` s (the float-to-integer cast is range-checked).
#[inline]
pub fn micros(seconds: f32) -> Option<u64> {
    if !(is_finite(seconds) && (0.0..=4_000.0).contains(&seconds)) {
        return None;
    }
    let us = libm::ceilf(seconds * 1e6);
    // In range (checked above: finite, at most 4e9): the cast truncates nothing.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let us = us as u64;
    Some(us)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helpers_handle_nan_and_infinities() {
        assert_eq!(clamp(f32::NAN, -2.0, 2.0), -2.0);
        assert_eq!(clamp(5.0, -2.0, 2.0), 2.0);
        assert_eq!(clamp(-5.0, -2.0, 2.0), -2.0);
        assert!(!is_finite(f32::NAN) && !is_finite(f32::INFINITY) && is_finite(-3.0));
        assert_eq!(abs(-0.5), 0.5);
        assert_eq!(min(1.0, 2.0), 1.0);
        assert_eq!(micros(0.1), Some(100_000));
        assert_eq!(micros(1.5e-6), Some(2));
        assert_eq!(micros(0.0), Some(0));
        assert_eq!(micros(f32::INFINITY), None);
        assert_eq!(micros(f32::NAN), None);
        assert_eq!(micros(-1e-3), None);
    }
}
