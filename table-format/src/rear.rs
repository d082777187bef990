//! The rear gap in closed form against a follower that reacts like a person: the smallest gap
//! behind the ego when the ego brakes at a given level from now and the follower notices only
//! after its reaction time, and the hardest braking the follower therefore allows the ego.
//!
//! # Why
//! The split certificate's rear table is solved against the paper's IDM follower, which brakes
//! the instant the gap closes: it certifies a follower 0.1 m behind at equal speeds, and so lets
//! the ego brake at its whole band there. A driver needs time to see the ego's brake lights and
//! to move a foot: UN R157's careful driver takes 0.4 s to perceive and 0.75 s to brake, 1.15 s
//! in all, then reaches 0.774 g over 0.6 s. Against such a follower, how hard the ego may brake
//! depends on the gap behind it: the trade-off the paper's three-car game is about, one seat
//! further.
//!
//! # The model and why its value is [`front_value`] with the roles swapped
//! The ego brakes at `b` from now; the follower keeps an acceleration of at most
//! `reaction_acceleration` for `reaction_time`, then its braking builds up at `jerk` to
//! `braking` and stays there until it stops. The rear gap is the front gap of the pair (ego
//! ahead, follower behind), so its smallest value is the front game's closed form with the ego
//! as the car ahead braking at `b` and the follower as the car behind with a response, a ramp
//! and a braking level ([`FrontModel`]): [`rear_gap`] calls [`front_value`] so. Every ego that
//! brakes no harder than `b` covers at least the distance of the step to `b` at every instant
//! (a braking that builds up over time is one of them), and every follower that reacts no later
//! and brakes no less covers at most the distance of the model at every instant; so the closed
//! form is the least gap over all of them. The property tests check it against brute-force
//! integration, and that an ego whose braking builds up at a finite jerk keeps a larger gap.
//!
//! # The reaction clock, and why a certificate built on it is invariant
//! The follower reacts to a braking that it has seen for `reaction_time`: [`rear_gap_after`]
//! takes how long the ego has been braking (`braking_for`, from the moment its braking took
//! effect: its brake lights, so a command's dead time is not part of it) and evaluates the
//! model from the middle of the follower's reaction, or from inside its build-up. Write
//! `G(t) = rear_gap_after(state(t), b, t - t_0)` for an ego that has braked at most at `b` since
//! `t_0`, and `X` for the model's extremal pair from `state(t_0)` (the ego braking at `b` at
//! once, the follower at its model's bound). Then, for every `t >= t_0`:
//! - `X`'s continuation from `X(t)`, evaluated with the clock at `t - t_0`, is `X` itself (the
//!   model is written in absolute time from `t_0`), so `G` evaluated at `X(t)` is the least gap
//!   of `X` after `t`, which is at least its least gap after `t_0`: `G(t_0)`;
//! - the true state at `t` has a gap at least `X(t)`'s, an ego at least as fast and a follower
//!   no faster (each car covered, and kept, at least the extremal's margin at every instant),
//!   and the closed form is non-decreasing in the gap and the ego's speed and non-increasing in
//!   the follower's;
//!
//! so `G(t) >= G(t_0)` along every admissible episode while the braking lasts: a state
//! certified by `G` stays certified, and its gap stays above `G(t_0)`. The property test
//! `never_decreases_along_an_admissible_braking` checks it by integrating random admissible
//! episodes.
//!
//! A **release** ends the braking, and the model then assumes nothing of the follower but its
//! `reaction_acceleration`: the clock restarts at zero with the next braking (a fresh reaction,
//! the least the follower can be credited with), and nothing makes `G` invariant across the
//! release. A controller built on it may release only into a state that the fresh clock
//! certifies at the braking it will need next: an authority is kept until a lower one
//! certifies.
//!
//! **When the lights come on.** The follower reacts to the lights, which are on for sure
//! while the ego's actual acceleration is below `-threshold` (the declared lights' deceleration,
//! [`crate::EmergencyDeclaration::lights_deceleration`]: UN R13-H requires the signal only
//! above 1.3 m/s^2 of deceleration where the service brake's pedal is not used); through a dead
//! time and a lag that is later than the command. [`lights_on_within`] bounds it from what the
//! controller knows (the actuator's acceleration, the commands in its dead time, the braking ramp
//! from now), in closed form along the lag's response to a ramp, checked against a brute-force
//! actuator; the follower's reaction is then taken that much longer. The property test
//! `a_release_restarts_the_clock` checks that the restarted clock still bounds the gap from below
//! after a release in which the follower accelerated.
//!
//! # Crediting an IDM follower
//! The model's follower accelerates at up to `reaction_acceleration` until it reacts,
//! whatever the gap: at the IDM's jam distance behind a stopped ego it may drive into the ego
//! at its largest acceleration for its whole reaction, and so no move-off from a standstill
//! with a follower there is ever certified. A follower that drives by the IDM (the table's
//! declared one, its time gap anywhere in its range), and keeps the acceleration it had for
//! its reaction time when it sees brake lights late, does not: it accelerates only below the
//! speed at which its desired gap reaches its gap, so over a time in which the gap stays at
//! most `S` its speed stays at most the larger of its speed and
//! [`crate::IdmParameters::speed_cap`] for `S`. [`rear_gap_capped`] is the closed form with
//! the follower at that cap. Using it needs a bound of the gap over the follower's reaction,
//! and from its reaction time before: the ego's travel from now until the lights come on and
//! the follower has reacted bounds it from above, and the gaps measured in the reaction time
//! before now bound where a late follower's held acceleration came from. The cap is the
//! better bound only near a standstill: the gap's bound grows with the ego's travel, and the
//! cap with the gap's bound, so at 1-2 m/s behind an IDM follower 1 s behind it exceeds the
//! speed the model's follower reaches in its reaction, and the larger of the two values is the
//! model's. Nor does it certify a move-off with the declared measurement errors, so the
//! firmware does not argue it: behind an IDM follower stopped about 2 m back, the range's
//! error and the ego's travel until the lights are on alone put the gap's bound 0.4-0.6 m
//! above the jam distance for a move-off command of 0.4-1 m/s^2, where the cap is 0.8-1.2 m/s
//! (a third of it the hold term), and a follower at that speed for its reaction and the
//! lights' on-time (about 1.75 s) closes most of the gap. Even a cap without the hold term
//! lets the ego reach only 0.4-0.8 m/s before the model's own bound, a follower that follows
//! at 1 m/s^2 from a few metres, sends it back to the lights. The property test
//! `an_idm_follower_stays_above_the_capped_gap` checks it against IDM followers integrated by
//! brute force.
//!
//! # A committed move-off
//! [`rear_gap_moving_off`] is the rear half for the one thing the fresh clock cannot certify
//! behind a follower close behind: pulling away. At a standstill with the lights on and the
//! follower stopped at its jam distance, a release darkens the lights, the model's follower
//! may then accelerate blind, and any braking after it reaches the follower only after its
//! reaction: the gentlest level's rear value is below zero, and the car stands until the
//! follower leaves, which it does not. The ego that instead commits to accelerating, every
//! command in force at least a positive `commitment` until a declared end
//! ([`MoveOff`]), drives away from the follower when it commits harder than the follower
//! can accelerate blind, and the rear half then needs only the closed form at the
//! commitment's end.
//!
//! **The ego's least travel.** The actuator's acceleration is at least `from` (taken at most
//! zero: a held brake) until the commitment is in force (`delay`: the longest dead time
//! after the first committed command), then at least the lag of the slowest actuator from
//! there towards the commitment `c` (a first-order lag is monotone in its start and its
//! input, and a faster one towards a command above it is above it: at a touch, `(u - a) /
//! tau' >= (c - a) / tau`), which crosses zero at `t_0 = delay + tau ln((c - from) / c)` and
//! stays above it. An ego at or above zero speed at `t_0` is at least as fast as its
//! acceleration's bound integrated from there, so its least travel is that of an ego at rest
//! until `t_0`, then along the lag from zero ([`lag_segment`]): [`MoveOff::least_ego`]. Any
//! speed it had is credited nothing.
//!
//! **The follower's farthest travel.** Until it reacts to lights that come on after the
//! commitment's end it accelerates at most at `reaction_acceleration` (taken at least zero),
//! up to its top speed.
//!
//! **The least gap.** Within the move-off the gap is at least the measured one plus the
//! ego's least travel less the follower's farthest: both extremals are the same run of each
//! car. Their speeds' difference starts at minus the follower's and is convex (its derivative,
//! the ego's bound less the follower's acceleration, never falls), so the travel difference
//! falls, then rises: its least is where the ego's speed overtakes the follower's, found by
//! bisection and taken less the follower's travel over the bracket. At the commitment's end
//! the pair is at least at the extremals' gap, the ego at least at their ego's speed and the
//! follower at most at theirs, and every command after is at least the braking level: the
//! closed form [`rear_gap`] there, with the follower's reaction counted from the end (the
//! caller adds how long after it the lights are on for sure, [`lights_on_within`]), bounds
//! the rest (it is non-decreasing in the gap and the ego's speed and non-increasing in the
//! follower's). The property tests check the bound against brute-force integration of
//! actuators no slower than declared, commands above the bounds and followers below theirs,
//! and that it is met by the extremal pair.
//!
//! A commitment is a promise about the ego's commands: a controller that argues with it must
//! keep every command at or above the commitment until the end it declared, and argue the
//! front with the ego accelerating for as long. Against the firmware's follower, blind at its
//! IDM's largest acceleration, that is a long promise: the braking after it must outlast a
//! follower that gains speed for its reaction and the lights' on-time, which at a few metres
//! a second only a fast ego does, so the commitment lasts seconds and the front needs the
//! leader far ahead for all of it. The firmware does not argue it (`host-tests move-off`
//! measures it; docs/closed-loop.md has the figures).
//!
//! # The ego's build-up
//! [`rear_gap`] brakes the ego at its level at once. A real ego brakes through its actuator: a
//! dead time in which the commands already issued act, then a first-order lag. Any ego whose
//! acceleration is at least `-level + g(s)` with `0 <= g <= level` covers at least the
//! distance of an ego braking at `level` at once that starts `int g` faster and `int s g`
//! further back ([`KnownBraking::credit`] derives it, [`EgoBuildUp`] the lag's `g`), so
//! [`rear_gap_built_up`] is the closed form there (the larger of it and the value at once).
//! A lower bound of the ego's acceleration needs an actuator no faster than the one argued
//! with: a dead time and lag declared as the slowest the actuator may be (as the front needs)
//! do not give one through the lag. What any such actuator does give is the commands already
//! issued: its acceleration is a weighted average of the commands in force, so it stays at
//! least their least until new ones are issued. The firmware credits that much
//! ([`EgoBuildUp`] with no lag: the least command since the follower's measurement, for as long
//! as it has been known), and nothing of the commands to come.

use crate::front::{front_value, FrontModel};

/// A follower that reacts after a delay, then brakes with a bounded build-up. All in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReactingFollower {
    /// How long the follower keeps its acceleration after the ego starts braking, s.
    pub reaction_time: f32,
    /// Its largest acceleration during the reaction, m/s^2 (0: it holds its speed).
    pub reaction_acceleration: f32,
    /// Its braking once it reacts, m/s^2 (positive).
    pub braking: f32,
    /// How fast its braking builds up, m/s^3 (positive; `f32::INFINITY`: at once).
    pub jerk: f32,
    /// The largest speed of any car, m/s (the ego's speed is taken in `[0, max_speed]`).
    pub max_speed: f32,
}

