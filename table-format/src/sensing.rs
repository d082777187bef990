//! What the certificate assumes of the sensors: a bounded measurement error, and how old a
//! track may be. Declared here, once, for both sides: the firmware argues every measurement as
//! the box of true values its error allows, the solver measures and checks a table under the
//! same error, and a verified table's header records the error it was checked for
//! ([`crate::Verification::measurement_error`]), so that the firmware refuses a table checked
//! for less error than it declares.
//!
//! # The model
//! A radar states its accuracy as a bound, not a standard deviation (Bosch LRR3: 0.1 m and
//! 0.12 m/s; Delphi ESR: 1.8 m and 0.12 m/s; Continental ARS30x: 1.5% and 0.14 m/s, from their
//! datasheets). So the error is a box: for a measured range `m` of a true range `g`,
//! `|m - g| <= range + range_relative * g`, and so
//! `(m - range) / (1 + range_relative) <= g <= (m + range) / (1 - range_relative)`; the range
//! rate is within `range_rate`, and the ego's speed over ground within
//! `ego_speed + ego_speed_relative * v` in the same way. The bounds cover every source of error
//! between the car and the controller: the sensor's own accuracy, its tracker's smoothing, and
//! the CAN frame's resolution (0.01 m and 0.01 m/s, half of that each way).
//!
//! # Age
//! Every measurement carries the time it was taken, and the certificate is argued from that
//! time, so an aged track is not wrong, only less informative. A sensor with cycle `cycle_us`
//! and latency `latency_us` delivers tracks up to `latency_us + cycle_us` old on every cycle; a
//! missed detection ages the track further; beyond `max_track_age_us` the firmware runs its
//! certified fallback on the last good measurement (`firmware::controller`'s module docs).
//!
//! # The defaults
//! 0.1 m + 1.5% of the range (the Bosch LRR3's and the Continental ARS30x's figures both
//! inside), 0.14 m/s of range rate (the largest of the three), 80 ms cycles (the slowest) and
//! 50 ms of latency, tracks covered up to 1 s. The ego's speed over ground is not in the
//! radar's datasheets: 0.1 m/s + 0.5% is an assumption (wheel speeds with a calibrated rolling
//! radius); a car whose speed signal is worse must declare it. The actuator's reported state
//! (the powertrain's acceleration request in force) within 0.2 m/s^2 is an assumption too.

use serde::{Deserialize, Serialize};

/// The largest absolute range error a configuration may declare, m.
pub const MAX_RANGE_ERROR: f32 = 5.0;
/// The largest relative error (range or ego speed) a configuration may declare.
pub const MAX_RELATIVE_ERROR: f32 = 0.1;
/// The largest speed error (range rate or ego speed) a configuration may declare, m/s.
pub const MAX_SPEED_ERROR: f32 = 1.0;
/// The longest track age a configuration may declare covered, microseconds.
pub const MAX_TRACK_AGE_US: u32 = 2_000_000;
/// The longest time a configuration may declare between a track and the ego-speed measurement
/// paired with it, s.
pub const MAX_EGO_AGE: f32 = 0.5;

/// The measurement error: the part of the sensor bounds that the rear half's error box is made
/// of (module docs), and what a verified table records.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(deny_unknown_fields, default)]
pub struct MeasurementError {
    /// The range error's absolute part, m (at most [`MAX_RANGE_ERROR`]).
    pub range: f32,
    /// The range error's part relative to the range (at most [`MAX_RELATIVE_ERROR`]).
    pub range_relative: f32,
    /// The range-rate error, m/s (at most [`MAX_SPEED_ERROR`]).
    pub range_rate: f32,
    /// The ego speed's error, absolute part, m/s (at most [`MAX_SPEED_ERROR`]).
    pub ego_speed: f32,
    /// The ego speed's error relative to the speed (at most [`MAX_RELATIVE_ERROR`]).
    pub ego_speed_relative: f32,
    /// The longest time between a track and the ego-speed measurement paired with it, s (at
    /// most [`MAX_EGO_AGE`]). The firmware pairs a track with the kept ego measurement nearest
    /// its time and argues the ego's speed change in between exactly; the solver's check of a
    /// table under measurement error takes the ego's speed that far away at the band's
    /// accelerations. The default, 10 ms, is half the 20 ms control period at which the ego's
    /// speed arrives.
    pub ego_age: f32,
}

