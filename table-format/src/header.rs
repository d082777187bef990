//! The table header: what game the table solves, on which grid, and how its bytes are to be read.
//!
//! Everything here is postcard-encoded between the preamble and the payload. The header is
//! self-describing: a consumer needs no other file to interpret the payload or to know under
//! which assumptions the value function was computed.

use serde::{Deserialize, Serialize};

use crate::sensing::MeasurementError;
use crate::Error;

/// The largest number of state axes a table may have (six; the solver's games have two to
/// five).
pub const MAX_DIMS: usize = 6;

/// A closed interval `[min, max]`: an input's bounds, or one axis of a box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bounds {
    /// The lower end.
    pub min: f32,
    /// The upper end.
    pub max: f32,
}

impl Bounds {
    /// The interval `[min, max]`.
    pub const fn new(min: f32, max: f32) -> Self {
        Bounds { min, max }
    }

    /// Whether `x` lies in the interval (NaN does not).
    pub fn contains(&self, x: f32) -> bool {
        self.min <= x && x <= self.max
    }

    fn is_valid(&self) -> bool {
        self.min.is_finite() && self.max.is_finite() && self.min <= self.max
    }
}

/// Where an axis' nodes sit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Spacing {
    /// Equally spaced from `min` to `max`.
    Uniform,
    /// At breakpoints listed in the table's breakpoint block (`points` little-endian `f32`,
    /// strictly increasing, the first `min` and the last `max`): fine where the value needs it,
    /// coarse elsewhere.
    Listed,
}

/// One grid axis: `points` nodes from `min` to `max` inclusive, placed as `spacing` says.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Axis<'a> {
    /// The state variable on this axis, e.g. `gap_leader`.
    pub name: &'a str,
    /// Its unit, e.g. `m` or `m/s`.
    pub unit: &'a str,
    /// The first node's coordinate.
    pub min: f32,
    /// The last node's coordinate.
    pub max: f32,
    /// The number of nodes, at least 2.
    pub points: u32,
    /// Uniform, or at listed breakpoints.
    pub spacing: Spacing,
}

impl Axis<'_> {
    /// The distance between neighbouring nodes of a uniform axis (the mean one of a listed
    /// axis).
    pub fn uniform_spacing(&self) -> f32 {
        (self.max - self.min) / (self.points.saturating_sub(1).max(1)) as f32
    }

    /// The coordinate of node `i` of a uniform axis (not range-checked).
    pub fn uniform_coordinate(&self, i: u32) -> f32 {
        self.min + i as f32 * self.uniform_spacing()
    }

    /// The bytes its breakpoints take in the breakpoint block (zero for a uniform axis).
    pub fn breakpoint_bytes(&self) -> usize {
        match self.spacing {
            Spacing::Uniform => 0,
            Spacing::Listed => self.points as usize * 4,
        }
    }
}

/// The parameters of the Intelligent Driver Model (Treiber, Hennecke & Helbing 2000) that the
/// three-car IDM game assumes for the follower.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdmParameters {
    /// `a`: maximum acceleration, m/s^2.
    pub max_acceleration: f32,
    /// `b`: comfortable deceleration (positive), m/s^2.
    pub comfortable_deceleration: f32,
    /// `v0`: desired speed, m/s.
    pub desired_speed: f32,
    /// `delta`: acceleration exponent (usually 4).
    pub exponent: u8,
    /// `s0`: jam distance (minimum desired gap), m. The paper uses 0.
    pub jam_distance: f32,
}

impl IdmParameters {
    fn is_valid(&self) -> bool {
        self.max_acceleration.is_finite()
            && self.max_acceleration > 0.0
            && self.comfortable_deceleration.is_finite()
            && self.comfortable_deceleration > 0.0
            && self.desired_speed.is_finite()
            && self.desired_speed > 0.0
            && self.exponent >= 1
            && self.jam_distance.is_finite()
            && self.jam_distance >= 0.0
    }
}

