//! The measurements: which are plausible and new, what is kept of each track (the leader's
//! measurement with the ego's speed at its time, the follower's rear value), their ages and
//! states, and the cut-in test.

use super::certificate::{LeaderMemo, Model, RearMemo};
use super::history::seconds;
use super::{Controller, Event, Fault};
use crate::inputs::{Measurement, Track};
use crate::math;
use crate::sensing::{self, TrackState};

/// How far below the least range the old vehicle can have closed to a new measurement must be
/// to be another vehicle, m: `f32` rounding of the bound's few terms at up to 150 m is below
/// a millimetre.
const NEW_VEHICLE_ROUNDING: f32 = 0.01;

/// Ego-speed measurements kept to find the one nearest a track's time: 16 periods, 320 ms at
/// the default period, more than the radar's latency and cycle.
pub(super) const EGO_HISTORY: usize = 16;

/// The measurement of `history` (times strictly increasing, as
/// [`Controller::remember_ego_speed`] keeps them) nearest the time `t`, the earlier of two as
/// near: the first nearest in time order. Along the history the distance to `t` falls, then
/// rises, so the scan goes from the newest and stops at the first measurement farther than the
/// one before it: a few steps where `t` is a recent track's time, not the whole history (on
/// the board, scanning the whole history twice a step cost the default step's worst about
/// 1,050 of its budget's 20,000 instructions: docs/board.md).
fn nearest_in_time<'h>(
    history: impl DoubleEndedIterator<Item = &'h (u64, f32)>,
    t: u64,
) -> Option<(u64, f32)> {
    let mut nearest: Option<(u64, f32)> = None;
    for &e in history.rev() {
        match nearest {
            Some(n) if e.0.abs_diff(t) > n.0.abs_diff(t) => break,
            _ => nearest = Some(e),
        }
    }
    nearest
}

impl Controller<'_> {
    /// A track measurement the controller can use: flagged valid by the sensor, a gap that is
    /// not NaN and not below minus the range's absolute error (`+inf`: no vehicle; a vehicle a
    /// few centimetres away can be measured below zero within the declared error, and its
    /// error box still holds the truth), a finite relative speed within 100 m/s, taken no later
    /// than now.
    pub(super) fn is_plausible(&self, m: &Measurement<Track>, now_us: u64) -> bool {
        let t = m.value;
        m.valid
            && !t.gap.is_nan()
            && t.gap >= -self.config.sensors.error.range
            && math::is_finite(t.rel_speed)
            && math::abs(t.rel_speed) <= 100.0
            && m.timestamp_us <= now_us
    }

    /// Whether `m` is plausible and newer than the measurement `kept` (its time and track): a
    /// later time stamp, or the same one with another value.
    pub(super) fn is_new_measurement(
        &self,
        m: &Measurement<Track>,
        kept: Option<(u64, Track)>,
        now: u64,
    ) -> bool {
        self.is_plausible(m, now)
            && kept.is_none_or(|(at, track)| {
                m.timestamp_us > at || (m.timestamp_us == at && m.value != track)
            })
    }

    /// The state of a track kept from `at_us`, at `now`.
    pub(super) fn track_state(&self, at_us: u64, now: u64) -> TrackState {
        sensing::track_state(&self.config.sensors, now.saturating_sub(at_us))
    }

    /// The ego's speed, if its measurement is valid, finite, in `[0, 100]` m/s and no older than
    /// `stale_periods` periods.
    pub(super) fn check_ego_speed(&self, m: &Measurement<f32>, now_us: u64) -> Result<f32, Fault> {
        let v = m.value;
        if !(m.valid && math::is_finite(v) && (0.0..=100.0).contains(&v)) {
            return Err(Fault::EgoSpeedInvalid);
        }
        let limit = u64::from(self.config.period_us) * u64::from(self.config.stale_periods);
        if !(m.timestamp_us <= now_us && now_us - m.timestamp_us <= limit) {
            return Err(Fault::EgoSpeedStale);
        }
        Ok(v)
    }

    /// Keeps the ego's speed measurement at `t_e` (a newer one than the last kept).
    pub(super) fn remember_ego_speed(&mut self, t_e: u64, v: f32) {
        if self.ego_history.back().is_some_and(|e| e.0 >= t_e) {
            return;
        }
        if self.ego_history.is_full() {
            self.ego_history.pop_front();
        }
        let _ = self.ego_history.push_back((t_e, v));
    }

    /// The interval of the ego's speed at time `t` (m/s, error included): from the kept
    /// measurement nearest `t`, moved to `t` within the accelerations possible in between (at
    /// most `pending`, at least the band's lowest, or the emergency's level while its effect
    /// may last).
    pub(super) fn ego_speed_interval_at(&self, t: u64, model: &Model) -> (f32, f32) {
        let Some((t_e, v)) = nearest_in_time(self.ego_history.iter(), t) else {
            return (0.0, model.max_ego_speed.max(0.0) + 100.0);
        };
        let pending = self.pending(t.min(t_e), model);
        ego_speed_at(
            self.config.sensors.ego_speed(v),
            t_e,
            t,
            pending,
            self.hardest_braking_from(t.min(t_e), model),
        )
    }

    /// Takes this period's leader measurement if it is plausible and newer than the one kept,
    /// and says what the controller makes of the track.
    pub(super) fn observe_leader(
        &mut self,
        m: &Measurement<Track>,
        now: u64,
        model: &Model,
    ) -> TrackState {
        let newer = self.is_new_measurement(m, self.leader.map(|l| (l.at_us, l.track)), now);
        if !newer {
            return self
                .leader
                .map_or(TrackState::Missing, |l| self.track_state(l.at_us, now));
        }
        let new_vehicle = self
            .leader
            .is_some_and(|old| self.is_another_vehicle(&old, m, model));
        let ego = self.ego_speed_interval_at(m.timestamp_us, model);
        self.leader = Some(LeaderMemo {
            at_us: m.timestamp_us,
            track: m.value,
            ego,
        });
        if new_vehicle {
            self.log(Event::NewLeader {
                at_us: now,
                gap: m.value.gap,
            });
            TrackState::New
        } else {
            self.track_state(m.timestamp_us, now)
        }
    }

    /// Whether a new leader measurement cannot be the vehicle of the last one: its range is
    /// below the least the old vehicle can have closed to (by more than
    /// [`NEW_VEHICLE_ROUNDING`]) (the old range's lowest, closing at
    /// the old range rate's lowest, the relative speed falling at most at the leader's hardest
    /// braking plus the ego's largest acceleration), or a vehicle appears where there was none.
    pub(super) fn is_another_vehicle(
        &self,
        old: &LeaderMemo,
        new: &Measurement<Track>,
        model: &Model,
    ) -> bool {
        let sensors = &self.config.sensors;
        if !math::is_finite(old.track.gap) {
            return math::is_finite(new.value.gap);
        }
        let dt = seconds(new.timestamp_us.saturating_sub(old.at_us));
        let closing = model.leader_braking + model.ego.max;
        let least = sensors.range(old.track.gap).0 + sensors.range_rate(old.track.rel_speed).0 * dt
            - 0.5 * closing * dt * dt;
        // Less a centimetre of `f32` rounding: a leader braking as hard as its model allows
        // while the ego accelerates at the band's top, measured at opposite corners of the
        // error box, sits exactly on this bound, and a rounding below it took the same car for
        // a new one (and its certified chain with it).
        sensors.range(new.value.gap).1 < least - NEW_VEHICLE_ROUNDING
    }

    /// Takes this period's follower measurement if it is plausible and newer than the one
    /// kept, computing its rear value at its time, and says what the controller makes of it.
    pub(super) fn observe_follower(
        &mut self,
        m: &Measurement<Track>,
        now: u64,
        model: &Model,
    ) -> TrackState {
        let newer = self.is_new_measurement(m, self.rear.map(|r| (r.at_us, r.track)), now);
        if let (true, Ok(certifier)) = (newer, &self.certifier) {
            let (ego_low, raw_high) = self.ego_speed_interval_at(m.timestamp_us, model);
            // Where every step since before the track's time kept a speed headroom of zero or
            // more, the ego's true speed has stayed within the domain (module docs: the ego's
            // speed), and its interval is held there too.
            let ego_high = if self.speed_kept_from_us.is_some_and(|t| t <= m.timestamp_us) {
                math::min(raw_high, model.max_ego_speed)
            } else {
                raw_high
            };
            let value = certifier.rear_value_of_track(m.value, (ego_low, ego_high));
            self.rear = Some(RearMemo {
                at_us: m.timestamp_us,
                track: m.value,
                ego: (ego_low, raw_high),
                value,
            });
        }
        self.rear
            .map_or(TrackState::Missing, |r| self.track_state(r.at_us, now))
    }
}