impl Default for MeasurementError {
    /// The datasheets' figures (module docs).
    fn default() -> Self {
        MeasurementError {
            range: 0.1,
            range_relative: 0.015,
            range_rate: 0.14,
            ego_speed: 0.1,
            ego_speed_relative: 0.005,
            ego_age: 0.01,
        }
    }
}

impl MeasurementError {
    /// Exact sensors.
    pub const EXACT: MeasurementError = MeasurementError {
        range: 0.0,
        range_relative: 0.0,
        range_rate: 0.0,
        ego_speed: 0.0,
        ego_speed_relative: 0.0,
        ego_age: 0.0,
    };

    /// Each bound with its name, as configurations and flags name it.
    pub fn named(&self) -> [(&'static str, f32); 6] {
        [
            ("range", self.range),
            ("range_relative", self.range_relative),
            ("range_rate", self.range_rate),
            ("ego_speed", self.ego_speed),
            ("ego_speed_relative", self.ego_speed_relative),
            ("ego_age", self.ego_age),
        ]
    }

    /// The first bound that is not finite, negative or above its limit, by name.
    pub fn invalid_bound(&self) -> Option<&'static str> {
        let limits = [
            MAX_RANGE_ERROR,
            MAX_RELATIVE_ERROR,
            MAX_SPEED_ERROR,
            MAX_SPEED_ERROR,
            MAX_RELATIVE_ERROR,
            MAX_EGO_AGE,
        ];
        self.named()
            .into_iter()
            .zip(limits)
            .find(|((_, x), max)| !(x.is_finite() && (0.0..=*max).contains(x)))
            .map(|((name, _), _)| name)
    }

    /// Whether every bound is finite, not negative and within its limit.
    pub fn is_valid(&self) -> bool {
        self.invalid_bound().is_none()
    }

    /// Whether this error is at least `other` in every bound: a check made under `self` holds
    /// for sensors that declare `other`.
    pub fn covers(&self, other: &MeasurementError) -> bool {
        self.named()
            .into_iter()
            .zip(other.named())
            .all(|((_, mine), (_, theirs))| mine >= theirs)
    }

    /// The interval that holds the true range of a measured range `m` (m): `(lowest,
    /// highest)`. An infinite range ("no vehicle") stays infinite.
    pub fn range(&self, m: f32) -> (f32, f32) {
        error_interval(m, self.range, self.range_relative)
    }

    /// The interval that holds the true range rate of a measured one, m/s.
    pub fn range_rate(&self, m: f32) -> (f32, f32) {
        (m - self.range_rate, m + self.range_rate)
    }

    /// The interval that holds the ego's true speed for a measured `m`, m/s, at or above zero.
    pub fn ego_speed(&self, m: f32) -> (f32, f32) {
        let (lo, hi) = error_interval(m, self.ego_speed, self.ego_speed_relative);
        (max(lo, 0.0), max(hi, 0.0))
    }

    /// The box of true rear states `(gap_follower, follower_speed, ego_speed)` that a measured
    /// rear track `(gap, range_rate)` allows, for the ego's true speed at the track's time in
    /// `ego` (`(lowest, highest)`: its measurement's error, and what it can have gained or lost
    /// since, are the caller's): the gap within the range error, and the follower's speed
    /// `ego - range_rate` within both errors, at or above zero. `(lowest corner, highest
    /// corner)`. The firmware's rear test and the solver's check of a table under measurement
    /// error both take the box from here.
    pub fn rear_box(&self, gap: f32, range_rate: f32, ego: (f32, f32)) -> ([f32; 3], [f32; 3]) {
        let (gap_lo, gap_hi) = self.range(gap);
        let (rate_lo, rate_hi) = self.range_rate(range_rate);
        let follower_lo = max(ego.0 - rate_hi, 0.0);
        let follower_hi = max(ego.1 - rate_lo, 0.0);
        ([gap_lo, follower_lo, ego.0], [gap_hi, follower_hi, ego.1])
    }
}

