//! The ego's own build-up in the rear check: a lower bound of the actuator's acceleration,
//! followed through the declared lag from the commands the controller issued, so that the rear
//! check credits what the actuator must still do before a braking takes force
//! ([`table_format::rear::KnownBraking`]'s derivation).
//!
//! # Why a record of every command, not a running minimum
//! A certificate argued with a credit must keep it along the braking it argued for: the
//! two-authority rule keeps a braking in force because the rear value it was certified with
//! does not fall while the ego brakes under it (`table_format::authority`'s module docs). A
//! bound that summarises the commands since the measurement by their least would fall as soon
//! as the braking's first command joins that least: the gentle commands before it would then
//! count as hard as the braking. The record here keeps each command in force for its own time
//! and follows the lag through them exactly, so a later check rebuilds the same lower bound
//! for the commands an earlier one knew, and a higher one for the braking it did not (every
//! command of a braking is at least the level argued with). A lower bound of the actuator's
//! acceleration, followed exactly through the actuator's declared lag, is a lower bound at every
//! later instant (a first-order lag is monotone in its start and its input).
//!
//! # What it assumes
//! The actuator's acceleration follows the declared dead time and lag of the commands, as the
//! front's argument assumes; before the first command recorded it is at least the hardest
//! acceleration the certificate allows there (the band's floor, or an emergency's level while
//! its effect lasts: `Controller::hardest_braking_from`). Every command is taken at most zero
//! (a lower bound may be lowered, and the credit's derivation needs one at most zero).

use heapless::Deque;
use table_format::rear::{lag_segment, GentlePart, KnownBraking};

use super::certificate::Model;
use super::history::{seconds, COMMANDS};
use super::Controller;
use crate::math;

/// One command as the actuator receives it: from when it takes force, the lower bound of the
/// actuator's acceleration then, and the command (at most zero) held until the next one takes
/// force.
#[derive(Debug, Clone, Copy)]
struct Segment {
    /// When the command takes force (issued plus the dead time), microseconds.
    from_us: u64,
    /// The lower bound of the actuator's acceleration at `from_us`, m/s^2 (at most zero).
    start: f32,
    /// The command, m/s^2 (at most zero).
    input: f32,
    /// Over the whole segment, once the next one is recorded: `int a_lb` (m/s) and
    /// `int (s - from) a_lb` (m), [`lag_segment`].
    whole: (f32, f32),
}

/// The commands the controller issued, each as a segment of the actuator's lower bound
/// (module docs), back to the oldest measurement a rear check can ask about.
#[derive(Clone)]
pub(super) struct ActuatorFloor {
    segments: Deque<Segment, COMMANDS>,
}

impl ActuatorFloor {
    /// No command recorded.
    pub(super) fn new() -> Self {
        ActuatorFloor {
            segments: Deque::new(),
        }
    }

    /// Forgets every command: the actuator's acceleration is unknown from here on.
    pub(super) fn forget(&mut self) {
        self.segments.clear();
    }

    /// Records `command` (m/s^2), taking force at `in_force_us`, through the lag `lag` (s):
    /// the actuator's lower bound then is where the last segment's lag has brought it, or
    /// `unknown` (m/s^2) with none recorded. Segments that end at or before `keep_from_us`
    /// (no check asks about them) go, and the oldest where the record is full. A command that
    /// takes force before the last one's (a clock that went back) starts the record again.
    pub(super) fn push(
        &mut self,
        in_force_us: u64,
        command: f32,
        lag: f32,
        unknown: f32,
        keep_from_us: u64,
    ) {
        let input = math::min(command, 0.0);
        let in_order = self
            .segments
            .back()
            .is_none_or(|s| s.from_us <= in_force_us);
        if !in_order || !math::is_finite(input) {
            self.segments.clear();
        }
        let start = match self.segments.back_mut() {
            Some(last) => {
                let d = seconds(in_force_us - last.from_us);
                let (speed, moment, end) = lag_segment(last.start, last.input, d, lag);
                last.whole = (speed, moment);
                end
            }
            None => math::min(unknown, 0.0),
        };
        // Segments wholly before the oldest time asked about go (the one holding it stays).
        while self.segments.len() >= 2
            && self
                .segments
                .get(1)
                .is_some_and(|s| s.from_us <= keep_from_us)
        {
            self.segments.pop_front();
        }
        if self.segments.is_full() {
            self.segments.pop_front();
        }
        let segment = Segment {
            from_us: in_force_us,
            start,
            input,
            whole: (0.0, 0.0),
        };
        if !math::is_finite(start) || self.segments.push_back(segment).is_err() {
            self.segments.clear();
        }
    }

