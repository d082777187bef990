//! The emergency answer, as hard as the leader's worst case needs: gentler than the band's
//! floor where that suffices, and harder under the emergency authority where braking at the
//! band's floor at once cannot keep the leader's worst case off the car, no harder than the
//! follower allows (the controller's module docs: emergencies).

use table_format::rear::{rear_gap_after, ReactingFollower};

use super::certificate::{profile, LeaderMemo, Model, Ramp, RearMemo, WorstCorner};
use super::history::seconds;
use super::{Controller, CERTIFICATE_TOLERANCE};
use crate::math;

/// How many lag time constants after the last command below the band takes force the
/// actuator's acceleration is taken back in the band: a first-order lag still passes on
/// `e^-10` of the excess then (2e-4 m/s^2 from 8 m/s^2 to a 3.5 m/s^2 band).
const AFTERMATH_LAGS: u64 = 10;

/// The last braking below the band, while its effect may last.
#[derive(Debug, Clone, Copy)]
pub(super) struct EmergencyMemo {
    /// The hardest braking level commanded while its effect lasts, m/s^2 (positive).
    pub(super) level: f32,
    /// When the last command below the band was issued, microseconds.
    pub(super) last_below_band_us: u64,
}

/// A braking the lights' run's on-time was counted from: every command is at most `command`
/// until `until_us` (the controller's module docs: emergencies).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LightsHold {
    /// The held command, m/s^2 (at or below the band's floor).
    pub(super) command: f32,
    /// When the lights are on for sure along it, microseconds.
    pub(super) until_us: u64,
}