/// The larger of two values, the first if either is NaN (as the firmware's `math::max`: a NaN
/// measurement stays NaN, and the firmware's domain checks refuse it).
fn max(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// `|m - x| <= a + r x` solved for `x`: `((m - a) / (1 + r), (m + a) / (1 - r))` (`r < 1`).
fn error_interval(m: f32, a: f32, r: f32) -> (f32, f32) {
    ((m - a) / (1.0 + r), (m + a) / (1.0 - r))
}

/// The sensors' error bounds and timing. Units: SI, times in microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorBounds {
    /// The measurement error ([`MeasurementError`]).
    pub error: MeasurementError,
    /// The error of the actuator's reported state (the firmware's `Inputs::ego_acceleration`),
    /// m/s^2 (at most [`MAX_SPEED_ERROR`] in m/s^2).
    pub acceleration_error: f32,
    /// The radar's cycle, microseconds (10 to 200 ms).
    pub cycle_us: u32,
    /// The radar's latency from measurement to delivery, microseconds (at most 200 ms).
    pub latency_us: u32,
    /// The longest track age the certificate covers with the nominal law, microseconds: at
    /// least `cycle_us + latency_us` (a track delivered on time is never beyond it), at most
    /// [`MAX_TRACK_AGE_US`].
    pub max_track_age_us: u32,
}

impl Default for SensorBounds {
    /// The datasheets' figures (module docs).
    fn default() -> Self {
        SensorBounds {
            error: MeasurementError::default(),
            acceleration_error: 0.2,
            cycle_us: 80_000,
            latency_us: 50_000,
            max_track_age_us: 1_000_000,
        }
    }
}

impl SensorBounds {
    /// Exact sensors (no error), with the default timing.
    pub const EXACT: SensorBounds = SensorBounds {
        error: MeasurementError::EXACT,
        acceleration_error: 0.0,
        cycle_us: 80_000,
        latency_us: 50_000,
        max_track_age_us: 1_000_000,
    };

    /// Whether every bound is finite, not negative and within its limit, and the timing is
    /// consistent (module docs).
    pub fn is_valid(&self) -> bool {
        self.error.is_valid()
            && self.acceleration_error.is_finite()
            && (0.0..=MAX_SPEED_ERROR).contains(&self.acceleration_error)
            && (10_000..=200_000).contains(&self.cycle_us)
            && self.latency_us <= 200_000
            && self.max_track_age_us <= MAX_TRACK_AGE_US
            && u64::from(self.max_track_age_us)
                >= u64::from(self.cycle_us) + u64::from(self.latency_us)
    }

    /// [`MeasurementError::range`].
    pub fn range(&self, m: f32) -> (f32, f32) {
        self.error.range(m)
    }

    /// [`MeasurementError::range_rate`].
    pub fn range_rate(&self, m: f32) -> (f32, f32) {
        self.error.range_rate(m)
    }

    /// [`MeasurementError::ego_speed`].
    pub fn ego_speed(&self, m: f32) -> (f32, f32) {
        self.error.ego_speed(m)
    }

    /// Whether a track measured `age_us` ago was delivered on time (within the latency and
    /// one cycle).
    pub fn is_on_time(&self, age_us: u64) -> bool {
        age_us <= u64::from(self.cycle_us) + u64::from(self.latency_us)
    }

