//! Two braking authorities and a follower that reacts like a person: the split certificate's
//! rule for moving between them, and why it keeps a certified state certified.
//!
//! # Why
//! A certificate that lets the ego brake only at the comfort band's `beta` (ISO 15622's
//! 3.5 m/s^2) must keep room for a leader that may brake harder: 97 m at 30 m/s against a
//! 6 m/s^2 leader. A car can brake at 8 m/s^2 on a dry road, but braking harder than the car
//! behind can follow is how automated cars get hit. So the ego gets two authorities, a comfort
//! one and an emergency one (the vehicle's full braking and its build-up), and every braking
//! it may do is checked against both neighbours: the leader ([`crate::front`]) and a follower
//! that sees the brake lights only after its reaction time ([`crate::rear`]).
//!
//! # The model (exact states; delays and measurement error are the caller's)
//! - The leader brakes at most at `leader_braking` and keeps its speed in `[0, max_speed]`.
//! - The follower is a [`ReactingFollower`]: while the ego's brake lights are off, and for
//!   `reaction_time` after they come on, its acceleration is at most `reaction_acceleration`;
//!   from then on, while the lights stay on, at most its build-up towards `-braking`. The
//!   lights are on for sure while the ego's acceleration is below `-lights_deceleration` (UN
//!   R13-H's 1.3 m/s^2 by default: [`crate::EmergencyDeclaration::lights_deceleration`]), and
//!   at standstill after a braking; an ego that starts a braking ramp from above it lights
//!   them only where the ramp crosses it. Below, "crosses `-theta`" is that crossing.
//! - The ego's acceleration is what it is commanded (an ideal actuator: the caller argues a
//!   real one, as the firmware does for the front, through a hold, and for the lights through
//!   [`crate::rear::lights_on_within`]).
//!
//! # The certificate and the rule
//! A braking `A` (a [`Braking`]: a level and a build-up) **certifies** a state for an ego
//! whose acceleration is `a` and whose lights have been on for `clock` seconds (zero when they
//! are off), `C(A, clock)`, when both halves clear their margins with the ego braking from `a`
//! along `A`'s ramp: the front value ([`front_value`]: the ramp from `a` at `A`'s jerk to `A`'s
//! level) and the rear value ([`rear_gap_after`] at `A`'s level with the follower's reaction
//! `clock` under way, or, with the lights still off, starting where the ramp crosses `-theta`,
//! `max(a + theta, 0) / jerk` from now). The brakings are the comfort authority and the emergency
//! authority's build-up at any level from [`LEAST_LEVEL`] to its own: the front value grows
//! with the level and the rear value falls, so the level that certifies most is the hardest
//! the follower allows ([`TwoAuthorities::allowed_level`]). A close follower leaves a lower
//! level, and the front then needs more room: the authority the follower leaves.
//!
//! A command `u` **passes the look-ahead** at a level `b` when the rear value at `b` keeps the
//! rear above its margin (with the follower's reaction `clock` under way for a braking command
//! `u < -theta`, which keeps the lights on or turns them on, `b` at least `-u`; with it
//! starting `h + (u + theta) / jerk` from now for any other: the lights may go off, and come
//! on for sure only where the ramp from `u` crosses `-theta`), and `u` held for a period `h`, then
//! the emergency authority's ramp from `u` to `b`, keeps the front above its margin. The level is
//! the hardest the follower allows so ([`TwoAuthorities::look_ahead`]), and a passed look-ahead
//! names it: the braking the next state is certified with. [`TwoAuthorities::decide`] takes, in
//! this order:
//! - the law's proposal, if it passes the look-ahead;
//! - a braking between the comfort level and the proposal that passes it, close to the
//!   gentlest (a comfort response where comfort suffices);
//! - a braking under the braking in force: the one the last passed look-ahead named, or the
//!   one under way.
//!
//! No separate step to the comfort authority is needed: where it certifies, the comfort
//! level held for a period passes the look-ahead (its front is no worse, braking at least as
//! hard, and its rear is the same at a level of at least 3.5 m/s^2), so the second step takes
//! a braking no harder than it.
//!
//! # Why a certified state stays certified
//! By induction over the periods, with `B` the braking in force: a state the rule reaches
//! from a state that `C(B, 0)` certifies ([`TwoAuthorities::certified_braking`]) is either
//! reached by a command that passed the look-ahead at a level `b` (and then `B` becomes
//! `b`'s braking) or braking under a braking that certified it (and `B` becomes it), and then:
//! - *after a passed look-ahead*, `C(b, clock)` holds a period on with the lights' clock then.
//!   The front: the look-ahead's value is the least front gap over every leader behaviour
//!   from now, the ego holding `u` and then ramping to `b`; the state a period on, ramping from
//!   `u` there, is one of the behaviours it took the minimum over. The rear: the ego brakes at
//!   most at `b` from now on (a held `u` at or above `-b` covers more distance); with the
//!   lights on, the clock's invariance (`table_format::rear`'s module docs) carries the value a
//!   period on; with them off, a follower that sees them only where the ramp crosses `-theta`
//!   has not reacted for `h + (u + theta) / jerk` plus its reaction from now, and the value a
//!   period on with the lights off is that same extremal seen from later, no lower. The level is
//!   fixed between the look-ahead and the next period: what the follower allows a period on may be
//!   less (it drew closer), but `b` is still certified there, and braking under it is what comes
//!   next if nothing passes;
//! - *braking under `B`*, `C(B, clock)` stays true along `B`'s ramp: the front value never
//!   decreases along the ego's own braking ([`crate::front`]), and the rear value with the
//!   clock never decreases while the lights stay on ([`crate::rear`]); a braking that starts
//!   is under `B`, which the last look-ahead certified.
//!
//! So a braking is kept until a lower one certifies, and the lights go off (a release, which
//! restarts the follower's reaction) only under a command that passed the look-ahead with the
//! reaction restarted. The property tests `a_certified_start_stays_certified_and_collision_free`
//! and `a_start_on_the_boundary_stays_certified_and_collision_free` run the rule in closed
//! loop (integrated in `f64`) against leaders within their model (braking as hard as they
//! may, and exactly when the decision changes) and followers at their model's bound, reacting
//! after 0 and 1.15 s, from random certified states and from the certified set's boundary
//! (the follower at the least gap any braking certifies, the leader at the least gap that
//! certifies with it there); run once with 30,000 cases each, green.

