//! The plant: three vehicles on a lane, integrated exactly between control samples, with
//! collision detection inside every interval, and the sensors the firmware reads.

use firmware::{Inputs, Measurement, Track};
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

/// Sensor imperfections.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorModel {
    /// Standard deviation of the gap noise, m (uniform noise of that standard deviation).
    pub gap_noise: f32,
    /// Standard deviation of the relative-speed and ego-speed noise, m/s.
    pub speed_noise: f32,
    /// Measurement latency per channel (leader track, follower track, ego speed), control
    /// periods: the value the firmware sees on that channel is that old, stamped with its time.
    pub latency_periods: [u32; 3],
    /// Probability that a measurement is not refreshed in a period (it keeps its old stamp).
    pub dropout: f32,
}

impl SensorModel {
    /// Perfect sensors.
    pub const IDEAL: SensorModel = SensorModel {
        gap_noise: 0.0,
        speed_noise: 0.0,
        latency_periods: [0; 3],
        dropout: 0.0,
    };

    /// Exact measurements, every channel `periods` old.
    pub fn exact_with_latency(periods: u32) -> Self {
        SensorModel {
            latency_periods: [periods; 3],
            ..SensorModel::IDEAL
        }
    }
}

/// The world the firmware sees through its sensors: keeps a short history for latency and the
/// last delivered measurements for dropouts.
#[derive(Debug, Clone)]
pub struct Sensors {
    model: SensorModel,
    history: std::collections::VecDeque<(u64, [Car; 3])>,
    last: Option<Inputs>,
}

impl Sensors {
    /// Sensors with the given imperfections.
    pub fn new(model: SensorModel) -> Self {
        Sensors {
            model,
            history: std::collections::VecDeque::new(),
            last: None,
        }
    }

    /// The firmware's inputs at `now_us` for the true state `cars` (leader, ego, follower).
    pub fn measure(&mut self, now_us: u64, cars: [Car; 3], rng: &mut impl Rng) -> Inputs {
        self.history.push_back((now_us, cars));
        let deepest = self
            .model
            .latency_periods
            .iter()
            .copied()
            .max()
            .unwrap_or(0) as usize;
        while self.history.len() > deepest + 1 {
            self.history.pop_front();
        }
        // Each channel's state and stamp, `latency` periods back (the oldest kept, early on).
        let back = |latency: u32| {
            let n = self.history.len();
            self.history[n - 1 - (latency as usize).min(n - 1)]
        };
        let [l_lat, f_lat, e_lat] = self.model.latency_periods;
        let (leader_stamp, [leader, ego_l, _]) = back(l_lat);
        let (follower_stamp, [_, ego_f, follower]) = back(f_lat);
        let (ego_stamp, [_, ego, _]) = back(e_lat);
        let mut noise = |sd: f32| {
            if sd > 0.0 {
                // Uniform on [-sqrt(3) sd, sqrt(3) sd]: standard deviation sd.
                (rng.random::<f32>() * 2.0 - 1.0) * 1.732_050_8 * sd
            } else {
                0.0
            }
        };
        let fresh = Inputs {
            leader: Measurement::new(
                Track {
                    gap: leader.x - ego_l.x + noise(self.model.gap_noise),
                    rel_speed: leader.v - ego_l.v + noise(self.model.speed_noise),
                },
                leader_stamp,
            ),
            follower: Measurement::new(
                Track {
                    gap: ego_f.x - follower.x + noise(self.model.gap_noise),
                    rel_speed: ego_f.v - follower.v + noise(self.model.speed_noise),
                },
                follower_stamp,
            ),
            ego_speed: Measurement::new(
                (ego.v + noise(self.model.speed_noise)).max(0.0),
                ego_stamp,
            ),
            now_us,
        };
        let mut inputs = fresh;
        if let Some(last) = self.last {
            if rng.random::<f32>() < self.model.dropout {
                inputs.leader = last.leader;
            }
            if rng.random::<f32>() < self.model.dropout {
                inputs.follower = last.follower;
            }
            if rng.random::<f32>() < self.model.dropout {
                inputs.ego_speed = last.ego_speed;
            }
        }
        self.last = Some(inputs);
        inputs
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

    /// Issue 19 (E): in `f32` seconds, from about 128 s on a fifth of the commands took force
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