/// UN R157's careful driver's reaction, s: 0.4 s to perceive and 0.75 s to move the foot and
/// brake (UN Regulation No. 157, Annex 3, the careful and competent human driver). The
/// firmware's default follower reaction and the campaigns' reacting follower.
pub const CAREFUL_DRIVER_REACTION: f32 = 1.15;

impl ReactingFollower {
    /// UN R157's careful driver: 0.4 s to perceive and 0.75 s to brake (1.15 s in which its
    /// speed is held), then 0.774 g (7.59 m/s^2) reached over 0.6 s (12.65 m/s^3), speeds up
    /// to `max_speed`.
    pub const fn careful_driver(max_speed: f32) -> Self {
        ReactingFollower {
            reaction_time: CAREFUL_DRIVER_REACTION,
            reaction_acceleration: 0.0,
            braking: 0.774 * 9.81,
            jerk: 0.774 * 9.81 / 0.6,
            max_speed,
        }
    }

    /// The largest acceleration the model allows the follower (m/s^2) `braking_for` seconds
    /// into a braking of the ego (its brake lights on for that long): `reaction_acceleration`
    /// until `reaction_time`, then its build-up `reaction_acceleration - jerk (t -
    /// reaction_time)` down to `-braking`, where it stays while the braking lasts. A follower
    /// of the model drives anything at or below it (it may brake harder); the closed forms
    /// are the least gap over all of them (module docs). Before a braking (`braking_for`
    /// negative) and for NaN, `reaction_acceleration`.
    pub fn most_acceleration(&self, braking_for: f32) -> f32 {
        let into_build_up = braking_for - self.reaction_time;
        if into_build_up.is_nan() || into_build_up < 0.0 {
            return self.reaction_acceleration;
        }
        let built = if self.jerk.is_finite() {
            self.reaction_acceleration - self.jerk * into_build_up
        } else {
            f32::NEG_INFINITY
        };
        if built > -self.braking {
            built
        } else {
            -self.braking
        }
    }

    /// The follower as the car behind in the front game's closed form.
    fn as_car_behind(&self, ego_braking: f32) -> FrontModel {
        FrontModel {
            leader_braking: ego_braking,
            ego_braking: self.braking,
            response_time: self.reaction_time,
            response_acceleration: self.reaction_acceleration,
            ramp_from: self.reaction_acceleration,
            jerk: self.jerk,
            max_speed: self.max_speed,
        }
    }
}

/// The smallest gap (m) behind an ego at `ego_speed` braking at `ego_braking` (m/s^2, positive)
/// from now, to a `follower` `gap` metres behind at `follower_speed`, both down to standstill
/// (module docs). Non-decreasing in `gap` and `ego_speed`, non-increasing in `ego_braking` and
/// `follower_speed`. NaN in, NaN out.
pub fn rear_gap(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    ego_braking: f32,
    follower: &ReactingFollower,
) -> f32 {
    rear_gap_after(gap, ego_speed, follower_speed, ego_braking, 0.0, follower)
}

/// [`rear_gap`] for an ego that has been braking for `braking_for` seconds (module docs: the
/// reaction clock): the follower's reaction already that far under way. `braking_for` at or
/// below zero, or NaN, is a braking that starts now (the least credit); at or beyond the
/// reaction and the follower's build-up, the follower is braking at its level. Non-decreasing
/// in `braking_for`.
pub fn rear_gap_after(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    ego_braking: f32,
    braking_for: f32,
    follower: &ReactingFollower,
) -> f32 {
    // (`>` is false for NaN: a NaN clock gets no credit.)
    let elapsed = if braking_for > 0.0 { braking_for } else { 0.0 };
    let mut car_behind = follower.as_car_behind(ego_braking);
    let left = follower.reaction_time - elapsed;
    if left > 0.0 {
        car_behind.response_time = left;
    } else {
        car_behind.response_time = 0.0;
        if follower.jerk.is_finite() {
            // Into the build-up by `-left` seconds; past its end the ramp's start is below
            // `-braking` and the closed form brakes at the level at once.
            car_behind.ramp_from = follower.reaction_acceleration + follower.jerk * left;
        }
    }
    front_value(gap, ego_speed, follower_speed, &car_behind)
}

/// [`rear_gap_after`] for a follower whose speed is known to stay at most `speed_cap` (m/s)
/// until it reacts: the follower taken at the larger of its speed and the cap from now, with
/// no acceleration, until its reaction, then braking as the model says. A lower bound of the
/// gap where the cap holds over the reaction (it covers at most the distance of that
/// follower at every instant, and reaches its braking no faster), so the larger of it and
/// [`rear_gap_after`] is one too. For an IDM follower, whose model the certificate's
/// follower then keeps to, [`crate::IdmParameters::speed_cap`] gives the cap from a bound of
/// the gap over the reaction (module docs: crediting an IDM follower). NaN in, NaN out.
pub fn rear_gap_capped(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    speed_cap: f32,
    ego_braking: f32,
    braking_for: f32,
    follower: &ReactingFollower,
) -> f32 {
    let capped = ReactingFollower {
        reaction_acceleration: 0.0,
        ..*follower
    };
    let speed = if follower_speed.is_nan() || speed_cap.is_nan() {
        f32::NAN
    } else {
        follower_speed.max(speed_cap)
    };
    rear_gap_after(gap, ego_speed, speed, ego_braking, braking_for, &capped)
}

/// What is known of the ego's acceleration from the follower measurement's time on, for
/// [`rear_gap_built_up`]: a lower bound `a_lb(s)` of it (`s` seconds from the measurement)
/// over the first `known_for` seconds, given by its integrals, after which the ego's
/// acceleration is a first-order lag `lag` (s) of commands no harder than the braking level
/// asked about. All in SI units. [`EgoBuildUp`] builds one for constant commands; a record of
/// the commands would sum one per command ([`lag_segment`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KnownBraking {
    /// How long the lower bound is known, s (at least zero).
    pub known_for: f32,
    /// `int_0^known_for a_lb(s) ds`, m/s.
    pub speed: f32,
    /// `int_0^known_for s a_lb(s) ds`, m.
    pub moment: f32,
    /// `a_lb(known_for)`, m/s^2: where the lag starts towards the level.
    pub at_end: f32,
    /// The least of `a_lb` over `[0, known_for]`, m/s^2.
    pub least: f32,
    /// The largest of `a_lb` over `[0, known_for]`, m/s^2: at most zero for a credit.
    pub most: f32,
    /// The actuator's first-order lag, s (zero: none).
    pub lag: f32,
}

impl KnownBraking {
    /// Nothing known: no credit at any level.
    pub const NOTHING: KnownBraking = KnownBraking {
        known_for: 0.0,
        speed: 0.0,
        moment: 0.0,
        at_end: f32::NEG_INFINITY,
        least: f32::NEG_INFINITY,
        most: 0.0,
        lag: 0.0,
    };

    /// The credit for an ego that brakes at most at `level` (m/s^2, positive) once the known
    /// part is spent: `(behind, faster)`, so that the ego is at every instant at least where
    /// an ego `faster` m/s faster and `behind` m further back, braking at `level` at once
    /// from the measurement, would be (both to standstill). `(0, 0)` (no credit) where the
    /// lower bound is below `-level` or above zero, or anything is NaN or not finite.
    ///
    /// **Derivation.** Write the ego's acceleration while it moves as at least
    /// `a_lb(s) = -level + g(s)`, with `0 <= g <= level`; let `G = int g` and `M = int s g`
    /// over `s >= 0`. The unclamped `y(s) = x_0 + v_0 s + int_0^s (s - r) a_lb(r) dr` and
    /// `z(s) = x_0 - M + (v_0 + G) s - level s^2 / 2` differ by
    /// `y - z = int_s^inf (r - s) g(r) dr >= 0`. The real ego stays at or above `y` until it
    /// stops (its speed is at least `y`'s), `y`'s speed reaches zero no later, and `y` then
    /// falls (`a_lb <= 0`), so the real ego stays at or above `y` held at its first stop;
    /// that is at or above `z` held at its stop (before `y` stops, `y >= z`; after, `y`'s stop
    /// is its highest point, at least `y` at `z`'s stop, which is at least `z`'s highest). So
    /// the ego covers at least the distance of the closed form's ego at `v_0 + G`, `M` back,
    /// and the follower is unchanged: the closed form there bounds the gap from below.
    ///
    /// After the known part the commands are at least `-level`, so through the lag the
    /// acceleration is at least `-level + (at_end + level) e^(-(s - T)/tau)`, `T =
    /// known_for` (a first-order lag is monotone in its start and its input), and
    /// - `G = speed + level T + (at_end + level) tau`,
    /// - `M = moment + level T^2 / 2 + (at_end + level) (tau T + tau^2)`.
    pub fn credit(&self, level: f32) -> (f32, f32) {
        let (t, tau) = (self.known_for, self.lag);
        // (NaN compares false: no credit.)
        let bounded = self.least >= -level
            && self.at_end >= -level
            && self.most <= 0.0
            && level > 0.0
            && t >= 0.0
            && tau >= 0.0;
        let finite = t.is_finite()
            && tau.is_finite()
            && self.speed.is_finite()
            && self.moment.is_finite()
            && level.is_finite();
        if !(bounded && finite) {
            return (0.0, 0.0);
        }
        let tail = self.at_end + level;
        let faster = self.speed + level * t + tail * tau;
        let behind = self.moment + level * 0.5 * t * t + tail * (tau * t + tau * tau);
        (behind, faster)
    }
}

/// What the ego's actuator guarantees of its acceleration from the follower measurement's
/// time on when its commands are known only by a bound: the ego's acceleration is a
/// first-order lag `lag` (s) of the command in force (the commands reach it after the
/// actuator's dead time), it is at least `acceleration` at the measurement's time, and every
/// command in force from then on for `known_for` seconds is at least `commands` (those
/// already issued: the dead time plus the time from the measurement to now). Everything after
/// is bounded by the braking level asked about. All in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EgoBuildUp {
    /// A lower bound of the ego's acceleration at the measurement's time, m/s^2.
    pub acceleration: f32,
    /// A lower bound of every command in force for `known_for` seconds from then, m/s^2.
    pub commands: f32,
    /// How long from the measurement's time the commands in force are known, s.
    pub known_for: f32,
    /// The actuator's first-order lag, s (zero: none).
    pub lag: f32,
}

impl EgoBuildUp {
    /// The lower bound's integrals ([`KnownBraking`]): with `p = commands` and `a_0 =
    /// acceleration` each taken at most zero (a lower bound may be lowered), the lag held at
    /// `p` from `a_0` for `known_for` ([`lag_segment`]), between `a_0` and `p`.
    /// [`KnownBraking::NOTHING`] where an argument is NaN or not finite.
    pub fn known(&self) -> KnownBraking {
        // Checked before clamping: `min` and `max` drop a NaN, and a NaN bound is no bound.
        let finite = [self.acceleration, self.commands, self.known_for, self.lag]
            .iter()
            .all(|x| x.is_finite());
        if !finite {
            return KnownBraking::NOTHING;
        }
        let (a_0, p) = (self.acceleration.min(0.0), self.commands.min(0.0));
        let (t, tau) = (self.known_for.max(0.0), self.lag.max(0.0));
        let (speed, moment, at_end) = lag_segment(a_0, p, t, tau);
        KnownBraking {
            known_for: t,
            speed,
            moment,
            at_end,
            least: a_0.min(p),
            most: a_0.max(p),
            lag: tau,
        }
    }