//! # What it does not claim
//! The follower's model credits its reaction to any braking with its whole `braking` once its
//! reaction time has passed: a driver who answers a gentle braking gently and is then
//! surprised by a harder one is outside it. The rule restarts nothing when the ego's braking
//! grows under one set of lights, so such a follower would need its reaction restarted at
//! every rise of the ego's braking level.

use core::cell::OnceCell;

use crate::front::{front_value, least_braking, FrontModel};
use crate::rear::{hardest_clearing, rear_gap_after, ReactingFollower};

/// A braking the certificate argues with: its level and how fast it builds up.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Braking {
    /// The braking level, m/s^2 (positive).
    pub level: f32,
    /// Its build-up, m/s^3 (positive; `f32::INFINITY`: at once).
    pub jerk: f32,
}

/// A car's full braking on a dry road: 8 m/s^2 (tyre-road friction about 0.8; ad-rss-lib's
/// parameter notes take 8 m/s^2 as the braking driving schools teach), built up at 12 m/s^3
/// (UN R157's careful driver reaches 0.774 g over 0.6 s, 12.65 m/s^3, rounded down). The
/// emergency authority's default, and the one the cut-in counterfactual is judged at.
pub const DRY_ROAD_EMERGENCY: Braking = Braking {
    level: 8.0,
    jerk: 12.0,
};

/// The state the rule decides on, exact, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// The gap to the leader, m.
    pub gap_leader: f32,
    /// The leader's speed, m/s.
    pub leader_speed: f32,
    /// The gap to the follower, m.
    pub gap_follower: f32,
    /// The follower's speed, m/s.
    pub follower_speed: f32,
    /// The ego's speed, m/s.
    pub ego_speed: f32,
    /// The ego's acceleration, m/s^2.
    pub ego_acceleration: f32,
}

/// The model of the two neighbours and the ego's two authorities (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoAuthorities {
    /// The leader's hardest braking, m/s^2 (positive).
    pub leader_braking: f32,
    /// The largest speed of any car, m/s.
    pub max_speed: f32,
    /// The comfort authority.
    pub comfort: Braking,
    /// The emergency authority: at least as hard and as fast as the comfort one.
    pub emergency: Braking,
    /// The follower.
    pub follower: ReactingFollower,
    /// The deceleration beyond which the ego's brake lights are on for sure, m/s^2 (at least
    /// zero; `theta` in the module docs).
    pub lights_deceleration: f32,
    /// The front value a certified state keeps, m.
    pub front_margin: f32,
    /// The rear value a certified state keeps, m.
    pub rear_margin: f32,
}

/// The gentlest braking level the rule certifies with, m/s^2: a gentler braking certifies no
/// gap worth following at (450 m at 30 m/s at 1 m/s^2), and the bound keeps the search for the
/// level the follower allows away from zero.
pub const LEAST_LEVEL: f32 = 1.0;

/// How close to the hardest level the follower allows [`TwoAuthorities::allowed_level`]
/// comes, m/s^2 (it never returns more).
pub const LEVEL_RESOLUTION: f32 = 0.02;

