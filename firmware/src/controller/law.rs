//! The nominal ACC law: what a comfortable ACC would command, before the certificate has its
//! say. It knows nothing of the certificate but one number, the gap the certificate needs at
//! the ego's speed while it closes on its leader at `gap_room_speed`
//! ([`Controller::law_certified_gap`](super::Controller::law_certified_gap)), which its gap
//! policy keeps; the certificate never trusts it.
//!
//! # The law
//! - **Gap policy**: the desired gap is the larger of the driver's
//!   `standstill_gap + time_gap v` and the gap the certificate needs while the ego closes on
//!   its leader at `gap_room_speed`, plus `gap_room`. Following at the policy's gap is then
//!   inside the certified set with room for the speed differences the law's own transients
//!   make, so it does not touch the override. The room is a speed, not a distance: the
//!   certificate turns it into metres with the braking it argues with, so a harder braking
//!   buys a shorter room as well as a shorter gap (1.5 m/s is 7.3 m at 30 m/s in the comfort
//!   band, 4.5 m with 8 m/s^2 against a leader's 9.8). With two authorities the braking is the
//!   gentlest the follower allowed over the last one to two seconds: the level moves with the
//!   follower's measurement noise, and the gap with it. A follower closing on the ego caps the
//!   following law's acceleration at what its gap policy with the braking the follower would
//!   allow a few seconds on lets (`ahead_gap`, never below zero): the law does not accelerate
//!   towards a gap the follower is about to take away, and never brakes for it.
//! - **Following**: `rel_speed_gain (rel_speed + closing(e)) + feedforward_gain a_leader`, `e`
//!   the gap's error against the policy: `closing(e) = (gap_gain / rel_speed_gain) e` near the
//!   policy (the classic `gap_gain e + rel_speed_gain rel_speed`), but never more than
//!   `sqrt(2 b e)`, the closing speed a braking at `b = stop_deceleration` takes back over the
//!   error (before, 150 m behind a car 19 m/s slower the linear law still accelerated at
//!   2 m/s^2, and the override had to brake hard). Closing on a leader it accelerates at
//!   1 m/s^2 at most, and not at all while the leader brakes harder than 1 m/s^2. The leader's
//!   acceleration is estimated from its speed (ego speed plus range rate), filtered twice (0.3 s on
//!   the speed, 0.5 s on its derivative).
//! - **Speed**: `speed_gain (set_speed - v) + I`, the integral `I` of `speed_integral_gain
//!   (set_speed - v)` updated only in periods whose command is the speed law's own, unclipped
//!   (conditional integration: no windup behind a leader, under the override, or at a limit),
//!   and held within +-1.5 m/s^2 (a 15% grade). The speed law brakes at most 1.5 m/s^2: a lower
//!   set speed is reached gently.
//! - **Stop and go**: behind a stopped car (estimated speed below 0.5 m/s) the law tracks the
//!   stopping profile `v*(d) = sqrt(2 b d)`, `d` the gap beyond the standstill gap and
//!   `b = stop_deceleration` (with two authorities and a follower behind, harder than the
//!   lights' command by a margin: the lit run the follower does not let end brakes as the
//!   plan does, [`Controller::stop_deceleration`](super::Controller::stop_deceleration)):
//!   `a = -b v / v* + (v* - v)`, the profile's own deceleration along
//!   the way fed forward and the speed error fed back (it decays as `e^-t`). On the profile the
//!   car brakes at exactly `b` and stops at the standstill gap, from 1 m/s in `1 / b` seconds,
//!   with no crawl (a proportional law converges exponentially: 9 s below 1 m/s before). The
//!   distance is taken less what the actuator's dead time and lag cover at the present speed,
//!   and the law accelerates towards a stopped car at 1 m/s^2 at most. Stopped, the car holds at -1
//!   m/s^2; it moves off when the leader does, within `auto_resume_us` of the stop by itself, later
//!   on the driver's resume.
//! - **Comfort**: the command is held within ISO 15622's acceleration and deceleration limits at
//!   the ego's speed, and moves from the last command by at most ISO 15622's jerk limit per
//!   period, both ways ([`crate::iso15622`]), the limit taken at the highest speed the last
//!   second can have had (the measured speed's upper end plus the braking commanded).