/// How the IDM game obtains the follower's absolute speed `v3 = v_ego - v_g2`, which the 4-D
/// state does not contain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FollowerSpeed {
    /// The paper's reading: the ego drives at a fixed nominal speed, so `v3 = ego_speed - v_g2`.
    /// An assumption, not a guarantee: the table is only valid near that ego speed.
    NominalEgoSpeed {
        /// The assumed ego speed, m/s.
        ego_speed: f32,
    },
    /// The sound reading: `v3` is one more adversarial input over every value consistent with
    /// the state and an ego speed in `[min_ego_speed, max_speed]`:
    /// `max(0, min_ego_speed - v_g2) <= v3 <= min(max_speed, max_speed - v_g2)`. With
    /// `min_ego_speed = 0` nothing is assumed; a positive one is an operating-range assumption the
    /// consumer must check (the table is valid while the ego is at least that fast).
    Adversarial {
        /// The lowest ego speed the table assumes, m/s.
        min_ego_speed: f32,
        /// The largest speed any vehicle may have, m/s.
        max_speed: f32,
    },
}

/// The differential game a table solves, with the parameters it was solved for. Accelerations are
/// in m/s^2; the ego maximises the value, the humans minimise it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Game {
    /// Two cars: state `(gap_leader, rel_speed_leader)`, `x' = v`, `v' = u1 - u2`.
    TwoCar {
        /// Bounds on the ego's acceleration `u2`.
        ego: Bounds,
        /// Bounds on the leader's acceleration `u1`.
        leader: Bounds,
    },
    /// Three cars, the paper's baseline: the follower's acceleration `u3` is any value within
    /// bounds. State `(gap_leader, rel_speed_leader, gap_follower, rel_speed_follower)`.
    ThreeCarBaseline {
        /// Bounds on the ego's acceleration `u2`.
        ego: Bounds,
        /// Bounds on the leader's acceleration `u1`.
        leader: Bounds,
        /// Bounds on the follower's acceleration `u3`.
        follower: Bounds,
    },
    /// Three cars, the paper's alternative: the follower drives by the IDM with an adversarial
    /// desired time gap (the paper's "safe reaction time") in `time_gap`.
    ThreeCarIdm {
        /// Bounds on the ego's acceleration `u2`.
        ego: Bounds,
        /// Bounds on the leader's acceleration `u1`.
        leader: Bounds,
        /// The follower's IDM acceleration is clipped to these bounds.
        follower_clip: Bounds,
        /// The follower's IDM parameters.
        idm: IdmParameters,
        /// The range of the IDM desired time gap `T`, s.
        time_gap: Bounds,
        /// How the follower's absolute speed is obtained.
        follower_speed: FollowerSpeed,
    },
    /// Three cars, IDM follower with an adversarial time gap, in *absolute speeds*: state
    /// `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`, five axes.
    /// `x_g1' = v1 - v_ego`, `v1' = u1`, `x_g2' = v_ego - v3`, `v3' = clip(IDM)`, `v_ego' = u2`,
    /// every speed held in `[0, max_speed]` (a car at rest does not brake further, one at
    /// `max_speed` does not speed up). The follower's IDM sees its true speed, so nothing is
    /// assumed about the ego's speed, and the game has a stationary value (everyone can stop).
    ThreeCarIdmSpeeds {
        /// Bounds on the ego's acceleration `u2`.
        ego: Bounds,
        /// Bounds on the leader's acceleration `u1`.
        leader: Bounds,
        /// The follower's IDM acceleration is clipped to these bounds.
        follower_clip: Bounds,
        /// The follower's IDM parameters.
        idm: IdmParameters,
        /// The range of the IDM desired time gap `T`, s.
        time_gap: Bounds,
        /// The largest speed of any vehicle, m/s.
        max_speed: f32,
    },
    /// The split three-car certificate (since format version 2): three-car safety from a rear table
    /// and a front closed form, for one braking level `beta = -ego.min`.
    ///
    /// The table holds the rear value `W_beta` on three axes in absolute speeds: `gap_follower`
    /// (m), `follower_speed` (m/s), `ego_speed` (m/s), every speed in `[0, max_speed]`: a follower
    /// by its model ([`FollowerModel`]: the IDM with an adversarial time gap) behind an
    /// ego whose acceleration anywhere in the band `ego = [-beta, a_max]` is adversarial too, so
    /// the value bounds the rear gap for as long as the ego keeps its acceleration in the band,
    /// whatever else it does. The front value needs no table: it is
    /// [`crate::front::front_value`] with the leader braking at `-leader.min` and the ego at
    /// `beta`. Where both are positive the ego keeps both gaps for ever (braking at `beta` when
    /// the front demands it), see `solver::games::rear_idm`.
    ThreeCarSplit {
        /// The ego's acceleration band, m/s^2: `min = -beta`.
        ego: Bounds,
        /// The leader's acceleration bounds, m/s^2: `min` is its hardest braking.
        leader: Bounds,
        /// The follower the rear value is solved and proven against (since format version 5).
        follower: FollowerModel,
        /// The largest speed of any vehicle, m/s.
        max_speed: f32,
        /// The vehicle's braking beyond the band and what the follower sees of it (since
        /// format version 6): the firmware refuses a table whose declaration differs from its
        /// configuration's.
        emergency: EmergencyDeclaration,
    },
}

