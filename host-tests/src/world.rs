//! One episode's closed loop, one control period at a time: the plant, the sensors, the
//! actuator and the firmware's `Controller`, judged on the *true* state after every period.
//!
//! One responsibility: step the loop and keep score. Who drives the humans is the caller's
//! business (the sampled campaign's [`crate::humans::Humans`], or the adversarial search's
//! schedules and rollouts), so every method of driving them is judged the same way. A `World`
//! is a value: a clone is an independent copy of the loop in the same state, which is how the
//! search looks ahead.
//!
//! What a period judges:
//! - a **collision**: a gap reaches zero, inside the period (each sub-step's exact least gap)
//!   or at a sample;
//! - a **certificate loss**: at a sample, the true state's certificate
//!   ([`firmware::Controller::certificate_with_response`], with what the actuator has yet to do)
//!   has a half below its own tolerance ([`Tolerances`]), or the state is outside the table's
//!   domain; the firmware's mode then and the half are kept;
//! - whether the **humans alone** had made a collision unavoidable first.

use firmware::{Certificate, Command, Config, Controller, Mode};
use rand::rngs::StdRng;
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use crate::humans::HumanModel;
use crate::sim::{
    humans_make_a_collision_unavoidable, lowest_gap, seconds_to_us, Actuator, ActuatorModel, Car,
    SensorModel, Sensors,
};

/// Sub-steps per control period in the plant: the actuator's lag changes the ego's
/// acceleration within a period (5 ms steps against a lag of 0.3 s).
pub const SUB_STEPS: u64 = 4;

/// The firmware's mode, for reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModeName {
    /// [`Mode::Nominal`].
    Nominal,
    /// [`Mode::Override`].
    Override,
    /// [`Mode::MinimumRisk`].
    MinimumRisk,
    /// [`Mode::Uncertified`].
    Uncertified,
    /// [`Mode::Standby`].
    Standby,
}

impl From<Mode> for ModeName {
    fn from(m: Mode) -> Self {
        match m {
            Mode::Nominal => ModeName::Nominal,
            Mode::Override => ModeName::Override,
            Mode::MinimumRisk => ModeName::MinimumRisk,
            Mode::Uncertified => ModeName::Uncertified,
            Mode::Standby => ModeName::Standby,
        }
    }
}

/// Which part of the certificate was lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Half {
    /// The front value.
    Front,
    /// The rear value.
    Rear,
    /// The ego's speed headroom (the ego may leave the speed domain).
    Speed,
    /// The state left the table's domain.
    Domain,
}

/// How far below zero each part of the true state's certificate may read at a sample before it
/// counts as lost, each stated with its reason.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// The front half, m: `f32` rounding of the closed form and the plant
    /// ([`firmware::CERTIFICATE_TOLERANCE`]).
    pub front_m: f32,
    /// The rear half, m: what `solver verify` proves of the rear value at every control period
    /// between its proof periods ([`firmware::REAR_SAMPLE_TOLERANCE`]).
    pub rear_m: f32,
    /// The speed headroom, m/s: `f32` rounding of a speed near 35 m/s.
    pub speed_m_per_s: f32,
}

impl Tolerances {
    /// The tolerances of `config`'s certificate: the default's in the comfort band; with two
    /// authorities the rear half is a closed form, held to the front's rounding tolerance
    /// ([`firmware::CERTIFICATE_TOLERANCE`]), not to the rear table's sampling bound.
    pub fn for_config(config: &Config) -> Self {
        match config.certificate.authorities {
            firmware::Authorities::ComfortBand => Tolerances::default(),
            firmware::Authorities::Two => Tolerances {
                rear_m: firmware::CERTIFICATE_TOLERANCE,
                ..Tolerances::default()
            },
        }
    }
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            front_m: firmware::CERTIFICATE_TOLERANCE,
            rear_m: firmware::REAR_SAMPLE_TOLERANCE,
            speed_m_per_s: firmware::SPEED_TOLERANCE,
        }
    }
}

impl Tolerances {
    /// The part lost at `certificate` (`None` outside the domain), if any: the front first,
    /// then the rear, then the speed.
    pub fn lost(&self, certificate: Option<&Certificate>) -> Option<Half> {
        let Some(c) = certificate else {
            return Some(Half::Domain);
        };
        if c.front.is_nan() || c.front <= -self.front_m {
            Some(Half::Front)
        } else if c.rear.is_nan() || c.rear <= -self.rear_m {
            Some(Half::Rear)
        } else if c.speed.is_nan() || c.speed < -self.speed_m_per_s {
            Some(Half::Speed)
        } else {
            None
        }
    }
}

/// Where an episode starts: the three cars and the ego's acceleration at engagement (the
/// command in force and reached by the actuator; the firmware does not know it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Start {
    /// Leader, ego, follower.
    pub cars: [Car; 3],
    /// The ego's acceleration at engagement, m/s^2.
    pub engaged_acceleration: f32,
}

/// Where the road asks for no braking: the leader more than this far ahead (m) and more than
/// this much faster than the ego (m/s) ([`Needless`]).
pub const FREE_ROAD: (f32, f32) = (40.0, 2.0);

/// Below this speed the ego stands (m/s; [`Needless::standstill`]).
const STANDING_SPEED: f32 = 0.1;

/// Braking and standing the road did not ask for while the firmware drives, at the true state
/// ([`FREE_ROAD`]: the leader more than 40 m ahead and more than 2 m/s faster): the longest
/// stretch of each over an episode, s. A liveness figure: the certificate is not at stake, but
/// a car that brakes, or stands, while the car ahead draws away is one no driver keeps on
/// (with two authorities, a lights' run kept for a follower that closes as the speeds fall).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Needless {
    /// The longest stretch of commands braking beyond the declared lights' deceleration
    /// (-1.3 m/s^2 by default: the brake lights on for sure) while the ego moves, s.
    pub braking: f32,
    /// The longest stretch at a standstill, s.
    pub standstill: f32,
    /// The stretches under way, s (braking, standstill).
    #[serde(skip)]
    under_way: [f32; 2],
}

