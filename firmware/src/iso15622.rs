//! ISO 15622's comfort limits for an ACC, as functions of the ego's speed: the one place the
//! law, the override and the host-side checks take them from.
//!
//! The normative text (ISO 15622:2018) is paywalled. The figures are those the open
//! implementations that cite it agree on (FrogPilot, sunnypilot, opendbc's Honda and GM code,
//! the ACC_W211 project's requirements):
//!
//! | quantity | at or below 5 m/s | at or above 20 m/s |
//! |---|---|---|
//! | automatic acceleration | 4.0 m/s^2 | 2.0 m/s^2 |
//! | automatic deceleration, averaged over 2 s | 5.0 m/s^2 | 3.5 m/s^2 |
//! | rate of change of deceleration (braking jerk), averaged over 1 s | 5.0 m/s^3 | 2.5 m/s^3 |
//!
//! Between 5 and 20 m/s each limit is interpolated **linearly in speed** (the choice the open
//! implementations make). The 1 s window of the jerk is the common reading, not confirmed
//! from the text. The shortest steady-state time gap a driver may select is quoted as 0.8 s
//! (ISO 15622:2018) and as 1 s (older wording): [`MIN_TIME_GAP`] takes the longer.

use crate::math;

/// The shortest time gap a driver may select, s (module docs: 0.8 s or 1 s by the source; the
/// longer is taken).
pub const MIN_TIME_GAP: f32 = 1.0;

/// The speeds between which the limits are interpolated, m/s.
const LOW_SPEED: f32 = 5.0;
const HIGH_SPEED: f32 = 20.0;

/// `low` at or below 5 m/s, `high` at or above 20 m/s, linear in between (NaN: `high`, the
/// stricter at speed).
fn between(speed: f32, low: f32, high: f32) -> f32 {
    if speed.is_nan() {
        return high;
    }
    let share = math::clamp((speed - LOW_SPEED) / (HIGH_SPEED - LOW_SPEED), 0.0, 1.0);
    low + share * (high - low)
}

/// The largest automatic acceleration at `speed`, m/s^2.
pub fn acceleration_limit(speed: f32) -> f32 {
    between(speed, 4.0, 2.0)
}

/// The largest automatic deceleration at `speed`, averaged over 2 s, m/s^2 (positive).
pub fn deceleration_limit(speed: f32) -> f32 {
    between(speed, 5.0, 3.5)
}

/// The largest braking jerk at `speed`, averaged over 1 s, m/s^3 (positive).
pub fn jerk_limit(speed: f32) -> f32 {
    between(speed, 5.0, 2.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_published_figures_and_the_interpolation() {
        assert_eq!(jerk_limit(0.0), 5.0);
        assert_eq!(jerk_limit(5.0), 5.0);
        assert_eq!(jerk_limit(20.0), 2.5);
        assert_eq!(jerk_limit(35.0), 2.5);
        assert!((jerk_limit(12.5) - 3.75).abs() < 1e-6);
        assert!((deceleration_limit(12.5) - 4.25).abs() < 1e-6);
        assert!((acceleration_limit(12.5) - 3.0).abs() < 1e-6);
        assert_eq!(jerk_limit(f32::NAN), 2.5);
    }
}
