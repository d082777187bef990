//! Two authorities through the delays and the error boxes ([`Authorities::Two`]; the
//! controller's module docs: two authorities): the braking the certificate argues with, the
//! level the follower allows a look-ahead, and the rear half in closed form.

use table_format::authority::Braking;
use table_format::rear::hardest_clearing;

use super::certificate::Model;
use super::history::seconds;
use super::Controller;
use crate::config::Authorities;
use crate::{iso15622, math};

/// How close to the hardest level the follower allows the look-ahead's level comes, m/s^2
/// ([`table_format::authority::LEVEL_RESOLUTION`]: the search never returns more).
const LEVEL_RESOLUTION: f32 = table_format::authority::LEVEL_RESOLUTION;

/// What a look-ahead argues with: the braking after the period, and the largest command it
/// holds for (the follower may allow less after a command that keeps the lights off longer).
#[derive(Debug, Clone, Copy)]
pub(super) struct Look {
    pub(super) braking: Braking,
    pub(super) up_to: f32,
    /// When the lights are on for sure along `braking`'s ramp after the period (microseconds).
    pub(super) lights_on_us: u64,
    /// Where the comfort band's braking (its floor at the braking ramp's jerk) clears the rear
    /// too, its lights coming on along its own, slower, ramp: when they are on for sure.
    pub(super) comfort_lights_on_us: Option<u64>,
}