/// The vehicle's emergency authority and how the follower behind learns of a braking: the
/// facts the certificate's emergency answer and its two-authority rule argue with, beside the
/// band the rear table is solved for (since format version 6).
///
/// None of them enters the rear table's values (its follower is the paper's IDM, reacting at
/// once, and its ego keeps to the band), so [`crate::with_emergency`] may declare them anew on
/// a solved table. They are declared here so that a table says which vehicle and which
/// follower it certifies for, and a firmware configured for another refuses it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmergencyDeclaration {
    /// The emergency authority: the vehicle's full braking and its build-up
    /// ([`crate::authority::DRY_ROAD_EMERGENCY`] by default). A level no harder than the
    /// band's `beta` declares none.
    pub braking: crate::authority::Braking,
    /// How long the follower keeps its acceleration after the ego's brake lights come on, s
    /// ([`crate::rear::CAREFUL_DRIVER_REACTION`] by default).
    pub follower_reaction_time: f32,
    /// The deceleration beyond which the brake lights are on for sure, m/s^2 (at least zero;
    /// since format version 7): they are on while the ego's actual acceleration is below its
    /// negative ([`crate::rear::lights_on_within`]), and the follower's reaction counts from
    /// there. Default [`R13H_LIGHTS_DECELERATION`].
    pub lights_deceleration: f32,
    /// The command (m/s^2, below `-lights_deceleration`) at or below which the brake lights
    /// are on once the actuator delivers it: the follower's reaction is counted only from a
    /// run of such commands ([`crate::rear::lights_on_within`]).
    pub lights_command: f32,
}

/// The deceleration above which UN Regulation No. 13-H requires the braking signal where the
/// service brake's pedal is not what brakes, m/s^2: its paragraph 5.2.22.4 lets such braking
/// (regenerative braking; the thresholds were clarified for automatically commanded braking
/// by the 2022 supplement from GRVA/2022/10) stay dark up to 0.7 m/s^2, light the lamps or not
/// from 0.7 to 1.3 m/s^2, and requires them above 1.3 m/s^2. A car's ACC or AEB braking may
/// be such braking, so the lights are on for sure only beyond it.
pub const R13H_LIGHTS_DECELERATION: f32 = 1.3;

impl EmergencyDeclaration {
    /// The defaults: a dry road's full braking
    /// ([`DRY_ROAD_EMERGENCY`](crate::authority::DRY_ROAD_EMERGENCY)), UN R157's careful
    /// driver behind ([`CAREFUL_DRIVER_REACTION`](crate::rear::CAREFUL_DRIVER_REACTION)), the
    /// lights on for sure beyond UN R13-H's 1.3 m/s^2 ([`R13H_LIGHTS_DECELERATION`]), and
    /// counted from commands at or below -1.5 m/s^2 (through the declared 0.3 s lag a step to
    /// it reaches -1.3 in `0.3 ln(1.5 / 0.2)` = 0.6 s).
    pub const DEFAULT: EmergencyDeclaration = EmergencyDeclaration {
        braking: crate::authority::DRY_ROAD_EMERGENCY,
        follower_reaction_time: crate::rear::CAREFUL_DRIVER_REACTION,
        lights_deceleration: R13H_LIGHTS_DECELERATION,
        lights_command: -1.5,
    };

