//! Two authorities through the delays and the error boxes ([`Authorities::Two`]; the
//! controller's module docs: two authorities): the braking the certificate argues with, the
//! level the follower allows a look-ahead, and the rear half in closed form.

use table_format::authority::Braking;
use table_format::rear::hardest_clearing;

use super::certificate::Model;
use super::emergency::RearCorner;
use super::history::seconds;
use super::Controller;
use crate::config::Authorities;
use crate::{iso15622, math};

/// How close to the hardest level the follower allows the look-ahead's level comes, m/s^2
/// ([`table_format::authority::LEVEL_RESOLUTION`]: the search never returns more).
pub(super) const LEVEL_RESOLUTION: f32 = table_format::authority::LEVEL_RESOLUTION;

/// How much longer a proposal must leave the follower the comfort band's floor to leave the
/// comfortable way down to the lights' command once it is under way, s
/// (`Controller::lit_in_time`): a follower's range is known to 0.1 m + 1.5% (half a metre at
/// 30 m), which moves the prediction by more than a period's worth of the way down.
pub(super) const LIGHTS_WAY_RELEASE_S: f32 = 1.0;

/// How much longer than a period a proposal that ends a lights' run is held dark in the
/// release check ([`Controller::release_allowed`], asked by [`Controller::look_ahead`]),
/// microseconds: the law's proposals after a run's end stay above the lights' command for
/// several periods, where the check assumes one. Chosen by measurement (300 episodes per group
/// of `host-tests campaign --authorities two`, behind leaders at 6 m/s^2, with
/// [`RELEASE_WATCH_US`]): the emergency periods in ISO 15622's scope from starts the comfort
/// band certifies were 1,625 before either, 1,213 with the watch alone and 731 with 0.2 s
/// (2,097 and 1,256 behind leaders at 9.8 m/s^2). Without the watch, 1 s left 624 but held a car
/// braking at the lights' command for 33 s, to a standstill 400 m behind a leader at 18 m/s (the
/// scenario suite's approach to a 40 mph car), and 0.5 s braked at it for up to 35 s while
/// the leader, faster, drew away (0.2 s: up to 10 s, 7.5 s before).
pub(super) const RELEASE_SPARE_US: u64 = 200_000;

/// How long after a lights' run ends the look-ahead asks the release check again of every
/// proposal that keeps the lights dark ([`Controller::look_ahead`]), microseconds. Measured as
/// [`RELEASE_SPARE_US`] was, without the spare: 1,227 emergency periods with 0.5 s, 1,213
/// with 1 s, 1,171 with 2 s.
pub(super) const RELEASE_WATCH_US: u64 = 1_000_000;

/// How much harder than the lights' command a stop behind a stopped car is planned where a
/// follower's track is kept, m/s^2 ([`Controller::stop_deceleration`]). The stopping profile's
/// feedback swings its commands by a few tenths around the planned deceleration, and a command
/// above the lights' deceleration's negative ends a lit run, which the follower closing on a
/// slowing car rarely allows: the run is then kept at the gentlest command that keeps it and
/// the car stops short. Chosen by measurement (`host-tests scenarios --authorities two`, the
/// seven stops behind a stopped car with an IDM follower that engage, leaders at 6 and at
/// 9.8 m/s^2 alike): planned at 1.0 m/s^2 five of them halted 35-48 m short of the standstill
/// gap, at 1.5 (the lights' command) 1.3-10 m, at 1.6 0.8-2.2 m, at 1.8 (this margin)
/// 0.63-0.74 m beyond it, at 2.0 0.6-0.7 m; the other two halt 154 m and 23 m short at every
/// plan (their runs are lit by the comfortable way to the lights at the start, with the
/// follower at the rear half's edge). None has an emergency period.
pub(super) const STOP_UNDER_LIGHTS: f32 = 0.3;