/// What the rule decided for one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    /// Drive by `command` (the law's proposal, or a braking down to the comfort level that
    /// passes the look-ahead), m/s^2: the command passed the look-ahead, and the state a period
    /// on is certified under `certified` (the emergency authority's build-up at the level the
    /// follower allowed).
    Drive {
        /// The command, m/s^2.
        command: f32,
        /// The braking the look-ahead certified the next state with.
        certified: Braking,
    },
    /// Brake along this braking's ramp from the ego's acceleration: the braking in force.
    Brake(Braking),
}

impl TwoAuthorities {
    /// How long a braking ramp at `jerk` from the acceleration `a` takes to light the brakes
    /// for sure (s): where it crosses `-lights_deceleration`, zero if it is below already.
    fn dark(&self, a: f32, jerk: f32) -> f32 {
        let above = a + self.lights_deceleration;
        if above > 0.0 {
            above / jerk
        } else {
            0.0
        }
    }

    /// Whether a command keeps the brake lights on for sure (or turns them on): one below
    /// `-lights_deceleration`.
    fn lights(&self, u: f32) -> bool {
        u < -self.lights_deceleration
    }

    /// The emergency authority's build-up at `level`.
    fn at_level(&self, level: f32) -> Braking {
        Braking {
            level,
            jerk: self.emergency.jerk,
        }
    }

    /// The front value (m) of an ego that holds `hold` for `response` seconds, then ramps from
    /// `ramp_from` along `braking`.
    fn front(&self, s: &State, braking: Braking, response: f32, hold: f32, ramp_from: f32) -> f32 {
        front_value(
            s.gap_leader,
            s.leader_speed,
            s.ego_speed,
            &FrontModel {
                leader_braking: self.leader_braking,
                ego_braking: braking.level,
                response_time: response,
                response_acceleration: hold,
                ramp_from,
                jerk: braking.jerk,
                max_speed: self.max_speed,
            },
        )
    }

    /// The rear value (m) of an ego braking at most at `level` from now whose lights come on
    /// `dark` seconds from now (zero: they are on, or come on at once), and have been on for
    /// `clock` seconds (zero unless `dark` is): the follower's reaction is taken `dark` longer.
    fn rear(&self, s: &State, level: f32, clock: f32, dark: f32) -> f32 {
        let follower = ReactingFollower {
            reaction_time: self.follower.reaction_time + dark.max(0.0),
            ..self.follower
        };
        rear_gap_after(
            s.gap_follower,
            s.ego_speed,
            s.follower_speed,
            level,
            clock,
            &follower,
        )
    }

    /// The hardest level in `[least, emergency.level]` (`least` at least a resolution above
    /// the lights' deceleration, which a gentler braking need not cross) at which the rear value
    /// (the lights on for `clock` seconds, the follower's reaction taken `dark` longer) clears the
    /// rear margin, m/s^2, to within [`LEVEL_RESOLUTION`]: the braking the follower allows
    /// ([`crate::rear::hardest_clearing`]). The emergency level if it clears; `None` where not even
    /// `least` does (or NaN). Every level returned clears.
    pub fn allowed_level(&self, s: &State, clock: f32, dark: f32, least: f32) -> Option<f32> {
        let margin = self.rear_margin;
        let slack = |level: f32| self.rear(s, level, clock, dark) - margin;
        // A braking no harder than the lights' deceleration need not light the brakes, and
        // the rear value counts the follower's reaction from the lights.
        let least = least.max(self.lights_deceleration + LEVEL_RESOLUTION);
        hardest_clearing(slack, least, self.emergency.level, LEVEL_RESOLUTION)
    }

    /// The certificate's two halves (m, each less its margin) for braking along `braking`'s
    /// ramp from the ego's acceleration, the lights on for `clock` seconds (module docs). An
    /// ego above `-lights_deceleration` lights its brakes for sure only where its ramp crosses
    /// it, `(a + lights_deceleration) / jerk` from now: the follower's reaction starts there.
    pub fn margins(&self, s: &State, braking: Braking, clock: f32) -> (f32, f32) {
        let a = s.ego_acceleration;
        let front = self.front(s, braking, 0.0, a, a);
        let dark = self.dark(a, braking.jerk);
        let rear = self.rear(s, braking.level, clock, dark);
        (front - self.front_margin, rear - self.rear_margin)
    }

    /// Whether `braking` certifies the state, the lights on for `clock` seconds.
    pub fn certifies(&self, s: &State, braking: Braking, clock: f32) -> bool {
        let (front, rear) = self.margins(s, braking, clock);
        front > 0.0 && rear > 0.0
    }