impl Controller<'_> {
    /// Whether the certificate argues with two authorities.
    pub(super) fn two_authorities(&self) -> bool {
        self.config.certificate.authorities == Authorities::Two
    }

    /// The braking the certified front value argues with: the band's floor at the braking
    /// ramp's jerk in the comfort band; with two authorities the braking in force (the one the
    /// last passed look-ahead, or the standby certificate before an engagement, named), or,
    /// where none is known, the band's floor at the emergency authority's build-up.
    pub(super) fn braking_in_force(&self, model: &Model) -> Braking {
        let jerk = self.config.certificate.brake_jerk;
        if !self.two_authorities() {
            return model.band_braking(jerk);
        }
        self.in_force
            .unwrap_or_else(|| model.band_braking(model.emergency.map_or(jerk, |e| e.jerk)))
    }

    /// The braking a look-ahead at `now` of commands up to `command` argues with: the band's
    /// in the comfort band; with two authorities the emergency authority's build-up at the
    /// hardest level from the band's floor up to its own that the follower allows
    /// ([`hardest_clearing`] to [`LEVEL_RESOLUTION`]), `None` where not even the band's floor
    /// clears.
    ///
    /// The rear check is the emergency answer's ([`Controller::rear_gap`]: the worst corner of
    /// the follower's box at its time, the ego braking at most at the level from now on, an
    /// earlier harder braking counted there), with the lights off until `command` held for the
    /// period and the emergency ramp from it bring them on for sure (what is pending held
    /// before it): a gentler command ends a lights' run no later, and a braking command keeps
    /// one under way, so one level serves every command up to `command`. Levels below the
    /// band's floor are not tried: the comfort band brakes to it.
    pub(super) fn look_ahead_braking(
        &self,
        model: &Model,
        now: u64,
        command: f32,
    ) -> Option<Braking> {
        if !self.two_authorities() {
            return Some(self.braking_in_force(model));
        }
        let e = model.emergency?;
        let rear = self.rear?;
        if !math::is_finite(rear.track.gap) {
            return Some(e);
        }
        let (dark, _) = self.dark_after(model, now, command, e.jerk, -model.ego.min)?;
        let margin = self.config.certificate.rear_margin;
        let corner = self.rear_corner(model, &rear, now);
        let level = hardest_clearing(
            |level| corner.gap_after(model, level, 0.0, dark) - margin,
            -model.ego.min,
            e.level,
            LEVEL_RESOLUTION,
        )?;
        Some(Braking {
            level,
            jerk: e.jerk,
        })
    }

    /// How long after the kept follower measurement the brake lights are on for sure (s), for
    /// `command` held a period from `now` and then a braking ramp at `jerk` from it down to
    /// `-level` (what is pending held before it), or the lights' run under way where that is
    /// later; and when that ramp brings them on (microseconds).
    fn dark_after(
        &self,
        model: &Model,
        now: u64,
        command: f32,
        jerk: f32,
        level: f32,
    ) -> Option<(f32, u64)> {
        let rear = self.rear?;
        let off = self.ramp_lights_on(model, now, command, jerk, level)?;
        let on = self.lights_on_us.map_or(off, |run| run.max(off));
        Some((seconds(on.saturating_sub(rear.at_us)), off))
    }

    /// When the lights are on for sure (microseconds) for `command` held a period from `now`,
    /// then a braking ramp at `jerk` from it down to `-level` (what is pending held before
    /// it).
    ///
    /// The ramp's commands are issued once a period and held: the committed ramp from
    /// `command` starts a period on, so it issues `command` again then, and `command - j k h`
    /// `k` periods later. Each is held above the continuous ramp through its period, so the
    /// bound is the continuous ramp from `command` starting a period later still, `now + 2 h`,
    /// with `command` (at most `held`) in force until then: a staircase lights the brakes no
    /// later than the ramp it stays under.
    pub(super) fn ramp_lights_on(
        &self,
        model: &Model,
        now: u64,
        command: f32,
        jerk: f32,
        level: f32,
    ) -> Option<u64> {
        let h_us = u64::from(self.config.period_us);
        let held = math::max(self.pending(now, model), command);
        self.lights_on_after(now.saturating_add(2 * h_us), held, command, jerk, level)
    }

    /// The look-ahead for a `proposal`: the braking [`Controller::look_ahead_braking`] finds
    /// for it; with two authorities, where the follower allows none (a command that keeps the
    /// lights off longer), for the last command, then for the comfort band's step down from it
    /// (ISO 15622's jerk limit), then for the lights' command (which keeps a lights' run going,
    /// or starts one): the command is capped there, as by the speed, and the follower then
    /// lets it down gently where it can.
    pub(super) fn look_ahead(
        &self,
        model: &Model,
        now: u64,
        proposal: f32,
        ego_speed: f32,
    ) -> Option<Look> {
        let comfort_lights_on = |up_to: f32| {
            let jerk = self.config.certificate.brake_jerk;
            let (dark, on) = self.dark_after(model, now, up_to, jerk, -model.ego.min)?;
            let rear = self.rear?;
            self.rear_check(model, &rear, -model.ego.min, 0.0, dark, now)
                .then_some(on)
        };
        let look = |up_to: f32| {
            let braking = self.look_ahead_braking(model, now, up_to)?;
            Some(Look {
                braking,
                up_to,
                lights_on_us: self
                    .ramp_lights_on(model, now, up_to, braking.jerk, braking.level)
                    .unwrap_or(u64::MAX),
                comfort_lights_on_us: if self.two_authorities() {
                    comfort_lights_on(up_to)
                } else {
                    None
                },
            })
        };
        if !self.two_authorities() {
            return look(f32::INFINITY);
        }
        let last = self.last_command_or_unknown(model);
        let step = iso15622::jerk_limit(ego_speed) * seconds(u64::from(self.config.period_us));
        let mut tried = proposal;
        let mut found = look(proposal);
        for candidate in [last, last - step, self.lights_command()] {
            if found.is_some() {
                break;
            }
            if candidate < tried {
                tried = candidate;
                found = look(candidate);
            }
        }
        found
    }

    /// The rear half of `braking` now (m, less `rear_margin`), with two authorities: the
    /// follower's reaction counted from the lights' run under way, or from where `braking`'s
    /// ramp from the last command, starting now, brings the lights on ([`Controller::rear_gap`]).
    /// `-inf` where the follower's track is not kept or when the lights come on is not known.
    pub(super) fn rear_slack(&self, model: &Model, now: u64, braking: Braking) -> f32 {
        let Some(rear) = self.rear else {
            return f32::NEG_INFINITY;
        };
        if !math::is_finite(rear.track.gap) {
            return f32::INFINITY;
        }
        match self.lights_on_in_force(model, now, braking) {
            Some(on) => self.rear_slack_at(model, braking, on, now),
            None => f32::NEG_INFINITY,
        }
    }

    /// The rear half of `braking` (m, less `rear_margin`), the lights on for sure from `on`
    /// (microseconds): [`Controller::rear_gap`] with the follower's reaction counted from there.
    pub(super) fn rear_slack_at(&self, model: &Model, braking: Braking, on: u64, now: u64) -> f32 {
        let Some(rear) = self.rear else {
            return f32::NEG_INFINITY;
        };
        if !math::is_finite(rear.track.gap) {
            return f32::INFINITY;
        }
        let t_f = rear.at_us;
        let (clock, dark) = if t_f >= on {
            (seconds(t_f - on), 0.0)
        } else {
            (0.0, seconds(on - t_f))
        };
        self.rear_gap(model, &rear, braking.level, clock, dark, now)
            - self.config.certificate.rear_margin
    }

    /// When the lights are on for sure along `braking` in force (microseconds): the lights'
    /// run under way, or where its ramp from the last command, starting now (its commands
    /// held a period each), brings them on,
    /// or the earlier on-time the certificate argued with while its commands stay under that
    /// argument's ramp (`lights_expected_us`).
    pub(super) fn lights_on_in_force(
        &self,
        model: &Model,
        now: u64,
        braking: Braking,
    ) -> Option<u64> {
        if let Some(on) = self.lights_on_us {
            return Some(on);
        }
        // The ramp from the last command, its commands held a period each: under the
        // continuous ramp from it starting a period on (`ramp_lights_on`).
        let last = self.last_command_or_unknown(model);
        let ramp = self.lights_on_after(
            now.saturating_add(u64::from(self.config.period_us)),
            math::max(self.pending(now, model), last),
            last,
            braking.jerk,
            braking.level,
        );
        self.lights_no_later_than_argued(ramp)
    }

    /// The earlier of `bound` and the on-time the certificate last argued with
    /// (`lights_expected_us`): both hold while the commands stay under that argument's ramp.
    pub(super) fn lights_no_later_than_argued(&self, bound: Option<u64>) -> Option<u64> {
        match (bound, self.lights_expected_us) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// After a decision: whether its command passed the look-ahead, and with two authorities
    /// the braking in force from then on (the one it passed with) and when the lights are on
    /// for sure along it (the look-ahead's bound; where nothing passed, the ramp in force's
    /// bound, the earlier of it and the last: every command since is under both ramps).
    pub(super) fn note_decision(
        &mut self,
        model: &Model,
        now: u64,
        passed: bool,
        named: Option<Braking>,
        look: Option<Look>,
    ) {
        self.passed = passed;
        if !self.two_authorities() {
            return;
        }
        match (passed, named, look) {
            (true, Some(b), Some(look)) => {
                self.in_force = Some(b);
                self.lights_expected_us = if b == look.braking {
                    Some(look.lights_on_us)
                } else {
                    look.comfort_lights_on_us
                };
            }
            _ => {
                let braking = self.braking_in_force(model);
                self.lights_expected_us = self.lights_on_in_force(model, now, braking);
            }
        }
    }
}
