//! The plant: three vehicles on a lane, integrated exactly between control samples, with
//! collision detection inside every interval, and the sensors the firmware reads.

use firmware::{Inputs, Measurement, Track};
use rand::Rng;

/// One vehicle: front-bumper position (m) and speed (m/s, never negative). Gaps are
/// bumper-to-bumper, so vehicle lengths are folded into the positions.
#[derive(Debug, Clone, Copy, PartialEq)]
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

/// Sensor imperfections.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SensorModel {
    /// Standard deviation of the gap noise, m (uniform noise of that standard deviation).
    pub gap_noise: f32,
    /// Standard deviation of the relative-speed and ego-speed noise, m/s.
    pub speed_noise: f32,
    /// Measurement latency, control periods (the value the firmware sees is that old).
    pub latency_periods: u32,
    /// Probability that a measurement is not refreshed in a period (it keeps its old stamp).
    pub dropout: f32,
}

impl SensorModel {
    /// Perfect sensors.
    pub const IDEAL: SensorModel = SensorModel {
        gap_noise: 0.0,
        speed_noise: 0.0,
        latency_periods: 0,
        dropout: 0.0,
    };
}

/// The world the firmware sees through its sensors: keeps a short history for latency and the
/// last delivered measurements for dropouts.
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
        while self.history.len() > self.model.latency_periods as usize + 1 {
            self.history.pop_front();
        }
        let (stamp, [leader, ego, follower]) = self.history[0];
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
                    gap: leader.x - ego.x + noise(self.model.gap_noise),
                    rel_speed: leader.v - ego.v + noise(self.model.speed_noise),
                },
                stamp,
            ),
            follower: Measurement::new(
                Track {
                    gap: ego.x - follower.x + noise(self.model.gap_noise),
                    rel_speed: ego.v - follower.v + noise(self.model.speed_noise),
                },
                stamp,
            ),
            ego_speed: Measurement::new((ego.v + noise(self.model.speed_noise)).max(0.0), stamp),
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
