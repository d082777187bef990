//! What the certificate assumes of the sensors: bounded measurement error, and how old a track
//! may be. One responsibility: turn a measurement into the interval that holds the true value.
//!
//! # The model
//! A radar states its accuracy as a bound, not a standard deviation (ANCHORS.md: Bosch LRR3
//! 0.1 m and 0.12 m/s, Delphi ESR 1.8 m and 0.12 m/s, Continental ARS30x 1.5% and 0.14 m/s).
//! So the error is a box: for a measured range `m` of a true range `g`,
//! `|m - g| <= range_error + range_error_relative * g`, and so
//! `(m - range_error) / (1 + range_error_relative) <= g <= (m + range_error) / (1 - range_error_relative)`;
//! the range rate is within `range_rate_error`, and the ego's speed over ground within
//! `ego_speed_error + ego_speed_error_relative * v` in the same way. The bounds cover every
//! source of error between the car and the controller: the sensor's own accuracy, its
//! tracker's smoothing, and the CAN frame's resolution (0.01 m and 0.01 m/s, half of that
//! each way).
//!
//! # Age
//! Every measurement carries the time it was taken. The certificate is argued from that time
//! (`controller`'s module docs), so an aged track is not wrong, only less informative: the
//! look-ahead covers the leader's worst case since then, and the car slows as the track ages.
//! A sensor with cycle `cycle_us` and latency `latency_us` delivers tracks up to
//! `latency_us + cycle_us` old on every cycle ([`TrackState::Fresh`]); a missed detection
//! ages the track further ([`TrackState::Aging`]); beyond `max_track_age_us` it is
//! [`TrackState::Lost`], and the controller runs its certified fallback on the last good
//! measurement (`controller`'s module docs).
//!
//! # The defaults
//! 0.1 m + 1.5% of the range (the Bosch LRR3's and the Continental ARS30x's figures both
//! inside), 0.14 m/s of range rate (the largest of the three), 80 ms cycles (the slowest) and
//! 50 ms of latency, tracks covered up to 1 s. The ego's speed over ground is not in the
//! radar's datasheets: 0.1 m/s + 0.5% is an assumption (wheel speeds with a calibrated rolling
//! radius); a car whose speed signal is worse must declare it. The actuator's reported state
//! (the powertrain's acceleration request in force) within 0.2 m/s^2 is an assumption too.

use crate::math;

/// The sensors' error bounds and timing. Units: SI, times in microseconds.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorBounds {
    /// The range error's absolute part, m (at most [`MAX_RANGE_ERROR`]).
    pub range_error: f32,
    /// The range error's part relative to the range (at most [`MAX_RELATIVE_ERROR`]).
    pub range_error_relative: f32,
    /// The range-rate error, m/s (at most [`MAX_SPEED_ERROR`]).
    pub range_rate_error: f32,
    /// The ego speed's error, absolute part, m/s (at most [`MAX_SPEED_ERROR`]).
    pub ego_speed_error: f32,
    /// The ego speed's error relative to the speed (at most [`MAX_RELATIVE_ERROR`]).
    pub ego_speed_error_relative: f32,
    /// The error of the actuator's reported state ([`crate::Inputs::ego_acceleration`]),
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

/// The largest absolute range error a configuration may declare, m.
pub const MAX_RANGE_ERROR: f32 = 5.0;
/// The largest relative error (range or ego speed) a configuration may declare.
pub const MAX_RELATIVE_ERROR: f32 = 0.1;
/// The largest speed error (range rate or ego speed) a configuration may declare, m/s.
pub const MAX_SPEED_ERROR: f32 = 1.0;
/// The longest track age a configuration may declare covered, microseconds.
pub const MAX_TRACK_AGE_US: u32 = 2_000_000;

impl Default for SensorBounds {
    /// The datasheets' figures (module docs).
    fn default() -> Self {
        SensorBounds {
            range_error: 0.1,
            range_error_relative: 0.015,
            range_rate_error: 0.14,
            ego_speed_error: 0.1,
            ego_speed_error_relative: 0.005,
            acceleration_error: 0.2,
            cycle_us: 80_000,
            latency_us: 50_000,
            max_track_age_us: 1_000_000,
        }
    }
}

impl SensorBounds {
    /// Exact sensors (no error), with the default timing: what the certificate assumed before
    /// measurement error entered it, and what the exact-sensor tests use.
    pub const EXACT: SensorBounds = SensorBounds {
        range_error: 0.0,
        range_error_relative: 0.0,
        range_rate_error: 0.0,
        ego_speed_error: 0.0,
        ego_speed_error_relative: 0.0,
        acceleration_error: 0.0,
        cycle_us: 80_000,
        latency_us: 50_000,
        max_track_age_us: 1_000_000,
    };