impl Controller<'_> {
    /// Remembers `command` while its effect may last where it is below the band (the
    /// emergency answer's, the lights' hold, or with two authorities the ramp of the braking
    /// in force).
    pub(super) fn remember_below_band(&mut self, now: u64, command: f32, model: &Model) {
        if command < model.ego.min {
            let level = -command;
            let effect_lasts = self.emergency_reaches(now);
            self.emergency = Some(EmergencyMemo {
                level: match self.emergency {
                    Some(m) if effect_lasts => math::max(m.level, level),
                    _ => level,
                },
                last_below_band_us: now,
            });
        }
    }

    /// The lights' run after this period's `command` (at or below the lights' command): when
    /// they are on for sure, and the hold that on-time needs. The run's on-time
    /// ([`Controller::lights_on_from`]), or, for a command at or below the band's floor, the
    /// on-time of commands at or below it from now ([`Controller::lights_on_holding`]) where
    /// that is earlier: then every command until it must be at most this one. A hold under
    /// way is kept while the run's on-time is its own.
    pub(super) fn lights_run(
        &self,
        now: u64,
        model: &Model,
        command: f32,
    ) -> (Option<u64>, Option<LightsHold>) {
        let run = self.lights_on_from(now, model);
        let kept = self
            .lights_hold
            .filter(|h| now < h.until_us && run == Some(h.until_us));
        match (run, self.lights_on_holding(now, model, command)) {
            (Some(r), Some(h)) if h < r => (
                Some(h),
                Some(LightsHold {
                    command,
                    until_us: h,
                }),
            ),
            (None, Some(h)) => (
                Some(h),
                Some(LightsHold {
                    command,
                    until_us: h,
                }),
            ),
            (r, _) => (r, kept),
        }
    }

    /// When the brake lights are on for sure if `command` (at or below the band's floor) is
    /// issued now and every command until then is at most it
    /// ([`lights_on_within`](table_format::EmergencyDeclaration::lights_on_within) from what
    /// is pending, the command at once); `None` for a command above the band's floor or a
    /// bound that is not finite.
    pub(super) fn lights_on_holding(&self, now: u64, model: &Model, command: f32) -> Option<u64> {
        // (A NaN command is not at or below the floor.)
        let below_floor = command <= model.ego.min;
        if !below_floor {
            return None;
        }
        let pending = self.pending(now, model);
        self.lights_on_after(now, pending, command, f32::INFINITY, -command)
    }

    /// The vehicle's declared lights' command ([`EmergencyDeclaration::lights_command`]): one at
    /// or below it keeps a run of braking commands going, and so the brake lights on once
    /// [`lights_on_within`](table_format::EmergencyDeclaration::lights_on_within) of the run's start has passed; one above it ends the run (the
    /// follower's reaction starts again at the next one).
    ///
    /// [`EmergencyDeclaration::lights_command`]: crate::EmergencyDeclaration::lights_command
    pub(super) fn lights_command(&self) -> f32 {
        self.config.certificate.emergency.lights_command
    }

    /// Until when (microseconds) the last command below the band may still pull the
    /// actuator's acceleration below it: a period, the dead time and [`AFTERMATH_LAGS`] lag
    /// time constants after it was issued. `None` when no such command was issued.
    pub(super) fn emergency_effect_until(&self) -> Option<u64> {
        let c = &self.config;
        let memo = self.emergency?;
        Some(
            memo.last_below_band_us
                .saturating_add(u64::from(c.period_us))
                .saturating_add(u64::from(c.plant.actuator_dead_time_us))
                .saturating_add(AFTERMATH_LAGS * u64::from(c.plant.actuator_lag_us)),
        )
    }

    /// From when the brake lights are on for sure if this period's command is at or below
    /// the lights' command (microseconds): the run's, if one is under way, else a run's that
    /// starts now, from what the actuator may be doing ([`lights_on_within`](table_format::EmergencyDeclaration::lights_on_within), every command of
    /// the run at or below the lights' command). `None` if the bound is not finite.
    pub(super) fn lights_on_from(&self, now: u64, model: &Model) -> Option<u64> {
        if let Some(on) = self.lights_on_us {
            return Some(on);
        }
        let pending = self.pending(now, model);
        let run = self.lights_on_after(
            now,
            pending,
            self.lights_command(),
            f32::INFINITY,
            -self.lights_command(),
        );
        // The on-time the certificate argued with holds too: the run's commands are under its
        // ramp (they are at or below the lights' command, where that ramp ends).
        self.lights_no_later_than_argued(run)
    }

    /// When the brake lights are on for sure (microseconds) if, from `now`, the actuator's
    /// acceleration and the commands in its dead time are at most `held` and every command is
    /// at most the ramp from `from` at `jerk` down to `-level` (the lights' command for a
    /// lights' run, the braking argued with for its ramp;
    /// [`lights_on_within`](table_format::EmergencyDeclaration::lights_on_within) through the
    /// declared dead time and lag). `None` if the bound is not finite.
    pub(super) fn lights_on_after(
        &self,
        now: u64,
        held: f32,
        from: f32,
        jerk: f32,
        level: f32,
    ) -> Option<u64> {
        let c = &self.config;
        let within = c.certificate.emergency.lights_on_within(
            seconds(u64::from(c.plant.actuator_dead_time_us)),
            seconds(u64::from(c.plant.actuator_lag_us)),
            held,
            held,
            from,
            jerk,
            level,
        );
        now.checked_add(math::micros(within)?)
    }

    /// Whether the brake lights may be off for the next period while a braking below the band
    /// may still act (a command `u` above the lights' command ends the lights' run, and the
    /// follower's reaction starts again at the next braking): the rear check of
    /// [`Controller::below_band`] for the band's floor, the hardest braking that may
    /// come next without a check of its own, with the follower's reaction starting only when
    /// the lights come on again after `u` is held a period and the braking ramp
    /// (`brake_jerk`) brings the command down to the lights' command. Where it fails, the step
    /// follows that ramp from its last command (the one the last check passed with): the
    /// lights come on, and the follower, reacting, falls back.
    pub(super) fn release_allowed(&self, model: &Model, now: u64, u: f32) -> bool {
        if model.emergency.is_none() {
            return true;
        }
        let c = &self.config;
        let Some(rear) = self.rear else {
            return false;
        };
        if !math::is_finite(rear.track.gap) {
            return true;
        }
        let held = math::max(self.pending(now, model), u);
        // `u` held a period, then the braking ramp down to the gentlest braking that keeps the
        // lights on (what the step commands where this check fails); at once without a ramp.
        let jerk = c.certificate.brake_jerk;
        let (from, held_for) = if math::is_finite(jerk) {
            (u + jerk * seconds(u64::from(c.period_us)), 0)
        } else {
            (self.lights_command(), u64::from(c.period_us))
        };
        let level = -self.lights_command();
        let Some(on) = self.lights_on_after(now.saturating_add(held_for), held, from, jerk, level)
        else {
            return false;
        };
        let dark = seconds(on.saturating_sub(rear.at_us));
        self.rear_check(model, &rear, -model.ego.min, 0.0, dark)
    }

    /// Whether the effect of a braking below the band may reach time `t`, or after it.
    pub(super) fn emergency_reaches(&self, t: u64) -> bool {
        self.emergency_effect_until().is_some_and(|end| t <= end)
    }

    /// The hardest acceleration the ego may have had from `t` on: the band's floor, or the
    /// emergency's level while its effect may last.
    pub(super) fn hardest_braking_from(&self, t: u64, model: &Model) -> f32 {
        match self.emergency {
            Some(memo) if self.emergency_reaches(t) => math::min(-memo.level, model.ego.min),
            _ => model.ego.min,
        }
    }

    /// The emergency answer's braking level (m/s^2, positive; commanded at once as its
    /// negative) where the step found the front not certified and nothing passing
    /// (`enforce_front`'s jump): as hard as the leader's worst case needs, not a fixed level.
    ///
    /// The front is judged as the step judges it: the worst corner of the leader's
    /// measurement, the ego's acceleration held at what is `pending` until the command takes
    /// force through the dead time and the lag. Where braking at the band's floor then keeps
    /// the worst case above the front margin, the answer is the gentlest level between the
    /// committed ramp's command for this period (`floor`; no gentler: the ramp's own command)
    /// and the band's floor that does ([`Controller::gentlest_in_band`]): a comfort response
    /// where comfort suffices. Otherwise the emergency authority's level
    /// ([`Controller::below_band`]), or the band's floor where it has none or buys nothing.
    pub(super) fn emergency_answer(
        &self,
        model: &Model,
        leader: &LeaderMemo,
        now: u64,
        pending: f32,
        floor: f32,
    ) -> f32 {
        let c = &self.config;
        let beta = -model.ego.min;
        let corner = self.worst_corner(leader);
        // Every command from now on is at or below the answer. The ego's acceleration is
        // bounded as the actuator's declared dead time and lag bound it: a hold of what is
        // pending until the command takes force, plus the lag.
        let (response, _) = profile(
            leader.at_us,
            Ramp {
                start_us: now,
                from: -beta,
            },
            u64::from(c.plant.actuator_dead_time_us),
            seconds(u64::from(c.plant.actuator_lag_us)),
            f32::INFINITY,
        );
        self.gentlest_in_band(model, &corner, response, pending, floor)
            .or_else(|| self.below_band(model, &corner, now, response, pending))
            .unwrap_or(beta)
    }

    /// The gentlest braking level in the band that keeps the leader's worst case at `corner`
    /// above the front margin, commanded at once: `None` where not even the band's floor does.
    /// Through the band's actuator (a dead time and a first-order lag: a hold of `pending` for
    /// `response`, then the level, the bound `table_format::front`'s module docs derive), the
    /// front value is nearly affine in `1 / level` (the stopping distance): a secant there
    /// between the committed ramp's command (`floor`) and the band's floor, 10% short of its
    /// root, checked, then halfway back, checked, else the band's floor: at most four front
    /// evaluations. What follows it: with no ramp under way, the step starts the braking ramp
    /// through the answer (`Controller::step`); the next step's committed ramp has the same
    /// hold, then the continuous ramp through the answer's period (`brake_jerk h` gentler than
    /// the answer at its start, harder after its first period), so its front value at the same
    /// corner is this one less a few micrometres, or more. With a ramp under way the step keeps
    /// it (as for the band's floor: the answer is at or below its command). Either way the next
    /// step judges the state again.
    fn gentlest_in_band(
        &self,
        model: &Model,
        corner: &WorstCorner,
        response: f32,
        pending: f32,
        floor: f32,
    ) -> Option<f32> {
        let beta = -model.ego.min;
        let margin = self.config.certificate.front_margin;
        let ahead = |level: f32| corner.front_at(model, response, pending, level, f32::INFINITY);
        let at_band = ahead(beta);
        // (A NaN is not in the band: the comparison is false.)
        let band_suffices = at_band > margin;
        if !band_suffices {
            return None;
        }
        // No gentler than the ramp's own command, and a braking (the lights' command at the
        // least: an answer the follower sees).
        let gentlest = math::clamp(-floor, -self.lights_command(), beta);
        if gentlest >= beta {
            return Some(beta);
        }
        let at_gentlest = ahead(gentlest);
        if at_gentlest > margin {
            return Some(gentlest);
        }
        let (x_band, x_gentlest) = (1.0 / beta, 1.0 / gentlest);
        let share = math::clamp(0.9 * (at_band - margin) / (at_band - at_gentlest), 0.0, 1.0);
        let candidate = x_band + share * (x_gentlest - x_band);
        let halfway = 0.5 * (candidate + x_band);
        [candidate, halfway]
            .iter()
            .map(|x| 1.0 / x)
            .find(|level| ahead(*level) > margin)
            .or(Some(beta))
    }

    /// The emergency authority's braking level (m/s^2, positive, harder than the band's
    /// floor) where braking at the band's floor at once cannot keep the leader's worst case at
    /// `corner` above the front margin: `None` where the full level buys no more than
    /// [`CERTIFICATE_TOLERANCE`] of front value over the band's floor, where no emergency
    /// authority is configured, or where the follower allows no braking harder than the band.
    ///
    /// Otherwise the gentlest level between the band's floor and the emergency level that
    /// keeps the front above its margin, or the emergency level when none does, lowered to
    /// what the follower allows; it is commanded at once, and the actuator builds it up. The
    /// ego's acceleration is held at what is `pending` for `response` (the dead time and the
    /// lag), then ramps at the emergency's jerk (a brake that builds up no faster than
    /// declared: the slower of the two); its value is nearly affine in `1 / level` (the
    /// stopping distance), so a secant there, checked, finds the level in at most four
    /// evaluations. The rear is [`rear_gap_after`] at the worst corner of the follower's
    /// measurement box at its time `t_f`: the ego braking at most at the level (or the hardest
    /// since `t_f`) from then on, the follower accelerating at most at its model's top until
    /// its reaction time after the lights come on, then braking at its model's hardest. The
    /// lights' on-time is the run's ([`Controller::lights_on_from`]) or, where earlier, the
    /// level's own held from now ([`Controller::lights_on_holding`]), as the step keeps it if
    /// the level is commanded ([`Controller::lights_run`]).
    fn below_band(
        &self,
        model: &Model,
        corner: &WorstCorner,
        now: u64,
        response: f32,
        pending: f32,
    ) -> Option<f32> {
        let e = model.emergency?;
        let beta = -model.ego.min;
        let margin = self.config.certificate.front_margin;
        let ahead = |level: f32| corner.front_at(model, response, pending, level, e.jerk);
        let at_band = ahead(beta);
        let at_full = ahead(e.level);
        // Braking harder buys nothing ahead (at a standstill, or a worst case decided before the
        // braking takes effect): the band's floor.
        if at_full <= at_band + CERTIFICATE_TOLERANCE {
            return None;
        }
        let (x_band, x_full) = (1.0 / beta, 1.0 / e.level);
        let level = if at_full > margin {
            // The share of the way from the full level back towards the band's, 10% short of
            // the secant's root.
            let share = math::clamp(0.9 * (at_full - margin) / (at_full - at_band), 0.0, 1.0);
            let candidate = x_full + share * (x_band - x_full);
            let halfway = 0.5 * (candidate + x_full);
            if ahead(1.0 / candidate) > margin {
                1.0 / candidate
            } else if ahead(1.0 / halfway) > margin {
                1.0 / halfway
            } else {
                e.level
            }
        } else {
            e.level
        };
        self.follower_allows(model, now, level)
            .filter(|level| *level > beta)
    }

    /// The hardest level up to `wanted` (above the band's floor) that the rear check passes
    /// ([`Controller::below_band`]): `None` when no level above the band's floor
    /// passes, the follower's track is not kept, or when the lights come on is not known.
    fn follower_allows(&self, model: &Model, now: u64, wanted: f32) -> Option<f32> {
        let beta = -model.ego.min;
        let rear = self.rear?;
        let run = self.lights_on_from(now, model);
        if !math::is_finite(rear.track.gap) {
            return run
                .or(self.lights_on_holding(now, model, -wanted))
                .map(|_| wanted);
        }
        let t_f = rear.at_us;
        [1.0, 0.5, 0.25]
            .iter()
            .map(|share| beta + share * (wanted - beta))
            .find(|level| {
                // The lights' run as the step will keep it if this level is commanded.
                let held = self.lights_on_holding(now, model, -*level);
                let Some(on) = [run, held].into_iter().flatten().min() else {
                    return false;
                };
                let (clock, dark) = if t_f >= on {
                    (seconds(t_f - on), 0.0)
                } else {
                    (0.0, seconds(on - t_f))
                };
                self.rear_check(model, &rear, *level, clock, dark)
            })
    }

    /// The rear check: [`Controller::rear_gap`] above `rear_margin`.
    pub(super) fn rear_check(
        &self,
        model: &Model,
        rear: &RearMemo,
        level: f32,
        clock: f32,
        dark: f32,
    ) -> bool {
        self.rear_gap(model, rear, level, clock, dark) > self.config.certificate.rear_margin
    }

    /// [`rear_gap_after`] at the worst corner of the kept follower measurement's box at its
    /// time, for an ego braking at most at `level` (or the hardest since then) and a follower
    /// whose reaction has run `clock` seconds, or starts `dark` seconds after the measurement,
    /// m.
    pub(super) fn rear_gap(
        &self,
        model: &Model,
        rear: &RearMemo,
        level: f32,
        clock: f32,
        dark: f32,
    ) -> f32 {
        let c = &self.config;
        let (lo, hi) = c
            .sensors
            .error
            .rear_box(rear.track.gap, rear.track.rel_speed, rear.ego);
        let (gap, follower_speed, ego_speed) = (lo[0], math::min(hi[1], model.max_speed), lo[2]);
        let follower = ReactingFollower {
            reaction_time: model.follower.reaction_time + dark,
            ..model.follower
        };
        let since = -self.hardest_braking_from(rear.at_us, model);
        rear_gap_after(
            gap,
            ego_speed,
            follower_speed,
            math::max(level, since),
            clock,
            &follower,
        )
    }
}