/// How many levels below the band's floor a look-ahead tries where the follower allows not
/// even the floor ([`Controller::gentler_than_band`]): with the defaults 3.0, 2.5, 2.0 and
/// 1.5 m/s^2. A handful of fixed levels rather than a search: each pair needs a lights'
/// on-time of its own, and the step's instruction budget is shared with the rest of the
/// look-ahead.
const GENTLER_LEVELS: usize = 4;
// The levels are tried in pairs (`Controller::gentler_than_band`).
const _: () = assert!(GENTLER_LEVELS.is_multiple_of(2));

/// What a look-ahead argues with: the braking after the period, and the largest command it
/// holds for (the follower may allow less after a command that keeps the lights off longer).
#[derive(Debug, Clone, Copy)]
pub(super) struct Look {
    pub(super) braking: Braking,
    pub(super) up_to: f32,
    /// When the lights are on for sure along `braking`'s ramp after the period (microseconds).
    pub(super) lights_on_us: u64,
    /// Where the comfort band's braking (its floor at [`Controller::comfort_jerk`]) clears the
    /// rear too, its lights coming on along its own, slower, ramp: that braking, and when they
    /// are on for sure. Where the follower allows not even the band's floor, the same for
    /// `braking`'s gentler level built up at that jerk: where nothing passes later, the
    /// command follows the ramp of the braking in force, and one at ISO 15622's jerk limit is
    /// no emergency, where the same level named at the emergency authority's build-up would be
    /// followed at its 12 m/s^3 (the CHANGELOG has the lossless surveys' figures).
    pub(super) comfort: Option<(Braking, u64)>,
    /// `up_to` was lowered to the comfortable way down to the lights' command
    /// ([`Controller::look_ahead`]).
    pub(super) way_down: bool,
    /// The rear check the braking was found with (`None` without a follower's track to argue
    /// with, or in the comfort band).
    argued: Option<RearArgued>,
}

/// What a look-ahead's rear check argued with: the follower's box corner, and how long its
/// reaction has run at the measurement's time, or how long after it the lights are on (s).
#[derive(Debug, Clone, Copy)]
struct RearArgued {
    corner: RearCorner,
    clock: f32,
    dark: f32,
}

