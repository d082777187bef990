//! The plant: three vehicles on a lane, integrated exactly between control samples, with
//! collision detection inside every interval, and the sensors the firmware reads.

use firmware::{Inputs, Measurement, SensorBounds, Track};
use rand::Rng;

/// One vehicle: front-bumper position (m) and speed (m/s, never negative). Gaps are
/// bumper-to-bumper, so vehicle lengths are folded into the positions.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Car {
    /// Position, m.
    pub x: f32,
    /// Speed, m/s.
    pub v: f32,
}

impl Car {
    /// The motion under constant acceleration `a` for `h` seconds, exactly, stopping (and
    /// staying stopped) at zero speed.
    pub fn advance(&mut self, a: f32, h: f32) {
        let stop = if a < 0.0 { self.v / -a } else { f32::INFINITY };
        let t = stop.min(h);
        self.x += self.v * t + 0.5 * a * t * t;
        self.v = (self.v + a * t).max(0.0);
    }

    /// Position after `t <= h` seconds under `a`, with the same stopping rule.
    pub fn position_after(&self, a: f32, t: f32) -> f32 {
        let stop = if a < 0.0 { self.v / -a } else { f32::INFINITY };
        let t = stop.min(t);
        self.x + self.v * t + 0.5 * a * t * t
    }
}

/// The lowest value over `[0, h]` of the gap `ahead - behind` when both move under constant
/// accelerations (with stops). The gap is piecewise quadratic with at most two pieces (each car
/// stops at most once), so its minimum is at an end or at a piece's vertex: all are checked.
pub fn lowest_gap(ahead: Car, a_ahead: f32, behind: Car, a_behind: f32, h: f32) -> f32 {
    let gap = |t: f32| ahead.position_after(a_ahead, t) - behind.position_after(a_behind, t);
    let stop = |c: Car, a: f32| if a < 0.0 { c.v / -a } else { f32::INFINITY };
    // The ends, each car's stop, and the first piece's vertex (where the relative speed
    // vanishes). After a stop only one car moves and the gap is monotone until the other stops.
    let rel_a = a_ahead - a_behind;
    let vertex = if rel_a != 0.0 {
        (behind.v - ahead.v) / rel_a
    } else {
        f32::NAN
    };
    [0.0, h, stop(ahead, a_ahead), stop(behind, a_behind), vertex]
        .iter()
        .filter(|t| t.is_finite() && **t >= 0.0 && **t <= h)
        .map(|&t| gap(t))
        .fold(f32::INFINITY, f32::min)
}

/// Whether the humans alone have made a collision unavoidable: the follower, braking as hard
/// as its model allows, cannot stop short of where the leader stops when it brakes as hard as
/// its model allows. The ego is between them (cars are points on one lane), so whatever it
/// does it is hit or hits. With a leader that does brake to a stop, this is exact.
pub fn humans_make_a_collision_unavoidable(
    leader: Car,
    follower: Car,
    leader_braking: f32,
    follower_braking: f32,
) -> bool {
    if leader_braking <= 0.0 || follower_braking <= 0.0 {
        return false;
    }
    let leader_stop = leader.x + leader.v * leader.v / (2.0 * leader_braking);
    let follower_stop = follower.x + follower.v * follower.v / (2.0 * follower_braking);
    follower_stop >= leader_stop
}

/// The ego's actuator: a dead time, then a first-order lag, between the firmware's command and
/// the car's acceleration.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ActuatorModel {
    /// Dead time, s.
    pub dead_time: f32,
    /// First-order lag time constant, s (0: none).
    pub lag: f32,
}

impl ActuatorModel {
    /// The acceleration is the command, at once.
    pub const IDEAL: ActuatorModel = ActuatorModel {
        dead_time: 0.0,
        lag: 0.0,
    };

    /// The dead time in whole microseconds (rounded to the nearest).
    pub fn dead_time_us(&self) -> u64 {
        seconds_to_us(self.dead_time)
    }
}

/// Seconds to whole microseconds, rounded to the nearest; negative and NaN become 0.
pub fn seconds_to_us(s: f32) -> u64 {
    if s.is_nan() || s <= 0.0 {
        0
    } else {
        (f64::from(s) * 1e6).round() as u64
    }
}