    /// Whether the numbers are a declaration at all: a finite positive braking level, a
    /// positive build-up (`f32::INFINITY`: at once), a finite reaction of 0 to
    /// [`MAX_REACTION_TIME`] s, a finite lights' deceleration of at least zero, and a finite
    /// lights' command below its negative. (The firmware checks the rest against its vehicle:
    /// the envelope, the band, ISO 15622.)
    pub fn is_valid(&self) -> bool {
        let b = &self.braking;
        b.level.is_finite()
            && b.level > 0.0
            && b.jerk > 0.0
            && self.follower_reaction_time.is_finite()
            && (0.0..=MAX_REACTION_TIME).contains(&self.follower_reaction_time)
            && self.lights_deceleration.is_finite()
            && self.lights_deceleration >= 0.0
            && self.lights_command.is_finite()
            && self.lights_command < -self.lights_deceleration
    }

    /// [`crate::rear::lights_on_within`] for these lights: until the actual acceleration is
    /// below `-lights_deceleration` for good, the commands from now on at most the ramp from
    /// `ramp_from` at `jerk` down to `-level`.
    #[allow(clippy::too_many_arguments)]
    pub fn lights_on_within(
        &self,
        dead_time: f32,
        lag: f32,
        acceleration: f32,
        pipeline: f32,
        ramp_from: f32,
        jerk: f32,
        level: f32,
    ) -> f32 {
        crate::rear::lights_on_within(
            dead_time,
            lag,
            acceleration,
            pipeline,
            ramp_from,
            jerk,
            level,
            self.lights_deceleration,
        )
    }
}

/// The longest follower reaction a declaration may name, s: beyond it the follower is not a
/// driver the certificate argues about (a surprised driver takes about 1.5 s).
pub const MAX_REACTION_TIME: f32 = 5.0;

/// The follower behind the ego in a split table's rear game: the model the rear value is
/// solved and proven against. A new follower model is a new variant (the files it touches are
/// listed in `docs/numerics.md`, "Adding a follower model").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FollowerModel {
    /// The Intelligent Driver Model with an adversarial desired time gap (the paper's
    /// alternative), [`crate::idm`]: the IDM's output clipped to `clip`, its time gap anywhere
    /// in `time_gap` at every instant.
    Idm {
        /// The follower's IDM output is clipped to these bounds, m/s^2.
        clip: Bounds,
        /// The follower's IDM.
        idm: IdmParameters,
        /// The adversarial time gap's range, s.
        time_gap: Bounds,
    },
}

/// What every follower model gives the games, the proof and the simulations: its acceleration
/// at a point for one value of its adversarial parameter, and over a box of states for every
/// value of it. The contract, which the rear game's adversary and the proof rely on: the
/// acceleration is non-increasing in the parameter, so that the adversary's choice is an end of
/// [`FollowerModel::parameter_range`].
impl FollowerModel {
    /// The bounds the follower's acceleration is clipped to, m/s^2.
    pub fn clip(&self) -> Bounds {
        match self {
            FollowerModel::Idm { clip, .. } => *clip,
        }
    }

    /// The range of the model's adversarial parameter (the IDM's desired time gap, s).
    pub fn parameter_range(&self) -> Bounds {
        match self {
            FollowerModel::Idm { time_gap, .. } => *time_gap,
        }
    }

    /// The model's (unclipped) acceleration of a follower at `speed` (>= 0), `gap` metres
    /// behind its leader, approaching it at `approach_rate = speed - leader_speed`, for the
    /// parameter `parameter`, m/s^2.
    #[inline(always)]
    pub fn acceleration(&self, speed: f32, approach_rate: f32, gap: f32, parameter: f32) -> f32 {
        match self {
            FollowerModel::Idm { idm, .. } => {
                idm.acceleration(speed, approach_rate, gap, parameter)
            }
        }
    }

    /// [`FollowerModel::acceleration`] in `f64`, the proof's arithmetic.
    pub fn acceleration_f64(
        &self,
        speed: f64,
        approach_rate: f64,
        gap: f64,
        parameter: f64,
    ) -> f64 {
        match self {
            FollowerModel::Idm { idm, .. } => {
                idm.acceleration_f64(speed, approach_rate, gap, parameter)
            }
        }
    }