    /// The braking that certifies the state, if one does, the lights on for `clock` seconds:
    /// the comfort authority where it certifies, else the emergency authority's build-up at
    /// the hardest level the follower allows ([`TwoAuthorities::allowed_level`]) where its
    /// front clears. What an engagement is judged by, and what braking is in force at it.
    pub fn certified_braking(&self, s: &State, clock: f32) -> Option<Braking> {
        if self.certifies(s, self.comfort, clock) {
            return Some(self.comfort);
        }
        let a = s.ego_acceleration;
        let dark = self.dark(a, self.emergency.jerk);
        let level = self.allowed_level(s, clock, dark, LEAST_LEVEL.max(-a))?;
        let braking = self.at_level(level);
        self.certifies(s, braking, clock).then_some(braking)
    }

    /// The look-ahead of the command `u` held for `h` seconds (module docs), the lights on for
    /// `lights` seconds (zero: off): its margin (m, the front value less its margin, at the
    /// hardest level the follower allows with the rear margin kept) and the braking it
    /// certifies the next state with. A braking command below `-lights_deceleration` keeps the
    /// lights on (or turns them on), so the follower's reaction goes on, and the level is at
    /// least the command's; otherwise they come on for sure at the latest where the ramp from
    /// `u` crosses `-lights_deceleration` after the hold. `-inf` for a command below the emergency
    /// level, where the follower allows no level, or NaN (outside the model).
    pub fn look_ahead(&self, s: &State, u: f32, h: f32, lights: f32) -> (f32, Braking) {
        let braking_level = self
            .lights(u)
            .then(|| self.allowed_level(s, lights, 0.0, LEAST_LEVEL))
            .flatten();
        self.look_ahead_with(s, u, h, braking_level)
    }

    /// [`TwoAuthorities::look_ahead`] with the level the follower allows a braking command
    /// (the lights on for `lights` seconds, no level below [`LEAST_LEVEL`]) given: it depends
    /// on the command only through being at least as hard, so a decision finds it once for
    /// every braking it looks ahead for.
    fn look_ahead_with(
        &self,
        s: &State,
        u: f32,
        h: f32,
        braking_level: Option<f32>,
    ) -> (f32, Braking) {
        let e = self.emergency;
        let refused = (f32::NEG_INFINITY, e);
        // (A NaN command is not in the model: the comparison is false.)
        let in_model = u >= -e.level;
        if !in_model {
            return refused;
        }
        let allowed = if self.lights(u) {
            braking_level.filter(|level| *level >= -u)
        } else {
            self.allowed_level(s, 0.0, h + self.dark(u, e.jerk), LEAST_LEVEL)
        };
        let Some(level) = allowed else {
            return refused;
        };
        let braking = self.at_level(level);
        (self.front(s, braking, h, u, u) - self.front_margin, braking)
    }

    /// Whether the command `u` held for `h` seconds passes the look-ahead: its margin
    /// ([`TwoAuthorities::look_ahead`]) is above zero.
    pub fn passes(&self, s: &State, u: f32, h: f32, lights: f32) -> bool {
        self.look_ahead(s, u, h, lights).0 > 0.0
    }