    /// The actuator's lower bound from `t_f` (microseconds, the follower measurement's time)
    /// until `until_us` (the commands already issued are in force until then: now plus the
    /// dead time), through the lag `lag` (s), as [`KnownBraking`] from `t_f`; and its part
    /// on the segments where it stays at or above `gentle_floor` (m/s^2, negative: the band's
    /// floor), as [`GentlePart`]. Nothing where the record does not reach back to `t_f` or
    /// `until_us` is not after it.
    pub(super) fn known(
        &self,
        t_f: u64,
        until_us: u64,
        lag: f32,
        gentle_floor: f32,
    ) -> (KnownBraking, GentlePart) {
        let nothing = (KnownBraking::NOTHING, GentlePart::NOTHING);
        let Some(first) = self.segments.front() else {
            return nothing;
        };
        if t_f < first.from_us || until_us <= t_f {
            return nothing;
        }
        let mut gentle = GentlePart {
            least: f32::INFINITY,
            most: f32::NEG_INFINITY,
            ..GentlePart::NOTHING
        };
        // The last segment in force at `t_f` (the first is), by bisection.
        let count = self.segments.len();
        let (mut lo, mut hi) = (0usize, count);
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if self.segments.get(mid).is_some_and(|s| s.from_us <= t_f) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (mut speed, mut moment) = (0.0f32, 0.0f32);
        let (mut at_end, mut least, mut most) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY);
        for k in lo..count {
            let Some(segment) = self.segments.get(k) else {
                break;
            };
            let next = self.segments.get(k + 1).filter(|n| n.from_us < until_us);
            let ends_us = next.map_or(until_us, |n| n.from_us);
            // The part of this segment from `t_f` on, up to `until_us`.
            let (begin_us, value) = if segment.from_us < t_f {
                let into = seconds(t_f - segment.from_us);
                (t_f, lag_segment(segment.start, segment.input, into, lag).2)
            } else {
                (segment.from_us, segment.start)
            };
            // A whole segment's integrals were taken when the next one was recorded, which
            // starts where this one's lag ends.
            let (s, m, end) = match next {
                Some(n) if begin_us == segment.from_us => {
                    (segment.whole.0, segment.whole.1, n.start)
                }
                _ => lag_segment(value, segment.input, seconds(ends_us - begin_us), lag),
            };
            let offset = seconds(begin_us - t_f);
            speed += s;
            moment += m + offset * s;
            at_end = end;
            let (low, high) = (
                math::min(value, segment.input),
                math::max(value, segment.input),
            );
            least = math::min(least, low);
            most = math::max(most, high);
            if low >= gentle_floor {
                let d = seconds(ends_us - begin_us);
                gentle.speed += s;
                gentle.moment += m + offset * s;
                gentle.duration += d;
                gentle.duration_moment += offset * d + 0.5 * d * d;
                gentle.least = math::min(gentle.least, low);
                gentle.most = math::max(gentle.most, high);
            }
            if next.is_none() {
                break;
            }
        }
        if gentle.duration <= 0.0 {
            gentle = GentlePart::NOTHING;
        }
        let known = KnownBraking {
            known_for: seconds(until_us - t_f),
            speed,
            moment,
            at_end,
            least,
            most,
            lag,
        };
        (known, gentle)
    }
}