/// The ego's speed at time `t` from its measurement's interval `(low, high)` at `t_e`, within
/// the accelerations it can have had in between (at most `pending`, at least `band_min`):
/// `(lowest, highest)`, both at or above zero.
pub(super) fn ego_speed_at(
    (low, high): (f32, f32),
    t_e: u64,
    t: u64,
    pending: f32,
    band_min: f32,
) -> (f32, f32) {
    let (low, high) = if t_e <= t {
        let dt = seconds(t - t_e);
        (low + band_min * dt, high + pending * dt)
    } else {
        let dt = seconds(t_e - t);
        (low - pending * dt, high - band_min * dt)
    };
    (math::max(low, 0.0), math::max(high, 0.0))
}

#[cfg(test)]
mod tests {
    use super::nearest_in_time;
    use proptest::prelude::*;

    proptest! {
        /// The scan from the newest finds what the whole history's first nearest is, for any
        /// history in time order and any time, before, inside or after it, and at the midpoint
        /// of two measurements (the tie the first nearest breaks for the earlier).
        #[test]
        fn the_nearest_is_the_whole_historys_first_nearest(
            steps in proptest::collection::vec(1u64..20_000, 0..16),
            start in 0u64..500_000,
            free in 0u64..1_700_000,
            midpoint in proptest::option::of(0usize..15),
        ) {
            let mut time = 2 * start;
            let history: std::vec::Vec<(u64, f32)> = steps
                .iter()
                .enumerate()
                .map(|(i, step)| {
                    time += 2 * step;
                    (time, i as f32)
                })
                .collect();
            let t = match midpoint {
                Some(i) if i + 1 < history.len() => (history[i].0 + history[i + 1].0) / 2,
                _ => free,
            };
            let whole = history
                .iter()
                .min_by(|a, b| a.0.abs_diff(t).cmp(&b.0.abs_diff(t)))
                .copied();
            prop_assert_eq!(nearest_in_time(history.iter(), t), whole);
        }
    }
}