/// The actuator's state: commands in the dead-time pipeline (each with the microsecond at
/// which it takes force), the one in force, and the acceleration the lag has reached.
///
/// Time is kept in integer microseconds, as the firmware keeps it: in `f32` seconds a 100 ms
/// dead time lost its last microseconds from about two minutes on (the spacing of `f32` near
/// 128 s is 7.6 us), and a fifth of the commands took force a sub-step late.
#[derive(Debug, Clone)]
pub struct Actuator {
    model: ActuatorModel,
    pipeline: std::collections::VecDeque<(u64, f32)>,
    in_force: f32,
    acceleration: f32,
}

impl Actuator {
    /// At rest: no command in force, zero acceleration.
    pub fn new(model: ActuatorModel) -> Self {
        Actuator::engaged(model, 0.0)
    }

    /// Engaged while the car already accelerates at `acceleration` (the driver's, or the
    /// previous controller's, command in force and fully reached).
    pub fn engaged(model: ActuatorModel, acceleration: f32) -> Self {
        Actuator {
            model,
            pipeline: std::collections::VecDeque::new(),
            in_force: acceleration,
            acceleration,
        }
    }

    /// The firmware issues `command` at `t_us`; it takes force at `t_us + dead_time`.
    pub fn request(&mut self, t_us: u64, command: f32) {
        self.pipeline
            .push_back((t_us + self.model.dead_time_us(), command));
    }

    /// Moves from `t_us` over `dt_us`: takes the commands due by `t_us` into force, then lets
    /// the lag act for `dt_us`. Returns the mean acceleration over the interval (the exact
    /// integral of the lag's exponential, divided by the interval).
    pub fn advance(&mut self, t_us: u64, dt_us: u64) -> f32 {
        while self.pipeline.front().is_some_and(|(at, _)| *at <= t_us) {
            if let Some((_, c)) = self.pipeline.pop_front() {
                self.in_force = c;
            }
        }
        let c = self.in_force;
        if self.model.lag <= 0.0 || dt_us == 0 {
            if self.model.lag <= 0.0 {
                self.acceleration = c;
            }
            return if dt_us == 0 { self.acceleration } else { c };
        }
        let dt = dt_us as f32 * 1e-6;
        let decay = (-dt / self.model.lag).exp();
        let start = self.acceleration;
        self.acceleration = c + (start - c) * decay;
        c + (start - c) * self.model.lag * (1.0 - decay) / dt
    }

    /// When the next command in the dead-time pipeline takes force, us (`None`: none waits).
    pub fn next_take_force(&self) -> Option<u64> {
        self.pipeline.front().map(|(at, _)| *at)
    }

    /// The actuator's model.
    pub fn model(&self) -> ActuatorModel {
        self.model
    }

    /// The acceleration the lag has reached.
    pub fn acceleration(&self) -> f32 {
        self.acceleration
    }

    /// The response the certificate allows for, at `now_us`, if braking at `braking` (the
    /// band's lowest command) is commanded from now on: `(response_time, response_acceleration)`
    /// in seconds and m/s^2, such that the acceleration is at most `response_acceleration`
    /// until `response_time` from now and the braking then acts in full (a first-order lag's
    /// speed never exceeds that of a step delayed by its time constant, see
    /// `table_format::front`). Braking already in the pipeline counts from when it takes force.
    pub fn response(&self, now_us: u64, braking: f32) -> (f32, f32) {
        // The trailing run of braking commands in the pipeline, and whether the one in force
        // is braking too.
        let run = self
            .pipeline
            .iter()
            .rev()
            .take_while(|(_, c)| *c <= braking)
            .count();
        let before_run = self.pipeline.len() - run;
        let all_braking = before_run == 0 && self.in_force <= braking;
        let dead_end = now_us + self.model.dead_time_us();
        let braking_takes_force = if all_braking {
            now_us
        } else if run > 0 {
            self.pipeline
                .get(before_run)
                .map_or(dead_end, |(at, _)| *at)
        } else {
            dead_end
        };
        let pending = self.pipeline.iter().take(before_run).map(|(_, c)| *c).fold(
            self.acceleration
                .max(if all_braking { braking } else { self.in_force }),
            f32::max,
        );
        (
            braking_takes_force.saturating_sub(now_us) as f32 * 1e-6 + self.model.lag,
            pending,
        )
    }
}