impl Controller<'_> {
    /// Records the command issued at `now` ([`ActuatorFloor::push`]): in force after the
    /// declared dead time, from the hardest acceleration the certificate allows where no
    /// earlier command is recorded. Segments end before the oldest time a rear check can ask
    /// about: the kept follower measurement's, or a track as old as the sensors allow.
    /// Without a table the record is forgotten.
    pub(super) fn record_for_build_up(&mut self, now: u64, command: f32, model: Option<&Model>) {
        self.known_memo.set(None);
        let Some(model) = model else {
            self.actuator_floor.forget();
            return;
        };
        let c = &self.config;
        let oldest = now.saturating_sub(u64::from(c.sensors.max_track_age_us));
        let keep_from = self.rear.map_or(oldest, |r| r.at_us.min(oldest));
        let unknown = self.hardest_braking_from(now, model);
        self.actuator_floor.push(
            now.saturating_add(u64::from(c.plant.actuator_dead_time_us)),
            command,
            seconds(u64::from(c.plant.actuator_lag_us)),
            unknown,
            keep_from,
        );
    }

    /// What the record knows of the actuator's acceleration from a follower measurement's
    /// time `t_f` on, at `now`: the commands issued are in force until the dead time after
    /// `now`; and its part within the band ([`ActuatorFloor::known`]).
    pub(super) fn known_braking(
        &self,
        t_f: u64,
        now: u64,
        model: &Model,
    ) -> (KnownBraking, GentlePart) {
        if let Some((at, asked, known)) = self.known_memo.get() {
            if at == t_f && asked == now {
                return known;
            }
        }
        let c = &self.config;
        let known = self.actuator_floor.known(
            t_f,
            now.saturating_add(u64::from(c.plant.actuator_dead_time_us)),
            seconds(u64::from(c.plant.actuator_lag_us)),
            model.ego.min,
        );
        self.known_memo.set(Some((t_f, now, known)));
        known
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The actuator by brute force (f64, 1 us steps, the clock's: every command switches on a
    /// step's edge): the commands `(issued_us, command)`
    /// take force `dead_us` later, through a first-order lag `lag` from `start` at the first
    /// one's force; the integrals `(int a, int (s - t_f) a, a(until), least, most)` over
    /// `[t_f, until_us]`.
    fn integrated(
        commands: &[(u64, f32)],
        dead_us: u64,
        lag: f64,
        start: f64,
        t_f: u64,
        until_us: u64,
    ) -> (f64, f64, f64, f64, f64) {
        let first = commands[0].0 + dead_us;
        let dt_us = 1u64;
        let dt = dt_us as f64 * 1e-6;
        let (mut a, mut t) = (start, first);
        let (mut speed, mut moment) = (0.0f64, 0.0f64);
        let (mut least, mut most) = (f64::INFINITY, f64::NEG_INFINITY);
        while t < until_us {
            let input = commands
                .iter()
                .rev()
                .find(|(at, _)| at + dead_us <= t)
                .map_or(start, |(_, c)| f64::from(*c));
            // Without a lag the command acts at once.
            if lag <= 0.0 {
                a = input;
            }
            let next = if lag > 0.0 {
                input + (a - input) * (-dt / lag).exp()
            } else {
                input
            };
            if t >= t_f {
                let mean = if lag > 0.0 {
                    input + (a - input) * lag / dt * (1.0 - (-dt / lag).exp())
                } else {
                    input
                };
                let s = (t - t_f) as f64 * 1e-6;
                speed += mean * dt;
                moment += mean * dt * (s + 0.5 * dt);
                least = least.min(a.min(next));
                most = most.max(a.max(next));
            }
            a = next;
            t += dt_us;
        }
        (speed, moment, a, least, most)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// With every command at most zero and the actuator starting at the bound given for
        /// it, the record's lower bound is the actuator itself: its integrals from a
        /// measurement's time to the end of the commands issued agree with brute force, so
        /// the lag is followed through each command for its own time (periods jittered,
        /// measurement times anywhere in the record, records that drop old segments). Run once
        /// with the whole segments' stored integrals replaced by zero: it fails.
        #[test]
        fn the_record_follows_the_actuator_through_every_command(
            commands in proptest::collection::vec((15_000u64..25_000, -8.0f32..0.0), 2..60),
            lag in 0.0f64..0.5, start in -8.0f32..0.0, dead_us in 0u64..200_000,
            at in 0.0f64..1.0, keep in 0.0f64..0.5,
        ) {
            let mut issued = Vec::new();
            let mut now = 1_000_000u64;
            for (gap, c) in &commands {
                now += gap;
                issued.push((now, *c));
            }
            let first = issued[0].0;
            let keep_from = first + ((now - first) as f64 * keep) as u64;
            let mut floor = ActuatorFloor::new();
            for (t, c) in &issued {
                floor.push(t + dead_us, *c, lag as f32, start, keep_from.min(*t));
            }
            let until = now + dead_us;
            let oldest = floor.segments.front().map_or(until, |s| s.from_us);
            let t_f = oldest + ((until - oldest) as f64 * at) as u64;
            let (known, gentle) = floor.known(t_f, until, lag as f32, -9.0);
            prop_assert_eq!((gentle.speed, gentle.moment), (known.speed, known.moment));
            prop_assert!((f64::from(gentle.duration) - (until - t_f) as f64 * 1e-6).abs() < 1e-5);
            if t_f >= until {
                prop_assert_eq!(known, KnownBraking::NOTHING);
                prop_assert_eq!(gentle, GentlePart::NOTHING);
                return Ok(());
            }
            let (speed, moment, end, least, most) =
                integrated(&issued, dead_us, lag, f64::from(start), t_f, until);
            let scale = 1.0 + speed.abs();
            prop_assert!((f64::from(known.speed) - speed).abs() < 1e-3 * scale, "{:?} {}", known, speed);
            prop_assert!((f64::from(known.moment) - moment).abs() < 1e-3 * (1.0 + moment.abs()), "{:?} {}", known, moment);
            prop_assert!((f64::from(known.at_end) - end).abs() < 1e-3, "{:?} {}", known, end);
            prop_assert!(f64::from(known.least) <= least + 1e-4, "{:?} {}", known, least);
            prop_assert!(f64::from(known.most) >= most - 1e-4, "{:?} {}", known, most);
            prop_assert!((f64::from(known.known_for) - (until - t_f) as f64 * 1e-6).abs() < 1e-5);
        }
    }

    /// Nothing is known before the record's first command, and the record starts again after
    /// a command that takes force before the last one's (a clock that went back).
    #[test]
    fn the_record_knows_nothing_before_its_first_command() {
        let mut floor = ActuatorFloor::new();
        assert_eq!(floor.known(0, 1_000, 0.3, -3.5).0, KnownBraking::NOTHING);
        floor.push(100_000, -1.0, 0.3, -3.5, 0);
        floor.push(120_000, -1.0, 0.3, -3.5, 0);
        assert_eq!(
            floor.known(99_999, 200_000, 0.3, -3.5).0,
            KnownBraking::NOTHING
        );
        assert!(floor.known(100_000, 200_000, 0.3, -3.5).0.speed < 0.0);
        floor.push(110_000, 0.0, 0.3, -3.5, 0);
        assert_eq!(floor.segments.len(), 1);
        assert_eq!(
            floor.known(100_000, 200_000, 0.3, -3.5).0,
            KnownBraking::NOTHING
        );
    }
}