impl Controller<'_> {
    /// The build-up of the comfort band's braking a look-ahead tries first, m/s^3: ISO 15622's
    /// jerk limit at the highest speed the ego may reach while it brakes (the measured speed's
    /// upper end, plus what `pending`, the acceleration the actuator may be doing, adds over a
    /// second), at least the braking ramp's `brake_jerk` and at most the emergency authority's
    /// build-up where that is faster.
    ///
    /// The braking a look-ahead names is in force until another passes, and where none does
    /// the command follows its ramp: at ISO 15622's jerk limit that is no emergency. Below
    /// 20 m/s the limit is above `brake_jerk` (5 m/s^3 at and below 5 m/s), and the faster
    /// build-up certifies the front in less room, so the comfort band's braking is named more
    /// often there. A comfort choice, not a bound: a ramp at any build-up is argued the same
    /// way (the front along it, its lights' on-time in the rear check).
    pub(super) fn comfort_jerk(&self, model: &Model, ego_speed: f32, pending: f32) -> f32 {
        let band = self.config.certificate.brake_jerk;
        let fastest = self.config.sensors.ego_speed(ego_speed).1 + math::max(pending, 0.0);
        let iso = iso15622::jerk_limit(fastest);
        let emergency = model.emergency.map_or(band, |e| e.jerk);
        math::max(band, math::min(iso, emergency))
    }

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
    /// ([`hardest_clearing`] to [`LEVEL_RESOLUTION`]), where not even the band's floor clears
    /// the hardest gentler level that does ([`Controller::gentler_than_band`]), `None` where
    /// none does.
    ///
    /// The rear check is the emergency answer's ([`RearCorner::gap_after`]: the worst corner of
    /// the follower's box at its time, the ego braking at most at the level from now on, an
    /// earlier harder braking counted there), with the lights off until `command` held for the
    /// period and the emergency ramp from it bring them on for sure (what is pending held
    /// before it): a gentler command ends a lights' run no later, and a braking command keeps
    /// one under way, so one level serves every command up to `command`.
    pub(super) fn look_ahead_braking(
        &self,
        model: &Model,
        now: u64,
        command: f32,
    ) -> Option<Braking> {
        let pending = self.pending(now, model);
        self.look_ahead_argued(model, now, pending, command)
            .map(|(b, _)| b)
    }

    /// [`Controller::look_ahead_braking`], with the rear check it argued with: the follower's
    /// box corner and where its reaction stands (`None` without a follower's track to argue
    /// with, or in the comfort band). `pending` is [`Controller::pending`] at `now`.
    fn look_ahead_argued(
        &self,
        model: &Model,
        now: u64,
        pending: f32,
        command: f32,
    ) -> Option<(Braking, Option<RearArgued>)> {
        self.allowed_with_lights_at(model, now, pending, command, None)
    }

    /// [`Controller::look_ahead_argued`] with the lights brought on by a ramp from `command`
    /// at `lights_jerk` (`None`: the look-ahead's, the emergency authority's build-up): the
    /// hardest level the follower then allows, at the emergency authority's build-up.
    fn allowed_with_lights_at(
        &self,
        model: &Model,
        now: u64,
        pending: f32,
        command: f32,
        lights_jerk: Option<f32>,
    ) -> Option<(Braking, Option<RearArgued>)> {
        if !self.two_authorities() {
            return Some((self.braking_in_force(model), None));
        }
        let e = model.emergency?;
        let rear = self.rear?;
        if !math::is_finite(rear.track.gap) {
            return Some((e, None));
        }
        let beta = -model.ego.min;
        let lights_jerk = lights_jerk.unwrap_or(e.jerk);
        let ((clock, dark), _) = self.dark_after(now, pending, command, lights_jerk, beta)?;
        let margin = self.config.certificate.rear_margin;
        let corner = self.rear_corner(model, &rear, now);
        let braking = hardest_clearing(
            |level| corner.gap_after(model, level, clock, dark) - margin,
            beta,
            e.level,
            LEVEL_RESOLUTION,
        )
        .map(|level| Braking {
            level,
            jerk: e.jerk,
        })
        .or_else(|| {
            self.gentler_than_band(model, now, pending, command, lights_jerk, &corner)
                .map(|level| Braking {
                    level,
                    jerk: e.jerk,
                })
        })?;
        Some((
            braking,
            Some(RearArgued {
                corner,
                clock,
                dark,
            }),
        ))
    }

    /// The deceleration the law plans a stop behind a stopped car with, m/s^2 (positive): the
    /// configured `stop_deceleration`, and with two authorities and a follower's track kept
    /// at least [`STOP_UNDER_LIGHTS`] harder than the lights' command. Behind a follower a
    /// stop's braking lights the brakes, and the follower closing on the slowing car seldom
    /// allows the lit run to end ([`Controller::release_allowed`]): the run then holds the car
    /// at the lights' command or below until it stops. A stop planned gentler than that is
    /// cut short by it, and the car stays there: no move-off with a follower close behind is
    /// certified (the controller's module docs). Planned at it, the run's braking is the
    /// plan's.
    pub(super) fn stop_deceleration(&self) -> f32 {
        let planned = self.config.law.stop_deceleration;
        if !self.two_authorities() || !self.rear.is_some_and(|r| math::is_finite(r.track.gap)) {
            return planned;
        }
        math::max(planned, -self.lights_command() + STOP_UNDER_LIGHTS)
    }

    /// The gentlest level a look-ahead argues with, m/s^2: the lights' command's. A braking
    /// ramp to it ends at or below the lights' command, as one to the band's floor does, so it
    /// keeps a lights' run going ([`Controller::lights_run`]) and lights the brakes for sure
    /// (the lights' command is below the lights' deceleration).
    fn least_level(&self) -> f32 {
        -self.lights_command()
    }

    /// The levels below the band's floor a look-ahead tries ([`GENTLER_LEVELS`], evenly spaced
    /// from a step below the band's floor down to [`Controller::least_level`]), hardest first;
    /// none where the lights' command is not below the band's floor.
    pub(super) fn gentler_levels(&self, model: &Model) -> impl Iterator<Item = f32> {
        let beta = -model.ego.min;
        let least = self.least_level();
        // (NaN compares false: no level.)
        let count = if least < beta { GENTLER_LEVELS } else { 0 };
        (0..count).rev().map(move |k| gentler_level(least, beta, k))
    }

    /// The level a look-ahead argues with where the follower allows not even the band's
    /// floor: the hardest of [`GENTLER_LEVELS`] levels, evenly spaced from a step below the
    /// band's floor down to [`Controller::least_level`], at which the rear check of
    /// [`Controller::look_ahead_braking`] clears, the lights coming on along a ramp at `jerk`
    /// (the look-ahead's: the emergency authority's build-up, the rule's brakings,
    /// `table_format::authority`'s module docs); `None` where none does.
    /// Each pair of neighbouring levels is checked with the lights' on-time of its gentler
    /// level: a ramp that ends nearer the lights' deceleration lights them later through the
    /// lag (the lag is monotone in its input), so the harder level is credited no more than
    /// its own on-time allows. The front needs more room at a gentler
    /// level, which the look-ahead's front check and the law's gap policy (through the allowed
    /// braking) take into account.
    fn gentler_than_band(
        &self,
        model: &Model,
        now: u64,
        pending: f32,
        command: f32,
        jerk: f32,
        corner: &RearCorner,
    ) -> Option<f32> {
        let beta = -model.ego.min;
        let least = self.least_level();
        // (NaN compares false: no level.)
        let below_band = least < beta;
        if !below_band {
            return None;
        }
        let margin = self.config.certificate.rear_margin;
        let level = |k: usize| gentler_level(least, beta, k);
        // Two neighbouring levels share the gentler one's on-time: the later, so the harder
        // one is credited less than its own.
        (0..GENTLER_LEVELS / 2).rev().find_map(|pair| {
            let (harder, gentler) = (level(2 * pair + 1), level(2 * pair));
            let ((clock, dark), _) = self.dark_after(now, pending, command, jerk, gentler)?;
            [harder, gentler]
                .into_iter()
                .find(|l| corner.clears(model, *l, clock, dark, margin))
        })
    }

    /// Where the follower's reaction stands at the kept follower measurement's time, for
    /// `command` held a period from `now` and then a braking ramp at `jerk` from it down to
    /// `-level` (what is pending held before it): `(clock, dark)`, how long it has run there
    /// or how long after it the lights are on for sure (s, [`RearCorner::gap_after`]); and when
    /// that ramp brings them on (microseconds).
    ///
    /// A command that keeps a lights' run under way ([`Controller::keeps_lights_run`]: at or
    /// below the lights' command, or below the lights' deceleration's negative once the run is
    /// lit) keeps its on-time (the step keeps it, or an earlier one:
    /// [`Controller::lights_run`]), and so does the
    /// ramp of the braking in force after it: the follower's reaction is counted from the
    /// run's own on-time where that is earlier than the later of the run's and the ramp's
    /// (the bound for a command that may end the run), and the clock's invariance carries the
    /// rear value a period on (`table_format::rear`'s module docs), as for the braking in
    /// force ([`Controller::rear_slack_at`]). The run's own: its commands alone bound it
    /// (`lights_run_own_us`), where the run's on-time may be the earlier one a look-ahead
    /// argued with along its ramp (`lights_expected_us`), which holds only while the commands
    /// follow that ramp; a look-ahead that passes holds the lights' command instead (counted
    /// from the argued time, the truth's rear fell to -0.47 m behind a follower that reacts
    /// late, seed 5,001,692). A gentler command may end the run: the reaction then starts
    /// where the lights come on again, the later of the two.
    fn dark_after(
        &self,
        now: u64,
        pending: f32,
        command: f32,
        jerk: f32,
        level: f32,
    ) -> Option<((f32, f32), u64)> {
        let rear = self.rear?;
        let off = self.ramp_lights_on(now, pending, command, jerk, level)?;
        // (A NaN command does not keep a run.)
        let keeps_run = self.keeps_lights_run(now, command);
        let on = match (self.lights_on_us, self.lights_run_own_us) {
            (Some(run), Some(own)) if keeps_run => own.min(run.max(off)),
            (Some(run), _) => run.max(off),
            (None, _) => off,
        };
        Some((reaction_at(rear.at_us, on), off))
    }

    /// When the lights are on for sure (microseconds) for `command` held a period from `now`,
    /// then a braking ramp at `jerk` from it down to `-level` (`pending`,
    /// [`Controller::pending`] at `now`, held before it).
    ///
    /// The ramp's commands are issued once a period and held: the committed ramp from
    /// `command` starts a period on, so it issues `command` again then, and `command - j k h`
    /// `k` periods later. Each is held above the continuous ramp through its period, so the
    /// bound is the continuous ramp from `command` starting a period later still, `now + 2 h`,
    /// with `command` (at most `held`) in force until then: a staircase lights the brakes no
    /// later than the ramp it stays under.
    pub(super) fn ramp_lights_on(
        &self,
        now: u64,
        pending: f32,
        command: f32,
        jerk: f32,
        level: f32,
    ) -> Option<u64> {
        let h_us = u64::from(self.config.period_us);
        let held = math::max(pending, command);
        self.lights_on_after(now.saturating_add(2 * h_us), held, command, jerk, level)
    }

    /// The look-ahead for a `proposal`: the braking [`Controller::look_ahead_braking`] finds
    /// for it; with two authorities, where the follower allows none (a command that keeps the
    /// lights off longer), for the last command, then for the comfort band's step down from it
    /// (ISO 15622's jerk limit), then for the lights' command (which keeps a lights' run going,
    /// or starts one): the command is capped there, as by the speed, and the follower then
    /// lets it down gently where it can. A proposal that would end a lights' run the follower
    /// does not allow to end ([`Controller::release_allowed`]) is the gentlest command that
    /// keeps the run ([`Controller::gentlest_keeping_run`]).
    pub(super) fn look_ahead(
        &self,
        model: &Model,
        now: u64,
        proposal: f32,
        ego_speed: f32,
        front_certified: &dyn Fn(Braking) -> bool,
    ) -> Option<Look> {
        // What the actuator may be doing: one bound for every command the look-ahead tries.
        let pending = self.pending(now, model);
        // (Built where it is asked for: the band's step never pays for it.)
        let comfort_lights_on = |up_to: f32, level: f32| {
            let jerk = self.comfort_jerk(model, ego_speed, pending);
            let clears = |comfort: Braking| {
                let ((clock, dark), on) =
                    self.dark_after(now, pending, up_to, comfort.jerk, comfort.level)?;
                let rear = self.rear?;
                self.rear_check(model, &rear, comfort.level, clock, dark, now)
                    .then_some((comfort, on))
            };
            let band = model.band_braking(jerk);
            clears(band).or_else(|| {
                (level < band.level)
                    .then(|| clears(Braking { level, jerk }))
                    .flatten()
            })
        };
        let look = |up_to: f32| {
            let (braking, argued) = self.look_ahead_argued(model, now, pending, up_to)?;
            Some(Look {
                braking,
                up_to,
                lights_on_us: self
                    .ramp_lights_on(now, pending, up_to, braking.jerk, braking.level)
                    .unwrap_or(u64::MAX),
                comfort: if self.two_authorities() {
                    comfort_lights_on(up_to, braking.level)
                } else {
                    None
                },
                way_down: false,
                argued,
            })
        };
        if !self.two_authorities() {
            return look(f32::INFINITY);
        }
        let last = self.last_command_or_unknown(model);
        let step = iso15622::jerk_limit(ego_speed) * seconds(u64::from(self.config.period_us));
        // The comfortable way's next command: ISO 15622's jerk down from the last, to the
        // lights' command.
        let down = math::max(last - step, self.lights_command());
        // A proposal that ends a lights' run (`Controller::keeps_lights_run`) where the
        // follower would allow not even the comfort band's floor, nor a gentler level at which
        // the front certifies, with its reaction starting again when the comfort band's ramp
        // brings the lights back, the proposal held RELEASE_SPARE_US longer than a period
        // first (`Controller::release_allowed`, the band's rule for ending a run): the
        // gentlest command that keeps the run instead, which keeps the follower's reaction
        // clock going. Ended there, the run's next look-ahead, counted from the new run's own
        // on-time, failed, and the command followed the braking in force's ramp at
        // the emergency authority's build-up (an emergency by ISO 15622's jerk limit): 143 of
        // the 228 emergency runs behind the comfortable leader with the fixed IDM began within
        // 0.7 s of a run's end. The same question is asked of every proposal that keeps the
        // lights dark for RELEASE_WATCH_US after a run ended: the law's proposals near a stop
        // hover above the lights' command for several periods (-1.4, -1.3, -1.2 m/s^2), and
        // every dark period costs the follower's reaction; where it fails the command goes down
        // the comfortable way (ISO 15622's jerk) to the lights' command.
        let run_on = self.lights_on_us.is_some();
        let watched = !run_on
            && self
                .lights_off_at_us
                .is_some_and(|off| now.saturating_sub(off) < RELEASE_WATCH_US);
        let keeps_lit = (run_on || watched)
            && self.ends_lights_run(now, proposal)
            && !self.release_allowed(
                model,
                now,
                proposal,
                RELEASE_SPARE_US,
                Some(front_certified),
            );
        let proposal = match (keeps_lit, run_on) {
            (false, _) => proposal,
            (true, true) => self.gentlest_keeping_run(now),
            // (The proposal is above the lights' command: the way down caps it.)
            (true, false) => math::min(proposal, down),
        };
        let mut tried = proposal;
        let mut found = look(proposal);
        // A proposal that passes now, but after which a follower closing on the ego would
        // allow not even the comfort band's floor by the time the comfortable way to the
        // lights (ISO 15622's jerk down to the lights' command) brought them on: the command
        // goes down that way now, while it is still comfortable, where the look-ahead would
        // later have to jump to the lights' command. One level serves every command up to the
        // proposal (`Controller::look_ahead_braking`), so the look-ahead that passed covers it.
        if let Some(l) = found {
            let spare = if self.lights_way_down {
                LIGHTS_WAY_RELEASE_S
            } else {
                0.0
            };
            let down =
                self.way_down_past_the_lights(model, now, last - step, l.braking.level, down);
            if down < proposal && !self.lit_in_time(model, l.argued, proposal, ego_speed, spare) {
                found = Some(Look {
                    up_to: down,
                    way_down: true,
                    ..l
                });
            }
        }
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

    /// The hardest braking the follower would allow `horizon` seconds on, were it and the ego
    /// to keep the speeds of the look-ahead's rear corner ([`RearCorner::ahead_by`]), with the
    /// look-ahead's reaction clock and lights, at the emergency authority's build-up; the
    /// comfort band's floor where not even that clears. A prediction that caps the law's
    /// acceleration (`LAW_FOLLOWER_HORIZON_S`), not a bound. `None` without a follower's track
    /// to argue with or in the comfort band.
    pub(super) fn allowed_ahead(
        &self,
        model: &Model,
        look: &Look,
        horizon: f32,
    ) -> Option<Braking> {
        let RearArgued {
            corner,
            clock,
            dark,
        } = look.argued?;
        let e = model.emergency?;
        let beta = -model.ego.min;
        let margin = self.config.certificate.rear_margin;
        let ahead = corner.ahead_by(horizon, 0.0);
        let level = hardest_clearing(
            |level| ahead.gap_after(model, level, clock, dark) - margin,
            beta,
            e.level,
            LEVEL_RESOLUTION,
        )
        .unwrap_or(beta);
        Some(Braking {
            level,
            jerk: e.jerk,
        })
    }

    /// The comfortable way's next command once it has reached the lights' command (`down`,
    /// [`Controller::look_ahead`]) while the brakes are not yet lit for sure by the run's own
    /// commands ([`Controller::lights_run`]: its own on-time is not yet reached, or not
    /// known): `next` (ISO 15622's jerk down from the last command), no harder than the
    /// look-ahead's `level` nor the band's floor. Elsewhere `down`.
    ///
    /// A command held at the lights' command lights the brakes slowly: through the actuator's
    /// lag its acceleration only nears the lights' deceleration (with the defaults, -1.5 m/s^2
    /// against -1.3, the run's own on-time 0.2-0.4 s after the one the look-ahead argued along
    /// its ramp), while the follower closes. Where its box then came so near that no level
    /// cleared, the command followed the ramp of the braking in force at the emergency
    /// authority's build-up, faster than ISO 15622's jerk limit (the first emergency period
    /// of 20 of the 35 episodes that had one in a 300-per-group survey with the datasheets'
    /// radars losing no refresh, behind leaders at 6 m/s^2, the comfort band's braking at
    /// [`Controller::comfort_jerk`]: an ego below 6 m/s slowing towards a stopped car, a
    /// follower closing at 5-9 m/s). Going on down at the jerk limit lights them sooner. A comfort
    /// choice, not a bound: the look-ahead that passed covers every command down to its level
    /// (a harder command lights the brakes no later), so the certificate does not rest on it.
    fn way_down_past_the_lights(
        &self,
        model: &Model,
        now: u64,
        next: f32,
        level: f32,
        down: f32,
    ) -> f32 {
        let at_the_lights = self
            .last_command
            .is_some_and(|last| last <= self.lights_command());
        let lit = self.lights_run_own_us.is_some_and(|own| own <= now);
        if self.lights_on_us.is_none() || lit || !at_the_lights {
            return down;
        }
        math::max(next, math::max(model.ego.min, -level))
    }

    /// Whether the follower would still allow the comfort band's floor if `command` were held
    /// for as long as the comfortable way to the lights' command takes from it (ISO 15622's
    /// jerk limit at `ego_speed`, after a period, and `spare` longer: [`LIGHTS_WAY_RELEASE_S`]
    /// while that way is under way, so that the measurement's noise does not flip it every
    /// period): the
    /// look-ahead's rear check for the
    /// band's floor (the lights after `command` along the emergency ramp: `argued`, the
    /// look-ahead's own for `command`), with the follower's box corner carried that long at
    /// its relative speed and the ego at `command` ([`RearCorner::ahead_by`]). A prediction
    /// for comfort, not a bound: where it fails the command goes down the comfortable way now
    /// ([`Controller::look_ahead`]), which the look-ahead that passed covers, so the
    /// certificate does not rest on it. `true` without a follower's track to argue with.
    fn lit_in_time(
        &self,
        model: &Model,
        argued: Option<RearArgued>,
        command: f32,
        ego_speed: f32,
        spare: f32,
    ) -> bool {
        let Some(RearArgued {
            corner,
            clock,
            dark,
        }) = argued
        else {
            return true;
        };
        let h = seconds(u64::from(self.config.period_us));
        let lead = h + (command - self.lights_command()) / iso15622::jerk_limit(ego_speed) + spare;
        corner.ahead_by(lead, command).clears(
            model,
            -model.ego.min,
            clock,
            dark,
            self.config.certificate.rear_margin,
        )
    }

    /// Whether an engagement from standby now starts without an emergency as far as the
    /// follower behind decides it (a prediction for the driver, not a bound: the engaged steps
    /// keep their own certificate). Either the look-ahead would not send the first commands
    /// down the comfortable way to the lights ([`Controller::lit_in_time`]), or, where it
    /// would, the braking the follower allows with the lights lit that way certifies the front
    /// (`front_certified`; the look-ahead's level with the lights coming on along a ramp at ISO
    /// 15622's jerk limit at `ego_speed`, not the emergency authority's build-up). Otherwise the
    /// engaged steps go down that way until their look-ahead fails and then jump, faster than
    /// the jerk limit, to the lights' command or along the braking ramp: an emergency the
    /// driver did not ask for (with the defaults, a follower 14.5 m behind at the ego's
    /// 8.3 m/s: the scenario suite's CCRs and CCRm at 30 km/h). `true` where the kept follower
    /// track shows no follower, `false` without one.
    ///
    /// Argued from what the engaged steps may see, not what standby sees: the actuator doing
    /// the report plus three times its error and the lag's tail (the truth is at most the report
    /// plus its error, [`Controller::unknown_acceleration`], and the next report reads at most
    /// the truth plus its error again: a period later the noise at its other corner read
    /// 0.47 m/s^2 where standby had 0.06, and the look-ahead's bound added the lag's tail),
    /// and the way starting two periods on (the first engaged step is a period after standby,
    /// and it was the second whose look-ahead sent the commands down the way, in the suite's
    /// steady following at 10 m/s behind a 9.8 m/s^2 leader).
    pub(super) fn engages_comfortably(
        &self,
        model: &Model,
        now: u64,
        ego_speed: f32,
        front_certified: impl Fn(Braking) -> bool,
    ) -> bool {
        let Some(rear) = self.rear else {
            return false;
        };
        if !math::is_finite(rear.track.gap) {
            return true;
        }
        let reread = 2.0 * self.config.sensors.acceleration_error;
        let doing = math::min(self.unknown_acceleration(model) + reread, model.ego.max)
            + self.lag_tail(model);
        let pending = math::max(self.pending(now, model), doing);
        let later = now.saturating_add(2 * u64::from(self.config.period_us));
        let held = self
            .look_ahead_argued(model, later, pending, doing)
            .is_some_and(|(_, argued)| self.lit_in_time(model, argued, doing, ego_speed, 0.0));
        let comfortable = Some(iso15622::jerk_limit(ego_speed));
        held || self
            .allowed_with_lights_at(model, now, pending, doing, comfortable)
            .is_some_and(|(braking, _)| front_certified(braking))
    }

    /// The rear half of `braking` now (m, less `rear_margin`), with two authorities: the
    /// follower's reaction counted from the lights' run under way, or from where `braking`'s
    /// ramp from the last command, starting now, brings the lights on ([`RearCorner::gap_after`]).
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
    /// (microseconds): [`RearCorner::gap_after`] with the follower's reaction counted from there.
    pub(super) fn rear_slack_at(&self, model: &Model, braking: Braking, on: u64, now: u64) -> f32 {
        let Some(rear) = self.rear else {
            return f32::NEG_INFINITY;
        };
        if !math::is_finite(rear.track.gap) {
            return f32::INFINITY;
        }
        let (clock, dark) = reaction_at(rear.at_us, on);
        self.rear_corner(model, &rear, now)
            .gap_after(model, braking.level, clock, dark)
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
                    look.comfort.map(|(_, on)| on)
                };
            }
            _ => {
                let braking = self.braking_in_force(model);
                self.lights_expected_us = self.lights_on_in_force(model, now, braking);
            }
        }
    }
}

/// The `k`-th of [`GENTLER_LEVELS`] levels evenly spaced from `least` (`k` = 0) to a step
/// below the band's floor `beta`, m/s^2.
fn gentler_level(least: f32, beta: f32, k: usize) -> f32 {
    least + (beta - least) * (k as f32) / (GENTLER_LEVELS as f32)
}

/// Where the follower's reaction to lights on for sure from `on` stands at a measurement's
/// time `t_f` (microseconds): `(clock, dark)`, how long it has run then, or how long after it
/// the lights are on (s; the other zero).
pub(super) fn reaction_at(t_f: u64, on: u64) -> (f32, f32) {
    if t_f >= on {
        (seconds(t_f - on), 0.0)
    } else {
        (0.0, seconds(on - t_f))
    }
}