    /// [`KnownBraking::credit`] of [`EgoBuildUp::known`]. The property test
    /// `an_ego_braking_through_its_actuator_keeps_the_credited_gap` checks the bound against
    /// brute-force integration of the actuator and both cars.
    pub fn credit(&self, level: f32) -> (f32, f32) {
        self.known().credit(level)
    }
}

/// A first-order lag `lag` (s) held at `input` for `duration` (s) from the acceleration
/// `start` (m/s^2): `(int a, int s a, a(duration))` over `[0, duration]`, with
/// `a(s) = input + (start - input) e^(-s/lag)`, `E = e^(-duration/lag)`:
/// `int a = input d + (start - input) lag (1 - E)` and
/// `int s a = input d^2 / 2 + (start - input) lag^2 (1 - E (1 + d / lag))`. Without a lag the
/// input at once. The pieces of [`KnownBraking`]: [`EgoBuildUp::known`] in one.
pub fn lag_segment(start: f32, input: f32, duration: f32, lag: f32) -> (f32, f32, f32) {
    let d = duration;
    if lag > 0.0 {
        let e = libm::expf(-d / lag);
        let excess = start - input;
        (
            input * d + excess * lag * (1.0 - e),
            input * 0.5 * d * d + excess * lag * lag * (1.0 - e * (1.0 + d / lag)),
            input + excess * e,
        )
    } else {
        (input * d, input * 0.5 * d * d, input)
    }
}

/// [`rear_gap_after`] for an ego whose braking builds up through its actuator (`build_up`):
/// the larger of the value braking at `ego_braking` at once and the value with the build-up's
/// credit ([`EgoBuildUp::credit`]: the ego `faster` and `behind`), both lower bounds of the
/// gap. NaN in, NaN out.
pub fn rear_gap_built_up(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    ego_braking: f32,
    braking_for: f32,
    build_up: &EgoBuildUp,
    follower: &ReactingFollower,
) -> f32 {
    let at_once = rear_gap_after(
        gap,
        ego_speed,
        follower_speed,
        ego_braking,
        braking_for,
        follower,
    );
    let (behind, faster) = build_up.credit(ego_braking);
    if faster <= 0.0 && behind <= 0.0 {
        return at_once;
    }
    let credited = rear_gap_after(
        gap - behind,
        ego_speed + faster,
        follower_speed,
        ego_braking,
        braking_for,
        follower,
    );
    // (A NaN value stays NaN: `max` would drop it.)
    if at_once.is_nan() || credited.is_nan() {
        return f32::NAN;
    }
    at_once.max(credited)
}

/// A committed move-off, for [`rear_gap_moving_off`] (module docs: a committed move-off):
/// what the ego's commands guarantee of its acceleration from the follower measurement's time
/// on while it pulls away from a follower close behind. All in SI units, times from the
/// measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MoveOff {
    /// A lower bound of the ego's acceleration at the measurement's time and of every command
    /// in force until `delay`, m/s^2 (taken at most zero: a held brake).
    pub from: f32,
    /// From when every command in force is at least `commitment`, s: the actuator's longest
    /// dead time after the first committed command's issue.
    pub delay: f32,
    /// The least committed command, m/s^2 (positive).
    pub commitment: f32,
    /// Until when every command in force is at least `commitment`, s (at least `delay`): the
    /// last committed command's end, plus the actuator's shortest dead time. After it every
    /// command is at least the braking level asked about.
    pub until: f32,
    /// The actuator's first-order lag, s: the longest it may be (zero: none).
    pub lag: f32,
}

/// How many halvings [`rear_gap_moving_off`] brackets the moment the ego's speed overtakes the
/// follower's with: a window of 10 s to 0.6 microseconds.
const MOVE_OFF_HALVINGS: u32 = 24;

impl MoveOff {
    /// When the lower bound of the ego's acceleration crosses zero for good, s: the dead time
    /// holds it at `from` (at most zero), then the lag `tau` takes it towards `commitment`
    /// `c`: `delay + tau ln((c - from) / c)`. `+inf` where the commitment is not positive.
    fn moving_from(&self) -> f32 {
        let from = self.from.min(0.0);
        let c = self.commitment;
        // (NaN is no commitment.)
        if c.is_nan() || c <= 0.0 {
            return f32::INFINITY;
        }
        if self.lag > 0.0 {
            self.delay + self.lag * libm::logf((c - from) / c)
        } else {
            self.delay
        }
    }

    /// The ego's least travel and speed `t` seconds after the measurement, to `until`
    /// (`(m, m/s)`; module docs: a committed move-off): at rest until the lower bound of its
    /// acceleration crosses zero, then the lag from zero towards the commitment
    /// ([`lag_segment`]: travel `D int a - int s a` over the `D` seconds since).
    pub fn least_ego(&self, t: f32) -> (f32, f32) {
        let start = self.moving_from();
        let d = t.min(self.until) - start;
        // (NaN: no travel credited.)
        if d.is_nan() || d <= 0.0 {
            return (0.0, 0.0);
        }
        let (speed, moment, _) = lag_segment(0.0, self.commitment, d, self.lag);
        (d * speed - moment, speed)
    }
}

/// The follower's farthest travel and highest speed `t` seconds after the measurement from
/// `speed`, accelerating at `acceleration` (at least zero) up to `max_speed`: `(m, m/s)`.
fn farthest_follower(speed: f32, acceleration: f32, max_speed: f32, t: f32) -> (f32, f32) {
    if acceleration > 0.0 && speed < max_speed {
        let to_top = (max_speed - speed) / acceleration;
        if t <= to_top {
            return (
                speed * t + 0.5 * acceleration * t * t,
                speed + acceleration * t,
            );
        }
        let run = speed * to_top + 0.5 * acceleration * to_top * to_top;
        (run + max_speed * (t - to_top), max_speed)
    } else {
        (speed * t, speed)
    }
}

