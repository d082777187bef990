//! Intervals and boxes of rear states, with bounds widened outward so that they stay sound
//! under `f64` rounding.

use serde::Serialize;

pub(super) use table_format::idm::{widen_down, widen_up};

/// A closed interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

impl Interval {
    pub(super) fn new(lo: f64, hi: f64) -> Self {
        Interval { lo, hi }
    }

    pub(super) fn halves(&self) -> (Interval, Interval) {
        let mid = 0.5 * (self.lo + self.hi);
        (Interval::new(self.lo, mid), Interval::new(mid, self.hi))
    }
}

/// A box of rear states: gap to the follower (m), the follower's and the ego's speeds (m/s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StateBox {
    /// Gap to the follower, m.
    pub gap: Interval,
    /// The follower's speed, m/s.
    pub follower_speed: Interval,
    /// The ego's speed, m/s.
    pub ego_speed: Interval,
}

impl StateBox {
    pub(super) fn axis(&self, k: usize) -> Interval {
        match k {
            0 => self.gap,
            1 => self.follower_speed,
            _ => self.ego_speed,
        }
    }

    pub(super) fn with_axis(mut self, k: usize, i: Interval) -> Self {
        match k {
            0 => self.gap = i,
            1 => self.follower_speed = i,
            _ => self.ego_speed = i,
        }
        self
    }
}