    /// Bounds `(lowest, highest)` of the (unclipped) acceleration over a box of gaps and speeds
    /// (each `(lo, hi)`) and every parameter in range, widened outward for `f64` rounding.
    pub fn acceleration_bounds(
        &self,
        gap: (f64, f64),
        follower_speed: (f64, f64),
        leader_speed: (f64, f64),
    ) -> (f64, f64) {
        match self {
            FollowerModel::Idm { idm, time_gap, .. } => idm.acceleration_bounds(
                gap,
                follower_speed,
                leader_speed,
                (f64::from(time_gap.min), f64::from(time_gap.max)),
            ),
        }
    }

    /// The gap `G` at and below which the model asks for `braking` (m/s^2, negative) or harder
    /// whatever the speeds and the parameter, m; `None` where there is none. For the IDM,
    /// `a (1 - (s0 / G)^2) <= braking` with `s* >= s0`: `G = s0 / sqrt(1 - braking / a)`.
    pub fn braking_gap(&self, braking: f64) -> Option<f64> {
        match self {
            FollowerModel::Idm { idm, .. } => {
                let ratio = 1.0 - braking / f64::from(idm.max_acceleration);
                (braking < 0.0 && ratio > 1.0)
                    .then(|| f64::from(idm.jam_distance) / libm::sqrt(ratio))
            }
        }
    }

    /// The gap at which a follower at `speed` behind a leader at the same speed holds its
    /// speed, for the parameter `parameter`, m: for the IDM `s* / sqrt(1 - (v / v0)^delta)`,
    /// with the free-road term held at most 0.9 (a follower at or above its desired speed
    /// would hold no gap).
    pub fn equilibrium_gap(&self, speed: f32, parameter: f32) -> f32 {
        match self {
            FollowerModel::Idm { idm, .. } => {
                let desired = idm.jam_distance + speed * parameter;
                let free = 1.0 - idm.free_road_term(speed);
                desired / crate::math::sqrt(if free > 0.1 { free } else { 0.1 })
            }
        }
    }

    fn validate(&self) -> bool {
        match self {
            FollowerModel::Idm {
                clip,
                idm,
                time_gap,
            } => idm_follower_is_valid(clip, time_gap, idm),
        }
    }
}

/// The game without its parameters, for checks such as "the firmware expects a three-car table".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GameKind {
    /// [`Game::TwoCar`].
    TwoCar,
    /// [`Game::ThreeCarBaseline`].
    ThreeCarBaseline,
    /// [`Game::ThreeCarIdm`].
    ThreeCarIdm,
    /// [`Game::ThreeCarIdmSpeeds`].
    ThreeCarIdmSpeeds,
    /// [`Game::ThreeCarSplit`].
    ThreeCarSplit,
}

impl Game {
    /// The game's kind.
    pub fn kind(&self) -> GameKind {
        match self {
            Game::TwoCar { .. } => GameKind::TwoCar,
            Game::ThreeCarBaseline { .. } => GameKind::ThreeCarBaseline,
            Game::ThreeCarIdm { .. } => GameKind::ThreeCarIdm,
            Game::ThreeCarIdmSpeeds { .. } => GameKind::ThreeCarIdmSpeeds,
            Game::ThreeCarSplit { .. } => GameKind::ThreeCarSplit,
        }
    }

    /// The number of state axes: 2 for the two-car game, 4 for the three-car games in
    /// relative speeds, 5 in absolute speeds.
    pub fn dims(&self) -> usize {
        match self {
            Game::TwoCar { .. } => 2,
            Game::ThreeCarIdmSpeeds { .. } => 5,
            Game::ThreeCarSplit { .. } => 3,
            _ => 4,
        }
    }

    /// Bounds on the ego's acceleration.
    pub fn ego(&self) -> Bounds {
        match self {
            Game::TwoCar { ego, .. }
            | Game::ThreeCarBaseline { ego, .. }
            | Game::ThreeCarIdm { ego, .. }
            | Game::ThreeCarIdmSpeeds { ego, .. }
            | Game::ThreeCarSplit { ego, .. } => *ego,
        }
    }