/// The least of the ego's travel less the follower's over a move-off, m: the follower from
/// `follower_speed` (at least zero) accelerating at `climb` (at least zero) up to `top`.
/// The difference falls while the ego is the slower, and the difference of their speeds is
/// convex (its derivative, the ego's acceleration bound less the follower's, never falls: the
/// ego's rises along the lag, the follower's drops to zero at its top), so it is negative,
/// then positive: the least is where it changes sign (bracketed, less the follower's travel
/// over the bracket), or at the end.
fn least_within_move_off(follower_speed: f32, m: &MoveOff, climb: f32, top: f32) -> f32 {
    let follower_at = |t: f32| farthest_follower(follower_speed, climb, top, t);
    let closing = |t: f32| {
        let (ego, ego_speed) = m.least_ego(t);
        let (behind, behind_speed) = follower_at(t);
        (ego - behind, ego_speed - behind_speed)
    };
    let (mut lo, mut hi) = (0.0f32, m.until);
    if closing(hi).1 <= 0.0 {
        return closing(hi).0;
    }
    for _ in 0..MOVE_OFF_HALVINGS {
        let mid = 0.5 * (lo + hi);
        if closing(mid).1 > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    // Over the bracket the travel falls no faster than the follower's speed at its end.
    closing(lo).0 - (hi - lo) * follower_at(hi).1
}

/// The smallest gap (m) behind an ego that moves off along `move_off` from `gap` metres ahead
/// of a follower at `follower_speed`, and brakes at `ego_braking` (m/s^2, positive) once the
/// commitment ends, the follower accelerating blind at its `reaction_acceleration` all the
/// while and then as [`rear_gap`] has it: the lights, dark through the move-off, come on no
/// earlier than the commitment's end, so `follower`'s `reaction_time` counts from there and
/// must include how long after it they are on for sure ([`lights_on_within`]). The ego's speed
/// at the measurement is taken as zero (the least; it is at least that). The smaller of the
/// least gap within the move-off and the closed form at its end (module docs: a committed
/// move-off). NaN in, NaN out; `-inf` where the move-off is not one (a commitment not
/// positive, a negative delay or lag, an end before the delay, anything infinite).
pub fn rear_gap_moving_off(
    gap: f32,
    follower_speed: f32,
    move_off: &MoveOff,
    ego_braking: f32,
    follower: &ReactingFollower,
) -> f32 {
    let m = move_off;
    let inputs = [
        gap,
        follower_speed,
        m.from,
        m.delay,
        m.commitment,
        m.until,
        m.lag,
        ego_braking,
    ];
    if inputs.iter().any(|x| x.is_nan()) {
        return f32::NAN;
    }
    let usable = inputs.iter().all(|x| x.is_finite())
        && m.commitment > 0.0
        && m.delay >= 0.0
        && m.lag >= 0.0
        && m.until >= m.delay;
    if !usable {
        return f32::NEG_INFINITY;
    }
    let climb = follower.reaction_acceleration.max(0.0);
    let (top, follower_speed) = (follower.max_speed, follower_speed.max(0.0));
    let least_within = least_within_move_off(follower_speed, m, climb, top);
    let (follower_travel, speed_at_end) = farthest_follower(follower_speed, climb, top, m.until);
    let (ego_travel, ego_speed) = m.least_ego(m.until);
    let at_end = rear_gap(
        gap + ego_travel - follower_travel,
        ego_speed,
        speed_at_end,
        ego_braking,
        follower,
    );
    if at_end.is_nan() {
        return f32::NAN;
    }
    at_end.min(gap + least_within)
}

/// How finely [`lights_on_within`] brackets a last zero on the ramp's phase, s: a
/// microsecond, the firmware's clock (its bound is the bracket's later end, so no earlier than
/// the zero).
pub const LIGHTS_RESOLUTION: f32 = 1e-6;

/// How long until an ego's brake lights are on for good, at most (s): they are on for sure
/// while its actual acceleration is below `-threshold` (m/s^2, at least zero: the declared
/// lights' deceleration), and the follower's reaction starts there (module docs).
///
/// The actuator is a dead time `dead_time` (s) then a first-order lag `lag` (s, zero: none).
/// Its acceleration now is at most `acceleration`, the commands already in its dead time are
/// at most `pipeline`, and the commands from now on at most the braking ramp
/// `max(ramp_from - jerk t, -level)` (`jerk` positive, `f32::INFINITY`: at once; `level`
/// positive). Every profile below these bounds lights the brakes no later (the lag is monotone
/// in its input and its start), so the bound is the last time the actual acceleration `A`
/// is at `-threshold`, with every bound taken with equality. The lag and the ramp are linear
/// and the dead time a shift, so `A + threshold` is the same actuator's answer to the bounds
/// each raised by `threshold` (the level lowered by it): the bound is that profile's last
/// zero, and none where the level is no harder than the threshold (`+inf`: the commands
/// need not light the brakes). Derivation of the last zero, `s` seconds after the dead time,
/// `tau` the lag, `r = ramp_from`, `j = jerk`, every acceleration so raised:
/// - in the dead time, `A` moves from `acceleration` towards `pipeline`:
///   `A(t) = P + (A_0 - P) e^(-t/tau)`, monotone;
/// - along the ramp (`s < s_b = (r + level) / j`), the lag of a linear input trails it by
///   `j tau`: `A = r - j s + j tau + K e^(-s/tau)`, `K = A(D) - r - j tau`, which is concave
///   when `K < 0` (it may rise, then fall) and decreasing otherwise;
/// - at the level, `A = -level + (A(s_b) + level) e^(-(s - s_b)/tau)`, which crosses zero at
///   `s_b + tau ln((A(s_b) + level) / level)` when `A(s_b) > 0`.
///
/// So the last zero is in the last phase where `A` reaches zero: in closed form at the level,
/// by bisection on the falling side of the ramp's phase (to [`LIGHTS_RESOLUTION`], the
/// bracket's later end: about 20 halvings of a ramp's second), in closed form in the dead
/// time. `A` is below `-threshold` from the returned time on; zero when it already is and
/// stays so. NaN in any argument, or a negative threshold, gives `+inf` (no credit).
#[allow(clippy::too_many_arguments)]
pub fn lights_on_within(
    dead_time: f32,
    lag: f32,
    acceleration: f32,
    pipeline: f32,
    ramp_from: f32,
    jerk: f32,
    level: f32,
    threshold: f32,
) -> f32 {
    if threshold.is_nan() || threshold < 0.0 {
        return f32::INFINITY;
    }
    let (acceleration, pipeline, ramp_from, level) = (
        acceleration + threshold,
        pipeline + threshold,
        ramp_from + threshold,
        level - threshold,
    );
    let finite = [dead_time, lag, acceleration, pipeline, ramp_from, level]
        .iter()
        .all(|x| x.is_finite());
    let positive = jerk > 0.0 && level > 0.0;
    if !finite || !positive {
        return f32::INFINITY;
    }
    let (d, tau, a0, p) = (dead_time.max(0.0), lag.max(0.0), acceleration, pipeline);
    let r = ramp_from.max(-level);
    let s_b = if jerk.is_finite() {
        (r + level) / jerk
    } else {
        0.0
    };
    if tau <= 0.0 {
        // No lag: `A` is `a0` now, `p` in the dead time, the command after it.
        if s_b > 0.0 && r >= 0.0 {
            return d + r / jerk;
        }
        if d > 0.0 && p >= 0.0 {
            return d;
        }
        return if a0 >= 0.0 { d.min(f32::EPSILON) } else { 0.0 };
    }
    let decay = |t: f32| libm::expf(-t / tau);
    let at_dead_end = p + (a0 - p) * decay(d);
    let k = at_dead_end - r - if jerk.is_finite() { jerk * tau } else { 0.0 };
    let on_ramp = |s: f32| r - jerk * s + jerk * tau + k * decay(s);
    let at_level_start = if s_b > 0.0 { on_ramp(s_b) } else { at_dead_end };
    // At the level: `-level + (A(s_b) + level) e^(-(s - s_b)/tau)`.
    if at_level_start >= 0.0 {
        return d + s_b + tau * libm::logf((at_level_start + level) / level);
    }
    // On the ramp: concave when `k < 0` (highest where `A' = 0`, `s = tau ln(-k / (j tau))`),
    // decreasing otherwise; the last zero is on the falling side of the highest point.
    if s_b > 0.0 {
        let top = if k < 0.0 {
            (tau * libm::logf(-k / (jerk * tau))).clamp(0.0, s_b)
        } else {
            0.0
        };
        if on_ramp(top) >= 0.0 {
            let (mut lo, mut hi) = (top, s_b);
            // To a microsecond (the firmware's clock), or until `f32` can halve no further.
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if hi - lo <= LIGHTS_RESOLUTION || mid <= lo || mid >= hi {
                    break;
                }
                if on_ramp(mid) >= 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return d + hi;
        }
    }
    // In the dead time: monotone from `a0` to `A(D) < 0` (so `p < 0` when `a0 >= 0`).
    if a0 >= 0.0 && p < 0.0 {
        return (tau * libm::logf((a0 - p) / -p)).min(d);
    }
    0.0
}

/// The hardest braking in `[0, ceiling]` (m/s^2) the `follower` allows the ego: the largest
/// found whose [`rear_gap`] stays above `margin` (m), within 1e-3 m/s^2 of the largest there is
/// ([`hardest_clearing`]); `None` when not even holding the ego's speed (braking 0) keeps the
/// gap above `margin`. Whatever is returned passed [`rear_gap`] itself.
pub fn allowed_braking(
    gap: f32,
    ego_speed: f32,
    follower_speed: f32,
    follower: &ReactingFollower,
    margin: f32,
    ceiling: f32,
) -> Option<f32> {
    let slack = |b: f32| rear_gap(gap, ego_speed, follower_speed, b, follower) - margin;
    hardest_clearing(slack, 0.0, ceiling, 1e-3)
}

/// The largest braking `b` in `[least, ceiling]` with `slack(b)` above zero, to within
/// `resolution`, for a `slack` non-increasing in `b` (a rear value less its margin: an ego that
/// brakes harder is never farther from the follower): the braking a follower allows, the one
/// search behind [`allowed_braking`] and `crate::authority::TwoAuthorities::allowed_level`.
/// `ceiling` if it clears; `None` where `least` does not (or NaN, or `least >= ceiling`).
///
/// A bracket that always keeps a clearing end (`lo`) and a failing one, narrowed by the
/// Illinois method's false positions (the rear value is smooth between the points where its
/// least gap moves from one phase to another), with a bisection wherever a false position
/// would leave the bracket, and at every other step where the bracket has not halved since the
/// last such check: the bracket at least halves every four steps, so at most
/// `4 log2((ceiling - least) / resolution) + 3` evaluations (and never more than 64), mostly
/// far fewer. (Checking at every step, so that it halves every two, cost the two-authority
/// rule half as much again on QEMU: 29,228 instructions for its worst decision, not 20,123.
/// The bound was stated as every two steps until the property test
/// `the_search_finds_the_hardest_clearing_braking_within_its_bound` found a cliff-shaped value
/// that took four.) A secant in `1 / b` alone is not enough: the value is far from
/// affine there where the least gap comes while both cars brake (one returned 1.9 m/s^2 where
/// 5.3 clears). Returns the clearing end.
pub fn hardest_clearing(
    slack: impl Fn(f32) -> f32,
    least: f32,
    ceiling: f32,
    resolution: f32,
) -> Option<f32> {
    let at_ceiling = slack(ceiling);
    if at_ceiling > 0.0 {
        return Some(ceiling);
    }
    // (NaN compares false: nothing to search.)
    let searchable = least < ceiling;
    if !searchable {
        return None;
    }
    let at_least = slack(least);
    let clears = at_least > 0.0;
    if !clears {
        return None;
    }
    let (mut lo, mut at_lo, mut hi, mut at_hi) = (least, at_least, ceiling, at_ceiling);
    // Which end the last step kept (Illinois: an end kept twice has its value halved).
    let mut kept = 0i8;
    let mut width_before = hi - lo;
    for step in 0..62u32 {
        let width = hi - lo;
        if width <= resolution {
            break;
        }
        // Every other step: where the bracket has not halved since the last such check, this
        // step bisects it.
        let stalled = step % 2 == 0 && step > 0 && width > 0.5 * width_before;
        if step % 2 == 0 {
            width_before = width;
        }
        let false_position = hi - at_hi * width / (at_hi - at_lo);
        let mid = if !stalled && false_position > lo && false_position < hi {
            false_position
        } else {
            0.5 * (lo + hi)
        };
        let at_mid = slack(mid);
        if at_mid > 0.0 {
            (lo, at_lo) = (mid, at_mid);
            if kept < 0 {
                at_hi *= 0.5;
            }
            kept = -1;
        } else {
            (hi, at_hi) = (mid, at_mid);
            if kept > 0 {
                at_lo *= 0.5;
            }
            kept = 1;
        }
    }
    Some(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The smallest rear gap by brute-force integration (f64, 0.1 ms steps) from `(gap, ve,
    /// vf)`, the ego's mean acceleration over each step from `ego(mid, dt)`, the follower
    /// holding `reaction_acceleration` for its reaction, then ramping at its jerk to its
    /// braking; both to standstill, and at least for `at_least` seconds.
    fn least_gap(
        (gap, ve, vf): (f64, f64, f64),
        f: &ReactingFollower,
        at_least: f64,
        mut ego: impl FnMut(f64, f64) -> f64,
    ) -> f64 {
        let dt = 1e-4;
        let (mut g, mut ve, mut vf, mut t) = (gap, ve, vf, 0.0);
        let mut least = g;
        let (rho, ar) = (
            f64::from(f.reaction_time),
            f64::from(f.reaction_acceleration),
        );
        let (bf, jf) = (f64::from(f.braking), f64::from(f.jerk));
        while ve > 0.0 || vf > 0.0 || t <= rho + ar.max(0.0) / jf || t <= at_least {
            let mid = t + 0.5 * dt;
            let ae = ego(mid, dt);
            let af = if mid < rho {
                ar
            } else {
                (ar - jf * (mid - rho)).max(-bf)
            };
            crate::brute::advance(&mut g, &mut ve, &mut vf, (ae, af), dt);
            t += dt;
            least = least.min(g);
            if t > 200.0 {
                break;
            }
        }
        least
    }

    /// [`least_gap`] for an ego whose braking builds up at `ego_jerk` (infinite: at once) to
    /// `ego_braking` from now, its speed taken at most the follower's model's top.
    fn simulated(
        gap: f64,
        ve: f64,
        vf: f64,
        ego_braking: f64,
        ego_jerk: f64,
        f: &ReactingFollower,
    ) -> f64 {
        let ve = ve.clamp(0.0, f64::from(f.max_speed));
        least_gap((gap, ve, vf), f, 0.0, |mid, _| {
            -(ego_jerk * mid).min(ego_braking)
        })
    }

    fn follower(rho: f32, ar: f32, bf: f32, jf: f32) -> ReactingFollower {
        ReactingFollower {
            reaction_time: rho,
            reaction_acceleration: ar,
            braking: bf,
            jerk: jf,
            max_speed: 35.0,
        }
    }

    /// [`least_gap`] for an ego whose acceleration is a first-order lag `tau` of its commands,
    /// starting at `a_0`: the commands in force are `commands[k]` over the k-th 50 ms until
    /// `known_for`, then `late[k]` (the same slices, counted from `known_for`; the last held).
    #[allow(clippy::too_many_arguments)]
    fn simulated_through(
        start: (f64, f64, f64),
        a_0: f64,
        tau: f64,
        known_for: f64,
        commands: &[f64],
        late: &[f64],
        f: &ReactingFollower,
    ) -> f64 {
        let slice = |list: &[f64], t: f64| {
            let k = ((t / 0.05) as usize).min(list.len() - 1);
            list[k]
        };
        let mut a = a_0;
        least_gap(start, f, known_for, |mid, dt| {
            let u = if mid < known_for {
                slice(commands, mid)
            } else {
                slice(late, mid - known_for)
            };
            // The lag's exact step for the held command; the step's mean, the ends'.
            let next_a = if tau > 0.0 {
                u + (a - u) * (-dt / tau).exp()
            } else {
                u
            };
            let mean = 0.5 * (a + next_a);
            a = next_a;
            mean
        })
    }

    /// The smallest gap behind an ego braking at `braking` from `ego_speed` at once, to an IDM
    /// follower (f64, 0.5 ms steps): its time gap jumps between 1 and 2 s at the tenths of a
    /// second in `switches`; the ego's lights are on for sure `dark` seconds from now; a `late`
    /// follower keeps the acceleration it has then for its reaction time; after `dark` plus
    /// the reaction it brakes as the model's follower does (from zero at its jerk to its
    /// braking). Both to standstill.
    fn least_gap_behind_idm(
        (gap, ego_speed, follower_speed): (f64, f64, f64),
        braking: f64,
        f: &ReactingFollower,
        dark: f64,
        late: bool,
        switches: &[u32],
    ) -> f64 {
        let p = crate::IdmParameters::HIGHWAY;
        let dt = 5e-4;
        let (mut g, mut ve, mut vf, mut t) = (gap, ego_speed, follower_speed, 0.0f64);
        let reacts = dark + f64::from(f.reaction_time);
        let (bf, jf) = (f64::from(f.braking), f64::from(f.jerk));
        let mut time_gap = 1.0;
        let mut held: Option<f64> = None;
        let mut least = g;
        let mut k = 0u32;
        while ve > 0.0 || vf > 0.0 || t <= reacts {
            if k.is_multiple_of(200) && switches.contains(&(k / 200)) {
                time_gap = if time_gap == 1.0 { 2.0 } else { 1.0 };
            }
            let idm = p.acceleration_f64(vf, vf - ve, g, time_gap).clamp(-bf, 2.0);
            let af = if t < reacts {
                if late && t >= dark {
                    *held.get_or_insert(idm)
                } else {
                    idm
                }
            } else {
                (-jf * (t - reacts)).max(-bf)
            };
            let ae = if ve > 0.0 { -braking } else { 0.0 };
            crate::brute::advance(&mut g, &mut ve, &mut vf, (ae, af), dt);
            t += dt;
            k += 1;
            least = least.min(g);
            if t > 120.0 {
                break;
            }
        }
        least
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// An IDM follower, reacting to the lights at once or holding its acceleration for
        /// its reaction time, keeps at least [`rear_gap_capped`]'s gap, the cap
        /// ([`crate::IdmParameters::speed_cap`]) taken for the gap's bound over the run (its
        /// start plus the ego's stopping distance) and the ego's speed; and the credit is
        /// real: at the jam distance behind an ego at rest, the capped value is above the
        /// model's.
        #[test]
        fn an_idm_follower_stays_above_the_capped_gap(
            gap in 1.0f64..25.0,
            ego_speed in 0.0f64..2.4,
            follower_speed in 0.0f64..6.0,
            braking in 1.5f64..8.0,
            dark in 0.0f64..1.0,
            late in any::<bool>(),
            at_once in any::<bool>(),
            switches in proptest::collection::vec(0u32..60, 0..5),
        ) {
            let mut f = ReactingFollower::careful_driver(35.0);
            f.reaction_acceleration = 1.0;
            f.braking = 6.0;
            if at_once {
                f.jerk = f32::INFINITY;
            }
            let least = least_gap_behind_idm(
                (gap, ego_speed, follower_speed),
                braking,
                &f,
                dark,
                late,
                &switches,
            );
            let bound = gap + ego_speed * ego_speed / (2.0 * braking);
            let hold = if late { f.reaction_time } else { 0.0 };
            let cap = crate::IdmParameters::HIGHWAY.speed_cap(
                1.0,
                bound as f32,
                ego_speed as f32,
                hold,
            );
            let waiting = ReactingFollower {
                reaction_time: f.reaction_time + dark as f32,
                ..f
            };
            let capped = rear_gap_capped(
                gap as f32,
                ego_speed as f32,
                follower_speed as f32,
                cap,
                braking as f32,
                0.0,
                &waiting,
            );
            prop_assert!(
                least >= f64::from(capped) - 2e-3,
                "least {least} below the capped {capped} (cap {cap})"
            );
        }
    }

    /// At the IDM's jam distance behind an ego at rest, with its follower at rest: the model's
    /// follower, accelerating at 1 m/s^2 for its 1.15 s and the lights' 0.5 s, closes 1.6 m of
    /// the 2 m; the capped one stays where it is (the IDM gives it no acceleration there); with
    /// a measured speed of 0.4 m/s it closes 0.7 m, where the model's closes 2.4 m.
    #[test]
    fn the_capped_follower_at_the_jam_distance() {
        let p = crate::IdmParameters::HIGHWAY;
        let f = ReactingFollower {
            reaction_time: CAREFUL_DRIVER_REACTION + 0.5,
            reaction_acceleration: 1.0,
            braking: 6.0,
            jerk: f32::INFINITY,
            max_speed: 35.0,
        };
        let model = rear_gap(2.0, 0.0, 0.0, 3.5, &f);
        assert!((model - (2.0 - 0.5 * 1.65 * 1.65 - 1.65 * 1.65 / 12.0)).abs() < 1e-3);
        let cap = p.speed_cap(1.0, 2.0, 0.0, 0.0);
        assert_eq!(cap, 0.0);
        assert_eq!(rear_gap_capped(2.0, 0.0, 0.0, cap, 3.5, 0.0, &f), 2.0);
        let moving = rear_gap_capped(2.0, 0.0, 0.4, cap, 3.5, 0.0, &f);
        assert!(
            (moving - (2.0 - 0.4 * 1.65 - 0.4 * 0.4 / 12.0)).abs() < 1e-3,
            "{moving}"
        );
        assert!(rear_gap(2.0, 0.0, 0.4, 3.5, &f) < -0.3);
        assert!(rear_gap_capped(2.0, 0.0, f32::NAN, cap, 3.5, 0.0, &f).is_nan());
    }

    /// A bound that is NaN or not finite earns no credit (clamping it at zero would have
    /// credited an unknown acceleration as zero).
    #[test]
    fn a_bound_that_is_not_a_number_earns_no_credit() {
        let known = EgoBuildUp {
            acceleration: 0.0,
            commands: 0.0,
            known_for: 0.2,
            lag: 0.3,
        };
        assert!(known.credit(5.0).1 > 0.0);
        for bad in [f32::NAN, f32::NEG_INFINITY] {
            for b in [
                EgoBuildUp {
                    acceleration: bad,
                    ..known
                },
                EgoBuildUp {
                    commands: bad,
                    ..known
                },
                EgoBuildUp {
                    known_for: bad,
                    ..known
                },
                EgoBuildUp { lag: bad, ..known },
            ] {
                assert_eq!(b.credit(5.0), (0.0, 0.0), "{b:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// The closed form against brute force, the ego braking at once.
        #[test]
        fn matches_brute_force_integration(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.0f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            bf in 3.0f32..9.0, jf in 5.0f32..30.0,
        ) {
            let f = follower(rho, ar, bf, jf);
            let exact = rear_gap(gap, ve, vf, b, &f);
            let brute = simulated(
                f64::from(gap), f64::from(ve), f64::from(vf), f64::from(b), f64::INFINITY, &f,
            );
            prop_assert!(
                (f64::from(exact) - brute).abs() < 0.01 * (1.0 + brute.abs() * 1e-3),
                "{} vs {}", exact, brute
            );
        }

        /// An ego whose braking builds up at a finite jerk keeps at least the closed form's gap
        /// (the step is the hardest braking the level allows).
        #[test]
        fn bounds_an_ego_whose_braking_builds_up(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, ego_jerk in 2.0f64..40.0, rho in 0.0f32..2.0,
        ) {
            let f = follower(rho, 0.0, 7.0, 12.0);
            let exact = rear_gap(gap, ve, vf, b, &f);
            let brute = simulated(
                f64::from(gap), f64::from(ve), f64::from(vf), f64::from(b), ego_jerk, &f,
            );
            prop_assert!(brute >= f64::from(exact) - 0.01, "{} vs {}", exact, brute);
        }

        /// The build-up's credit ([`EgoBuildUp::credit`]) bounds the least gap of an ego
        /// braking through its actuator: its acceleration starts at or above the declared
        /// bound, its commands are at or above theirs while known and at or above the level
        /// after (mostly exactly there: the extremal; sometimes gentler, 50 ms at a time), the
        /// follower at its model's bound. Run once with `behind` dropped from the credit it
        /// fails (both cars standing, the follower closing 0.98 m on an ego credited with
        /// none), and once with the first phase's moment short by its `E T / tau` term (0.1 m
        /// over the value).
        #[test]
        fn an_ego_braking_through_its_actuator_keeps_the_credited_gap(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            level in 1.0f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            a_0 in -10.0f32..2.0, p in -10.0f32..2.0, above in 0.0f32..1.0,
            known_for in 0.0f32..1.0, tau in 0.0f32..0.6,
            gentler in proptest::collection::vec((0.0f64..1.0, 0.0f64..3.0), 40),
        ) {
            let f = follower(rho, ar, 7.59, 12.65);
            let build_up = EgoBuildUp { acceleration: a_0, commands: p, known_for, lag: tau };
            let value = rear_gap_built_up(gap, ve, vf, level, 0.0, &build_up, &f);
            // Mostly at the bound, a third of the slices gentler by up to 3 m/s^2.
            let draw = |bound: f64| -> Vec<f64> {
                gentler
                    .iter()
                    .map(|&(odds, by)| bound + if odds < 0.33 { by } else { 0.0 })
                    .collect()
            };
            // The episode brakes at most at the level (the closed form's premise): a bound
            // below it is no bound of this episode's (and earns no credit).
            let floor = -f64::from(level);
            let commands = draw(f64::from(p).max(floor));
            let late = draw(floor);
            let brute = simulated_through(
                (f64::from(gap), f64::from(ve), f64::from(vf)),
                f64::from(a_0).max(floor) + f64::from(above) * f64::from(gentler[0].0 < 0.5),
                f64::from(tau),
                f64::from(known_for),
                &commands,
                &late,
                &f,
            );
            prop_assert!(brute >= f64::from(value) - 0.01, "{} vs {}", value, brute);
        }

        /// The credit is the closed form's own value where there is nothing to credit (an ego
        /// that may brake at the level already, or no time and no lag), and never less than
        /// braking at once.
        #[test]
        fn the_credit_is_nothing_without_a_build_up_and_never_costs(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            level in 1.0f32..10.0, a_0 in -10.0f32..2.0, p in -10.0f32..2.0,
            known_for in 0.0f32..1.0, tau in 0.0f32..0.6,
        ) {
            let f = follower(1.15, 1.0, 7.59, 12.65);
            let at_once = rear_gap(gap, ve, vf, level, &f);
            let none = EgoBuildUp { acceleration: -level, commands: -level, known_for, lag: tau };
            prop_assert_eq!(rear_gap_built_up(gap, ve, vf, level, 0.0, &none, &f), at_once);
            let instant = EgoBuildUp { acceleration: a_0, commands: p, known_for: 0.0, lag: 0.0 };
            prop_assert_eq!(instant.credit(level), (0.0, 0.0));
            let some = EgoBuildUp { acceleration: a_0, commands: p, known_for, lag: tau };
            prop_assert!(rear_gap_built_up(gap, ve, vf, level, 0.0, &some, &f) >= at_once);
        }

        /// What `allowed_braking` returns keeps the margin, and a braking 0.01 m/s^2 harder
        /// does not (unless it is the ceiling).
        #[test]
        fn the_allowed_braking_is_the_largest_that_keeps_the_margin(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            rho in 0.0f32..2.0, margin in 0.0f32..2.0,
        ) {
            let f = follower(rho, 0.0, 7.59, 12.65);
            match allowed_braking(gap, ve, vf, &f, margin, 10.0) {
                None => prop_assert!(rear_gap(gap, ve, vf, 0.0, &f) <= margin),
                Some(b) => {
                    prop_assert!(rear_gap(gap, ve, vf, b, &f) > margin);
                    if b < 10.0 {
                        prop_assert!(rear_gap(gap, ve, vf, b + 0.01, &f) <= margin + 1e-3);
                    }
                }
            }
        }

        /// The search's claims on functions no one tuned it for: a smooth slope, a cliff (its
        /// false positions stall and the bisections must carry it), and a steep curve. What it
        /// returns clears, lies within the resolution of the root, and took at most
        /// `4 log2(width / resolution) + 3` evaluations.
        #[test]
        fn the_search_finds_the_hardest_clearing_braking_within_its_bound(
            root in 0.5f32..9.5, kind in 0u8..3, resolution in 0.001f32..0.1,
        ) {
            let (least, ceiling) = (0.25f32, 10.0f32);
            let calls = core::cell::Cell::new(0u32);
            let slack = |b: f32| {
                calls.set(calls.get() + 1);
                match kind {
                    0 => root - b,
                    1 => if b < root { 1.0 } else { -1.0 },
                    _ => (root - b) * (1.0 + 50.0 * (b - least).powi(4)),
                }
            };
            let found = hardest_clearing(slack, least, ceiling, resolution);
            let b = found.expect("the least braking clears");
            prop_assert!(b < root, "{} at or beyond {}", b, root);
            prop_assert!(root - b <= resolution + 1e-5, "{} short of {}", root - b, resolution);
            let bound = 4.0 * ((ceiling - least) / resolution).log2().ceil() + 3.0;
            prop_assert!(f64::from(calls.get()) <= f64::from(bound), "{} calls", calls.get());
        }
    }

    /// The extremal pair by brute force (f64, 0.1 ms steps), the ego braking at `b` at once,
    /// from `(gap, ve, vf)`: the state at `split` seconds, and the least gap from `split` on.
    fn extremal_after(
        (gap, ve, vf): (f64, f64, f64),
        b: f64,
        f: &ReactingFollower,
        split: f64,
    ) -> ((f64, f64, f64), f64) {
        let dt = 1e-4;
        let (mut g, mut ve, mut vf, mut t) = (gap, ve.clamp(0.0, f64::from(f.max_speed)), vf, 0.0);
        let (rho, ar) = (
            f64::from(f.reaction_time),
            f64::from(f.reaction_acceleration),
        );
        let (bf, jf) = (f64::from(f.braking), f64::from(f.jerk));
        let mut at_split = None;
        let mut least = f64::INFINITY;
        loop {
            if at_split.is_none() && t >= split - 0.5 * dt {
                at_split = Some((g, ve, vf));
            }
            if at_split.is_some() {
                least = least.min(g);
                if (ve <= 0.0 && vf <= 0.0 && t > rho) || t > 200.0 {
                    break;
                }
            }
            let mid = t + 0.5 * dt;
            let af = if mid < rho {
                ar
            } else {
                (ar - jf * (mid - rho)).max(-bf)
            };
            let ne = (ve - b * dt).max(0.0);
            let nf = (vf + af * dt).max(0.0);
            g += 0.5 * (ve + ne) * dt - 0.5 * (vf + nf) * dt;
            ve = ne;
            vf = nf;
            t += dt;
        }
        (at_split.unwrap_or((g, ve, vf)), least)
    }

    /// One admissible episode by integration (1 ms steps) for `seconds`: the ego's
    /// acceleration drawn in `[-b, 1]` while it brakes (`[0, 1]` while released), the
    /// follower's at most `reaction_acceleration` until `reaction_time` into each braking and
    /// at most its build-up after, at least -9 m/s^2 (it may brake harder than its model),
    /// each held for 50 ms. `released` says when the ego is not braking. Calls `visit` every
    /// 10 ms with the state and the clock; returns the least gap.
    #[allow(clippy::too_many_arguments)]
    fn admissible_episode(
        (gap, ve, vf): (f32, f32, f32),
        b: f32,
        f: &ReactingFollower,
        draws: &[(f32, f32)],
        released: impl Fn(f32) -> bool,
        seconds: f32,
        mut visit: impl FnMut(f32, (f32, f32, f32), f32),
    ) -> f32 {
        let dt = 1e-3f64;
        let (mut g, mut e, mut fv) = (f64::from(gap), f64::from(ve), f64::from(vf));
        let mut clock = 0.0f64;
        let mut least = g;
        let steps = (f64::from(seconds) / dt).round() as usize;
        for k in 0..steps {
            let t = k as f64 * dt;
            if k % 10 == 0 {
                visit(t as f32, (g as f32, e as f32, fv as f32), clock as f32);
            }
            let (ue, uf) = draws[(k / 50) % draws.len()];
            let off = released(t as f32);
            let ae = if off {
                f64::from(ue.abs())
            } else if ue < 0.0 {
                f64::from(ue * b)
            } else {
                f64::from(ue)
            };
            let bound = if off || clock < f64::from(f.reaction_time) {
                f64::from(f.reaction_acceleration)
            } else if f.jerk.is_finite() {
                (f64::from(f.reaction_acceleration)
                    - f64::from(f.jerk) * (clock - f64::from(f.reaction_time)))
                .max(-f64::from(f.braking))
            } else {
                -f64::from(f.braking)
            };
            // `uf` in [0, 1] picks between -9 and the bound.
            let af = bound - f64::from(uf) * (bound + 9.0).max(0.0);
            let ne = (e + ae * dt).clamp(0.0, f64::from(f.max_speed));
            let nf = (fv + af * dt).max(0.0);
            g += 0.5 * (e + ne) * dt - 0.5 * (fv + nf) * dt;
            e = ne;
            fv = nf;
            clock = if off { 0.0 } else { clock + dt };
            least = least.min(g);
        }
        least as f32
    }

    fn draws() -> impl Strategy<Value = Vec<(f32, f32)>> {
        proptest::collection::vec((-1.0f32..1.0, 0.0f32..1.0), 40)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The clock mid-reaction or mid-build-up against brute force: the extremal pair's state
        /// `split` seconds into the braking, evaluated with the clock at `split`, gives the
        /// extremal's least gap from then on.
        #[test]
        fn the_clock_matches_brute_force_from_inside_the_reaction(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            bf in 3.0f32..9.0, jf in 5.0f32..30.0, split in 0.0f64..3.0,
        ) {
            let f = follower(rho, ar, bf, jf);
            let (state, least) = extremal_after(
                (f64::from(gap), f64::from(ve), f64::from(vf)), f64::from(b), &f, split,
            );
            let exact = rear_gap_after(
                state.0 as f32, state.1 as f32, state.2 as f32, b, split as f32, &f,
            );
            prop_assert!(
                (f64::from(exact) - least).abs() < 0.01 * (1.0 + least.abs() * 1e-3),
                "{} vs {} at {:?}", exact, least, state
            );
        }

        /// More time braking never lowers the value.
        #[test]
        fn the_value_never_falls_as_the_clock_runs(
            gap in 0.0f32..120.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.0f32..2.0, t in 0.0f32..3.0, dt in 0.0f32..1.0,
        ) {
            let f = follower(rho, 0.5, 7.59, 12.65);
            let early = rear_gap_after(gap, ve, vf, b, t, &f);
            let late = rear_gap_after(gap, ve, vf, b, t + dt, &f);
            prop_assert!(late >= early - 1e-3 * (1.0 + early.abs()), "{} then {}", early, late);
        }

        /// The invariance (module docs): along every admissible episode of a braking that
        /// lasts, the value with the clock never falls below its start by more than rounding,
        /// and the gap never falls below it.
        #[test]
        fn never_decreases_along_an_admissible_braking(
            gap in 0.0f32..80.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.0f32..2.0, ar in -1.0f32..2.0,
            draws in draws(),
        ) {
            let f = follower(rho, ar, 7.59, 12.65);
            let start = rear_gap_after(gap, ve, vf, b, 0.0, &f);
            let tolerance = 2e-3 * (1.0 + start.abs());
            let mut visited = Vec::new();
            let least = admissible_episode((gap, ve, vf), b, &f, &draws, |_| false, 8.0,
                |_, (g, e, v), clock| visited.push((g, rear_gap_after(g, e, v, b, clock, &f))));
            let low = visited.iter().map(|p| p.1).fold(f32::INFINITY, f32::min);
            prop_assert!(low >= start - tolerance, "{} after {}", low, start);
            prop_assert!(least >= start - tolerance, "gap {} below {}", least, start);
            // And each value bounds the gaps after it (the clock gives no more credit than the
            // follower's reaction has earned).
            let mut after = f32::INFINITY;
            for &(g, value) in visited.iter().rev() {
                after = after.min(g);
                prop_assert!(after >= value - 2e-3 * (1.0 + value.abs()) - 0.02, "gap {} below {}", after, value);
            }
        }

        /// A release restarts the clock: after a release in which the follower accelerated at
        /// its bound, the fresh clock still bounds the rest of the episode's gap from below
        /// (a clock carried across the release would not; see the next test).
        #[test]
        fn a_release_restarts_the_clock(
            gap in 0.0f32..80.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0,
            b in 0.5f32..10.0, rho in 0.3f32..2.0,
            release in 0.2f32..3.0, length in 0.1f32..2.0,
            draws in draws(),
        ) {
            let f = follower(rho, 1.0, 7.59, 12.65);
            let again = release + length;
            let mut fresh = None;
            let mut after = f32::INFINITY;
            admissible_episode((gap, ve, vf), b, &f, &draws,
                |t| t >= release && t < again, 10.0,
                |t, (g, e, v), clock| {
                    if t >= again {
                        if fresh.is_none() {
                            fresh = Some(rear_gap_after(g, e, v, b, clock, &f));
                        }
                        after = after.min(g);
                    }
                });
            if let Some(fresh) = fresh {
                prop_assert!(after >= fresh - 2e-3 * (1.0 + fresh.abs()), "gap {} below {}", after, fresh);
            }
        }
    }

    /// Why the clock must restart: carried across a release, it credits the follower with a
    /// reaction to a braking it no longer sees. Both at 30 m/s, 20 m apart; the ego brakes at
    /// 6 m/s^2 for 1.5 s, releases for 2 s, then brakes again. A follower that accelerates at
    /// +1 m/s^2 while the ego does not brake, and reacts 1.15 s after the second braking,
    /// comes closer than the value with the old clock (3.5 s) promises; the fresh clock's value
    /// is below what it does.
    #[test]
    fn a_clock_carried_across_a_release_is_unsound() {
        let f = follower(1.15, 1.0, 7.59, 12.65);
        let b = 6.0;
        let (release, again) = (1.5f32, 3.5f32);
        let mut at_again = None;
        let mut after = f32::INFINITY;
        // The ego brakes at `b` while braking (draw -1) and holds its speed while released
        // (draw 0 is no acceleration); the follower at its bound (draw 0).
        let draws = [(-1.0f32, 0.0f32)];
        admissible_episode(
            (120.0, 30.0, 30.0),
            b,
            &f,
            &draws,
            |t| t >= release && t < again,
            12.0,
            |t, state, clock| {
                if t >= again {
                    at_again.get_or_insert((state, clock));
                    after = after.min(state.0);
                }
            },
        );
        let ((g, e, v), clock) = at_again.unwrap();
        assert!(clock < 0.011, "{clock}");
        let carried = rear_gap_after(g, e, v, b, again, &f);
        let fresh = rear_gap_after(g, e, v, b, clock, &f);
        assert!(after > 0.0, "{after}");
        assert!(carried > after + 1.0, "carried {carried}, gap {after}");
        assert!(fresh <= after + 0.05, "fresh {fresh}, gap {after}");
    }

    /// The actual acceleration by brute force (f64, 0.1 ms steps) of a dead time `d` and a
    /// first-order lag `tau` from `a0`, with the commands in the dead time `pipeline(t)` and
    /// after it `ramp(t)` (both at `t` seconds from now, before the dead time): the samples
    /// `(t, A(t))` every step until `until`. Each step is cut at the dead time's end and at the
    /// times in `kinks` (where the commands jump or bend), and the lag's response to a command
    /// taken linear over each piece is exact: exact along the ramp. (A command held at its
    /// midpoint value over whole steps put the last zero 0.2-0.5 ms late where the
    /// acceleration crosses it slowly near its peak, a false alarm once in about 20,000 cases.)
    fn actuator(
        d: f64,
        tau: f64,
        a0: f64,
        pipeline: impl Fn(f64) -> f64,
        ramp: impl Fn(f64) -> f64,
        until: f64,
        kinks: &[f64],
    ) -> Vec<(f64, f64)> {
        let dt = 1e-4;
        let command = |t: f64| if t < d { pipeline(t) } else { ramp(t - d) };
        // Just inside a piece's ends: the command's values there from within the piece (a
        // jump at a cut belongs to the piece after it).
        let inside = 1e-12;
        let mut cuts: Vec<f64> = core::iter::once(d).chain(kinks.iter().copied()).collect();
        cuts.sort_by(f64::total_cmp);
        let (mut a, mut t) = (a0, 0.0);
        let mut out = vec![(0.0, a0)];
        let mut next = 0;
        while t < until {
            let end = t + dt;
            while next < cuts.len() && cuts[next] <= t {
                next += 1;
            }
            let inner = cuts[next..].iter().copied().take_while(|&c| c < end);
            let mut from = t;
            for to in inner.chain(core::iter::once(end)) {
                // (A cut within a nanosecond of the last one makes no piece: a slope over it
                // would be all rounding.)
                if to - from < 1e-9 {
                    continue;
                }
                let (c0, c1) = (command(from + inside), command(to - inside));
                a = if tau > 0.0 {
                    let m = (c1 - c0) / (to - from);
                    c1 - m * tau + (a - c0 + m * tau) * (-(to - from) / tau).exp()
                } else {
                    c1
                };
                from = to;
            }
            t = end;
            out.push((t, a));
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        /// The bound against the actuator by brute force: with every bound taken with
        /// equality, the acceleration is below zero from the bound on and reaches zero within
        /// 2 ms before it (tight); with commands drawn below the bounds, below zero from the
        /// bound on.
        #[test]
        fn the_lights_come_on_within_the_bound(
            d in 0.0f32..0.2, tau in prop_oneof![Just(0.0f32), 0.0f32..0.5], a0 in -6.0f32..3.0,
            p in -6.0f32..3.0,
            r in -8.0f32..3.0, j in 1.0f32..30.0, at_once in proptest::bool::ANY,
            level in 2.0f32..9.0,
            threshold in prop_oneof![Just(0.0f32), 0.0f32..1.8],
            below in proptest::collection::vec(0.0f64..1.0, 100),
        ) {
            let a0 = a0.max(-level);
            let p = p.max(-level);
            let jerk = if at_once { f32::INFINITY } else { j };
            let bound = lights_on_within(d, tau, a0, p, r, jerk, level, threshold);
            // Compared with `-threshold` below: `A + threshold` against zero.
            let th = f64::from(threshold);
            prop_assert!(bound.is_finite() && bound >= 0.0, "{}", bound);
            let ramp = |s: f64| {
                let c = if at_once { -f64::from(level) } else { f64::from(r) - f64::from(j) * s };
                c.max(-f64::from(level))
            };
            let until = f64::from(bound) + 3.0;
            // The ramp meets the level `(r + level) / j` after the dead time.
            let at_level = if at_once {
                0.0
            } else {
                (f64::from(r).max(-f64::from(level)) + f64::from(level)) / f64::from(j)
            };
            let kinks = [f64::from(d) + at_level];
            let exact = actuator(
                f64::from(d), f64::from(tau), f64::from(a0), |_| f64::from(p), ramp, until, &kinks,
            );
            let t_bound = f64::from(bound);
            for &(t, a) in &exact {
                if t >= t_bound + 2e-4 {
                    prop_assert!(a + th < 1e-5, "A({}) = {} after the bound {}", t, a, bound);
                }
            }
            // Tight: within the 2 ms up to the bound, `A` reaches zero (less the sampling's
            // 0.1 ms; at a ramp that starts at zero after a braking dead time it touches zero
            // for an instant only).
            if t_bound > 3e-3 {
                let near = exact
                    .iter()
                    .filter(|x| x.0 >= t_bound - 2e-3 && x.0 <= t_bound + 2e-4)
                    .map(|x| x.1 + th)
                    .fold(f64::NEG_INFINITY, f64::max);
                prop_assert!(near > -0.05, "A before the bound {} is at most {}", bound, near);
            }
            // Commands below the bounds, drawn per 10 ms.
            let draw = |t: f64| below[((t / 0.01) as usize) % below.len()];
            // The draws jump every 10 ms: in the dead time at multiples of 10 ms, after it where
            // `s + 0.5` is one.
            let steps = (until / 0.01) as usize + 2;
            let lower_kinks: Vec<f64> = (0..steps)
                .map(|k| k as f64 * 0.01)
                .chain((50..50 + steps).map(|m| f64::from(d) + m as f64 * 0.01 - 0.5))
                .chain(kinks)
                .collect();
            let lower = actuator(
                f64::from(d), f64::from(tau), f64::from(a0) - 0.5 * draw(0.0),
                |t| f64::from(p) - 2.0 * draw(t),
                |s| (ramp(s) - 2.0 * draw(s + 0.5)).max(-f64::from(level)),
                until,
                &lower_kinks,
            );
            for &(t, a) in &lower {
                if t >= t_bound + 2e-4 {
                    prop_assert!(
                        a + th < 1e-5,
                        "A({}) = {} after the bound {} (below)",
                        t,
                        a,
                        bound
                    );
                }
            }
        }
    }

    /// Found by CI's draw: no lag, a braking already in the dead time, and a ramp that starts
    /// at zero. The acceleration touches zero for an instant where the dead time ends, and the
    /// bound is that instant.
    #[test]
    fn a_ramp_from_zero_after_a_braking_dead_time_touches_zero_at_its_start() {
        let bound = lights_on_within(0.068_203_33, 0.0, 0.0, -5.287_426_5, 0.0, 1.0, 2.0, 0.0);
        assert!((bound - 0.068_203_33).abs() < 1e-6, "{bound}");
    }

    /// Lights that need a deceleration beyond the commands' level never come on for sure, and
    /// a threshold that is not one gives no credit; at the threshold's level less a little,
    /// the time is the lag's to cover all but that little: `tau ln(level / (level - threshold))`.
    #[test]
    fn the_lights_threshold_shifts_the_crossing() {
        assert_eq!(
            lights_on_within(0.1, 0.3, 0.0, 0.0, 0.0, 12.0, 1.3, 1.3),
            f32::INFINITY
        );
        assert_eq!(
            lights_on_within(0.1, 0.3, 0.0, 0.0, 0.0, 12.0, 1.0, 1.3),
            f32::INFINITY
        );
        assert_eq!(
            lights_on_within(0.1, 0.3, 0.0, 0.0, 0.0, 12.0, 8.0, -0.1),
            f32::INFINITY
        );
        assert_eq!(
            lights_on_within(0.1, 0.3, 0.0, 0.0, 0.0, 12.0, 8.0, f32::NAN),
            f32::INFINITY
        );
        // A step to -1.5 from rest, no dead time: `0.3 ln(1.5 / 0.2)` = 0.6045 s to -1.3,
        // against an instant to zero.
        let at = lights_on_within(0.0, 0.3, 0.0, 0.0, -1.5, f32::INFINITY, 1.5, 1.3);
        assert!((at - 0.3 * (1.5f32 / 0.2).ln()).abs() < 1e-4, "{at}");
        assert!(lights_on_within(0.0, 0.3, 0.0, 0.0, -1.5, f32::INFINITY, 1.5, 0.0) < 1e-6);
    }

    /// The careful driver (1.15 s, 7.59 m/s^2 over 0.6 s): its speed held through the reaction,
    /// half its braking 0.3 s into the build-up, all of it from 0.6 s on; the firmware's
    /// follower (the IDM's 1 m/s^2, 6 m/s^2 at once) at its level the instant it reacts.
    #[test]
    fn the_followers_largest_acceleration_worked_out_by_hand() {
        let careful = ReactingFollower::careful_driver(35.0);
        for t in [-1.0, 0.0, 0.5, 1.149, f32::NAN] {
            assert_eq!(careful.most_acceleration(t), 0.0, "at {t}");
        }
        let half = careful.most_acceleration(1.15 + 0.3);
        assert!((half + 0.5 * 0.774 * 9.81).abs() < 1e-3, "{half}");
        let built = careful.most_acceleration(1.75);
        assert!((built + 0.774 * 9.81).abs() < 1e-5, "{built}");
        for t in [2.0, 100.0, f32::INFINITY] {
            assert_eq!(careful.most_acceleration(t), -0.774 * 9.81, "at {t}");
        }
        let firmwares = ReactingFollower {
            reaction_time: 1.15,
            reaction_acceleration: 1.0,
            braking: 6.0,
            jerk: f32::INFINITY,
            max_speed: 35.0,
        };
        assert_eq!(firmwares.most_acceleration(1.1499), 1.0);
        assert_eq!(firmwares.most_acceleration(1.15), -6.0);
        assert_eq!(firmwares.most_acceleration(3.0), -6.0);
    }

    /// A follower at the IDM's closest time gap (1 s: 30 m + 2 m at 30 m/s), both at 30 m/s.
    /// By hand: the follower gains on the ego until it stops, so the smallest gap is at the end,
    /// `32 + 900 / (2 b) - d_f`, with `d_f` the follower's distance to standstill.
    /// - Holding its speed 1.15 s, then braking at 6 m/s^2 at once: `d_f = 34.5 + 75 = 109.5` m,
    ///   so `b < 450 / 77.5 = 5.806` m/s^2.
    /// - R157's careful driver (then 7.59 m/s^2 reached over 0.6 s): `d_f = 34.5 + 17.545 +
    ///   27.723^2 / 15.18 = 102.67` m, so `b < 450 / 70.67 = 6.368` m/s^2.
    ///
    /// Either is far below a car's 8 m/s^2.
    #[test]
    fn a_follower_one_second_behind_allows_the_braking_worked_out_by_hand() {
        let at_once = follower(1.15, 0.0, 6.0, f32::INFINITY);
        let b = allowed_braking(32.0, 30.0, 30.0, &at_once, 0.0, 12.0).unwrap();
        assert!((b - 5.806).abs() < 0.005, "{b}");
        let careful = ReactingFollower::careful_driver(35.0);
        let b = allowed_braking(32.0, 30.0, 30.0, &careful, 0.0, 12.0).unwrap();
        assert!((b - 6.368).abs() < 0.005, "{b}");
        // An instant follower (the paper's IDM at its clip) allows the whole band 0.1 m behind;
        // one that reacts after 1.15 s allows only what loses less than 0.1 m: `b 1.15^2 / 2`
        // in the reaction, then `(1.15 b)^2 / (2 (6 - b))` until the speeds are equal, so
        // `b = 0.1472`.
        let instant = follower(0.0, 0.0, 6.0, f32::INFINITY);
        assert_eq!(
            allowed_braking(0.1, 30.0, 30.0, &instant, 0.0, 6.0),
            Some(6.0)
        );
        let b = allowed_braking(0.1, 30.0, 30.0, &at_once, 0.0, 12.0).unwrap();
        assert!((b - 0.1472).abs() < 0.0005, "{b}");
        // A faster follower that reacts late is hit even by an ego holding its speed.
        assert_eq!(allowed_braking(1.0, 20.0, 25.0, &at_once, 0.0, 12.0), None);
    }

    /// A move-off by brute force (f64, 0.1 ms steps): the least gap over the whole run from
    /// `gap` behind an ego at `ego_speed`, its actuator a dead time `dead` and a lag `tau`
    /// from the acceleration `a_0`, its commands in force `early(t)` before the dead time's
    /// end, `committed(t)` until `until` and `late(t)` after; the follower at `follower(t,
    /// since)` (`since`: seconds since `until`, negative before it). For `run_for` seconds, then
    /// until the follower stops where `to_standstill` says so.
    #[allow(clippy::too_many_arguments)]
    fn moved_off(
        (gap, ego_speed, follower_speed): (f64, f64, f64),
        (dead, tau, a_0): (f64, f64, f64),
        until: f64,
        early: impl Fn(f64) -> f64,
        committed: impl Fn(f64) -> f64,
        late: impl Fn(f64) -> f64,
        follower: impl Fn(f64, f64) -> f64,
        (run_for, to_standstill): (f64, bool),
    ) -> f64 {
        let dt = 1e-4;
        let (mut g, mut ve, mut vf, mut a, mut t) = (gap, ego_speed, follower_speed, a_0, 0.0);
        let mut least = g;
        while t < run_for - 0.5 * dt || (to_standstill && vf > 0.0) {
            let mid = t + 0.5 * dt;
            let u = if mid < dead {
                early(mid)
            } else if mid < until {
                committed(mid)
            } else {
                late(mid)
            };
            let next_a = if tau > 0.0 {
                u + (a - u) * (-dt / tau).exp()
            } else {
                u
            };
            let ae = 0.5 * (a + next_a);
            a = next_a;
            let af = follower(mid, mid - until);
            crate::brute::advance(&mut g, &mut ve, &mut vf, (ae, af), dt);
            t += dt;
            least = least.min(g);
            if t > 120.0 {
                break;
            }
        }
        least
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Every admissible move-off keeps at least [`rear_gap_moving_off`]'s gap: an actuator
        /// no slower than the one declared (its dead time and lag drawn below theirs), starting
        /// at or above `from`, commands at or above the bounds (`from` in the dead time, the
        /// commitment until `until`, `-level` after), an ego that may be moving, and a follower
        /// that accelerates at most at its `reaction_acceleration` until its reaction after
        /// `until` has run, then at most along its build-up.
        #[test]
        fn a_move_off_keeps_the_gap_its_closed_form_bounds(
            gap in 0.3f32..8.0, vf in 0.0f32..4.0, from in -3.0f32..0.5,
            delay in 0.0f32..0.5, c in 0.3f32..3.0, window in 0.0f32..4.0,
            lag in prop_oneof![Just(0.0f32), 0.0f32..0.5], level in 1.0f32..8.0,
            rho in 0.0f32..2.0, ar in 0.0f32..2.0, bf in 4.0f32..8.0,
            jf in prop_oneof![Just(f32::INFINITY), 5.0f32..30.0],
            ve in prop_oneof![Just(0.0f32), 0.0f32..1.0],
            slower in prop_oneof![Just(1.0f64), 0.0f64..1.0],
            draws in proptest::collection::vec(0.0f64..1.0, 64),
        ) {
            let f = follower(rho, ar, bf, jf);
            let m = MoveOff { from, delay, commitment: c, until: delay + window, lag };
            let bound = rear_gap_moving_off(gap, vf, &m, level, &f);
            prop_assert!(!bound.is_nan());
            let draw = |t: f64| draws[((t / 0.05) as usize) % draws.len()];
            // Mostly at the bound, now and then above it.
            let above = |t: f64| draw(t).powi(4);
            let (from, c, level) = (f64::from(from), f64::from(c), f64::from(level));
            let (rho, ar, bf, jf) = (f64::from(rho), f64::from(ar), f64::from(bf), f64::from(jf));
            let until = f64::from(m.until);
            let least = moved_off(
                (f64::from(gap), f64::from(ve), f64::from(vf)),
                (f64::from(delay) * slower, f64::from(lag) * slower, from + above(0.0)),
                until,
                |t| from + 2.0 * above(t),
                |t| c + above(t),
                |t| -level + 2.0 * above(t),
                |t, since| {
                    let most = if since < rho {
                        ar
                    } else {
                        (ar - jf * (since - rho)).max(-bf)
                    };
                    most - 3.0 * above(t + 0.025)
                },
                (until + rho + 1.0, true),
            );
            prop_assert!(
                least >= f64::from(bound) - 2e-3,
                "brute force {} below the bound {}", least, bound
            );
        }

        /// The bound is tight where everything is at its bound and the ego brakes at once
        /// (no lag): the extremal move-off by brute force comes within 1 cm of it.
        #[test]
        fn the_extremal_move_off_meets_its_closed_form(
            gap in 0.3f32..8.0, vf in 0.0f32..4.0, from in -3.0f32..0.0,
            delay in 0.0f32..0.5, c in 0.3f32..3.0, window in 0.0f32..4.0, level in 1.0f32..8.0,
            rho in 0.0f32..2.0, ar in 0.0f32..2.0, bf in 4.0f32..8.0,
        ) {
            let f = follower(rho, ar, bf, f32::INFINITY);
            let m = MoveOff { from, delay, commitment: c, until: delay + window, lag: 0.0 };
            let bound = f64::from(rear_gap_moving_off(gap, vf, &m, level, &f));
            let (from, c, level) = (f64::from(from), f64::from(c), f64::from(level));
            let (rho, ar, bf) = (f64::from(rho), f64::from(ar), f64::from(bf));
            let until = f64::from(m.until);
            let least = moved_off(
                (f64::from(gap), 0.0, f64::from(vf)),
                (f64::from(delay), 0.0, from),
                until,
                |_| from,
                |_| c,
                |_| -level,
                |_, since| if since < rho { ar } else { -bf },
                (until + rho + 1.0, true),
            );
            prop_assert!((least - bound).abs() < 1e-2, "brute force {} against {}", least, bound);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Within the move-off the bound is tight with a lag too: the extremal pair (the
        /// actuator at its declared dead time and lag from `from`, the commitment held, the
        /// follower at its climb) by brute force to the commitment's end comes within 2 mm of
        /// the least travel difference.
        #[test]
        fn the_extremal_move_off_meets_its_least_within(
            vf in 0.0f32..4.0, from in -3.0f32..0.0, delay in 0.0f32..0.5, c in 0.3f32..3.0,
            window in 0.0f32..4.0, lag in 0.0f32..0.5, ar in 0.0f32..2.0,
        ) {
            let m = MoveOff { from, delay, commitment: c, until: delay + window, lag };
            let bound = f64::from(least_within_move_off(vf, &m, ar, 35.0));
            let (from, c) = (f64::from(from), f64::from(c));
            let until = f64::from(m.until);
            // Run to the end only.
            let least = moved_off(
                (0.0, 0.0, f64::from(vf)),
                (f64::from(delay), f64::from(lag), from),
                until,
                |_| from,
                |_| c,
                |_| 0.0,
                |_, _| f64::from(ar),
                (until, false),
            );
            prop_assert!(
                (least - bound).abs() < 2e-3,
                "brute force {} against {}", least, bound
            );
        }
    }

    /// Worked by hand: from rest 2 m ahead of a stopped follower that accelerates at 1 m/s^2,
    /// the ego's acceleration at 2 m/s^2 from 0.5 s (no lag): the ego's speed catches the
    /// follower's at `t = 2 (t - 0.5)`, 1 s, where the follower is 0.5 m on and the ego 0.25 m:
    /// 1.75 m. At the commitment's end, 3 s, the ego is at 6.25 m and 5 m/s, the follower at
    /// 4.5 m and 3 m/s: 3.75 m apart, and an ego that then brakes at 1 m/s^2 with the follower
    /// braking at 6 m/s^2 after 1 s keeps the gap from falling below `3.75 + 5 + 12.5 - (3 +
    /// 0.5 + 3 + 16 / 12) = 13.417` m (the ego stops last).
    #[test]
    fn a_move_off_worked_out_by_hand() {
        let f = follower(1.0, 1.0, 6.0, f32::INFINITY);
        let m = MoveOff {
            from: -1.0,
            delay: 0.5,
            commitment: 2.0,
            until: 3.0,
            lag: 0.0,
        };
        assert!((rear_gap_moving_off(2.0, 0.0, &m, 1.0, &f) - 1.75).abs() < 1e-4);
        // Braking at 8 m/s^2 after it: the least gap is where the speeds meet, after the
        // ego's braking; `rear_gap` has it from 3.75 m, 5 and 3 m/s.
        let after = rear_gap(3.75, 5.0, 3.0, 8.0, &f);
        assert!(after < 1.75);
        assert!((rear_gap_moving_off(2.0, 0.0, &m, 8.0, &f) - after).abs() < 1e-4);
        // Not a move-off: no commitment, a NaN.
        let none = MoveOff {
            commitment: 0.0,
            ..m
        };
        assert_eq!(
            rear_gap_moving_off(2.0, 0.0, &none, 1.0, &f),
            f32::NEG_INFINITY
        );
        assert!(rear_gap_moving_off(f32::NAN, 0.0, &m, 1.0, &f).is_nan());
    }
}