use super::Config;
use crate::inputs::Track;
use crate::iso15622;
use crate::math;

/// A leader slower than this is stopped, for the law, m/s.
const STOPPED: f32 = 0.5;
/// The ego is at standstill below this measured speed, m/s.
const STANDSTILL: f32 = 0.1;
/// The brake hold at standstill, m/s^2.
const HOLD: f32 = -1.0;
/// The speed law's hardest braking, m/s^2.
const SPEED_LAW_BRAKING: f32 = -1.5;
/// The stopping profile's feedback gain, 1/s: the speed error decays as `e^(-t STOP_GAIN)`.
const STOP_GAIN: f32 = 1.0;
/// The most the following law accelerates towards a leader, m/s^2 (before the feedforward).
const CLOSING_ACCELERATION: f32 = 1.0;
/// The most the law accelerates towards a stopped car, m/s^2.
const STOP_APPROACH: f32 = 1.0;
/// The speed integral's bound, m/s^2.
const INTEGRAL_MAX: f32 = 1.5;

/// The law's memory: the speed integral, the leader's speed and acceleration estimates, the
/// stop.
#[derive(Debug, Clone, Copy)]
pub(super) struct Law {
    integral: f32,
    leader: Option<LeaderEstimate>,
    stopped_since_us: Option<u64>,
    /// The last proposal was the speed law's, unclipped: `(proposal, speed error)`.
    speed_law: Option<(f32, f32)>,
    /// The last proposal was the speed law's (clipped or not).
    speed_law_proposal: Option<f32>,
}

#[derive(Debug, Clone, Copy)]
struct LeaderEstimate {
    at_us: u64,
    speed: f32,
    acceleration: f32,
}

/// What the law sees in one period.
pub(super) struct LawInputs {
    /// The last plausible leader measurement: its time and track (`gap = inf`: no vehicle).
    pub(super) leader: Option<(u64, Track)>,
    pub(super) ego_speed: f32,
    pub(super) now_us: u64,
    pub(super) period: f32,
    pub(super) set_speed: f32,
    pub(super) time_gap: f32,
    /// The gap the certificate needs at the ego's speed while the ego closes on its leader at
    /// `gap_room_speed`, m.
    pub(super) certified_gap: f32,
    /// The same with the braking the follower would allow a short while on, m (at least
    /// `certified_gap`): the following law accelerates only as far as its gap policy with it
    /// lets, and never brakes for it.
    pub(super) ahead_gap: f32,
    /// The last command issued (or what the actuator is doing, before the first), m/s^2.
    pub(super) last_command: f32,
    /// The driver asked to resume.
    pub(super) resume: bool,
    /// The ego speed's measurement error at this speed, m/s.
    pub(super) speed_error: f32,
    /// The deceleration a stop behind a stopped car is planned with, m/s^2 (positive:
    /// [`Controller::stop_deceleration`](super::Controller::stop_deceleration)).
    pub(super) stop_deceleration: f32,
}

impl Law {
    pub(super) fn new() -> Self {
        Law {
            integral: 0.0,
            leader: None,
            stopped_since_us: None,
            speed_law: None,
            speed_law_proposal: None,
        }
    }

    /// Forgets the leader's estimate and the integral (a disengagement).
    pub(super) fn reset(&mut self) {
        *self = Law::new();
    }

    /// Forgets the leader's estimate (a new vehicle ahead).
    pub(super) fn forget_leader(&mut self) {
        self.leader = None;
    }

