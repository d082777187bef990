//! The emergency answer, as hard as the leader's worst case needs: gentler than the band's
//! floor where that suffices, and harder under the emergency authority where braking at the
//! band's floor at once cannot keep the leader's worst case off the car, no harder than the
//! follower allows (the controller's module docs: emergencies).

use table_format::rear::{hardest_clearing, rear_gap_after, EgoBuildUp, ReactingFollower};

use super::authorities::{reaction_at, LEVEL_RESOLUTION};
use super::certificate::{profile, LeaderMemo, Model, Ramp, RearMemo, WorstCorner};
use super::history::seconds;
use super::{Controller, CERTIFICATE_TOLERANCE};
use crate::math;
use table_format::authority::Braking;

/// How many lag time constants after the last command below the band takes force the
/// actuator's acceleration is taken back in the band: a first-order lag still passes on
/// `e^-10` of the excess then (2e-4 m/s^2 from 8 m/s^2 to a 3.5 m/s^2 band).
const AFTERMATH_LAGS: u64 = 10;

/// How far below the lights' deceleration's negative the gentlest command that keeps a lit
/// lights' run stays, m/s^2 ([`Controller::gentlest_keeping_run`]): any margin keeps the lights
/// on in the declared model; this one is the largest step down from a command of the run
/// above it that ISO 15622's jerk limit allows in a 20 ms period at every speed (2.5 m/s^3).
pub(super) const LIT_RUN_MARGIN: f32 = 0.05;

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
    /// they are on for sure, the hold that on-time needs, and when they are on for sure by
    /// the run's own commands (`lights_run_own_us`). The run's on-time
    /// ([`Controller::lights_on_from`]), or, for a command at or below the band's floor, the
    /// on-time of commands at or below it from now ([`Controller::lights_on_holding`]) where
    /// that is earlier: then every command until it must be at most this one. A hold under
    /// way is kept while the run's on-time is its own. The run's own on-time is kept while it
    /// goes on, else [`Controller::lights_run_starting`]'s, and no later than a hold's.
    pub(super) fn lights_run(
        &self,
        now: u64,
        model: &Model,
        command: f32,
    ) -> (Option<u64>, Option<LightsHold>, Option<u64>) {
        // (`lights_on_from`, with the run's own bound kept.)
        let (run, own) = match self.lights_on_us {
            Some(on) => (Some(on), self.lights_run_own_us),
            None => {
                let own = self.lights_run_starting(now, model);
                (self.lights_no_later_than_argued(own), own)
            }
        };
        let kept = self
            .lights_hold
            .filter(|h| now < h.until_us && run == Some(h.until_us));
        match self.lights_on_holding(now, model, command) {
            Some(h) if run.is_none_or(|r| h < r) => (
                Some(h),
                Some(LightsHold {
                    command,
                    until_us: h,
                }),
                Some(own.map_or(h, |o| o.min(h))),
            ),
            _ => (run, kept, own.filter(|_| run.is_some())),
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
    /// [`lights_on_within`] of the run's start has passed; one above it ends the run (the
    /// follower's reaction starts again at the next one).
    ///
    /// [`EmergencyDeclaration::lights_command`]: crate::EmergencyDeclaration::lights_command
    /// [`lights_on_within`]: table_format::EmergencyDeclaration::lights_on_within
    pub(super) fn lights_command(&self) -> f32 {
        self.config.certificate.emergency.lights_command
    }

    /// Whether `command`, issued at `now`, keeps the lights' run under way going: one at or
    /// below the lights' command always does; once the run's own commands have lit the brakes
    /// for sure ([`Controller::run_lit`]), so does any command below the declared lights'
    /// deceleration's negative.
    ///
    /// Why: the lights are on for sure while the actuator's acceleration `A` is below
    /// `-theta` (`table_format::authority`'s module docs). The run's commands alone keep `A`
    /// below `-theta` from the run's own on-time on, and `A` until `now` plus the dead time
    /// depends only on commands issued before `now`, so it is below `-theta` there. From then
    /// on the first-order lag moves `A` only towards the commands in force (`A' = (u - A) /
    /// lag`: `A` is a convex combination of where it was and of those commands, or the
    /// command itself without a lag), all below `-theta`: it stays below, and the follower's
    /// reaction, counted from the run's on-time, goes on. (At standstill after a braking the
    /// lights are on by the same model.) A NaN command keeps no run.
    pub(super) fn keeps_lights_run(&self, now: u64, command: f32) -> bool {
        let theta = self.config.certificate.emergency.lights_deceleration;
        command <= self.lights_command() || (self.run_lit(now) && command < -theta)
    }

    /// Whether `command`, issued at `now`, ends the lights' run under way (or, with none, would
    /// end one): it does not keep it ([`Controller::keeps_lights_run`]). A NaN command ends
    /// none: the release question is not asked of it.
    pub(super) fn ends_lights_run(&self, now: u64, command: f32) -> bool {
        command > self.lights_command() && !self.keeps_lights_run(now, command)
    }

    /// Whether a lights' run is under way whose own commands have lit the brakes for sure by
    /// `now` (`lights_run_own_us`, not an earlier on-time a look-ahead argued with: that one
    /// holds only while the commands stay under its ramp).
    pub(super) fn run_lit(&self, now: u64) -> bool {
        self.lights_on_us.is_some() && self.lights_run_own_us.is_some_and(|own| own <= now)
    }

    /// The gentlest command that keeps the lights' run under way at `now` going
    /// ([`Controller::keeps_lights_run`]), m/s^2: once the run is lit, [`LIT_RUN_MARGIN`]
    /// below the lights' deceleration's negative (or the lights' command, if gentler), else
    /// the lights' command.
    pub(super) fn gentlest_keeping_run(&self, now: u64) -> f32 {
        let theta = self.config.certificate.emergency.lights_deceleration;
        if self.run_lit(now) {
            math::max(-theta - LIT_RUN_MARGIN, self.lights_command())
        } else {
            self.lights_command()
        }
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
    /// starts now, from what the actuator may be doing ([`lights_on_within`], every command of
    /// the run at or below the lights' command). `None` if the bound is not finite.
    ///
    /// [`lights_on_within`]: table_format::EmergencyDeclaration::lights_on_within
    pub(super) fn lights_on_from(&self, now: u64, model: &Model) -> Option<u64> {
        if let Some(on) = self.lights_on_us {
            return Some(on);
        }
        // The on-time the certificate argued with holds too: the run's commands are under its
        // ramp (they are at or below the lights' command, where that ramp ends).
        self.lights_no_later_than_argued(self.lights_run_starting(now, model))
    }

    /// When the brake lights are on for sure (microseconds) for a run of commands at or below
    /// the lights' command starting now, by the run alone: what the actuator may be doing
    /// ([`Controller::pending`]) held, then the lights' command at once, through the declared
    /// dead time and lag. `None` if the bound is not finite.
    pub(super) fn lights_run_starting(&self, now: u64, model: &Model) -> Option<u64> {
        let pending = self.pending(now, model);
        self.lights_on_after(
            now,
            pending,
            self.lights_command(),
            f32::INFINITY,
            -self.lights_command(),
        )
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

    /// Whether the brake lights may be off for the next period (a command `u` above the lights'
    /// command ends the lights' run, and the follower's reaction starts again at the next
    /// braking): the rear check of [`Controller::below_band`] for the band's floor, with the
    /// follower's reaction starting only when the lights come on again after `u` is held a
    /// period and the braking ramp (`brake_jerk`) brings the command down to the lights'
    /// command. In the band it is asked while a braking below the band may still act (the
    /// band's floor is then the hardest braking that may come next without a check of its
    /// own); where it fails, the step follows that ramp from its last command (the one the
    /// last check passed with): the lights come on, and the follower, reacting, falls back.
    /// With two authorities it is asked of every proposal that would end a run, and of every
    /// proposal that keeps the lights dark for a while after one ended, with `u` held
    /// `spare_us` longer than the period ([`Controller::look_ahead`]); in the band `spare_us`
    /// is zero. With two authorities (`front_certified` given: whether the front certifies the
    /// measured state along a braking), where the follower would not allow the band's floor,
    /// the hardest of the gentler levels a look-ahead argues with that it would allow, the
    /// lights back the same way ([`Controller::gentler_levels`]; that way's on-time, down to
    /// the gentlest level, serves every harder one), passes where the front certifies with
    /// it: the look-ahead would then pass with that level too, so the release costs no
    /// emergency, where insisting on the band's floor held the lights' run, and the braking,
    /// while the leader drew away and a follower closed as the speeds fell. A prediction for
    /// comfort, not a bound: the look-ahead of the proposal decides what is certified.
    pub(super) fn release_allowed(
        &self,
        model: &Model,
        now: u64,
        u: f32,
        spare_us: u64,
        front_certified: Option<&dyn Fn(Braking) -> bool>,
    ) -> bool {
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
        let held_for = held_for.saturating_add(spare_us);
        let level = -self.lights_command();
        let Some(on) = self.lights_on_after(now.saturating_add(held_for), held, from, jerk, level)
        else {
            return false;
        };
        let dark = seconds(on.saturating_sub(rear.at_us));
        if self.rear_check(model, &rear, -model.ego.min, 0.0, dark, now) {
            return true;
        }
        // With two authorities, a gentler level the follower allows with the lights back that
        // way, where the front certifies with it: the hardest such level (the front needs more
        // room at a gentler one).
        let (Some(front_certified), Some(e)) = (front_certified, model.emergency) else {
            return false;
        };
        self.gentler_levels(model)
            .find(|level| self.rear_check(model, &rear, *level, 0.0, dark, now))
            .is_some_and(|level| {
                front_certified(Braking {
                    level,
                    jerk: e.jerk,
                })
            })
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
    /// measurement box at its time `t_f` ([`RearCorner::gap_after`]): the ego braking at most at
    /// the level from now on, the follower accelerating at most at its model's top until
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
    /// ([`Controller::below_band`]), to [`LEVEL_RESOLUTION`]: `None` when no level above the
    /// band's floor passes, the follower's track is not kept, or when the lights come on is
    /// not known.
    ///
    /// `wanted` is checked with the lights' on-time it brings held from now; where it fails,
    /// the hardest level in the band's floor to it that clears with the on-time the band's
    /// floor brings ([`hardest_clearing`]). A harder held command lights the brakes no later
    /// (the lag is monotone in its input), so the level found clears with its own on-time too,
    /// as the step keeps it ([`Controller::lights_run`]); one on-time keeps the rear value
    /// non-increasing in the level, as the search needs.
    fn follower_allows(&self, model: &Model, now: u64, wanted: f32) -> Option<f32> {
        let beta = -model.ego.min;
        let rear = self.rear?;
        let run = self.lights_on_from(now, model);
        let held = |level: f32| self.lights_on_holding(now, model, -level);
        if !math::is_finite(rear.track.gap) {
            return run.or(held(wanted)).map(|_| wanted);
        }
        let t_f = rear.at_us;
        let corner = self.rear_corner(model, &rear, now);
        let margin = self.config.certificate.rear_margin;
        // The lights' run as the step will keep it if `level` is commanded.
        let clock_for = |level: f32| {
            let on = [run, held(level)].into_iter().flatten().min()?;
            Some(reaction_at(t_f, on))
        };
        let (clock, dark) = clock_for(wanted)?;
        if corner.clears(model, wanted, clock, dark, margin) {
            return Some(wanted);
        }
        let (clock, dark) = clock_for(beta)?;
        hardest_clearing(
            |level| corner.gap_after(model, level, clock, dark) - margin,
            beta,
            wanted,
            LEVEL_RESOLUTION,
        )
    }

    /// The rear check: [`RearCorner::gap_after`] above `rear_margin`.
    pub(super) fn rear_check(
        &self,
        model: &Model,
        rear: &RearMemo,
        level: f32,
        clock: f32,
        dark: f32,
        now: u64,
    ) -> bool {
        self.rear_corner(model, rear, now).clears(
            model,
            level,
            clock,
            dark,
            self.config.certificate.rear_margin,
        )
    }

    /// The worst corner of the kept follower measurement `rear`'s box at its time (the least
    /// gap, the fastest follower up to the model's top speed, the slowest ego), with the ego's
    /// braking before `now` ([`Controller::rear_state`]): computed once where a step tries
    /// several levels.
    pub(super) fn rear_corner(&self, model: &Model, rear: &RearMemo, now: u64) -> RearCorner {
        let (lo, hi) =
            self.config
                .sensors
                .error
                .rear_box(rear.track.gap, rear.track.rel_speed, rear.ego);
        self.rear_state(
            model,
            [lo[0], math::min(hi[1], model.max_speed), lo[2]],
            rear.at_us,
            now,
        )
    }

    /// The rear state `[gap, follower_speed, ego_speed]` (m, m/s) at time `t_f`, with what
    /// [`RearCorner::gap_after`] takes of the ego's braking from `t_f` until `now`: its hardest
    /// ([`Controller::hardest_braking_from`]) and how long it may have owed speed, whatever
    /// level it is asked about.
    pub(super) fn rear_state(
        &self,
        model: &Model,
        [gap, follower_speed, ego_speed]: [f32; 3],
        t_f: u64,
        now: u64,
    ) -> RearCorner {
        let (owing_for, held, held_for) = self.owing(t_f, now);
        RearCorner {
            gap,
            follower_speed,
            ego_speed,
            since: -self.hardest_braking_from(t_f, model),
            owing_for,
            held,
            held_for,
            issued: self.least_issued_since(t_f, now, model),
        }
    }

    /// What [`debt_bound`] takes of the ego's braking for a measurement at `t_f`, at `now`:
    /// `(owing_for, held, held_for)`, the lag and the commands in force from the dead time
    /// before `t_f` until now (s), the lights' hold's braking (m/s^2, zero: none) and how long
    /// it lasts (s).
    fn owing(&self, t_f: u64, now: u64) -> (f32, f32, f32) {
        let c = &self.config;
        let in_force = now
            .saturating_sub(t_f)
            .saturating_add(u64::from(c.plant.actuator_dead_time_us));
        let (held, held_for) = self
            .lights_hold
            .filter(|h| now < h.until_us)
            .map_or((0.0, 0.0), |h| (-h.command, seconds(h.until_us - now)));
        (
            seconds(u64::from(c.plant.actuator_lag_us)) + seconds(in_force),
            held,
            held_for,
        )
    }
}

/// One of [`RearCorner::gap_after`]'s bounds: the closed form's gap (m), ego speed (m/s) and
/// braking level (m/s^2, positive).
type Bound = (f32, f32, f32);

/// A rear state at a follower measurement's time `t_f` (the worst corner of its box:
/// [`Controller::rear_corner`]; a true state: [`Controller::rear_state`]) and the ego's
/// braking from `t_f` until now.
#[derive(Debug, Clone, Copy)]
pub(super) struct RearCorner {
    /// The gap, m (at a box's worst corner, the least).
    gap: f32,
    /// The follower's speed, m/s (the fastest, up to the model's top speed).
    follower_speed: f32,
    /// The ego's speed, m/s (the slowest).
    ego_speed: f32,
    /// The hardest braking from `t_f` on, m/s^2 (positive).
    since: f32,
    /// How long a braking up to `since` may have owed speed, s: the lag, and the commands in
    /// force from the dead time before `t_f` until now ([`debt_bound`]).
    owing_for: f32,
    /// The lights' hold's braking, m/s^2 (positive; zero: none).
    held: f32,
    /// How long the hold lasts from now, s.
    held_for: f32,
    /// With two authorities, what the issued commands bound of the ego's acceleration from
    /// `t_f` until now: its least (m/s^2, at most zero) and for how long (s)
    /// ([`Controller::least_issued_since`]; `None`: not known).
    issued: Option<(f32, f32)>,
}

impl RearCorner {
    /// [`rear_gap_after`] at this state, for an ego that brakes at most at `level` from now on,
    /// and a follower whose reaction has run `clock` seconds, or starts `dark` seconds after
    /// the measurement, m.
    ///
    /// The ego's braking between `t_f` and `now` may have been harder than `level`: up to
    /// `since`, the hardest braking from `t_f` on ([`Controller::hardest_braking_from`]). Two
    /// bounds of its position hold, and the larger value is taken:
    /// - braking at `max(level, since)` from `t_f` on;
    /// - braking at `level` from `t_f` on, from a speed lower by the braking's debt beyond
    ///   `level` ([`debt_bound`]): the speed the ego's acceleration can lose below
    ///   `-level` from `t_f` on. With `e(t) = max(0, -a(t) - level)` the ego's speed is at
    ///   least `v(t_f) - level (t - t_f) - E` for `E` the integral of `e`, so its position is
    ///   at least that of the debt taken at once, which is the closed form's ego at the lower
    ///   speed (non-decreasing in the ego's speed).
    ///
    /// A braking held for a period is not then taken as held for good: one period at 5.75
    /// m/s^2, checked at 3.5 from a track 0.08 s old, costs 1.1 m/s of speed (0.48 s of the
    /// default lag, dead time and age at 2.25 m/s^2), where the first bound brakes at 5.75 to
    /// a standstill.
    ///
    /// With two authorities a third bound holds where the commands issued since `t_f` are known
    /// ([`Controller::least_issued_since`]: the ego's acceleration was at least `least`, at or
    /// above `-level`, for the `T` seconds from `t_f` until now) and no lights' hold brakes
    /// harder than `level`: the ego's acceleration is then at least `least` until now and at
    /// least `-level` after (every command from now on is, and the older ones still in force
    /// are at least `least`), whatever the actuator (no slower than declared: an instant one is
    /// the worst). That is [`table_format::rear::EgoBuildUp`]'s bound with no lag
    /// ([`table_format::rear::KnownBraking::credit`]: the ego as one braking at `level` from
    /// `t_f`, `(level + least) T` faster and `(level + least) T^2 / 2` further back). The
    /// commands from now on are not credited: a later step may command anything down to
    /// `-level`.
    pub(super) fn gap_after(&self, model: &Model, level: f32, clock: f32, dark: f32) -> f32 {
        let follower = self.follower(model, dark);
        let at = |bound| self.at(bound, clock, &follower);
        let (owed, held, credited) = self.bounds(level);
        let mut value = at(held);
        if let Some(owed) = owed {
            value = math::max(value, at(owed));
        }
        if let Some(credited) = credited {
            value = math::max(value, at(credited));
        }
        value
    }

    /// Whether [`RearCorner::gap_after`] is above `margin`: the bound that credits the issued
    /// commands first, then the one that counts the debt, the one that holds the earlier
    /// braking for good only where those fail.
    pub(super) fn clears(
        &self,
        model: &Model,
        level: f32,
        clock: f32,
        dark: f32,
        margin: f32,
    ) -> bool {
        let follower = self.follower(model, dark);
        let at = |bound| self.at(bound, clock, &follower);
        let (owed, held, credited) = self.bounds(level);
        credited.is_some_and(|credited| at(credited) > margin)
            || owed.is_some_and(|owed| at(owed) > margin)
            || at(held) > margin
    }

    /// [`RearCorner::gap_after`]'s bounds for `level`, as `(gap, ego_speed, braking)` from this
    /// state: braking at `level` from the speed less the debt, where `since` is harder than
    /// `level` (a NaN level is not); braking at `max(level, since)`; and braking at `level`
    /// credited with the issued commands, where they are known and none brakes harder than
    /// `level` (with no time known, the ego braking at `level` from now: a braking held
    /// earlier no longer counts for good).
    fn bounds(&self, level: f32) -> (Option<Bound>, Bound, Option<Bound>) {
        let held = (self.gap, self.ego_speed, math::max(level, self.since));
        let harder_before = self.since > level;
        let owed = harder_before.then(|| {
            let debt = debt_bound(self.since, level, self.owing_for, self.held, self.held_for);
            (self.gap, math::max(self.ego_speed - debt, 0.0), level)
        });
        // A hold harder than the level breaks "at least `-level` from now on" (`held_for` is
        // never NaN; a NaN level gets no credit).
        let hold_within = self.held_for <= 0.0 || self.held <= level;
        let credited = self
            .issued
            .filter(|_| hold_within)
            .and_then(|(least, known_for)| {
                let (behind, faster) = EgoBuildUp {
                    acceleration: least,
                    commands: least,
                    known_for,
                    lag: 0.0,
                }
                .credit(level);
                // A least command below `-level` credits nothing (the closed form's ego brakes
                // at `level` from `t_f`): the bound is then the one held for good's. With no
                // time known and no harder braking since, it is that bound itself, not
                // evaluated twice.
                (least >= -level && (faster > 0.0 || self.since > level)).then_some((
                    self.gap - behind,
                    self.ego_speed + faster,
                    level,
                ))
            });
        (owed, held, credited)
    }

    /// [`rear_gap_after`] from this state's follower and a bound's `(gap, ego_speed,
    /// braking)`.
    fn at(&self, (gap, ego_speed, braking): Bound, clock: f32, follower: &ReactingFollower) -> f32 {
        rear_gap_after(
            gap,
            ego_speed,
            self.follower_speed,
            braking,
            clock,
            follower,
        )
    }

    /// The corner `t` seconds on (s), the follower and the ego keeping the corner's speeds but
    /// for the ego's `acceleration` (m/s^2; its speed held at or above zero): a prediction of
    /// where a follower closing on the ego will be, for comfort ([`Controller::look_ahead`]),
    /// not a bound (the follower may accelerate).
    pub(super) fn ahead_by(&self, t: f32, acceleration: f32) -> RearCorner {
        let t = math::max(t, 0.0);
        let ego_speed = math::max(self.ego_speed + acceleration * t, 0.0);
        // The ego's distance, its speed held at zero once it stops.
        let ego_moves = if ego_speed > 0.0 {
            0.5 * (self.ego_speed + ego_speed) * t
        } else if acceleration < 0.0 {
            self.ego_speed * self.ego_speed / (-2.0 * acceleration)
        } else {
            0.0
        };
        RearCorner {
            gap: self.gap + ego_moves - self.follower_speed * t,
            ego_speed,
            ..*self
        }
    }

    /// The model's follower, its reaction starting `dark` seconds after the measurement.
    fn follower(&self, model: &Model, dark: f32) -> ReactingFollower {
        ReactingFollower {
            reaction_time: model.follower.reaction_time + dark,
            ..model.follower
        }
    }
}

/// The speed (m/s) an ego that brakes at most at `level` from now on can lose to braking
/// harder than `level` from the follower measurement's time `t_f` on, where its acceleration
/// has been at least `-since` from `t_f` on ([`RearCorner::gap_after`]): its actuator's lag and
/// the commands in force from the dead time before `t_f` until now, `owing_for` seconds in
/// all, at up to `since`; then the lights' hold, `held` for `held_for` seconds; then at most
/// `level`.
///
/// The actuator is the declared dead time `D` then a first-order lag `tau`. Write
/// `y = -a - level` for its acceleration `a` and `u(t) = -c(t - D) - level` for the commands
/// `c`: `tau y' = u - y`. The lag of `max(u, 0)` from `max(y(t_f), 0)` bounds `y` from above
/// and stays at or above zero, so it bounds `max(y, 0)`, and its integral from `t_f` on is at
/// most `tau max(y(t_f), 0)` plus the integral of `max(u, 0)` (a lag passes on its input's
/// integral and sheds its initial state's `tau y(t_f)`). So the debt is at most:
/// - the actuator's state at `t_f`, at least `-since`: `tau (since - level)`;
/// - the commands in force from `t_f - D` until now, each at least `-since` (a braking below
///   the band is remembered while its effect reaches `t_f`): `(since - level)` for
///   `now - t_f + D`;
/// - the commands from now on: at least `-level`, but the lights' hold ([`LightsHold`]), which
///   the step enforces: its braking beyond `level` until it ends.
fn debt_bound(since: f32, level: f32, owing_for: f32, held: f32, held_for: f32) -> f32 {
    math::max(since - level, 0.0) * owing_for + math::max(held - level, 0.0) * held_for
}

#[cfg(test)]
mod tests {
    use super::{debt_bound, RearCorner};
    use proptest::prelude::*;

    /// A measurement of this instant (no time since it), after a braking at 8 m/s^2 that the
    /// issued commands show over (none below -2 m/s^2 in force): the credited bound is the ego
    /// braking at the level from now, not the earlier braking held for good, and it is what
    /// the value takes. A least command below `-level` credits nothing.
    #[test]
    fn a_measurement_of_now_is_credited_with_the_commands_in_force() {
        let corner = |least: f32| RearCorner {
            gap: 30.0,
            follower_speed: 30.0,
            ego_speed: 30.0,
            since: 8.0,
            owing_for: 0.0,
            held: 0.0,
            held_for: 0.0,
            issued: Some((least, 0.0)),
        };
        let (_, held, credited) = corner(-2.0).bounds(4.0);
        assert_eq!(held, (30.0, 30.0, 8.0));
        assert_eq!(credited, Some((30.0, 30.0, 4.0)));
        let (_, _, credited) = corner(-4.5).bounds(4.0);
        assert_eq!(credited, None);
    }

    /// The speed a first-order lag behind a dead time loses below `-level` from `t_f` on, by
    /// brute force: piecewise-constant commands per 20 ms period, the lag solved exactly over
    /// each piece, the excess integrated on a 0.1 ms grid, until the excess has decayed.
    fn lost_below(
        level: f64,
        dead: f64,
        lag: f64,
        a_at_t_f: f64,
        command_at: &dyn Fn(f64) -> f64,
    ) -> f64 {
        let dt = 1e-4;
        let mut a = a_at_t_f;
        let mut lost = 0.0;
        let mut t = 0.0;
        while t < 6.0 {
            // The command in force at the actuator at `t` (after the measurement's time) was
            // issued at `t - dead`.
            let c = command_at(t - dead);
            let next = c + (a - c) * (-dt / lag).exp();
            // The excess at the two ends and the middle (Simpson on the smooth piece).
            let mid = c + (a - c) * (-dt / (2.0 * lag)).exp();
            let e = |x: f64| (-x - level).max(0.0);
            lost += dt / 6.0 * (e(a) + 4.0 * e(mid) + e(next));
            a = next;
            t += dt;
        }
        lost
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// The debt bounds the speed lost below `-level` for every history within its premises
        /// (commands drawn per period at or above their floors, the actuator's state at
        /// `t_f` at or above `-since`), and is the loss where every bound is taken with
        /// equality.
        #[test]
        fn the_braking_debt_bounds_the_speed_lost_below_the_level(
            dead in 0.0f64..0.2, lag in 0.02f64..0.5, level in 2.0f64..8.0,
            harder in 0.0f64..4.0, age in 0.0f64..0.4, held_harder in 0.0f64..3.0,
            held_for in prop_oneof![Just(0.0f64), 0.0f64..0.4],
            draws in proptest::collection::vec(0.0f64..1.0, 64),
        ) {
            let since = level + harder;
            let held = level + held_harder;
            // Times from `t_f`; `now` is `age` after it, commands issued per 20 ms from there
            // back to the dead time before `t_f`, and on.
            let floor_at = |t: f64| {
                if t < age {
                    -since
                } else if t < age + held_for {
                    -held
                } else {
                    -level
                }
            };
            let period = |t: f64| ((t - age) / 0.02).floor();
            let drawn = |t: f64| {
                let k = period(t).rem_euclid(draws.len() as f64) as usize;
                floor_at(t) + 3.0 * draws[k]
            };
            let bound = f64::from(debt_bound(
                since as f32, level as f32, (lag + age + dead) as f32, held as f32,
                held_for as f32,
            ));
            // The brute force holds each grid step's command from its start: a switch
            // between grid points shifts by up to a step, at up to 4 m/s^2 of excess, at each
            // of the three switches (into the hold, out of it, at the draws' periods).
            let grid = 3.0 * 4.0 * 1e-4;
            let worst = lost_below(level, dead, lag, -since, &floor_at);
            prop_assert!(worst <= bound * (1.0 + 1e-3) + grid, "{} above {}", worst, bound);
            prop_assert!(worst >= bound * 0.99 - grid, "{} well below {}", worst, bound);
            let a_at_t_f = -since + 2.0 * draws[0];
            let drawn_loss = lost_below(level, dead, lag, a_at_t_f, &drawn);
            prop_assert!(
                drawn_loss <= bound * (1.0 + 1e-3) + grid,
                "{} above {}",
                drawn_loss,
                bound
            );
        }
    }
}