/// How a measurement's error is drawn inside its declared bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Noise {
    /// Exact measurements.
    None,
    /// Uniform in the box, drawn anew for every measurement.
    Uniform,
    /// The box's worst corner for the front on every measurement: gaps read long, range rates
    /// read opening, the ego's speed reads low.
    WorstCorner,
    /// [`Noise::WorstCorner`] for the tracks, with the ego speed's error switching between its
    /// two ends every `period_us` (low first, as at the worst corner): every switch moves the
    /// measured speed, and every box built on it, by twice the error at once.
    EgoSpeedFlipping {
        /// How long the ego speed's error keeps one end, microseconds.
        period_us: u32,
    },
    /// Every error switches between [`Noise::WorstCorner`]'s end of its bound and the other
    /// end every `period_us`, all together (the worst corner first): the tracks and the ego's
    /// speed jump by twice their errors at every switch.
    CornersFlipping {
        /// How long the errors keep one corner, microseconds.
        period_us: u32,
    },
    /// Each error at one end of its bound or the other, drawn anew for every measurement: the
    /// box's corners, in random order.
    RandomCorners,
}

/// One sensor channel's timing and losses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Channel {
    /// The sensor's cycle, microseconds (0: a measurement every control period). A sample is
    /// taken at the first control period at or after its time, and stamped with that time.
    pub cycle_us: u32,
    /// Latency from the measurement to its delivery, microseconds.
    pub latency_us: u32,
    /// Extra latency, uniform in `[0, jitter_us]`, per measurement.
    pub jitter_us: u32,
    /// Probability that a cycle's measurement is lost.
    pub dropout: f32,
    /// Rate of bursts of lost measurements, per second.
    pub bursts_per_second: f32,
    /// A burst lasts uniformly up to this long, microseconds.
    pub burst_max_us: u32,
}

impl Channel {
    /// A measurement every period, delivered at once, never lost.
    pub const IDEAL: Channel = Channel {
        cycle_us: 0,
        latency_us: 0,
        jitter_us: 0,
        dropout: 0.0,
        bursts_per_second: 0.0,
        burst_max_us: 0,
    };
}

/// Sensor imperfections: the error inside its bounds, and per channel (leader track, follower
/// track, ego speed) the cycle, latency and losses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorModel {
    /// How the error is drawn.
    pub noise: Noise,
    /// The bounds it is drawn within.
    pub bounds: SensorBounds,
    /// Leader track, follower track, ego speed.
    pub channels: [Channel; 3],
}

impl SensorModel {
    /// Perfect sensors.
    pub const IDEAL: SensorModel = SensorModel {
        noise: Noise::None,
        bounds: SensorBounds::EXACT,
        channels: [Channel::IDEAL; 3],
    };

    /// Exact measurements, every channel `periods` control periods of 20 ms old.
    pub fn exact_with_latency(periods: u32) -> Self {
        SensorModel::exact_with_latencies([periods; 3])
    }

    /// Exact measurements, each channel its own number of 20 ms periods old.
    pub fn exact_with_latencies(periods: [u32; 3]) -> Self {
        let mut m = SensorModel::IDEAL;
        for (c, p) in m.channels.iter_mut().zip(periods) {
            c.latency_us = p * 20_000;
        }
        m
    }

    /// The radars of the datasheets (`table_format::sensing`), drawn for one episode: the error
    /// inside `bounds` (uniform a third of the time; else, in equal shares, the worst corner,
    /// random corners, the ego speed's error or every error switching corners every 20-500 ms: the
    /// noise that moves the error box's corners the most), radar cycles of 50-80 ms, latencies of
    /// 40-100 ms with up to 30 ms of jitter per channel, 10% of the refreshes lost at random and
    /// bursts of losses (one every 20 s on average) up to `burst_max_us`; the ego's speed every 20
    /// ms, 0-20 ms old, never lost.
    pub fn datasheet(bounds: SensorBounds, burst_max_us: u32, rng: &mut impl Rng) -> Self {
        let period_us = rng.random_range(20_000..=500_000);
        let noise = match rng.random_range(0..6) {
            0 | 1 => Noise::Uniform,
            2 => Noise::WorstCorner,
            3 => Noise::RandomCorners,
            4 => Noise::EgoSpeedFlipping { period_us },
            _ => Noise::CornersFlipping { period_us },
        };
        let mut radar = || Channel {
            cycle_us: rng.random_range(50_000..=80_000),
            latency_us: rng.random_range(40_000..=100_000),
            jitter_us: rng.random_range(0..=30_000),
            dropout: 0.1,
            bursts_per_second: 0.05,
            burst_max_us,
        };
        let (leader, follower) = (radar(), radar());
        let ego = Channel {
            cycle_us: 20_000,
            latency_us: rng.random_range(0..=20_000),
            ..Channel::IDEAL
        };
        SensorModel {
            noise,
            bounds,
            channels: [leader, follower, ego],
        }
    }