/// A stretch of braking or standing the road did not ask for longer than this is reported
/// ([`Needless::reported`]), s: a driver notices it.
pub const NEEDLESS_REPORTED_S: f32 = 5.0;

impl Needless {
    /// Whether the longest stretch of braking, and of standing, is longer than
    /// [`NEEDLESS_REPORTED_S`].
    pub fn reported(&self) -> [bool; 2] {
        [self.braking, self.standstill].map(|t| t > NEEDLESS_REPORTED_S)
    }

    /// One period of `h` seconds: on a free road or not, braking or not, standing or not (a
    /// car that stands is counted standing, whatever it commands).
    fn push(&mut self, free_road: bool, braking: bool, standing: bool, h: f32) {
        for (i, on) in [free_road && braking && !standing, free_road && standing]
            .into_iter()
            .enumerate()
        {
            self.under_way[i] = if on { self.under_way[i] + h } else { 0.0 };
        }
        self.braking = self.braking.max(self.under_way[0]);
        self.standstill = self.standstill.max(self.under_way[1]);
    }
}

/// The running score of an episode.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Score {
    /// Time of the first collision, s.
    pub collision_time: Option<f32>,
    /// The first time the humans alone made a collision unavoidable, s.
    pub unavoidable_from: Option<f32>,
    /// The first loss: time (s), the firmware's mode then, and the part lost.
    pub certificate_lost: Option<(f32, ModeName, Half)>,
    /// The smallest front, rear and speed margins at the samples (m, m, m/s).
    pub min_front: f32,
    /// See `min_front`.
    pub min_rear: f32,
    /// See `min_front`.
    pub min_speed: f32,
    /// Smallest gap to the leader, m.
    pub min_gap_leader: f32,
    /// Smallest gap to the follower, m.
    pub min_gap_follower: f32,
    /// Periods per firmware mode: nominal, override, minimum risk, uncertified, standby.
    pub periods_by_mode: [u64; 5],
    /// The periods whose command broke ISO 15622's jerk limit because the certificate needed it
    /// ([`firmware::Command::emergency`]), by cause as the world sees it.
    pub emergencies: EmergencyCauses,
    /// The worst of ISO 15622's checks after the first second ([`crate::iso::IsoCheck`]).
    pub iso: crate::iso::IsoWorst,
    /// Periods run.
    pub periods: u64,
    /// Largest |jerk| of the ego's command, m/s^3.
    pub max_jerk: f32,
    /// Times the leader came to a standstill.
    pub leader_stops: u32,
    /// The leader's hardest braking, m/s^2 (positive; ISO 15622's checks apply where it is
    /// at most the ACC's comfort braking, 3.5 m/s^2).
    pub leader_hardest_braking: f32,
    /// The engagement itself was an emergency: the firmware could not certify its first
    /// measured state (a true start at the certified set's edge, its error box past it) and
    /// gave the emergency answer.
    pub engaged_in_emergency: bool,
    /// The largest ego speed at the end of a period the firmware drove (engaged), m/s: in
    /// standby the driver drives, and nothing is claimed.
    pub max_ego_speed: f32,
    /// The firmware refused the engagement from standby ([`World::engage_from_standby`]): the
    /// driver drives on, and nothing after it is the firmware's.
    pub engagement_refused: bool,
    /// Whether the comfort band alone certified the true state a period into the engagement,
    /// braking along its own ramp from the first engaged command (`World::comfort_certificate`;
    /// with one authority, the comfort band, always): a start from which no emergency was
    /// needed. `None` before that period.
    pub started_comfort_certified: Option<bool>,
    /// Periods of the minimum-risk manoeuvre without a certificate (a fault the argument does
    /// not cover: the ego's speed signal lost, a clock jump).
    pub uncertified_minimum_risk: u64,
    /// Periods of the certified fallback: a track beyond its covered age, the minimum-risk
    /// deceleration under the front half of its last measurement.
    pub fallback_periods: u64,
    /// Periods whose command braked harder than the table's band: the emergency authority.
    pub below_band_periods: u64,
    /// The largest age of a track the firmware read, s (leader, follower).
    pub max_track_age: [f32; 2],
    /// What became of a cut-in, if the episode had one.
    pub cut_in: Option<CutInScore>,
    /// Braking and standing the road did not ask for.
    pub needless: Needless,
}

/// The emergency periods ([`firmware::Command::emergency`]) by cause, judged with what the world
/// knows and the firmware does not: the true state. Each period counts once, under the first
/// cause that holds, in this order.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct EmergencyCauses {
    /// Periods of emergency runs by the cause found at each run's first period (a run: an
    /// unbroken sequence of emergency periods, one emergency with one cause however long the
    /// braking that answers it lasts). At engagement: a run from the first period (a start
    /// whose measured state the firmware cannot certify).
    pub engagement: u64,
    /// Within 5 s of a cut-in (outside the model).
    pub cut_in: u64,
    /// The true state was not certified along the braking the firmware was committed to when
    /// the period began: the certificate needed it (a leader beyond its model, or the truth at
    /// the certified set's edge after an engagement).
    pub uncertified_truth: u64,
    /// The true state was certified along that braking: the measurement's error box, its age
    /// or the delays' bounds made an emergency the truth did not need. The firmware aims at
    /// none.
    pub certified_truth: u64,
    /// Of those, the periods of runs whose true state at their first period the comfort band
    /// alone certified, braking along its ramp from the last command before the run, its
    /// lights coming on along that ramp
    /// ([`firmware::Controller::comfort_certificate_with_actuator`]): the emergency authority
    /// was not needed either. With one authority (the comfort band) all of them. A lower bound
    /// of what the comfort band could have done: the lights of a run under way are not
    /// credited.
    pub comfort_certified_truth: u64,
    /// Of the certified-truth periods, those of runs that began while the leader's or the
    /// follower's newest measurement was older than it would have been without the radar's
    /// losses ([`crate::sim::Sensors::in_dropout`]): a lost refresh or a burst of losses,
    /// whose age the certificate's bounds pay for. The datasheet sensors lose 10% of the
    /// refreshes and draw bursts up to the covered track age.
    pub dropout: u64,
}