    /// Whether a track measured `age_us` ago is within the age the certificate covers.
    pub fn is_covered(&self, age_us: u64) -> bool {
        age_us <= u64::from(self.max_track_age_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_intervals_hold_every_value_the_error_allows() {
        let s = SensorBounds::default();
        let e = s.error;
        for &g in &[0.0f32, 1.0, 10.0, 80.0, 150.0] {
            for &sign in &[-1.0f32, 1.0] {
                let m = g + sign * (e.range + e.range_relative * g);
                let (lo, hi) = s.range(m);
                assert!(
                    lo <= g + 1e-4 && g <= hi + 1e-4,
                    "{g} not in {lo}..{hi} for {m}"
                );
            }
        }
        // The interval is as tight as the bound allows: its ends are values the error reaches.
        let (lo, _) = s.range(100.0);
        assert!((100.0 - lo - (0.1 + 0.015 * lo)).abs() < 1e-3);
        assert_eq!(s.range(f32::INFINITY).0, f32::INFINITY);
        let (lo, hi) = s.ego_speed(0.05);
        assert_eq!(lo, 0.0);
        assert!(hi > 0.15);
    }

    #[test]
    fn the_rear_box_holds_every_true_state_the_error_allows() {
        let e = MeasurementError::default();
        // A true state, every measurement its error allows at the corners, and the box of each.
        let (gap, follower, ego) = (30.0f32, 18.0f32, 20.0f32);
        for &dg in &[-1.0f32, 1.0] {
            for &dr in &[-1.0f32, 1.0] {
                for &de in &[-1.0f32, 1.0] {
                    let m_gap = gap + dg * (e.range + e.range_relative * gap);
                    let m_ego = ego + de * (e.ego_speed + e.ego_speed_relative * ego);
                    let m_rate = (ego - follower) + dr * e.range_rate;
                    let (lo, hi) = e.rear_box(m_gap, m_rate, e.ego_speed(m_ego));
                    for (k, x) in [gap, follower, ego].into_iter().enumerate() {
                        assert!(lo[k] <= x + 1e-4 && x <= hi[k] + 1e-4, "{k}: {lo:?} {hi:?}");
                    }
                }
            }
        }
        assert_eq!(
            MeasurementError::EXACT.rear_box(gap, ego - follower, (ego, ego)),
            ([gap, follower, ego], [gap, follower, ego])
        );
    }

    #[test]
    fn the_limits_are_checked() {
        assert!(SensorBounds::default().is_valid());
        assert!(SensorBounds::EXACT.is_valid());
        let with = |f: fn(&mut MeasurementError)| {
            let mut e = MeasurementError::default();
            f(&mut e);
            SensorBounds {
                error: e,
                ..SensorBounds::default()
            }
        };
        let bad = [
            with(|e| e.range = f32::NAN),
            with(|e| e.range_relative = 0.5),
            with(|e| e.range_rate = -0.1),
            with(|e| e.ego_age = 1.0),
            SensorBounds {
                max_track_age_us: 100_000,
                ..SensorBounds::default()
            },
            SensorBounds {
                max_track_age_us: 3_000_000,
                ..SensorBounds::default()
            },
            SensorBounds {
                cycle_us: 0,
                ..SensorBounds::default()
            },
            SensorBounds {
                acceleration_error: 2.0,
                ..SensorBounds::default()
            },
        ];
        for b in bad {
            assert!(!b.is_valid(), "{b:?}");
        }
        assert_eq!(
            with(|e| e.range_rate = -0.1).error.invalid_bound(),
            Some("range_rate")
        );
    }

    #[test]
    fn a_larger_error_covers_a_smaller_one() {
        let d = MeasurementError::default();
        assert!(d.covers(&d));
        assert!(d.covers(&MeasurementError::EXACT));
        assert!(!MeasurementError::EXACT.covers(&d));
        for k in 0..6 {
            let mut more = d;
            match k {
                0 => more.range += 0.01,
                1 => more.range_relative += 0.001,
                2 => more.range_rate += 0.01,
                3 => more.ego_speed += 0.01,
                4 => more.ego_speed_relative += 0.001,
                _ => more.ego_age += 0.001,
            }
            assert!(!d.covers(&more), "bound {k}");
            assert!(more.covers(&d), "bound {k}");
        }
    }
}