    /// The front model of a [`Game::ThreeCarSplit`] table: the leader braking at `-leader.min`,
    /// the ego at `beta = -ego.min` after holding `response_acceleration` for `response_time`
    /// seconds, braking at `beta` at once after it (no ramp). `None` for every other game.
    pub fn front_model(
        &self,
        response_time: f32,
        response_acceleration: f32,
    ) -> Option<crate::front::FrontModel> {
        match self {
            Game::ThreeCarSplit {
                ego,
                leader,
                max_speed,
                ..
            } => Some(crate::front::FrontModel::step(
                -leader.min,
                -ego.min,
                response_time,
                response_acceleration,
                *max_speed,
            )),
            _ => None,
        }
    }

    fn validate(&self) -> Result<(), Error> {
        let ok = match self {
            Game::TwoCar { ego, leader } => ego.is_valid() && leader.is_valid(),
            Game::ThreeCarBaseline {
                ego,
                leader,
                follower,
            } => ego.is_valid() && leader.is_valid() && follower.is_valid(),
            Game::ThreeCarIdm {
                ego,
                leader,
                follower_clip,
                idm,
                time_gap,
                follower_speed,
            } => {
                let speed_ok = match follower_speed {
                    FollowerSpeed::NominalEgoSpeed { ego_speed } => ego_speed.is_finite(),
                    FollowerSpeed::Adversarial {
                        min_ego_speed,
                        max_speed,
                    } => {
                        min_ego_speed.is_finite()
                            && max_speed.is_finite()
                            && *min_ego_speed >= 0.0
                            && *max_speed > *min_ego_speed
                    }
                };
                ego.is_valid()
                    && leader.is_valid()
                    && idm_follower_is_valid(follower_clip, time_gap, idm)
                    && speed_ok
            }
            Game::ThreeCarIdmSpeeds {
                ego,
                leader,
                follower_clip,
                idm,
                time_gap,
                max_speed,
            } => {
                ego.is_valid()
                    && leader.is_valid()
                    && idm_follower_is_valid(follower_clip, time_gap, idm)
                    && max_speed.is_finite()
                    && *max_speed > 0.0
            }
            Game::ThreeCarSplit {
                ego,
                leader,
                follower,
                max_speed,
                emergency,
            } => {
                ego.is_valid()
                    && ego.min < 0.0
                    && leader.is_valid()
                    && leader.min < 0.0
                    && follower.validate()
                    && max_speed.is_finite()
                    && *max_speed > 0.0
                    && emergency.is_valid()
            }
        };
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidHeader("game parameters"))
        }
    }
}

/// The IDM follower's parameters as every IDM game has them: clip bounds, a time-gap range of
/// non-negative times, and valid IDM parameters.
fn idm_follower_is_valid(follower_clip: &Bounds, time_gap: &Bounds, idm: &IdmParameters) -> bool {
    follower_clip.is_valid() && time_gap.is_valid() && time_gap.min >= 0.0 && idm.is_valid()
}

/// Whether the value function is the finite-horizon one or a converged (invariant) one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HorizonStatus {
    /// Solved to a fixed horizon; the value certifies safety for that long.
    Fixed,
    /// Solved until `max |dV/dt| < tolerance`: the value approximates the infinite-horizon one.
    Converged {
        /// The stopping tolerance on `max |dV/dt|`, value units per second.
        tolerance: f32,
        /// The last `max |dV/dt|` measured.
        residual: f32,
    },
    /// Asked to converge, stopped at the time limit before reaching the tolerance.
    NotConverged {
        /// The stopping tolerance on `max |dV/dt|`.
        tolerance: f32,
        /// The last `max |dV/dt|` measured.
        residual: f32,
    },
    /// Stopped at the first iterate `solver verify` proved invariant (its record is in
    /// [`Header::verification`]), before the value reached a fixed point: the value is a
    /// certificate, not the stationary value, and it may lie above the latter. Since format
    /// version 4.
    Proven {
        /// The largest change of a node value in the last iteration, value units.
        residual: f32,
        /// The largest change of a node value over the last stretch of the solve, value units.
        drift: f32,
        /// The stretch's length, s of horizon.
        stretch: f32,
    },
}