    /// These sensors with no refresh lost on any channel.
    pub fn lossless(self) -> Self {
        SensorModel {
            channels: self.channels.map(|c| Channel {
                dropout: 0.0,
                bursts_per_second: 0.0,
                ..c
            }),
            ..self
        }
    }
}

/// One channel's state: when its next sample is due, the measurements on their way, the last
/// delivered, the end of a burst of losses, and the oldest sample lost since the last delivered
/// one (its time, and when it would have arrived at the least latency).
#[derive(Debug, Clone)]
struct ChannelState<T> {
    next_sample_us: u64,
    in_flight: std::collections::VecDeque<(u64, Measurement<T>)>,
    delivered: Option<Measurement<T>>,
    burst_until_us: u64,
    lost: Option<(u64, u64)>,
}

impl<T: Copy> ChannelState<T> {
    fn new() -> Self {
        ChannelState {
            next_sample_us: 0,
            in_flight: std::collections::VecDeque::new(),
            delivered: None,
            burst_until_us: 0,
            lost: None,
        }
    }

    /// Whether the last delivered measurement is older than it would be without the losses: a
    /// sample taken after it was lost and would have arrived by `now_us` (at the channel's
    /// least latency).
    fn in_dropout(&self, now_us: u64) -> bool {
        self.lost.is_some_and(|(_, arrives)| arrives <= now_us)
    }

    /// Samples (`value` at `now_us`) if due and not lost, delivers what has arrived, and returns
    /// the last delivered measurement (`value` at once on the first period: the sensor has
    /// been tracking before the episode).
    fn step(&mut self, c: &Channel, now_us: u64, value: T, rng: &mut impl Rng) -> Measurement<T> {
        if now_us >= self.next_sample_us {
            self.next_sample_us = if c.cycle_us == 0 {
                now_us + 1
            } else {
                self.next_sample_us
                    .max(now_us.saturating_sub(u64::from(c.cycle_us)))
                    + u64::from(c.cycle_us)
            };
            let cycle_s = c.cycle_us.max(20_000) as f32 * 1e-6;
            if c.bursts_per_second > 0.0 && rng.random::<f32>() < c.bursts_per_second * cycle_s {
                self.burst_until_us = now_us + rng.random_range(0..=u64::from(c.burst_max_us));
            }
            let lost = now_us < self.burst_until_us || rng.random::<f32>() < c.dropout;
            if lost && self.delivered.is_some() && self.lost.is_none() {
                self.lost = Some((now_us, now_us + u64::from(c.latency_us)));
            }
            if !lost || self.delivered.is_none() {
                let jitter = if c.jitter_us > 0 {
                    rng.random_range(0..=u64::from(c.jitter_us))
                } else {
                    0
                };
                let at = if self.delivered.is_none() {
                    now_us
                } else {
                    now_us + u64::from(c.latency_us) + jitter
                };
                self.in_flight
                    .push_back((at, Measurement::new(value, now_us)));
            }
        }
        while let Some(&(at, m)) = self.in_flight.front() {
            if at > now_us {
                break;
            }
            self.in_flight.pop_front();
            // A measurement overtaken by a newer one (jitter) is not used.
            if self
                .delivered
                .is_none_or(|d| d.timestamp_us < m.timestamp_us)
            {
                self.delivered = Some(m);
                if self.lost.is_some_and(|(taken, _)| taken <= m.timestamp_us) {
                    self.lost = None;
                }
            }
        }
        self.delivered.unwrap_or(Measurement::new(value, now_us))
    }
}

/// The world the firmware sees through its sensors (module docs of [`SensorModel`]).
#[derive(Debug, Clone)]
pub struct Sensors {
    model: SensorModel,
    leader: ChannelState<Track>,
    follower: ChannelState<Track>,
    ego: ChannelState<f32>,
}

impl Sensors {
    /// Sensors with the given imperfections.
    pub fn new(model: SensorModel) -> Self {
        Sensors {
            model,
            leader: ChannelState::new(),
            follower: ChannelState::new(),
            ego: ChannelState::new(),
        }
    }

    /// The model.
    pub fn model(&self) -> &SensorModel {
        &self.model
    }