impl EmergencyCauses {
    /// Every emergency period, whatever its cause.
    pub fn total(&self) -> u64 {
        self.engagement + self.cut_in + self.uncertified_truth + self.certified_truth
    }

    /// The sum of `other` and these.
    pub fn add(&self, other: &EmergencyCauses) -> EmergencyCauses {
        EmergencyCauses {
            engagement: self.engagement + other.engagement,
            cut_in: self.cut_in + other.cut_in,
            uncertified_truth: self.uncertified_truth + other.uncertified_truth,
            certified_truth: self.certified_truth + other.certified_truth,
            comfort_certified_truth: self.comfort_certified_truth + other.comfort_certified_truth,
            dropout: self.dropout + other.dropout,
        }
    }
}

/// A vehicle that cuts in: a new leader ahead of the ego, or a new follower behind it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CutInKind {
    /// A new leader between the ego and its leader, driving by the leader's model.
    Leader,
    /// A new leader between the ego and its leader that keeps its speed from then on: UN
    /// R157's cut-in, which its rule asks an automated car to avoid.
    SteadyLeader,
    /// A new follower between the ego and its follower.
    Follower,
}

impl CutInKind {
    /// Whether the new vehicle is ahead of the ego (a new leader).
    pub fn ahead(self) -> bool {
        !matches!(self, CutInKind::Follower)
    }
}

/// How the firmware answered a cut-in.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CutInScore {
    /// Which vehicle cut in.
    pub kind: CutInKind,
    /// When, s.
    pub at: f32,
    /// The new vehicle's gap and relative speed then (m, m/s; the relative speed in the
    /// track's convention).
    pub gap: f32,
    /// See `gap`.
    pub rel_speed: f32,
    /// How long after the cut-in the firmware first read a track of the new vehicle, s.
    pub delivered_after: Option<f32>,
    /// How many periods after that delivery the firmware reported the track as a new
    /// vehicle (0: in the same period).
    pub recognised_periods: Option<u64>,
    /// How many periods after that delivery the first command was the emergency answer (flagged
    /// [`firmware::Command::emergency`], as hard as the leader's worst case needs) or a braking
    /// at beta, when the front was not certified at the delivery.
    pub answered_periods: Option<u64>,
    /// That command, m/s^2.
    pub first_answer: Option<f32>,
    /// Whether the firmware's front half was certified at the delivery.
    pub front_certified_at_delivery: Option<bool>,
    /// The hardest command in the 5 s after the cut-in, m/s^2.
    pub hardest_command: f32,
    /// Whether a leader cut-in met UN R157's conditions for avoiding it at the intrusion
    /// ([`r157_requires_avoiding`]); `None` for a follower. The rule asks it only of a new car
    /// that keeps its speed ([`CutInScore::kept_its_speed`]); the closed loop's new leaders
    /// drive by the leader's model afterwards, braking too.
    pub r157_conditions_met: Option<bool>,
    /// The new vehicle's speed at the cut-in, m/s.
    pub speed: f32,
    /// Its least speed from the cut-in on (to the episode's end or its collision), m/s.
    pub slowest: f32,
    /// How long before it entered the ego's lane its lateral motion was visible and its track
    /// delivered as the leader's, s (0: it appeared in the lane; [`World::cut_in_seen`]). `at`,
    /// `gap` and `rel_speed` are at the start of that.
    pub lateral_warning: f32,
}

impl CutInScore {
    /// A cut-in that starts at `at` (s) with the new vehicle's `(gap, rel_speed)` then, its
    /// `speed` and its `lateral_warning`; nothing answered yet.
    fn started(
        kind: CutInKind,
        at: f32,
        (gap, rel_speed): (f32, f32),
        speed: f32,
        lateral_warning: f32,
    ) -> Self {
        CutInScore {
            kind,
            at,
            gap,
            rel_speed,
            delivered_after: None,
            recognised_periods: None,
            answered_periods: None,
            first_answer: None,
            front_certified_at_delivery: None,
            hardest_command: f32::INFINITY,
            r157_conditions_met: None,
            speed,
            slowest: speed,
            lateral_warning,
        }
    }

    /// How far (m/s) below its speed at the cut-in the new vehicle may drive and still count
    /// as keeping it: the leader's speed holds to `f32` rounding.
    const KEPT_SPEED_TOLERANCE: f32 = 1e-3;

    /// Whether the new vehicle kept its speed from the cut-in on, as UN R157's cut-in rule
    /// has it.
    pub fn kept_its_speed(&self) -> bool {
        self.slowest >= self.speed - Self::KEPT_SPEED_TOLERANCE
    }

    /// Whether UN R157 requires an automated car to avoid this cut-in: a new leader that met
    /// the rule's conditions at the intrusion and kept its speed afterwards.
    pub fn r157_requires_avoiding(&self) -> bool {
        self.r157_conditions_met == Some(true) && self.kept_its_speed()
    }
}

/// The deceleration R157's cut-in rule assumes, m/s^2.
const R157_CUT_IN_DECELERATION: f32 = 6.0;

/// UN R157's cut-in rule: a car cutting in `gap` metres ahead with the ego closing on it at
/// `closing_speed` (m/s; `v_ego - v_new`) must be avoided when its lateral motion was visible
/// for at least 0.72 s and the time to collision at the lane intrusion exceeds
/// `closing_speed / (2 * 6 m/s^2) + 0.35 s`. The closed loop's cut-ins have no lateral phase:
/// the cut-in is the intrusion, and its lateral motion is taken as visible long enough.
pub fn r157_requires_avoiding(gap: f32, closing_speed: f32) -> bool {
    closing_speed <= 0.0
        || gap / closing_speed > closing_speed / (2.0 * R157_CUT_IN_DECELERATION) + 0.35
}

/// The least gap (m) at which UN R157's cut-in rule asks an automated car to avoid a car
/// cutting in with the ego closing on it at `closing_speed` (m/s, positive):
/// `closing_speed (closing_speed / (2 * 6 m/s^2) + 0.35 s)` ([`r157_requires_avoiding`] past it).
pub fn r157_least_gap(closing_speed: f32) -> f32 {
    closing_speed * (closing_speed / (2.0 * R157_CUT_IN_DECELERATION) + 0.35)
}

