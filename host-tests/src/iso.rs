//! ISO 15622's comfort checks on a trace, as an outside review ran them: the braking
//! jerk averaged over 1 s, the deceleration averaged over 2 s, and the acceleration, each
//! against its limit at the ego's speed ([`firmware::iso15622`], the firmware's own figures
//! and interpolation), on the vehicle's realised acceleration and speed (not the command).
//!
//! Each check is a ratio to its limit (1 is the limit). A window's limit is taken at the
//! highest speed in it: the strictest, since every limit falls with speed.

use firmware::iso15622;
use serde::Serialize;
use std::collections::VecDeque;

/// The worst of each check over an episode: ratio to its limit, and the time it was reached.
#[derive(Debug, Clone, Copy, Serialize, Default, PartialEq)]
pub struct IsoWorst {
    /// Braking jerk averaged over 1 s, over its limit.
    pub jerk: f32,
    /// When, s.
    pub jerk_at: f32,
    /// Deceleration averaged over 2 s, over its limit.
    pub deceleration: f32,
    /// When, s.
    pub deceleration_at: f32,
    /// Acceleration over its limit.
    pub acceleration: f32,
    /// When, s.
    pub acceleration_at: f32,
}

impl IsoWorst {
    /// Whether every check is within its limit (with a relative slack of 1e-3 for the
    /// integration's rounding).
    pub fn holds(&self) -> bool {
        self.jerk <= 1.001 && self.deceleration <= 1.001 && self.acceleration <= 1.001
    }

    /// The largest of the three ratios.
    pub fn worst(&self) -> f32 {
        self.jerk.max(self.deceleration).max(self.acceleration)
    }
}

/// The running checks: samples of `(time, speed, acceleration)` once per period.
#[derive(Debug, Clone)]
pub struct IsoCheck {
    samples: VecDeque<(f32, f32, f32)>,
    /// Checks start this long after the first sample, s (engagement).
    pub settle: f32,
    worst: IsoWorst,
    start: Option<f32>,
}

impl IsoCheck {
    /// Checks that start `settle` seconds after the first sample.
    pub fn new(settle: f32) -> Self {
        IsoCheck {
            samples: VecDeque::new(),
            settle,
            worst: IsoWorst::default(),
            start: None,
        }
    }

    /// One period's sample: time (s), the ego's speed (m/s) and realised acceleration (m/s^2).
    pub fn push(&mut self, t: f32, speed: f32, acceleration: f32) {
        let start = *self.start.get_or_insert(t);
        self.samples.push_back((t, speed, acceleration));
        while self.samples.front().is_some_and(|s| s.0 < t - 2.0 - 1e-4) {
            self.samples.pop_front();
        }
        if t - start < self.settle {
            return;
        }
        let w = &mut self.worst;
        let accel_ratio = acceleration / iso15622::acceleration_limit(speed);
        if accel_ratio > w.acceleration {
            w.acceleration = accel_ratio;
            w.acceleration_at = t;
        }
        let window = |span: f32| {
            self.samples
                .iter()
                .find(|s| s.0 >= t - span - 1e-4)
                .copied()
                .filter(|s| t - s.0 >= span - 1e-3)
        };
        let highest = |span: f32| {
            self.samples
                .iter()
                .filter(|s| s.0 >= t - span - 1e-4)
                .map(|s| s.1)
                .fold(speed, f32::max)
        };
        if let Some((t0, _, a0)) = window(1.0) {
            let jerk = (a0 - acceleration) / (t - t0);
            let ratio = jerk / iso15622::jerk_limit(highest(1.0));
            if ratio > w.jerk {
                w.jerk = ratio;
                w.jerk_at = t;
            }
        }
        if let Some((t0, v0, _)) = window(2.0) {
            let deceleration = (v0 - speed) / (t - t0);
            let ratio = deceleration / iso15622::deceleration_limit(highest(2.0));
            if ratio > w.deceleration {
                w.deceleration = ratio;
                w.deceleration_at = t;
            }
        }
    }

    /// The worst so far.
    pub fn worst(&self) -> IsoWorst {
        self.worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A braking ramp at 3 m/s^3 at 25 m/s breaks the 2.5 m/s^3 limit by 1.2; one at 2 m/s^3
    /// does not. A constant 4 m/s^2 braking for 2 s at 25 m/s breaks the 3.5 m/s^2 limit.
    #[test]
    fn the_checks_catch_what_they_should() {
        let run = |jerk: f32, floor: f32| {
            let mut c = IsoCheck::new(0.0);
            let (mut v, h) = (25.0f32, 0.02f32);
            for k in 0..200 {
                let t = k as f32 * h;
                let a = (-jerk * t).max(-floor);
                c.push(t, v, a);
                v += a * h;
            }
            c.worst()
        };
        let w = run(3.0, 3.0);
        assert!((w.jerk - 1.2).abs() < 0.01, "{w:?}");
        assert!(run(2.0, 3.0).holds());
        let w = run(1e6, 4.0);
        assert!(w.deceleration > 1.1, "{w:?}");
    }
}