    /// Whether the leader's or the follower's last delivered measurement is older than it
    /// would be without its channel's losses at `now_us` (a lost sample after it would have
    /// arrived by then): a radar dropout, one lost refresh or a burst.
    pub fn in_dropout(&self, now_us: u64) -> bool {
        self.leader.in_dropout(now_us) || self.follower.in_dropout(now_us)
    }

    /// The firmware's inputs at `now_us` for the true state `cars` (leader, ego, follower) and
    /// the actuator's state `actuator` (the largest of its acceleration and its commands in
    /// force and in flight, m/s^2).
    pub fn measure(
        &mut self,
        now_us: u64,
        cars: [Car; 3],
        actuator: f32,
        rng: &mut impl Rng,
    ) -> Inputs {
        let [leader, ego, follower] = cars;
        let b = self.model.bounds.error;
        let error: [f32; 5] = match self.model.noise {
            Noise::None => [0.0; 5],
            Noise::Uniform => std::array::from_fn(|_| rng.random::<f32>() * 2.0 - 1.0),
            Noise::WorstCorner => [1.0, 1.0, 1.0, 1.0, -1.0],
            Noise::EgoSpeedFlipping { period_us } => {
                let other_end = (now_us / u64::from(period_us.max(1))) % 2 == 1;
                [1.0, 1.0, 1.0, 1.0, if other_end { 1.0 } else { -1.0 }]
            }
            Noise::RandomCorners => {
                std::array::from_fn(|_| if rng.random::<bool>() { 1.0 } else { -1.0 })
            }
            Noise::CornersFlipping { period_us } => {
                let other_end = (now_us / u64::from(period_us.max(1))) % 2 == 1;
                let s = if other_end { -1.0 } else { 1.0 };
                [s, s, s, s, -s]
            }
        };
        // The actuator's state at the low end of its error at the worst corner (the firmware
        // then assumes exactly the truth), anywhere in it otherwise.
        let actuator_error = match self.model.noise {
            Noise::None => 0.0,
            Noise::Uniform | Noise::RandomCorners => rng.random::<f32>() * 2.0 - 1.0,
            Noise::WorstCorner | Noise::EgoSpeedFlipping { .. } | Noise::CornersFlipping { .. } => {
                -1.0
            }
        };
        let range = |g: f32, e: f32| g + e * (b.range + b.range_relative * g.max(0.0));
        let leader_track = Track {
            gap: range(leader.x - ego.x, error[0]),
            rel_speed: leader.v - ego.v + error[1] * b.range_rate,
        };
        let follower_track = Track {
            gap: range(ego.x - follower.x, error[2]),
            rel_speed: ego.v - follower.v + error[3] * b.range_rate,
        };
        let ego_speed = (ego.v + error[4] * (b.ego_speed + b.ego_speed_relative * ego.v)).max(0.0);
        let [cl, cf, ce] = self.model.channels;
        Inputs {
            leader: self.leader.step(&cl, now_us, leader_track, rng),
            follower: self.follower.step(&cf, now_us, follower_track, rng),
            ego_speed: self.ego.step(&ce, now_us, ego_speed, rng),
            // Reported with the ego's speed, on its channel's timing.
            ego_acceleration: Measurement::new(
                actuator + actuator_error * self.model.bounds.acceleration_error,
                now_us,
            ),
            driver: None,
            now_us,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_actuator_waits_out_its_dead_time_then_lags() {
        let mut a = Actuator::new(ActuatorModel {
            dead_time: 0.1,
            lag: 0.3,
        });
        a.request(0, -3.0);
        // Nothing for 100 ms.
        for k in 0..10 {
            assert_eq!(a.advance(k * 10_000, 10_000), 0.0);
        }
        // Then an exponential approach: after one time constant, 1 - 1/e of the way.
        for k in 10..40 {
            a.advance(k * 10_000, 10_000);
        }
        assert!(
            (a.acceleration() + 3.0 * (1.0 - (-1.0f32).exp())).abs() < 0.02,
            "{}",
            a.acceleration()
        );
        // Braking in force: a lag's time constant more, from the acceleration reached.
        let (time, accel) = a.response(400_000, -3.0);
        assert!(
            (time - 0.3).abs() < 1e-6 && accel == a.acceleration(),
            "{time} {accel}"
        );
        // A command to accelerate in the pipeline: the braking acts after it, a dead time on.
        a.request(400_000, 1.0);
        let (time, accel) = a.response(400_000, -3.0);
        assert!((time - 0.4).abs() < 1e-6 && accel == 1.0, "{time} {accel}");
        a.request(420_000, -3.0);
        let (time, accel) = a.response(420_000, -3.0);
        assert!((time - 0.4).abs() < 1e-5 && accel == 1.0, "{time} {accel}");
    }

    /// In `f32` seconds, from about 128 s on a fifth of the commands took force
    /// 5 ms late. In microseconds every one takes force exactly one dead time after it is
    /// issued, at 300 s as at 0 s.
    #[test]
    fn the_dead_time_is_exact_late_in_a_long_episode() {
        let model = ActuatorModel {
            dead_time: 0.1,
            lag: 0.0,
        };
        let mut a = Actuator::new(model);
        let (period, sub) = (20_000u64, 5_000u64);
        let mut late = 0;
        for k in 0..15_000u64 {
            let t = k * period;
            let command = if k % 2 == 0 { 1.0 } else { -1.0 };
            a.request(t, command);
            for j in 0..4 {
                let at = t + j * sub;
                let applied = a.advance(at, sub);
                // The command issued 100 ms (5 periods) before this period's start is in force.
                if k >= 5 {
                    let expected = if (k - 5) % 2 == 0 { 1.0 } else { -1.0 };
                    if applied != expected {
                        late += 1;
                    }
                }
            }
        }
        assert_eq!(late, 0);
    }

    #[test]
    fn a_follower_that_cannot_stop_short_of_the_leader_makes_a_collision_unavoidable() {
        // Both brake at 1.5 m/s^2: the leader at 20 m/s 100 m ahead stops at 233 m.
        let leader = Car { x: 100.0, v: 20.0 };
        // A follower at 30 m/s needs 300 m; at 20 m/s, 133 m.
        assert!(humans_make_a_collision_unavoidable(
            leader,
            Car { x: 0.0, v: 30.0 },
            1.5,
            1.5
        ));
        assert!(!humans_make_a_collision_unavoidable(
            leader,
            Car { x: 0.0, v: 20.0 },
            1.5,
            1.5
        ));
        // A model without braking says nothing.
        assert!(!humans_make_a_collision_unavoidable(
            leader,
            Car { x: 0.0, v: 30.0 },
            0.0,
            1.5
        ));
    }

    /// A channel is in a dropout from when a lost sample would have arrived (at its latency)
    /// until a sample taken after it is delivered; a channel that loses nothing never is.
    #[test]
    fn a_dropout_lasts_from_a_lost_samples_arrival_to_a_newer_delivery() {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let lossy = |dropout: f32| Channel {
            cycle_us: 60_000,
            latency_us: 40_000,
            dropout,
            ..Channel::IDEAL
        };
        let period = 20_000u64;
        let mut never = ChannelState::new();
        for k in 0..200u64 {
            never.step(&lossy(0.0), k * period, 1.0f32, &mut rng);
            assert!(!never.in_dropout(k * period), "at {k}");
        }
        // Every sample after the first is lost: the one at 60 ms would have arrived at 100 ms.
        let mut all_lost = ChannelState::new();
        for k in 0..20u64 {
            let now = k * period;
            all_lost.step(&lossy(1.0), now, 1.0f32, &mut rng);
            assert_eq!(all_lost.in_dropout(now), now >= 100_000, "at {now} us");
        }
        // Then nothing is lost: the sample at 420 ms arrives at 460 ms and ends it.
        for k in 20..30u64 {
            let now = k * period;
            all_lost.step(&lossy(0.0), now, 1.0f32, &mut rng);
            assert_eq!(all_lost.in_dropout(now), now < 460_000, "at {now} us");
        }
    }

    #[test]
    fn cars_stop_and_stay_stopped() {
        let mut c = Car { x: 0.0, v: 2.0 };
        c.advance(-4.0, 1.0);
        assert_eq!(c.v, 0.0);
        assert!((c.x - 0.5).abs() < 1e-6);
        c.advance(-4.0, 1.0);
        assert!((c.x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn a_collision_inside_an_interval_is_found() {
        // gap(t) = 0.6 - 2.2 t + 2 t^2: 0.6 at t = 0, 0.4 at t = 1, yet -0.005 at t = 0.55.
        let ahead = Car { x: 10.6, v: 10.0 };
        let behind = Car { x: 10.0, v: 12.2 };
        let end = ahead.position_after(0.0, 1.0) - behind.position_after(-4.0, 1.0);
        assert!(end > 0.3);
        let low = lowest_gap(ahead, 0.0, behind, -4.0, 1.0);
        assert!(low < 0.0 && low > -0.01, "{low}");
    }
}