    /// Whether every bound is finite, not negative and within its limit, and the timing is
    /// consistent (module docs).
    pub fn is_valid(&self) -> bool {
        let within = |x: f32, max: f32| math::is_finite(x) && (0.0..=max).contains(&x);
        within(self.range_error, MAX_RANGE_ERROR)
            && within(self.range_error_relative, MAX_RELATIVE_ERROR)
            && within(self.range_rate_error, MAX_SPEED_ERROR)
            && within(self.ego_speed_error, MAX_SPEED_ERROR)
            && within(self.ego_speed_error_relative, MAX_RELATIVE_ERROR)
            && within(self.acceleration_error, MAX_SPEED_ERROR)
            && (10_000..=200_000).contains(&self.cycle_us)
            && self.latency_us <= 200_000
            && self.max_track_age_us <= MAX_TRACK_AGE_US
            && u64::from(self.max_track_age_us)
                >= u64::from(self.cycle_us) + u64::from(self.latency_us)
    }

    /// The interval that holds the true range of a measured range `m` (m): `(lowest,
    /// highest)`. An infinite range ("no vehicle") stays infinite.
    pub fn range(&self, m: f32) -> (f32, f32) {
        error_interval(m, self.range_error, self.range_error_relative)
    }

    /// The interval that holds the true range rate of a measured one, m/s.
    pub fn range_rate(&self, m: f32) -> (f32, f32) {
        (m - self.range_rate_error, m + self.range_rate_error)
    }

    /// The interval that holds the ego's true speed for a measured `m`, m/s, at or above zero.
    pub fn ego_speed(&self, m: f32) -> (f32, f32) {
        let (lo, hi) = error_interval(m, self.ego_speed_error, self.ego_speed_error_relative);
        (math::max(lo, 0.0), math::max(hi, 0.0))
    }

    /// The state of a track measured `age_us` ago.
    pub fn track_state(&self, age_us: u64) -> TrackState {
        if age_us <= u64::from(self.cycle_us) + u64::from(self.latency_us) {
            TrackState::Fresh
        } else if age_us <= u64::from(self.max_track_age_us) {
            TrackState::Aging
        } else {
            TrackState::Lost
        }
    }
}

/// `|m - x| <= a + r x` solved for `x`: `((m - a) / (1 + r), (m + a) / (1 - r))` (`r < 1`).
fn error_interval(m: f32, a: f32, r: f32) -> (f32, f32) {
    ((m - a) / (1.0 + r), (m + a) / (1.0 - r))
}

/// What the controller makes of a track's age and continuity, reported with every command
/// (and on CAN) so that the car knows which case of the argument holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TrackState {
    /// Measured within the sensor's latency and one cycle.
    Fresh,
    /// Older than that (detections missed), within the covered age: the nominal law runs,
    /// under a look-ahead that grows with the age.
    Aging,
    /// Older than the covered age: the certified fallback runs on the last good measurement.
    Lost,
    /// This period's measurement is not the same vehicle as the last one (a cut-in: the gap
    /// fell faster than the last track's vehicle can close it). The new track is used at once.
    New,
    /// No plausible measurement has been received yet.
    Missing,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_intervals_hold_every_value_the_error_allows() {
        let s = SensorBounds::default();
        for &g in &[0.0f32, 1.0, 10.0, 80.0, 150.0] {
            for &sign in &[-1.0f32, 1.0] {
                let m = g + sign * (s.range_error + s.range_error_relative * g);
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
    fn the_limits_are_checked() {
        assert!(SensorBounds::default().is_valid());
        assert!(SensorBounds::EXACT.is_valid());
        let bad = [
            SensorBounds {
                range_error: f32::NAN,
                ..SensorBounds::default()
            },
            SensorBounds {
                range_error_relative: 0.5,
                ..SensorBounds::default()
            },
            SensorBounds {
                range_rate_error: -0.1,
                ..SensorBounds::default()
            },
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
        ];
        for b in bad {
            assert!(!b.is_valid(), "{b:?}");
        }
    }

    #[test]
    fn a_track_ages_then_is_lost() {
        let s = SensorBounds::default();
        assert_eq!(s.track_state(130_000), TrackState::Fresh);
        assert_eq!(s.track_state(130_001), TrackState::Aging);
        assert_eq!(s.track_state(1_000_000), TrackState::Aging);
        assert_eq!(s.track_state(1_000_001), TrackState::Lost);
    }
}