    /// The desired gap at speed `v`, m (module docs: the gap policy).
    pub(super) fn desired_gap(config: &Config, time_gap: f32, certified_gap: f32, v: f32) -> f32 {
        let driver = config.law.standstill_gap + time_gap * v;
        math::max(driver, certified_gap + config.law.gap_room)
    }

    /// Whether the law holds the car at standstill (waiting for the leader or for the
    /// driver's resume).
    pub(super) fn is_holding(&self) -> bool {
        self.stopped_since_us.is_some()
    }

    /// The law's command for this period.
    pub(super) fn propose(&mut self, config: &Config, x: &LawInputs) -> f32 {
        let c = config;
        let v = x.ego_speed;
        self.update_leader(x);
        let speed_error = x.set_speed - v;
        // The proportional part within the comfort limits, then the integral on top: once it has
        // learnt a grade, the acceleration over ground is the proportional part's.
        let proportional = c.law.speed_gain * speed_error;
        let bounded = math::clamp(
            proportional,
            SPEED_LAW_BRAKING,
            iso15622::acceleration_limit(v),
        );
        let speed_law = bounded + self.integral;
        let leader_law = x
            .leader
            .filter(|(_, t)| math::is_finite(t.gap))
            .map(|(_, t)| self.leader_law(c, x, t));
        let law = match leader_law {
            Some(a) if a < speed_law => a,
            _ => speed_law,
        };
        let limited = math::clamp(
            law,
            -iso15622::deceleration_limit(v),
            iso15622::acceleration_limit(v),
        );
        // The jerk limit at the highest speed of the last second (the check's strictest), from
        // the measured speed's upper end and the braking commanded.
        let recent = v + x.speed_error + math::max(-x.last_command, 0.0);
        let step = iso15622::jerk_limit(recent) * x.period;
        let proposal = math::clamp(limited, x.last_command - step, x.last_command + step);
        // The integral learns only from the speed law's own, unsaturated command.
        let speed_law_active = leader_law.is_none_or(|a| a >= speed_law);
        self.speed_law = (speed_law_active && proposal == speed_law && bounded == proportional)
            .then_some((proposal, speed_error));
        self.speed_law_proposal = speed_law_active.then_some(proposal);
        proposal
    }

    /// After the step: the integral moves only if the command issued was the speed law's own
    /// proposal (conditional integration).
    pub(super) fn settle(&mut self, config: &Config, issued: f32, period: f32) {
        let mut integral = self.integral;
        if let Some((proposal, error)) = self.speed_law {
            if math::abs(issued - proposal) <= 1e-4 {
                integral += config.law.speed_integral_gain * error * period;
            }
        }
        // Back-calculation: where the certificate (or its speed cap) trimmed the speed law's
        // command, the integral gives back what it holds above the command issued, with a time
        // constant of 1 s, so that it does not wind up against the cap.
        if let Some(proposal) = self.speed_law_proposal {
            if issued < proposal - 1e-4 && integral > 0.0 {
                integral = math::max(integral - (proposal - issued) * period, 0.0);
            }
        }
        self.integral = math::clamp(integral, -INTEGRAL_MAX, INTEGRAL_MAX);
    }

    fn update_leader(&mut self, x: &LawInputs) {
        let Some((at, track)) = x.leader.filter(|(_, t)| math::is_finite(t.gap)) else {
            self.leader = None;
            return;
        };
        let measured = math::max(x.ego_speed + track.rel_speed, 0.0);
        self.leader = Some(match self.leader {
            Some(e) if at > e.at_us => {
                let dt = (at - e.at_us) as f32 * 1e-6;
                let dt = math::min(dt, 1.0);
                let speed = e.speed + dt / (0.3 + dt) * (measured - e.speed);
                let slope = (speed - e.speed) / dt;
                LeaderEstimate {
                    at_us: at,
                    speed,
                    acceleration: e.acceleration + dt / (0.5 + dt) * (slope - e.acceleration),
                }
            }
            Some(e) => e,
            None => LeaderEstimate {
                at_us: at,
                speed: measured,
                acceleration: 0.0,
            },
        });
    }