/// The time the value function was propagated for, and whether it converged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Horizon {
    /// Seconds of backward time solved.
    pub seconds: f32,
    /// Fixed horizon or convergence outcome.
    pub status: HorizonStatus,
}

/// How stored integers map to values: `value = offset + scale * q`, `q` an unsigned integer of
/// `bits` bits. Quantization rounds down, so a dequantized node value never exceeds the solver's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quantization {
    /// 8 or 16.
    pub bits: u8,
    /// Value units per step, finite and positive.
    pub scale: f32,
    /// The value of `q = 0`.
    pub offset: f32,
}

impl Quantization {
    /// Bytes per stored value.
    pub fn bytes_per_value(&self) -> usize {
        usize::from(self.bits / 8)
    }

    /// The value a stored integer stands for.
    pub fn dequantize(&self, q: u16) -> f32 {
        self.offset + self.scale * f32::from(q)
    }
}

/// How far the table's interpolated value may sit from the solver's value function, in value
/// units (metres of gap for the paper's games).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ErrorBound {
    /// Largest amount a dequantized node value lies below the solver's node value (quantization
    /// only rounds down, so it never lies above).
    pub quantization: f32,
    /// Bound on `|I(z) - V(z)|` inside the trusted box, where `I` is the multilinear interpolant
    /// of the solver's values at the table's nodes (derived by the solver from per-cell
    /// Lipschitz constants).
    pub interpolation: f32,
}

impl ErrorBound {
    /// The bound on `V_solver(z) - V_table(z)` from below: `V_table(z) - total() <= V_solver(z)`.
    /// A state with `V_table(z) > total()` is one the solver calls safe.
    pub fn total(&self) -> f32 {
        self.quantization + self.interpolation
    }
}

/// How the policy bits are to be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PolicyEncoding {
    /// One bit per node, set where the ego's Hamiltonian-maximising input is its maximum
    /// acceleration: `dV/dv_g2 - dV/dv_g1 > 0` in the three-car games, `-dV/dv > 0` in the
    /// two-car game. Between nodes the bits vote with their multilinear weights: the action is
    /// "accelerate" where the weighted sum of `+1` (set) and `-1` (clear) is positive, "brake"
    /// where it is negative, and the bit of the corner with the largest weight on a tie.
    SignBitWeightedVote,
    /// No policy bits: the table holds values only (the consumer derives its input otherwise).
    None,
}

/// Everything a consumer needs to interpret a table's payload.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header<'a> {
    /// The game and its parameters.
    pub game: Game,
    /// The constraint is `l(z) = min(gaps) - min_gap`, m.
    pub min_gap: f32,
    /// Horizon and convergence.
    pub horizon: Horizon,
    /// The grid, in state order (C order: the last axis varies fastest in the payload).
    #[serde(borrow)]
    pub axes: heapless::Vec<Axis<'a>, MAX_DIMS>,
    /// Per axis, the sub-interval where the grid's boundary does not pollute the value.
    pub trusted_box: heapless::Vec<Bounds, MAX_DIMS>,
    /// How stored integers map to values.
    pub quantization: Quantization,
    /// The error that quantization and interpolation add.
    pub error_bound: ErrorBound,
    /// How the policy bits are read.
    pub policy: PolicyEncoding,
    /// What `solver verify` proved of this table's payload, if it was run (since format version 3).
    pub verification: Option<Verification>,
}

/// The record `solver verify` writes into a rear table it has checked: the firmware refuses a
/// split table without one, or whose proof does not cover its configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Verification {
    /// The version of the check (`solver::verify::VERSION`); a change to what it proves bumps it.
    pub verifier: u16,
    /// The `rear_margin` the proof is for, m: the rear level is `error_bound + rear_margin`, and
    /// a proof at one level says nothing about another.
    pub rear_margin: f32,
    /// Cells holding a certified state.
    pub certified_cells: u32,
    /// Of those, cells proven.
    pub proven_cells: u32,
    /// The shortest period the proof uses, s.
    pub shortest_period: f32,
    /// The longest period the proof uses, s.
    pub longest_period: f32,
    /// The measurement error the table was checked under (since format version 5): every
    /// measured rear state whose error box the firmware's test passes lies in proven cells.
    /// The firmware refuses a table checked for less error than its configuration declares
    /// ([`MeasurementError::covers`]).
    pub measurement_error: MeasurementError,
}

