//! The delays' memory: the commands the controller issued and the actuator's reported
//! accelerations, each kept as a sliding-window maximum back to the oldest time a later step
//! can ask about, so that what the actuator may still do (`pending`) is known at any track age.

use heapless::Deque;

use super::certificate::{Model, LAG_TAIL};
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

/// Slots of the least commands' window (`Controller::least_issued_since`; merges under-state
/// the older entries, so the bound stays a lower one).
pub(super) const LEAST: usize = 64;

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

    /// With two authorities, a lower bound of the ego's acceleration from `t_f` until `now`
    /// that the controller's own commands give, and how long that is: `(least, seconds)`, the
    /// least at most zero (a lower bound may be lowered). `None` where it is not known: in the
    /// comfort band (not kept), before the commands reach back far enough (an engagement, a
    /// forgotten history), or where a value is not finite.
    ///
    /// **Why it holds.** The actuator is a dead time of at most the declared one and a
    /// first-order lag of at most the declared one ([`crate::Config::plant`]; either may be
    /// shorter, down to none): its acceleration at `t >= t_f` is a weighted average, weights
    /// summing to one, of the commands in force before `t`. Those in force from five lag time
    /// constants before `t_f` on were issued at most a dead time before that, and the window
    /// holds every command since then (the query and the window's horizon reach a period
    /// further back than `issued`'s, for the one in force at that time; the horizon may reach
    /// further still, which only lowers the least): each is at least the window's least, `m`. The older ones weigh at most
    /// `e^-5` at any `t >= t_f` (with a shorter lag, less) and are no lower than the floor
    /// `f`, the harder of the leader's declared braking (the hardest braking of any car on the
    /// road: the driver's, before an engagement, is assumed no harder) and the envelope's
    /// least command (the ego's own emergency braking), so `a(t) >= m - e^-5 max(0, m - f)`.
    pub(super) fn least_issued_since(
        &self,
        t_f: u64,
        now: u64,
        model: &Model,
    ) -> Option<(f32, f32)> {
        if !self.two_authorities() {
            return None;
        }
        let c = &self.config;
        let span = self.command_span_us() + u64::from(c.period_us);
        // The window holds the commands negated: its largest is the least command.
        let least = -self.least_issued.largest_since(t_f, span, f32::INFINITY);
        let tail = if c.plant.actuator_lag_us > 0 {
            let floor = math::min(-model.leader_braking, c.plant.envelope.min_acceleration);
            LAG_TAIL * math::max(least - floor, 0.0)
        } else {
            0.0
        };
        let least = math::min(least - tail, 0.0);
        let known_for = seconds(now.saturating_sub(t_f));
        math::is_finite(least).then_some((least, known_for))
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

#[cfg(test)]
mod least_tests {
    use crate::config::{Authorities, CertificateConfig, Config, PlantConfig};
    use crate::controller::Controller;

    /// The acceleration (m/s^2) of an actuator with `dead_us` of dead time and a first-order lag
    /// of `lag_us` at every millisecond: braking at `pre` until the first command (the driver,
    /// before the engagement), then following `commands`, one issued every `period_us`.
    fn actuator(commands: &[f32], period_us: u64, pre: f32, dead_us: u64, lag_us: u64) -> Vec<f32> {
        let in_force = |t_us: u64| {
            t_us.checked_sub(dead_us).map_or(pre, |t| {
                commands[((t / period_us) as usize).min(commands.len() - 1)]
            })
        };
        let end_ms = commands.len() as u64 * period_us / 1_000;
        let mut a = pre;
        (0..end_ms)
            .map(|ms| {
                let input = in_force(ms * 1_000);
                if lag_us == 0 {
                    return input;
                }
                // Exact over the millisecond: the input is constant there.
                let at = a;
                a = input + (a - input) * (-(1_000.0 / lag_us as f32)).exp();
                at
            })
            .collect()
    }

    /// `Controller::least_issued_since` bounds from below the acceleration of every actuator the
    /// declaration allows (a dead time and a first-order lag each none, half or all of the
    /// declared ones), braking at the hardest the bound assumes before the engagement (the
    /// envelope's least command, harder than the table's leader) and
    /// following the commands after, at every millisecond from a measurement's time until the
    /// step: commands at zero for 2 s after the engagement (where the clamp at zero does not
    /// hide what the driver's braking leaves through the lag), then a seeded walk over the
    /// envelope with stretches at zero; measurements 57, 133 and 499 ms old (between two
    /// periods), the window's horizon as the step keeps it for a measurement 499 ms old at the query. With
    /// the declared actuator and with none.
    #[test]
    fn the_least_command_bounds_every_admissible_actuator_from_below() {
        for (dead_us, lag_us) in [(100_000u64, 300_000u64), (0, 0)] {
            let config = Config {
                certificate: CertificateConfig {
                    authorities: Authorities::Two,
                    ..Config::default().certificate
                },
                plant: PlantConfig {
                    actuator_dead_time_us: dead_us as u32,
                    actuator_lag_us: lag_us as u32,
                    ..Config::default().plant
                },
                ..Config::default()
            };
            let mut c = Controller::new(crate::DEFAULT_TABLE, config);
            let model = c
                .certifier
                .as_ref()
                .map(|x| x.model)
                .expect("the table loads");
            let period = u64::from(config.period_us);
            let span = c.command_span_us();
            let mut seed = 0x2545_f491_4f6c_dd1du64;
            let mut uniform = || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                (seed >> 40) as f32 / (1u64 << 24) as f32
            };
            let floor = config.plant.envelope.min_acceleration;
            let commands: Vec<f32> = (0..600usize)
                .map(|k| match (k < 100, (k / 40) % 3) {
                    (true, _) => 0.0,
                    (false, 0) => 0.0,
                    (false, 1) => floor + (2.0 - floor) * uniform(),
                    _ => {
                        if uniform() < 0.1 {
                            floor
                        } else {
                            0.0
                        }
                    }
                })
                .collect();
            // The hardest braking the bound assumes before an engagement: the ego's own
            // emergency braking (8 m/s^2), harder than this table's leader (6).
            let pre = floor.min(-model.leader_braking);
            assert!(pre < -model.leader_braking);
            let actuators: Vec<Vec<f32>> = [(0, 0), (dead_us / 2, lag_us / 2), (dead_us, lag_us)]
                .iter()
                .map(|&(d, l)| actuator(&commands, period, pre, d, l))
                .collect();
            let mut known = 0;
            for (k, &command) in commands.iter().enumerate() {
                let now = k as u64 * period;
                for age in [57_000u64, 133_000, 499_000] {
                    let Some(t_f) = now.checked_sub(age) else {
                        continue;
                    };
                    let Some((least, known_for)) = c.least_issued_since(t_f, now, &model) else {
                        continue;
                    };
                    known += 1;
                    assert_eq!(known_for, age as f32 * 1e-6);
                    for (i, a) in actuators.iter().enumerate() {
                        let truth = a[(t_f / 1_000) as usize..(now / 1_000) as usize]
                            .iter()
                            .fold(f32::INFINITY, |m, x| m.min(*x));
                        assert!(
                            least <= truth + 1e-6,
                            "actuator {i} of ({dead_us}, {lag_us}) us, {age} us old at step {k}: \
                             {least} above {truth}"
                        );
                    }
                }
                // A measurement of this instant is bounded too, once the window reaches back.
                if k >= 200 {
                    assert!(c.least_issued_since(now, now, &model).is_some(), "step {k}");
                }
                // As the step keeps it, after its decision: the oldest measurement 479 ms old
                // now, 499 at the next step's query.
                let keep = now.saturating_sub(479_000 + span + period);
                c.least_issued.push(now, -command, keep);
            }
            assert!(known > 1_000, "{known} bounds known");
        }
    }
}