    /// The rule (module docs): the law's `proposal` for a period `h` if it passes the
    /// look-ahead, else a braking between the comfort level and the proposal that passes it
    /// ([`least_braking`], the firmware override's secant, else the comfort level), else a
    /// braking under `in_force` (the one the last passed look-ahead named, or the one under
    /// way).
    /// `lights`: how long the ego's brake lights have been on, s (zero: off).
    pub fn decide(
        &self,
        s: &State,
        in_force: Braking,
        lights: f32,
        proposal: f32,
        h: f32,
    ) -> Decision {
        // The level the follower allows a braking, found once (when first needed) for every
        // braking looked at.
        let braking_level = OnceCell::new();
        let look = |u: f32| {
            let level = self
                .lights(u)
                .then(|| {
                    *braking_level.get_or_init(|| self.allowed_level(s, lights, 0.0, LEAST_LEVEL))
                })
                .flatten();
            self.look_ahead_with(s, u, h, level)
        };
        let (at_proposal, certified) = look(proposal);
        if at_proposal > 0.0 {
            return Decision::Drive {
                command: proposal,
                certified,
            };
        }
        let floor = -self.comfort.level;
        let (at_floor, at_floor_certified) = look(floor);
        if proposal > floor && at_floor > 0.0 {
            // The margin is non-increasing in the command over the band (a harder braking is
            // never behind a gentler one ahead, and is allowed the same level or more behind)
            // and nearly affine: the override's secant, else the comfort level, which passed.
            let passes = |u: f32| look(u).0 > 0.0;
            if let Some(u) = least_braking(proposal, at_proposal, floor, at_floor, 0.0, passes) {
                let (margin, certified) = look(u);
                if margin > 0.0 {
                    return Decision::Drive {
                        command: u,
                        certified,
                    };
                }
            }
            return Decision::Drive {
                command: floor,
                certified: at_floor_certified,
            };
        }
        Decision::Brake(in_force)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The model with a follower that reacts after `reaction_time`, accelerates at most at
    /// `reaction_acceleration` until then, and brakes at the IDM's clip (6 m/s^2) at once, or,
    /// when `careful`, at R157's careful driver's 7.59 m/s^2 reached over 0.6 s.
    fn with_follower(
        leader_braking: f32,
        reaction_time: f32,
        reaction_acceleration: f32,
        careful: bool,
    ) -> TwoAuthorities {
        let (braking, jerk) = if careful {
            (7.59, 12.65)
        } else {
            (6.0, f32::INFINITY)
        };
        TwoAuthorities {
            leader_braking,
            max_speed: 35.0,
            comfort: Braking {
                level: 3.5,
                jerk: 2.5,
            },
            emergency: DRY_ROAD_EMERGENCY,
            follower: ReactingFollower {
                reaction_time,
                reaction_acceleration,
                braking,
                jerk,
                max_speed: 35.0,
            },
            lights_deceleration: crate::R13H_LIGHTS_DECELERATION,
            front_margin: 0.5,
            rear_margin: 0.5,
        }
    }

    /// The closed loop's state in f64.
    struct Exact {
        gap_leader: f64,
        leader_speed: f64,
        gap_follower: f64,
        follower_speed: f64,
        ego_speed: f64,
    }

    /// One closed-loop episode with the rule, exact states (1 ms steps, a decision every
    /// 20 ms), from a state `start` certified with the lights off, under `in_force` (what
    /// [`TwoAuthorities::certified_braking`] gives). The leader: a new acceleration in
    /// `[-b_L, 2]` every second from `leader`, and, when `brake_on_switch`, its hardest
    /// braking (until it stops) from the first period at which the rule changes its decision
    /// (between driving and braking, or the level in force by half a m/s^2). The follower at its
    /// model's bound: its speed held while it has not reacted (or a braking of up to 1 m/s^2 where
    /// `follower` draws one), its braking at its level once it has. The law's proposal: a new draw
    /// in `[-3.5, 2]` every second from `law`, none above zero beyond 34 m/s. Returns the least
    /// gaps ahead and behind, the least of the certified margins over the periods (the braking in
    /// force's: the one under way, or the one the last passed look-ahead certified), and how many
    /// periods braked under the braking in force.
    #[allow(clippy::too_many_arguments)]
    fn episode(
        m: &TwoAuthorities,
        start: State,
        in_force: Braking,
        leader: &[f32],
        follower: &[f32],
        law: &[f32],
        brake_on_switch: bool,
        flicker: bool,
    ) -> (f32, f32, f32, usize) {
        let (dt, h) = (1e-3f32, 0.02f32);
        let per_period = 20usize;
        let mut s = start;
        let mut exact = Exact {
            gap_leader: f64::from(s.gap_leader),
            leader_speed: f64::from(s.leader_speed),
            gap_follower: f64::from(s.gap_follower),
            follower_speed: f64::from(s.follower_speed),
            ego_speed: f64::from(s.ego_speed),
        };
        let mut lights_for: Option<f32> = None;
        let mut in_force = in_force;
        let mut last: Option<(bool, i32)> = None;
        let mut leader_hard = false;
        let mut proposal = 0.0;
        let (mut least_front, mut least_rear, mut least_margin) =
            (f32::INFINITY, f32::INFINITY, f32::INFINITY);
        let mut periods = 0usize;
        for k in 0..3000usize {
            let t = k as f32 * h;
            let second = (t as usize) % leader.len();
            if k % 50 == 0 {
                proposal = 3.5 * law[second % law.len()] - 1.5;
                proposal = proposal.clamp(-3.5, 2.0);
            }
            // A flickering law brakes and releases in turn, every period, so that the lights
            // go on and off and the follower's reaction restarts again and again.
            let proposal = if flicker {
                let p = proposal.abs().max(0.2);
                if k % 2 == 0 {
                    p.min(2.0)
                } else {
                    -p.min(3.5)
                }
            } else {
                proposal
            };
            let u = if s.ego_speed > 34.0 {
                proposal.min(0.0)
            } else {
                proposal
            };
            let clock = lights_for.unwrap_or(0.0);
            // The margin the induction claims for this period.
            let (f, r) = m.margins(&s, in_force, clock);
            least_margin = least_margin.min(f.min(r));
            let decision = m.decide(&s, in_force, clock, u, h);
            let (braking, command) = match decision {
                Decision::Drive { command, certified } => {
                    in_force = certified;
                    (None, command)
                }
                Decision::Brake(b) => {
                    in_force = b;
                    (Some(b), 0.0)
                }
            };
            // The decision changes: driving or braking, or the level in force by half a m/s^2.
            let now = Some((braking.is_some(), (2.0 * in_force.level).round() as i32));
            if last.is_some() && now != last && brake_on_switch {
                leader_hard = true;
            }
            last = now;
            if braking.is_some() {
                periods += 1;
            }
            let al_drawn = if leader_hard {
                -m.leader_braking
            } else {
                let x = leader[second];
                if x < 0.0 {
                    x * m.leader_braking
                } else {
                    2.0 * x
                }
            };
            for _ in 0..per_period {
                // The ego: the law's command, or its authority's ramp from where it is.
                let ae = match braking {
                    None => command,
                    Some(b) => {
                        if s.ego_acceleration < -b.level {
                            -b.level
                        } else {
                            (s.ego_acceleration - b.jerk * dt).max(-b.level)
                        }
                    }
                };
                let stopped = s.ego_speed <= 0.0;
                let lights =
                    ae < -m.lights_deceleration || (stopped && ae <= 0.0 && braking.is_some());
                lights_for = if lights {
                    Some(lights_for.unwrap_or(0.0) + dt)
                } else {
                    None
                };
                let on = lights_for.unwrap_or(0.0);
                let f = &m.follower;
                let af = if lights && on >= f.reaction_time {
                    if f.jerk.is_finite() {
                        (f.reaction_acceleration - f.jerk * (on - f.reaction_time)).max(-f.braking)
                    } else {
                        -f.braking
                    }
                } else {
                    let x = follower[second % follower.len()];
                    f.reaction_acceleration - if x > 0.7 { x - 0.7 } else { 0.0 } / 0.3
                };
                // In f64: f32 sums of 1 ms steps drift by centimetres over a minute (the
                // speed's rounding at every step biases a gentle braking's distance).
                let dt = f64::from(dt);
                let step = |v: f64, a: f32| -> (f64, f64) {
                    let a = f64::from(a);
                    let nv = (v + a * dt).clamp(0.0, f64::from(m.max_speed));
                    let d = if v + a * dt < 0.0 {
                        v * v / (2.0 * -a)
                    } else {
                        0.5 * (v + nv) * dt
                    };
                    (nv, d)
                };
                let al = if exact.leader_speed <= 0.0 && al_drawn < 0.0 {
                    0.0
                } else {
                    al_drawn
                };
                let (nl, dl) = step(exact.leader_speed, al);
                let (ne, de) = step(exact.ego_speed, ae);
                let (nf, df) = step(exact.follower_speed, af);
                exact.gap_leader += dl - de;
                exact.gap_follower += de - df;
                exact.leader_speed = nl;
                exact.ego_speed = ne;
                exact.follower_speed = nf;
                s = State {
                    gap_leader: exact.gap_leader as f32,
                    leader_speed: nl as f32,
                    gap_follower: exact.gap_follower as f32,
                    follower_speed: nf as f32,
                    ego_speed: ne as f32,
                    ego_acceleration: ae,
                };
                least_front = least_front.min(s.gap_leader);
                least_rear = least_rear.min(s.gap_follower);
            }
        }
        (least_front, least_rear, least_margin, periods)
    }

    fn start() -> impl Strategy<Value = State> {
        (
            0.0f32..150.0,
            0.0f32..35.0,
            0.0f32..80.0,
            0.0f32..35.0,
            0.0f32..35.0,
        )
            .prop_map(|(gl, vl, gf, vf, ve)| State {
                gap_leader: gl,
                leader_speed: vl,
                gap_follower: gf,
                follower_speed: vf,
                ego_speed: ve,
                ego_acceleration: 0.0,
            })
    }

    /// The least gap that `set` makes certified with the lights off (bisection: the certified
    /// set grows with both gaps), to 1e-5 of 400 m. `None` where 400 m does not certify.
    fn least_certified(m: &TwoAuthorities, set: &dyn Fn(f32) -> State) -> Option<f32> {
        let certified = |s: &State| m.certified_braking(s, 0.0).is_some();
        let (mut lo, mut hi) = (0.0f32, 400.0f32);
        if !certified(&set(hi)) {
            return None;
        }
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if certified(&set(mid)) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(hi)
    }

    /// `s` on the boundary of the certified set with the lights off, within `slack` of it:
    /// the follower at `slack.1` beyond the least gap any braking certifies with the leader
    /// far, then the leader at `slack.0` beyond the least gap that certifies with the
    /// follower there. `None` where no gap certifies.
    fn on_the_boundary(m: &TwoAuthorities, s: State, slack: (f32, f32)) -> Option<State> {
        let rear = least_certified(m, &|g| State {
            gap_follower: g,
            gap_leader: 1e3,
            ..s
        })? + slack.1;
        let front = least_certified(m, &|g| State {
            gap_leader: g,
            gap_follower: rear,
            ..s
        })? + slack.0;
        Some(State {
            gap_leader: front,
            gap_follower: rear,
            ..s
        })
    }

    fn draws(n: usize) -> impl Strategy<Value = Vec<f32>> {
        proptest::collection::vec(-1.0f32..1.0, n)
    }

    /// Emergency braking only where it must: following at 30 m/s 10% beyond the least gap
    /// certified against a 9.8 m/s^2 leader, with a follower that reacts after 1.15 s 62 m
    /// behind (it allows the full 8 m/s^2; the least gap is 20.7 m) and 32 m behind (it allows
    /// 5.77 m/s^2, and the least gap is 39.7 m). A leader that brakes at 3.5 m/s^2 to standstill,
    /// with a law that brakes with it, passes the look-ahead throughout: no period of braking under
    /// either authority. A law that holds its speed a second longer gets a braking that passes:
    /// none either. A leader that brakes at 9.8 m/s^2 gets a braking beyond the comfort authority.
    /// None collides.
    #[test]
    fn a_comfortable_leader_gets_a_comfort_response_and_a_hard_one_the_emergency_authority() {
        let m = with_follower(9.8, 1.15, 0.0, false);
        let mut least_gaps = Vec::new();
        for gap_follower in [62.0, 32.0] {
            let cruise = State {
                gap_leader: 0.0,
                leader_speed: 30.0,
                gap_follower,
                follower_speed: 30.0,
                ego_speed: 30.0,
                ego_acceleration: 0.0,
            };
            let least = least_certified(&m, &|g| State {
                gap_leader: g,
                ..cruise
            })
            .unwrap();
            least_gaps.push(least);
            let s = State {
                gap_leader: 1.1 * least,
                ..cruise
            };
            let in_force = m.certified_braking(&s, 0.0).unwrap();
            if gap_follower > 60.0 {
                assert_eq!(in_force, m.emergency);
            } else {
                assert!(in_force.level > 3.5 && in_force.level < 7.5, "{in_force:?}");
            }
            // The law's draw `x` proposes `3.5 x - 1.5`: -3.5 m/s^2 at `x = -2 / 3.5`.
            let with_it = vec![-2.0 / 3.5; 60];
            let mut late = with_it.clone();
            late[0] = 1.5 / 3.5;
            let still = vec![0.0; 60];
            let gentle = vec![-3.5 / 9.8; 60];
            let hard = vec![-1.0; 60];
            for law in [&with_it, &late] {
                let (front, rear, margin, periods) =
                    episode(&m, s, in_force, &gentle, &still, law, false, false);
                assert!(
                    front > 0.0 && rear > 0.0 && margin > -0.02,
                    "{front} {rear} {margin}"
                );
                assert_eq!(periods, 0, "{gap_follower}");
            }
            let (front, rear, margin, periods) =
                episode(&m, s, in_force, &hard, &still, &with_it, false, false);
            assert!(
                front > 0.0 && rear > 0.0 && margin > -0.02,
                "{front} {rear} {margin}"
            );
            assert!(periods > 0, "{periods}");
        }
        assert!(least_gaps[1] > least_gaps[0] + 5.0, "{least_gaps:?}");
    }

    /// A proposal that is NaN or beyond the emergency level never drives: the rule brakes.
    #[test]
    fn a_proposal_outside_the_model_is_not_driven() {
        let m = with_follower(9.8, 1.15, 0.0, false);
        let s = State {
            gap_leader: 200.0,
            leader_speed: 20.0,
            gap_follower: 200.0,
            follower_speed: 20.0,
            ego_speed: 20.0,
            ego_acceleration: 0.0,
        };
        let e = m.emergency;
        assert_eq!(
            m.decide(&s, e, 0.0, 0.0, 0.02),
            Decision::Drive {
                command: 0.0,
                certified: e
            }
        );
        for u in [f32::NAN, -9.0, f32::NEG_INFINITY] {
            assert!(!m.passes(&s, u, 0.02, 0.0), "{u}");
            assert!(
                matches!(m.decide(&s, e, 0.0, u, 0.02), Decision::Brake(_)),
                "{u}"
            );
        }
    }

    /// The least rear gap by brute force (f64, 0.1 ms steps) for an ego ramping from its
    /// acceleration along `braking`, its lights on once its acceleration is below
    /// `-lights_deceleration`, and a
    /// follower at its model's bound: `reaction_acceleration` until `reaction_time` after the
    /// lights, then its braking.
    fn rear_by_integration(m: &TwoAuthorities, s: &State, braking: Braking) -> f64 {
        let dt = 1e-4f64;
        let f = &m.follower;
        let (mut g, mut ve, mut vf) = (
            f64::from(s.gap_follower),
            f64::from(s.ego_speed),
            f64::from(s.follower_speed),
        );
        let (mut a, mut lights, mut t) = (f64::from(s.ego_acceleration), None::<f64>, 0.0);
        let mut least = g;
        while t < 60.0 {
            a = (a - f64::from(braking.jerk) * dt).max(-f64::from(braking.level));
            if a < -f64::from(m.lights_deceleration) && lights.is_none() {
                lights = Some(t);
            }
            let af = match lights {
                Some(on) if t - on >= f64::from(f.reaction_time) => -f64::from(f.braking),
                _ => f64::from(f.reaction_acceleration),
            };
            let ne = (ve + a * dt).clamp(0.0, 35.0);
            let nf = (vf + af * dt).clamp(0.0, 35.0);
            g += 0.5 * (ve + ne) * dt - 0.5 * (vf + nf) * dt;
            ve = ne;
            vf = nf;
            t += dt;
            least = least.min(g);
            if ve <= 0.0 && vf <= 0.0 && lights.is_some() {
                break;
            }
        }
        least
    }

    /// The closed loop's claim for one episode: no collision, the certified margin held (less
    /// the 1 ms integration's error).
    fn holds(
        m: &TwoAuthorities,
        s: State,
        in_force: Braking,
        [leader, follower, law]: [&[f32]; 3],
        (brake_on_switch, flicker): (bool, bool),
    ) -> Result<(), TestCaseError> {
        let (front, rear, margin, _) = episode(
            m,
            s,
            in_force,
            leader,
            follower,
            law,
            brake_on_switch,
            flicker,
        );
        prop_assert!(front > 0.0 && rear > 0.0, "gaps {} and {}", front, rear);
        prop_assert!(margin > -0.02, "margin {}", margin);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 2000,
            max_global_rejects: 100_000,
            ..ProptestConfig::default()
        })]

        /// The module's claim, in closed loop: from a certified start, with leaders at 6 and
        /// 9.8 m/s^2 and followers reacting after 0 and 1.15 s (holding or gaining 1 m/s^2
        /// until then; braking at the IDM's clip at once, or as R157's careful driver), a law
        /// that flickers the lights or does not, no collision, and the induction's margin above
        /// zero (less the 1 ms integration's error) at every period.
        #[test]
        fn a_certified_start_stays_certified_and_collision_free(
            s in start(),
            hard in proptest::bool::ANY,
            late in proptest::bool::ANY,
            gaining in proptest::bool::ANY,
            careful in proptest::bool::ANY,
            brake_on_switch in proptest::bool::ANY,
            flicker in proptest::bool::ANY,
            leader in draws(60), follower in draws(60), law in draws(60),
        ) {
            let m = with_follower(
                if hard { 9.8 } else { 6.0 },
                if late { 1.15 } else { 0.0 },
                if gaining { 1.0 } else { 0.0 },
                careful,
            );
            let in_force = m.certified_braking(&s, 0.0);
            prop_assume!(in_force.is_some());
            holds(&m, s, in_force.unwrap(), [&leader, &follower, &law], (brake_on_switch, flicker))?;
        }

        /// The same from the certified set's boundary: the follower within 0.5 m of the least
        /// gap any braking certifies, the leader within 0.5 m of the least gap that certifies
        /// with it there.
        #[test]
        fn a_start_on_the_boundary_stays_certified_and_collision_free(
            s in start(),
            slack in (0.0f32..0.5, 0.0f32..0.5),
            hard in proptest::bool::ANY,
            late in proptest::bool::ANY,
            careful in proptest::bool::ANY,
            brake_on_switch in proptest::bool::ANY,
            flicker in proptest::bool::ANY,
            leader in draws(60), follower in draws(60), law in draws(60),
        ) {
            let m = with_follower(
                if hard { 9.8 } else { 6.0 },
                if late { 1.15 } else { 0.0 },
                0.0,
                careful,
            );
            let Some(s) = on_the_boundary(&m, s, slack) else { return Ok(()) };
            let in_force = m.certified_braking(&s, 0.0);
            prop_assume!(in_force.is_some());
            holds(&m, s, in_force.unwrap(), [&leader, &follower, &law], (brake_on_switch, flicker))?;
        }

        /// An ego above the lights' deceleration lights its brakes only where its ramp crosses
        /// it: the rear half is a lower bound of the brute-force rear gap with the follower's
        /// reaction starting there.
        #[test]
        fn the_rear_waits_for_the_lights_of_a_ramp_from_an_acceleration(
            gap in 0.0f32..80.0, ve in 0.0f32..35.0, vf in 0.0f32..35.0, a in -2.5f32..2.0,
            emergency in proptest::bool::ANY,
        ) {
            let m = with_follower(6.0, 1.15, 0.0, false);
            let s = State {
                gap_leader: 1e3,
                leader_speed: 30.0,
                gap_follower: gap,
                follower_speed: vf,
                ego_speed: ve,
                ego_acceleration: a,
            };
            let braking = if emergency { m.emergency } else { m.comfort };
            let rear = m.margins(&s, braking, 0.0).1 + m.rear_margin;
            let brute = rear_by_integration(&m, &s, braking);
            prop_assert!(f64::from(rear) <= brute + 0.01, "{} above {}", rear, brute);
        }
    }
}