impl Verification {
    /// Whether the proof covers every certified cell.
    pub fn is_complete(&self) -> bool {
        self.proven_cells == self.certified_cells
    }
}

impl Header<'_> {
    /// The number of grid nodes, or an error if the grid is empty or too large.
    pub fn node_count(&self) -> Result<usize, Error> {
        let mut n: usize = 1;
        for axis in &self.axes {
            let points =
                usize::try_from(axis.points).map_err(|_| Error::InvalidHeader("axis points"))?;
            n = n
                .checked_mul(points)
                .filter(|&n| n <= crate::MAX_NODES)
                .ok_or(Error::InvalidHeader("grid has too many nodes"))?;
        }
        Ok(n)
    }

    /// Bytes of the payload: the breakpoint block, the values, then the policy bits (if any).
    pub fn payload_len(&self) -> Result<usize, Error> {
        let n = self.node_count()?;
        Ok(self.breakpoint_len() + n * self.quantization.bytes_per_value() + self.policy_len(n))
    }

    /// The bytes of the breakpoint block: four per node of every listed axis.
    pub fn breakpoint_len(&self) -> usize {
        self.axes.iter().map(Axis::breakpoint_bytes).sum()
    }

    /// The bytes of the policy bits for `nodes` nodes.
    pub fn policy_len(&self, nodes: usize) -> usize {
        match self.policy {
            PolicyEncoding::SignBitWeightedVote => nodes.div_ceil(8),
            PolicyEncoding::None => 0,
        }
    }

    /// Checks everything the reader relies on: finite numbers, increasing axes, a trusted box
    /// inside the grid, a quantization it can read, and a grid whose size fits.
    pub fn validate(&self) -> Result<(), Error> {
        self.game.validate()?;
        if self.axes.len() != self.game.dims() {
            return Err(Error::InvalidHeader(
                "number of axes does not match the game",
            ));
        }
        if self.trusted_box.len() != self.axes.len() {
            return Err(Error::InvalidHeader("trusted box dimensions"));
        }
        for (axis, trusted) in self.axes.iter().zip(self.trusted_box.iter()) {
            if !(axis.min.is_finite() && axis.max.is_finite() && axis.min < axis.max) {
                return Err(Error::InvalidHeader("axis bounds"));
            }
            if axis.points < 2 {
                return Err(Error::InvalidHeader("axis points"));
            }
            let spacing = axis.uniform_spacing();
            if !(spacing.is_finite() && spacing > 0.0) {
                return Err(Error::InvalidHeader("axis spacing"));
            }
            if !(trusted.is_valid() && trusted.min >= axis.min && trusted.max <= axis.max) {
                return Err(Error::InvalidHeader("trusted box"));
            }
        }
        self.node_count()?;
        let q = &self.quantization;
        if !(q.bits == 8 || q.bits == 16) {
            return Err(Error::InvalidHeader("quantization bits"));
        }
        if !(q.scale.is_finite() && q.scale > 0.0 && q.offset.is_finite()) {
            return Err(Error::InvalidHeader("quantization scale or offset"));
        }
        let e = &self.error_bound;
        if !(e.quantization.is_finite()
            && e.quantization >= 0.0
            && e.interpolation.is_finite()
            && e.interpolation >= 0.0)
        {
            return Err(Error::InvalidHeader("error bound"));
        }
        if !(self.min_gap.is_finite() && self.horizon.seconds.is_finite()) {
            return Err(Error::InvalidHeader("min gap or horizon"));
        }
        if let Some(v) = &self.verification {
            let ok = v.rear_margin.is_finite()
                && v.rear_margin >= 0.0
                && v.proven_cells <= v.certified_cells
                && v.shortest_period.is_finite()
                && v.shortest_period > 0.0
                && v.longest_period >= v.shortest_period
                && v.longest_period.is_finite()
                && v.measurement_error.is_valid();
            if !ok {
                return Err(Error::InvalidHeader("verification"));
            }
        }
        Ok(())
    }
}