impl Score {
    fn new() -> Self {
        Score {
            collision_time: None,
            unavoidable_from: None,
            certificate_lost: None,
            min_front: f32::INFINITY,
            min_rear: f32::INFINITY,
            min_speed: f32::INFINITY,
            min_gap_leader: f32::INFINITY,
            min_gap_follower: f32::INFINITY,
            periods_by_mode: [0; 5],
            emergencies: EmergencyCauses::default(),
            iso: crate::iso::IsoWorst::default(),
            periods: 0,
            max_jerk: 0.0,
            leader_stops: 0,
            leader_hardest_braking: 0.0,
            engaged_in_emergency: false,
            max_ego_speed: 0.0,
            engagement_refused: false,
            started_comfort_certified: None,
            uncertified_minimum_risk: 0,
            fallback_periods: 0,
            below_band_periods: 0,
            max_track_age: [0.0; 2],
            cut_in: None,
            needless: Needless::default(),
        }
    }

    /// The smaller of the front and rear margins, m (the speed headroom when it is negative and
    /// smaller): what a search minimises.
    pub fn min_margin(&self) -> f32 {
        let halves = self.min_front.min(self.min_rear);
        if self.min_speed < 0.0 {
            halves.min(self.min_speed)
        } else {
            halves
        }
    }

    /// A collision or a loss.
    pub fn failed(&self) -> bool {
        self.collision_time.is_some() || self.certificate_lost.is_some()
    }
}

/// One sample of a trajectory.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TracePoint {
    /// Time, s.
    pub t: f32,
    /// Gap to the leader, m.
    pub gap_leader: f32,
    /// Gap to the follower, m.
    pub gap_follower: f32,
    /// Speeds of leader, ego and follower, m/s.
    pub speeds: [f32; 3],
    /// The ego's actual acceleration at the sample, m/s^2.
    pub ego_acceleration: f32,
    /// The humans' accelerations over the period (leader, follower), m/s^2.
    pub human_accelerations: [f32; 2],
    /// The ego's command, m/s^2.
    pub command: f32,
    /// The firmware's mode.
    pub mode: ModeName,
    /// The certificate margin at the true state, m (see [`Certificate::margin`]).
    pub margin: f32,
    /// The true state's front and rear margins (m) and speed headroom (m/s); NaN outside the
    /// domain.
    pub parts: [f32; 3],
    /// The certificate margin the firmware computed from its measurements (NaN: none), m.
    pub firmware_margin: f32,
    /// The command was flagged an emergency ([`firmware::Command::emergency`]).
    pub emergency: bool,
}

/// A recorded trajectory.
pub type Trace = Vec<TracePoint>;

/// The true state `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`.
pub fn state_of([leader, ego, follower]: [Car; 3]) -> [f32; 5] {
    [
        leader.x - ego.x,
        leader.v,
        ego.x - follower.x,
        follower.v,
        ego.v,
    ]
}

/// The loop of one episode (module docs).
#[derive(Clone)]
pub struct World<'t> {
    controller: Controller<'t>,
    sensors: Sensors,
    actuator: Actuator,
    cars: [Car; 3],
    period: u64,
    /// The first engaged period: 0, or the one after the standby period of
    /// [`World::engage_from_standby`].
    engaged_from: u64,
    period_us: u64,
    model: HumanModel,
    tolerances: Tolerances,
    rng: StdRng,
    last_command: Option<f32>,
    last: Option<(Command, Option<Certificate>)>,
    score: Score,
    /// A cut-in under way: its period and the period its track was first delivered.
    cut_in: Option<(u64, Option<u64>)>,
    /// ISO 15622's checks on the ego's realised motion, from 1 s after engagement.
    iso: crate::iso::IsoCheck,
    /// The road's grade under the ego (rise over run; positive uphill). Outside the model:
    /// the certificate assumes an actuator that tracks the acceleration over ground.
    grade: f32,
    /// The emergency run under way and its cause (`None`: the last period was not one).
    emergency_run: Option<EmergencyCause>,
    /// Since when the ego's brake lights are on: its actual acceleration below the declared
    /// lights' deceleration's negative, as the certificate's assumptions declare them
    /// (docs/certificate.md; the reacting follower sees them so too: lights that a vehicle
    /// may show earlier are not credited) (`None`: off).
    lights_on_since_us: Option<u64>,
    /// The braking the firmware argued with after the last step, and when it last changed
    /// (us; `None`: not since the start).
    braking_in_force: (Option<firmware::Braking>, Option<u64>),
    /// The start's acceleration (the command in force at engagement).
    start_acceleration: f32,
    /// A car cutting in from the next lane, its lateral motion visible ([`World::cut_in_seen`]):
    /// where it is, and the period it enters the ego's lane.
    adjacent: Option<(Car, u64)>,
}

/// What started an emergency run ([`EmergencyCauses`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum EmergencyCause {
    Engagement,
    CutIn,
    UncertifiedTruth,
    /// `comfort`: the comfort band alone certified the truth as well; `dropout`: a radar was in
    /// a dropout ([`crate::sim::Sensors::in_dropout`]).
    CertifiedTruth {
        comfort: bool,
        dropout: bool,
    },
}