    /// The law behind a leader: following, or stop and go (module docs).
    fn leader_law(&mut self, c: &Config, x: &LawInputs, track: Track) -> f32 {
        let v = x.ego_speed;
        let (leader_speed, leader_acceleration) = self
            .leader
            .map_or((v + track.rel_speed, 0.0), |e| (e.speed, e.acceleration));
        let beyond = track.gap - c.law.standstill_gap;
        let stopped = v < STANDSTILL;
        // The stop: held until the leader moves off, then (after `auto_resume_us`) until the
        // driver resumes.
        if stopped && leader_speed < STOPPED && beyond < 1.0 {
            self.stopped_since_us = self.stopped_since_us.or(Some(x.now_us));
        }
        if let Some(since) = self.stopped_since_us {
            let leader_gone = leader_speed >= STOPPED || beyond >= 1.0;
            let waited = x.now_us.saturating_sub(since) > u64::from(c.law.auto_resume_us);
            if !stopped || (leader_gone && (!waited || x.resume)) {
                self.stopped_since_us = None;
            } else {
                return HOLD;
            }
        }
        if leader_speed < STOPPED {
            // The stopping profile `v*(d) = sqrt(2 b d)`: its own deceleration along the way,
            // `-b v / v*`, fed forward, and the speed error fed back; on the profile the car
            // brakes at exactly `b` and stops at the standstill gap in `v / b` seconds.
            // The actuator's delays are anticipated: the distance left is what remains after
            // the dead time and the lag at the present speed. Towards a stopped car the law
            // accelerates gently at most.
            let b = x.stop_deceleration;
            let delay = (c.plant.actuator_dead_time_us + c.plant.actuator_lag_us) as f32 * 1e-6;
            let d = math::max(beyond - v * delay, 0.0);
            let profile = math::max(math::sqrt(2.0 * b * d), 0.05);
            let a = -b * v / profile + STOP_GAIN * (profile - v);
            return math::min(a, STOP_APPROACH);
        }
        let following =
            |certified_gap| Law::following(c, x, track, certified_gap, leader_acceleration);
        let law = following(x.certified_gap);
        // The gap a follower closing on the ego will soon ask caps the acceleration, never
        // more: braking for it would let the follower close further and ask more.
        if law > 0.0 && x.ahead_gap > x.certified_gap {
            math::min(law, math::max(following(x.ahead_gap), 0.0))
        } else {
            law
        }
    }

    /// The following law over the certificate's gap `certified_gap` (module docs).
    fn following(
        c: &Config,
        x: &LawInputs,
        track: Track,
        certified_gap: f32,
        leader_acceleration: f32,
    ) -> f32 {
        let v = x.ego_speed;
        let desired = Law::desired_gap(c, x.time_gap, certified_gap, v);
        let feedforward = c.law.feedforward_gain * math::clamp(leader_acceleration, -3.5, 1.0);
        // The speed to close at: linear in the gap error near the policy (the classic law's
        // `gap_gain e + rel_speed_gain rel_speed`), and no faster than a braking at
        // `stop_deceleration` can take back over the error far from it (module docs).
        let error = track.gap - desired;
        let k = c.law.gap_gain / math::max(c.law.rel_speed_gain, 1e-3);
        let closing = if error > 0.0 {
            math::min(k * error, math::sqrt(2.0 * c.law.stop_deceleration * error))
        } else {
            k * error
        };
        // Closing on a leader the law accelerates gently (1 m/s^2 at most), and not at all
        // while the leader brakes (its estimate below -1 m/s^2): a car closing on a braking
        // leader would leave the override the whole of the braking.
        let cap = if track.rel_speed >= 0.0 {
            f32::INFINITY
        } else if leader_acceleration < -1.0 {
            0.0
        } else {
            CLOSING_ACCELERATION
        };
        math::min(c.law.rel_speed_gain * (track.rel_speed + closing), cap) + feedforward
    }
}
