//! The delays' memory: the commands the controller issued and the actuator's reported
//! accelerations, each kept as a sliding-window maximum back to the oldest time a later step
//! can ask about, so that what the actuator may still do (`pending`) is known at any track age.

use heapless::Deque;

use super::Controller;
use crate::math;

/// One command the controller issued.
#[derive(Debug, Clone, Copy)]
pub(super) struct Issued {
    pub(super) at_us: u64,
    pub(super) acceleration: f32,
}

/// The commands issued since the oldest time a later query can ask about, kept as a
/// sliding-window maximum (each entry larger than every later one), so that the largest is the
/// front entry: O(1) per step. A track may be old (the certified fallback argues from its last
/// measurement, whatever its age), so the window is bounded by its capacity, not by a time:
/// when it is full, the two oldest entries merge into one at the later one's time with the
/// earlier's (larger) value, which over-states the commands between them and so stays an upper
/// bound.
///
/// The same window keeps the actuator's reported accelerations (`Controller::reported_since`),
/// in fewer slots (`REPORTS`): there a merge over-states as well.
#[derive(Clone)]
pub(super) struct IssuedCommands<const N: usize = COMMANDS> {
    pub(super) window: Deque<Issued, N>,
    /// Every command issued at or after this time is in the window (`None` before the first
    /// command): before it, what the actuator did is unknown.
    pub(super) first_at_us: Option<u64>,
}

/// Slots of the command window: the covered track age and the command span at the period,
/// with room to spare.
pub(super) const COMMANDS: usize = 272;

/// Slots of the reported accelerations' window (merges over-state the older entries).
pub(super) const REPORTS: usize = 64;

impl<const N: usize> IssuedCommands<N> {
    /// No command issued yet.
    pub(super) fn new() -> Self {
        IssuedCommands {
            window: Deque::new(),
            first_at_us: None,
        }
    }

    /// Records `acceleration` issued at `at_us`; entries older than `keep_from_us` are no
    /// longer asked about and go.
    pub(super) fn push(&mut self, at_us: u64, acceleration: f32, keep_from_us: u64) {
        while let Some(e) = self.window.front().copied() {
            if e.at_us >= keep_from_us {
                break;
            }
            self.window.pop_front();
            // A query reaching back before this entry's time no longer finds it.
            self.first_at_us = self.first_at_us.map(|t| t.max(e.at_us + 1));
        }
        while self
            .window
            .back()
            .is_some_and(|e| e.acceleration <= acceleration)
        {
            self.window.pop_back();
        }
        if self.window.is_full() {
            if let (Some(oldest), Some(next)) = (self.window.pop_front(), self.window.pop_front()) {
                let merged = Issued {
                    at_us: next.at_us,
                    acceleration: math::max(oldest.acceleration, next.acceleration),
                };
                let _ = self.window.push_front(merged);
            }
        }
        if self
            .window
            .push_back(Issued {
                at_us,
                acceleration,
            })
            .is_err()
        {
            // Cannot happen (a slot was freed above); if it did, forget and start again (the
            // largest acceleration is then assumed until the window refills).
            self.window.clear();
            self.first_at_us = None;
        }
        if self.first_at_us.is_none() {
            self.first_at_us = Some(at_us);
        }
    }

    /// Forgets every command: what the actuator was told is unknown from here on.
    pub(super) fn forget(&mut self) {
        self.window.clear();
        self.first_at_us = None;
    }

    /// An upper bound of every command issued since `span_us` before `at_us`: the window's
    /// largest, or `unknown` if the first command recorded is later than that (before it, what
    /// the actuator did is not known).
    pub(super) fn largest_since(&self, at_us: u64, span_us: u64, unknown: f32) -> f32 {
        let known = self
            .first_at_us
            .is_some_and(|t| t.saturating_add(span_us) <= at_us);
        let largest = self
            .window
            .front()
            .map_or(f32::NEG_INFINITY, |e| e.acceleration);
        if known {
            largest
        } else {
            math::max(largest, unknown)
        }
    }
}

impl Controller<'_> {
    /// How far before a measurement's time the issued commands matter: the dead time and five
    /// lag time constants, microseconds.
    pub(super) fn command_span_us(&self) -> u64 {
        let c = &self.config;
        u64::from(c.plant.actuator_dead_time_us) + 5 * u64::from(c.plant.actuator_lag_us)
    }

    /// The oldest time a later step's `pending` can ask about: the kept measurements' times
    /// (a new one is never older than the last of its channel), less the command span; with
    /// none kept, the covered age and the stale limit before now.
    pub(super) fn keep_commands_from(&self, now: u64) -> u64 {
        let c = &self.config;
        let oldest = [
            self.leader.map(|l| l.at_us),
            self.rear.map(|r| r.at_us),
            self.ego_history.front().map(|e| e.0),
        ]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or_else(|| {
            now.saturating_sub(
                u64::from(c.sensors.max_track_age_us)
                    + u64::from(c.period_us) * u64::from(c.stale_periods),
            )
        });
        oldest.saturating_sub(self.command_span_us())
    }
}

/// Microseconds to seconds. The step's time differences are bounded by the covered age and the
/// delays (seconds at most), so they go through `u32`, which the Cortex-M4F converts in one
/// instruction (`u64` takes a library routine); a difference beyond `u32` (71 minutes) is
/// taken at `u32::MAX`.
pub(super) fn seconds(us: u64) -> f32 {
    u32::try_from(us).unwrap_or(u32::MAX) as f32 * 1e-6
}
#[cfg(test)]
mod tests {
    use super::*;

    /// The command window never under-states: after far more strictly falling commands than
    /// it holds (each push merges its two oldest entries), and with entries dropped before a
    /// horizon, `largest_since` is at least the true largest command since any time, and the
    /// band's top where the window no longer knows.
    #[test]
    pub(super) fn the_command_window_merges_and_forgets_without_under_stating() {
        let mut w: IssuedCommands = IssuedCommands::new();
        let commands: Vec<(u64, f32)> = (0..1_000u64)
            .map(|k| (k * 10_000, 2.0 - 0.005 * k as f32))
            .collect();
        for &(t, a) in &commands {
            w.push(t, a, 0);
        }
        assert!(w.window.len() <= 272);
        for &(t0, _) in commands.iter().step_by(7) {
            let truth = commands
                .iter()
                .filter(|(t, _)| *t >= t0)
                .map(|(_, a)| *a)
                .fold(f32::NEG_INFINITY, f32::max);
            let got = w.largest_since(t0, 0, 9.0);
            assert!(got >= truth, "since {t0}: {got} below {truth}");
        }
        // Dropped before a horizon: asked about, the window answers with the band's top.
        let mut w: IssuedCommands = IssuedCommands::new();
        for k in 0..10u64 {
            w.push(k * 10_000, 1.0 - 0.1 * k as f32, 0);
        }
        assert_eq!(w.largest_since(0, 0, 9.0), 1.0);
        w.push(200_000, -3.0, 55_000);
        assert_eq!(w.largest_since(20_000, 0, 9.0), 9.0);
        assert_eq!(w.largest_since(60_000, 0, 9.0), 1.0 - 0.1 * 6.0);
    }
}