impl<'t> World<'t> {
    /// The loop on `bytes` (a split table with `model`) from `start`; `seed` drives the sensor
    /// noise and dropouts.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        bytes: &'t [u8],
        config: Config,
        model: HumanModel,
        start: Start,
        sensors: SensorModel,
        actuator: ActuatorModel,
        tolerances: Tolerances,
        seed: u64,
    ) -> Self {
        World {
            controller: Controller::new(bytes, config),
            sensors: Sensors::new(sensors),
            actuator: Actuator::engaged(actuator, start.engaged_acceleration),
            cars: start.cars,
            period: 0,
            engaged_from: 0,
            period_us: u64::from(config.period_us),
            model,
            tolerances,
            rng: StdRng::seed_from_u64(seed),
            last_command: None,
            last: None,
            score: Score::new(),
            cut_in: None,
            iso: crate::iso::IsoCheck::new(1.0),
            grade: 0.0,
            emergency_run: None,
            lights_on_since_us: None,
            braking_in_force: (None, None),
            start_acceleration: start.engaged_acceleration,
            adjacent: None,
        }
    }

    /// A car in the next lane starts cutting in ahead of the ego now, at its speed plus
    /// `rel_speed` (m/s, at most zero: it is being caught up), which it keeps; its lateral
    /// motion is visible from now and it enters the ego's lane `lateral` seconds later, `gap`
    /// metres ahead if the ego keeps its speed until then. The radar's target selection takes
    /// it as the leader from now (a car in the next lane closing in on the ego's lane), so the
    /// firmware sees it `lateral` seconds before it can be hit; it replaces the leader when it
    /// enters the lane. UN R157's cut-in ([`CutInKind::SteadyLeader`]): the rule asks for
    /// 0.72 s of visible lateral motion, and judges its time to collision at the intrusion.
    pub fn cut_in_seen(&mut self, gap: f32, rel_speed: f32, lateral: f32) {
        let ego = self.cars[1];
        let new = Car {
            x: ego.x + gap - rel_speed * lateral,
            v: (ego.v + rel_speed).clamp(0.0, self.model.max_speed),
        };
        let h = self.period_us as f32 * 1e-6;
        let enters = self.period + (lateral / h).round() as u64;
        self.adjacent = Some((new, enters));
        self.cut_in = Some((self.period, None));
        self.score.cut_in = Some(CutInScore::started(
            CutInKind::SteadyLeader,
            self.time(),
            (new.x - ego.x, rel_speed),
            new.v,
            lateral,
        ));
    }

    /// The cars as the sensors see them: the leader is a car cutting in from the next lane
    /// while there is one ([`World::cut_in_seen`]).
    fn sensed_cars(&self) -> [Car; 3] {
        let [leader, ego, follower] = self.cars;
        [self.adjacent.map_or(leader, |(c, _)| c), ego, follower]
    }

    /// A vehicle cuts in now, `gap` metres ahead of (or behind) the ego with relative speed
    /// `rel_speed` in the track's convention (ahead: `v_new - v_ego`; behind: `v_ego - v_new`).
    /// It replaces the leader (or the follower) from here on; the humans' accelerations then
    /// drive it.
    pub fn cut_in(&mut self, kind: CutInKind, gap: f32, rel_speed: f32) {
        let ego = self.cars[1];
        let new = match kind {
            CutInKind::Leader | CutInKind::SteadyLeader => {
                self.cars[0] = Car {
                    x: ego.x + gap,
                    v: (ego.v + rel_speed).clamp(0.0, self.model.max_speed),
                };
                self.cars[0]
            }
            CutInKind::Follower => {
                self.cars[2] = Car {
                    x: ego.x - gap,
                    v: (ego.v - rel_speed).clamp(0.0, self.model.max_speed),
                };
                self.cars[2]
            }
        };
        self.cut_in = Some((self.period, None));
        let mut score = CutInScore::started(kind, self.time(), (gap, rel_speed), new.v, 0.0);
        score.r157_conditions_met = kind
            .ahead()
            .then(|| r157_requires_avoiding(gap, -rel_speed));
        self.score.cut_in = Some(score);
    }

    /// The cut-in's bookkeeping for this period's inputs and command.
    fn score_cut_in(&mut self, inputs: &firmware::Inputs, command: &Command) {
        let (Some((at_period, delivered)), Some(score)) = (self.cut_in, self.score.cut_in.as_mut())
        else {
            return;
        };
        let new = match (score.kind.ahead(), self.adjacent) {
            (true, Some((adjacent, _))) => adjacent,
            (true, None) => self.cars[0],
            (false, _) => self.cars[2],
        };
        score.slowest = score.slowest.min(new.v);
        let cut_at_us = at_period * self.period_us;
        let h = self.period_us as f32 * 1e-6;
        if self.period <= at_period + (5.0 / h) as u64 {
            score.hardest_command = score.hardest_command.min(command.acceleration);
        }
        let (track, state) = if score.kind.ahead() {
            (&inputs.leader, command.leader)
        } else {
            (&inputs.follower, command.follower)
        };
        let delivered = match delivered {
            Some(d) => d,
            None if track.timestamp_us >= cut_at_us => {
                score.delivered_after = Some((self.period - at_period) as f32 * h);
                // The front's answer is the leader's business; a new follower changes the rear
                // value only, which the band keeps whatever the command.
                score.front_certified_at_delivery = score.kind.ahead().then_some(!command.takeover);
                self.cut_in = Some((at_period, Some(self.period)));
                self.period
            }
            None => return,
        };
        let since = self.period - delivered;
        if score.recognised_periods.is_none() && state == firmware::TrackState::New {
            score.recognised_periods = Some(since);
        }
        if score.answered_periods.is_none()
            && score.front_certified_at_delivery == Some(false)
            && (command.emergency || command.acceleration <= self.model.band_min)
        {
            score.answered_periods = Some(since);
            score.first_answer = Some(command.acceleration);
        }
    }

    /// The road's grade under the ego from now on (rise over run, positive uphill): gravity's
    /// share along the road, `-g sin(atan(grade))`, adds to the actuator's acceleration, which
    /// is then no longer what the firmware commanded (outside the certificate's model, for
    /// the speed law's tests).
    pub fn set_grade(&mut self, grade: f32) {
        self.grade = grade;
    }

    /// A request from the driver's controls, through the firmware's API.
    pub fn request(
        &mut self,
        request: firmware::DriverRequest,
    ) -> Result<(), firmware::DriverError> {
        self.controller.request(request)
    }

    /// An engagement as a driver makes it, at the start: the controller disengaged, one period
    /// in standby (the humans holding `a_leader` and `a_follower`, the driver holding the ego's
    /// actuator at the start's acceleration), then resumed, which the controller refuses unless
    /// the state it measured in standby is certified ([`firmware::DriverError::NotCertified`]).
    pub fn engage_from_standby(
        &mut self,
        a_leader: f32,
        a_follower: f32,
    ) -> Result<(), firmware::DriverError> {
        self.controller.request(firmware::DriverRequest::Cancel)?;
        self.step_with(a_leader, a_follower, Some(self.start_acceleration), None);
        self.engaged_from = self.period;
        let engaged = self.controller.request(firmware::DriverRequest::Resume);
        self.score.engagement_refused = engaged.is_err();
        engaged
    }

    /// The firmware's controller.
    pub fn controller(&self) -> &Controller<'t> {
        &self.controller
    }

    /// The true cars: leader, ego, follower.
    pub fn cars(&self) -> [Car; 3] {
        self.cars
    }

    /// Moves the follower `closer` metres towards the ego and makes it `faster` m/s faster (at
    /// least at rest): a counterfactual's follower at a corner of an error box around its true
    /// state. The firmware's memory is left as it was.
    pub fn move_follower(&mut self, closer: f32, faster: f32) {
        let follower = &mut self.cars[2];
        follower.x += closer;
        follower.v = (follower.v + faster).max(0.0);
    }

    /// The deceleration beyond which the ego's brake lights are on (the configuration's
    /// declaration, which the table's matches), m/s^2.
    fn lights_deceleration(&self) -> f32 {
        self.controller
            .config()
            .certificate
            .emergency
            .lights_deceleration
    }

    /// Since when the ego's brake lights are on (its actual acceleration below the declared
    /// lights' deceleration's negative), as the loop samples them at each period's start, s;
    /// `None`: off.
    pub fn lights_on_since(&self) -> Option<f32> {
        self.lights_on_since_us.map(|t| t as f32 * 1e-6)
    }

    /// The earliest the lights on since [`World::lights_on_since`] can have come on: a period
    /// before the sample that first saw them, the one before it having seen them off. A human
    /// whose reaction is counted from here reacts no later than the model lets it, so that a
    /// follower the loop drives that way stays inside the model however the lights fell
    /// between samples.
    pub fn lights_on_at_the_earliest(&self) -> Option<f32> {
        self.lights_on_since()
            .map(|on| on - self.period_us as f32 * 1e-6)
    }

    /// When the braking the firmware argues with last changed (with two authorities: between
    /// the comfort band's and the emergency authority's, or the latter's level), s; `None`:
    /// not since the start.
    pub fn braking_in_force_changed_at(&self) -> Option<f32> {
        self.braking_in_force.1.map(|t| t as f32 * 1e-6)
    }

    /// The time of the next period's start, s.
    pub fn time(&self) -> f32 {
        (self.period * self.period_us) as f32 * 1e-6
    }

    /// The control period, s.
    pub fn period_seconds(&self) -> f32 {
        self.period_us as f32 * 1e-6
    }

    /// The score so far.
    pub fn score(&self) -> &Score {
        &self.score
    }

    /// The last period's command and true certificate.
    pub fn last(&self) -> Option<(Command, Option<Certificate>)> {
        self.last
    }

    /// The certificate at the true state now, with what the actuator has yet to do and the
    /// braking the firmware is committed to (its ramp), through the real actuator. Called
    /// after the firmware's step and before its command goes to the actuator.
    pub fn certificate(&self) -> Option<Certificate> {
        let now_us = self.period * self.period_us;
        // The band's floor bounds what is pending where every command is in the band; with
        // two authorities the braking may go below it, and the actuator's own state is the
        // bound.
        // The brake lights enter only with two authorities.
        let (floor, lights_on_us) = match self.controller.config().certificate.authorities {
            firmware::Authorities::ComfortBand => (self.model.band_min, None),
            firmware::Authorities::Two => (f32::NEG_INFINITY, self.lights_on_for_good(now_us)),
        };
        let (_, pending) = self.actuator.response(now_us, floor);
        let model = self.actuator.model();
        self.controller.certificate_with_actuator_and_lights(
            state_of(self.cars),
            now_us,
            model.dead_time_us(),
            model.lag,
            pending,
            lights_on_us,
        )
    }

    /// The cause of an emergency run that begins this period ([`EmergencyCauses`]), judged
    /// before [`World::last`] moves on: an engagement, a cut-in within 5 s, or the true state
    /// certified or not along the braking the firmware was committed to when the period began
    /// (the last period's certificate), and then whether the comfort band alone certified it
    /// (one authority: it is the certificate) and whether a radar is in a dropout at `now_us`.
    fn emergency_cause(&self, engagement: bool, now_us: u64) -> EmergencyCause {
        let h = self.period_us as f32 * 1e-6;
        let since_cut_in = self
            .cut_in
            .map(|(at, _)| self.period.saturating_sub(at) as f32 * h);
        let truth_before = self.last.and_then(|(_, c)| c).map(|c| c.margin());
        if engagement {
            EmergencyCause::Engagement
        } else if since_cut_in.is_some_and(|t| t <= 5.0) {
            EmergencyCause::CutIn
        } else if truth_before.is_some_and(|m| m > 0.0) {
            EmergencyCause::CertifiedTruth {
                comfort: self.comfort_band_certifies(),
                dropout: self.sensors.in_dropout(now_us),
            }
        } else {
            EmergencyCause::UncertifiedTruth
        }
    }

    /// Whether the comfort band alone certifies the true state now ([`World::comfort_certificate`];
    /// with one authority it is the certificate, so yes). Called as [`World::certificate`] is.
    fn comfort_band_certifies(&self) -> bool {
        match self.controller.config().certificate.authorities {
            firmware::Authorities::ComfortBand => true,
            firmware::Authorities::Two => {
                self.comfort_certificate().is_some_and(|c| c.is_certified())
            }
        }
    }

    /// With two authorities, the certificate at the true state now were the firmware to brake
    /// along the comfort band's ramp from the last period's command
    /// ([`firmware::Controller::comfort_certificate_with_actuator`]), with what the actuator
    /// has yet to do. Called as [`World::certificate`] is, before [`World::last`] moves on.
    fn comfort_certificate(&self) -> Option<Certificate> {
        let now_us = self.period * self.period_us;
        let (last, _) = self.last?;
        let (_, pending) = self.actuator.response(now_us, f32::NEG_INFINITY);
        let model = self.actuator.model();
        self.controller.comfort_certificate_with_actuator(
            state_of(self.cars),
            now_us,
            model.dead_time_us(),
            model.lag,
            pending,
            last.acceleration,
        )
    }

    /// From when the ego's brake lights are on for good (its actuator's acceleration below
    /// `-theta`, the declared lights' deceleration, from then on), us, if the firmware keeps
    /// to the braking it is committed to ([`firmware::Controller::committed_braking`]): this
    /// period's command, the committed
    /// ramp's next, then at most that ramp. Exact until the next period's command has been in
    /// force for a period (the commands in the dead time take force when they do, and the
    /// acceleration is monotone between two of those times, so its side of `-theta` at their
    /// ends tells),
    /// then the declared lights' bound ([`firmware::EmergencyDeclaration::lights_on_within`])
    /// from the acceleration reached along the
    /// ramp. Where the lights are on and stay on: since when they came on. Called as
    /// [`World::certificate`] is.
    fn lights_on_for_good(&self, now_us: u64) -> Option<u64> {
        let (last, next, braking) = self.controller.committed_braking(now_us)?;
        let model = self.actuator.model();
        let h = self.period_us;
        let exact_until = now_us + model.dead_time_us() + 2 * h;
        let mut actuator = self.actuator.clone();
        actuator.request(now_us, last);
        actuator.request(now_us + h, next);
        let mut t = now_us;
        let theta = self.lights_deceleration();
        // The last time up to `exact_until` at which the acceleration may be at or above
        // `-theta`.
        let mut lit_after = (actuator.acceleration() >= -theta).then_some(now_us);
        while t < exact_until {
            // The commands due now take force first (no time passes).
            actuator.advance(t, 0);
            let until = actuator
                .next_take_force()
                .filter(|&at| at > t && at < exact_until)
                .unwrap_or(exact_until);
            let before = actuator.acceleration();
            actuator.advance(t, until - t);
            if before >= -theta || actuator.acceleration() >= -theta {
                lit_after = Some(until);
            }
            t = until;
        }
        // From here the commands in force are at most the ramp from the next period's command
        // (the one issued `k` periods on is at most `next - jerk (k - 1) h`).
        let a = actuator.acceleration();
        let declared = self.controller.config().certificate.emergency;
        let within =
            declared.lights_on_within(0.0, model.lag, a, a, next, braking.jerk, braking.level);
        if within > 0.0 {
            return Some(exact_until + seconds_to_us(within).max(1));
        }
        match (lit_after, self.lights_on_since_us) {
            (Some(at), _) => Some(at),
            (None, Some(since)) => Some(since),
            (None, None) => Some(now_us),
        }
    }

    /// One period: the firmware measures and commands, the humans hold `a_leader` and
    /// `a_follower` (m/s^2, the caller keeps them within the model) over the period. Returns
    /// false once the episode has ended in a collision (nothing moves after it).
    pub fn step(&mut self, a_leader: f32, a_follower: f32, trace: Option<&mut Trace>) -> bool {
        self.step_with(a_leader, a_follower, None, trace)
    }

    /// [`World::step`], with the firmware's command replaced by `command` when given (for
    /// counterfactuals: what braking at beta from a moment on would have done).
    pub fn step_with(
        &mut self,
        a_leader: f32,
        a_follower: f32,
        command_override: Option<f32>,
        trace: Option<&mut Trace>,
    ) -> bool {
        if self.score.collision_time.is_some() {
            return false;
        }
        let now_us = self.period * self.period_us;
        let t = self.time();
        let [leader, _, follower] = self.cars;
        let (leader_braking, follower_braking) =
            (-self.model.leader.0, -self.model.follower_clip().0);
        if self.score.unavoidable_from.is_none()
            && humans_make_a_collision_unavoidable(
                leader,
                follower,
                leader_braking,
                follower_braking,
            )
        {
            self.score.unavoidable_from = Some(t);
        }
        if self.cars[0].v > 0.0 {
            self.score.leader_hardest_braking = self.score.leader_hardest_braking.max(-a_leader);
        }
        let actuator_state = self.actuator.response(now_us, self.model.band_min).1;
        let inputs =
            self.sensors
                .measure(now_us, self.sensed_cars(), actuator_state, &mut self.rng);
        let mut command = self.controller.step(&inputs);
        // The lights as they are (the actuator's own acceleration, not the firmware's account).
        self.lights_on_since_us = (self.actuator.acceleration() < -self.lights_deceleration())
            .then(|| self.lights_on_since_us.unwrap_or(now_us));
        let in_force = self
            .controller
            .committed_braking(now_us)
            .map(|(_, _, braking)| braking);
        if in_force != self.braking_in_force.0 {
            let changed_at = self.braking_in_force.0.is_some().then_some(now_us);
            self.braking_in_force = (in_force, changed_at.or(self.braking_in_force.1));
        }
        if let Some(a) = command_override {
            command.acceleration = a;
        }
        self.score_cut_in(&inputs, &command);
        let certificate = self.certificate();
        let lights_deceleration = self.lights_deceleration();
        // An emergency period counts under the cause its run began with.
        let engagement = self.period == self.engaged_from;
        let cause = command.emergency.then(|| {
            self.emergency_run
                .unwrap_or_else(|| self.emergency_cause(engagement, now_us))
        });
        // A period into the engagement (its first command issued): whether the comfort band
        // alone certified where it started.
        if self.period == self.engaged_from + 1 {
            self.score.started_comfort_certified = Some(self.comfort_band_certifies());
        }
        let s = &mut self.score;
        if let Some(c) = certificate {
            s.min_front = s.min_front.min(c.front);
            s.min_rear = s.min_rear.min(c.rear);
            s.min_speed = s.min_speed.min(c.speed);
        }
        // Nothing is claimed in standby: the driver drives.
        if s.certificate_lost.is_none() && command.mode != Mode::Standby {
            if let Some(half) = self.tolerances.lost(certificate.as_ref()) {
                s.certificate_lost = Some((t, command.mode.into(), half));
            }
        }
        let mode_index = match command.mode {
            Mode::Nominal => 0,
            Mode::Override => 1,
            Mode::MinimumRisk => 2,
            Mode::Uncertified => 3,
            Mode::Standby => 4,
        };
        s.periods_by_mode[mode_index] += 1;
        if let Some(cause) = cause {
            let e = &mut s.emergencies;
            s.engaged_in_emergency |= engagement;
            *match cause {
                EmergencyCause::Engagement => &mut e.engagement,
                EmergencyCause::CutIn => &mut e.cut_in,
                EmergencyCause::CertifiedTruth { comfort, dropout } => {
                    e.comfort_certified_truth += u64::from(comfort);
                    e.dropout += u64::from(dropout);
                    &mut e.certified_truth
                }
                EmergencyCause::UncertifiedTruth => &mut e.uncertified_truth,
            } += 1;
        }
        self.emergency_run = cause;
        let [ahead, ego, _] = self.cars;
        let free_road = command.mode != Mode::Standby
            && ahead.x - ego.x > FREE_ROAD.0
            && ahead.v > ego.v + FREE_ROAD.1;
        let braking = command.acceleration < -lights_deceleration;
        let h = self.period_us as f32 * 1e-6;
        s.needless
            .push(free_road, braking, ego.v < STANDING_SPEED, h);
        s.periods += 1;
        if command.acceleration < self.model.band_min {
            s.below_band_periods += 1;
        }
        if command.mode == Mode::MinimumRisk {
            if command.margin.is_some() {
                s.fallback_periods += 1;
            } else {
                s.uncertified_minimum_risk += 1;
            }
        }
        let age = |t: u64| now_us.saturating_sub(t) as f32 * 1e-6;
        s.max_track_age[0] = s.max_track_age[0].max(age(inputs.leader.timestamp_us));
        s.max_track_age[1] = s.max_track_age[1].max(age(inputs.follower.timestamp_us));
        if let Some(prev) = self.last_command {
            s.max_jerk = s.max_jerk.max((command.acceleration - prev).abs() / h);
        }
        self.last_command = Some(command.acceleration);
        self.last = Some((command, certificate));
        let gravity = -9.81 * self.grade / (1.0 + self.grade * self.grade).sqrt();
        let ego_acceleration = self.actuator.acceleration() + gravity;
        // The realised acceleration (none at a standstill held by the brakes).
        let realised = if self.cars[1].v <= 0.0 {
            ego_acceleration.max(0.0)
        } else {
            ego_acceleration
        };
        self.iso.push(t, self.cars[1].v, realised);
        s.iso = self.iso.worst();
        self.actuator.request(now_us, command.acceleration);
        let engaged = command.mode != Mode::Standby;
        let before = self.cars;
        let [mut leader, mut ego, mut follower] = self.cars;
        let dt_us = self.period_us / SUB_STEPS;
        let dt = dt_us as f32 * 1e-6;
        let mut collided = false;
        for j in 0..SUB_STEPS {
            let a_ego = self.actuator.advance(now_us + j * dt_us, dt_us) + gravity;
            let front = lowest_gap(leader, a_leader, ego, a_ego, dt);
            let rear = lowest_gap(ego, a_ego, follower, a_follower, dt);
            s.min_gap_leader = s.min_gap_leader.min(front);
            s.min_gap_follower = s.min_gap_follower.min(rear);
            if front <= 0.0 || rear <= 0.0 {
                collided = true;
                break;
            }
            leader.advance(a_leader, dt);
            ego.advance(a_ego, dt);
            follower.advance(a_follower, dt);
        }
        if engaged {
            s.max_ego_speed = s.max_ego_speed.max(ego.v);
        }
        self.cars = [leader, ego, follower];
        if let Some((mut adjacent, enters)) = self.adjacent {
            // In the next lane, it keeps its speed.
            adjacent.advance(0.0, h);
            self.adjacent = Some((adjacent, enters));
            if self.period + 1 >= enters && !collided {
                self.cars[0] = adjacent;
                self.adjacent = None;
                if let Some(c) = s.cut_in.as_mut() {
                    c.r157_conditions_met = Some(r157_requires_avoiding(
                        adjacent.x - ego.x,
                        ego.v - adjacent.v,
                    ));
                }
            }
        }
        if let Some(tr) = trace {
            let [l, e, f] = before;
            let parts = certificate.map_or([f32::NAN; 3], |c| [c.front, c.rear, c.speed]);
            tr.push(TracePoint {
                t,
                gap_leader: l.x - e.x,
                gap_follower: e.x - f.x,
                speeds: [l.v, e.v, f.v],
                ego_acceleration,
                human_accelerations: [a_leader, a_follower],
                command: command.acceleration,
                mode: command.mode.into(),
                margin: certificate.map_or(f32::NEG_INFINITY, |c| c.margin()),
                parts,
                firmware_margin: command.margin.unwrap_or(f32::NAN),
                emergency: command.emergency,
            });
        }
        self.period += 1;
        if collided {
            s.collision_time = Some(t);
            return false;
        }
        if before[0].v > 0.0 && leader.v <= 0.0 {
            s.leader_stops += 1;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::Needless;

    /// A stretch counts only on a free road, braking counts only while the car moves, and a
    /// break in a stretch starts it again: the longest is kept.
    #[test]
    fn needless_braking_and_standing_are_the_longest_stretches() {
        let mut n = Needless::default();
        let h = 0.5;
        // Braking on a free road for 1.5 s, then not free: 1.5 s.
        for _ in 0..3 {
            n.push(true, true, false, h);
        }
        n.push(false, true, false, h);
        // Braking again for 1 s: the longest stays 1.5 s.
        for _ in 0..2 {
            n.push(true, true, false, h);
        }
        assert_eq!(n.braking, 1.5);
        // Standing, commanding a braking, for 2 s: standstill, not braking.
        for _ in 0..4 {
            n.push(true, true, true, h);
        }
        assert_eq!((n.braking, n.standstill), (1.5, 2.0));
        // Neither off a free road.
        for _ in 0..10 {
            n.push(false, true, true, h);
        }
        assert_eq!((n.braking, n.standstill), (1.5, 2.0));
    }
}
