//! The floor under every certificate of the model: the least steady gap to the leader that any
//! braking of the ego keeps, whatever the certificate's form, and a braking that comes close to
//! it.
//!
//! # Why a floor
//! `gap-policy` measures what the firmware's argument certifies: a braking *level* the follower
//! allows, held from the measurement on. Whether a closer gap is a matter of a better argument
//! or is out of reach of the model itself, that figure cannot tell. The floor can: it is what
//! the model's own humans and the declared actuator leave to *any* ego.
//!
//! # The argument (stopping positions)
//! Steady following: the leader `g` ahead at `v_L`, the follower `s` behind, the ego's
//! acceleration and the commands in its pipeline at zero. Two admissible humans:
//! - the leader brakes at its hardest, `b_L`, at once from `t = 0`: it stops
//!   `v_L^2 / (2 b_L)` further on;
//! - the follower keeps its reaction's acceleration (up to the speed cap) until `t_r` =
//!   the moment the ego's lights come on plus its reaction time, then brakes as its model
//!   says, to standstill.
//!
//! Both cars stop. The ego must stop at least the front margin behind the leader's stop and at
//! least the rear margin ahead of the follower's, so
//! `g >= x_F(stop) + m_rear + m_front - v_L^2 / (2 b_L)`, with `x_F(stop)` the follower's stop
//! counted from the ego's start. That is a necessary condition only: any ego, however it
//! brakes, needs at least that gap (the gaps along the way can ask for more).
//!
//! The follower stops the earlier the sooner it reacts, so the floor takes the earliest the
//! lights can come on: the ego learns of the leader's braking `know` seconds late (the track's
//! age and a control period, at the worst), and from then its commands fall at most at the
//! declared build-up. Through the declared dead time and lag (the slowest actuator the
//! declaration admits, so one the certificate must hold for) the actual acceleration is
//! monotone in the commands, so the ramp at the build-up from zero down to the full braking
//! crosses the lights' deceleration first: `t_L = know + lights_on_within(ramp)`
//! (`table_format::rear::lights_on_within`, less its resolution).
//!
//! The floor is the true gap, with the follower and the ego's speed known exactly. A measured
//! gap certifies only if its box's least true gap clears it: `(g (1 + r) + e)` with the range's
//! relative and absolute errors. A measurement's error box can only raise it: a certificate
//! picks its braking knowing the measurement, not the state, so it needs at least the floor of
//! the worst state the box holds (`gap_policy::floor_rows` takes the one state that is worst
//! for both conditions: the ego at its fastest, the leader slower and the follower faster by
//! the range rate's error, the follower's gap short by the range's).
//!
//! # A braking that attains it
//! [`GentleThenHard`]: the ramp at the build-up until the lights are on, then a gentle braking
//! that keeps them on until the follower has reacted, then a ramp to the hardest level the rear
//! allows. It is driven by brute force ([`drive`]: the plant's actuator and cars, 2 ms steps,
//! the least gaps within each step), and the best of a scan ([`best_gentle_then_hard`]) keeps
//! within 2 cm of the floor in every case the tests drive, and none of it keeps less. So does
//! one level ramped to and held from the moment the ego learns of the leader's braking
//! ([`best_level`]), the form the firmware argues with: what separates the firmware's figure
//! from the floor is what its argument leaves out or must allow for (the ego's build-up in its
//! rear check, the measurement's errors, the follower's track age), not its form.

use table_format::rear::{hardest_clearing, ReactingFollower, LIGHTS_RESOLUTION};

use crate::gap_policy::EgoActuator;
use crate::sim::{lowest_gap, Actuator, Car};

/// A scene the floor is taken in: steady following, or the worst state a measurement of it
/// leaves. SI units.
#[derive(Debug, Clone, Copy)]
pub struct Scene {
    /// The leader's speed, m/s.
    pub leader_speed: f32,
    /// The ego's speed, m/s (its acceleration and the commands in its pipeline at zero).
    pub ego_speed: f32,
    /// The follower's speed, m/s.
    pub follower_speed: f32,
    /// The leader's hardest braking, m/s^2 (positive).
    pub leader_braking: f32,
    /// The true gap from the follower to the ego, m.
    pub follower_gap: f32,
    /// The follower's model.
    pub follower: ReactingFollower,
    /// The lights' deceleration: the follower's clock starts once the ego's actual acceleration
    /// is below its negative, m/s^2.
    pub lights_deceleration: f32,
    /// The least gap to the leader the ego must keep, m.
    pub front_margin: f32,
    /// The least gap to the follower, m.
    pub rear_margin: f32,
}

/// What the follower does at `t` (s) when it reacts at `reacts_at` (s), at `speed` (m/s),
/// its speed capped at `top`: its reaction's acceleration, then its braking, built up at its
/// jerk. The one statement of the reacting follower's motion for the host's integrations.
pub fn reacting_follower_acceleration(
    follower: &ReactingFollower,
    t: f32,
    reacts_at: f32,
    speed: f32,
    top: f32,
) -> f32 {
    if t < reacts_at {
        if speed >= top {
            0.0
        } else {
            follower.reaction_acceleration
        }
    } else if follower.jerk.is_infinite() {
        -follower.braking
    } else {
        (follower.reaction_acceleration - follower.jerk * (t - reacts_at)).max(-follower.braking)
    }
}

/// Where the follower of `scene` stops, m from the ego's start, when it reacts at `reacts_at`
/// (s): integrated in 1 ms steps, each with the acceleration at its middle.
pub fn follower_stops_at(scene: &Scene, reacts_at: f32) -> f32 {
    const H: f32 = 1e-3;
    let top = scene.follower.max_speed.max(scene.follower_speed);
    let mut car = Car {
        x: -scene.follower_gap,
        v: scene.follower_speed,
    };
    // 120 s: any car stops from 70 m/s within it.
    for k in 0..120_000u32 {
        let t = (k as f32 + 0.5) * H;
        if car.v <= 0.0 && t > reacts_at {
            break;
        }
        let a = reacting_follower_acceleration(&scene.follower, t, reacts_at, car.v, top);
        car.advance(a, H);
        car.v = car.v.min(top);
    }
    car.x
}

/// The earliest the ego's lights can come on, s after the leader starts braking: the ego learns
/// of it `know` seconds later and ramps its commands at the actuator's build-up from zero to
/// `full` (m/s^2) through its dead time and lag (module docs).
pub fn earliest_lights(
    actuator: EgoActuator,
    know: f32,
    full: f32,
    lights_deceleration: f32,
) -> f32 {
    let through = table_format::rear::lights_on_within(
        actuator.dead_time,
        actuator.lag,
        0.0,
        0.0,
        0.0,
        actuator.jerk,
        full,
        lights_deceleration,
    );
    know + (through - LIGHTS_RESOLUTION).max(0.0)
}

/// The floor in a scene (module docs), m of true gap to the leader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    /// The earliest the lights come on, s after the leader starts braking.
    pub lights_at: f32,
    /// The gap the follower's stop asks for: the ego stops behind the leader's stop and
    /// ahead of the follower's.
    pub behind_the_follower: f32,
    /// The gap the ego's hardest and earliest braking keeps with no follower.
    pub alone: f32,
    /// The floor: the larger of the two.
    pub gap: f32,
}

/// The floor (module docs) in `scene` for an ego that learns of the leader's braking `know`
/// seconds late and brakes through `actuator` up to `full` (m/s^2). Two necessary conditions,
/// the larger binding: the stopping positions with the follower reacting to the earliest
/// lights ([`earliest_lights`], [`follower_stops_at`]), and the ego's hardest and earliest
/// braking (the commands ramped at the build-up from `know` to `full`: its acceleration, so
/// its position, is then the least at every instant of any braking's) driven by [`drive`]
/// against the leader alone.
pub fn floor(scene: &Scene, actuator: EgoActuator, know: f32, full: f32) -> Floor {
    let lights_at = earliest_lights(actuator, know, full, scene.lights_deceleration);
    let reacts_at = lights_at + scene.follower.reaction_time;
    let behind_the_follower =
        follower_stops_at(scene, reacts_at) + scene.rear_margin + scene.front_margin
            - scene.leader_speed * scene.leader_speed / (2.0 * scene.leader_braking);
    let hardest = GentleThenHard {
        hold: full,
        switch_at: 0.0,
        level: full,
    };
    let alone = drive(scene, actuator, know, full, hardest).front_excess + scene.front_margin;
    Floor {
        lights_at,
        behind_the_follower,
        alone,
        gap: behind_the_follower.max(alone),
    }
}

/// A braking of three phases, from the moment the ego learns of the leader's braking: its
/// commands ramp at the actuator's build-up until the lights are on, then `hold` (m/s^2,
/// positive) until `switch_at` (s after the leader starts braking), then `level`; a harder
/// command than the last is reached along the build-up, a gentler one at once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GentleThenHard {
    /// The gentle braking that keeps the lights on, m/s^2.
    pub hold: f32,
    /// When the ramp to `level` starts, s.
    pub switch_at: f32,
    /// The braking it ramps to, m/s^2.
    pub level: f32,
}

/// What [`drive`] found.
#[derive(Debug, Clone, Copy)]
pub struct Drive {
    /// How far the ego came ahead of where a leader starting level with it would be, at
    /// the worst instant, m: the least gap to the leader that braking keeps is this plus the
    /// front margin.
    pub front_excess: f32,
    /// The least gap to the follower, m.
    pub rear_least: f32,
}

/// Drives `braking` in `scene` by brute force: the leader braking at its hardest at once from
/// `t = 0`, the ego learning of it `know` seconds later and ramping to `full` (m/s^2) until its
/// lights are on, its commands through the plant's [`Actuator`] (`actuator`'s dead time and
/// lag, its build-up for the ramps), the follower by [`reacting_follower_acceleration`] from
/// its reaction, its reaction time after the lights come on (the actual acceleration below the
/// lights' deceleration, found within a step by interpolation), its clock started again if
/// they go off before it reacts; once it has reacted it brakes to standstill, as the
/// firmware's rear check takes it. 2 ms steps, the least gaps within each ([`lowest_gap`]),
/// until all three cars stand.
pub fn drive(
    scene: &Scene,
    actuator: EgoActuator,
    know: f32,
    full: f32,
    braking: GentleThenHard,
) -> Drive {
    const STEP_US: u64 = 2_000;
    let h = STEP_US as f32 * 1e-6;
    let mut brake = Actuator::new(actuator.model());
    let top = scene.follower.max_speed.max(scene.follower_speed);
    let threshold = -scene.lights_deceleration;
    let ramp = actuator.jerk * h;
    let mut leader = Car {
        x: 0.0,
        v: scene.leader_speed,
    };
    let mut ego = Car {
        x: 0.0,
        v: scene.ego_speed,
    };
    let mut behind = Car {
        x: -scene.follower_gap,
        v: scene.follower_speed,
    };
    let (mut front_excess, mut rear_least) = (f32::NEG_INFINITY, scene.follower_gap);
    let mut lights_at = f32::INFINITY;
    let (mut lit_once, mut reacted) = (false, false);
    let mut command = 0.0f32;
    // 120 s: every car stops within it.
    for k in 0..60_000u64 {
        let t = k as f32 * h;
        if leader.v <= 0.0 && ego.v <= 0.0 && behind.v <= 0.0 {
            break;
        }
        // A braking harder than the command is reached along the build-up; a gentler one at
        // once.
        let toward = |target: f32| (command - ramp).max(target);
        command = if t < know {
            0.0
        } else if !lit_once && t < braking.switch_at {
            toward(-full)
        } else if t < braking.switch_at {
            toward(-braking.hold)
        } else {
            toward(-braking.level)
        };
        brake.request(k * STEP_US, command);
        let before = brake.acceleration();
        let a_ego = brake.advance(k * STEP_US, STEP_US);
        let after = brake.acceleration();
        let reacts_at = lights_at + scene.follower.reaction_time;
        reacted = reacted || t >= reacts_at;
        let a_leader = if leader.v > 0.0 {
            -scene.leader_braking
        } else {
            0.0
        };
        let a_follower =
            reacting_follower_acceleration(&scene.follower, t, reacts_at, behind.v, top);
        front_excess = front_excess.max(-lowest_gap(leader, a_leader, ego, a_ego, h));
        rear_least = rear_least.min(lowest_gap(ego, a_ego, behind, a_follower, h));
        leader.advance(a_leader, h);
        ego.advance(a_ego, h);
        behind.advance(a_follower, h);
        behind.v = behind.v.min(top);
        if !reacted {
            if after < threshold && lights_at.is_infinite() {
                // Within the step, by interpolation of the lag's exponential.
                let share = if before < threshold {
                    0.0
                } else {
                    (before - threshold) / (before - after)
                };
                lights_at = t + share * h;
                lit_once = true;
            } else if after >= threshold {
                lights_at = f32::INFINITY;
            }
        }
    }
    Drive {
        front_excess,
        rear_least,
    }
}

/// The best [`GentleThenHard`] braking of a scan in `scene`: gentle holds from just past the
/// lights' deceleration to 6 m/s^2, switches every 50 ms from the earliest lights to a second
/// past the follower's earliest reaction, and for each pair the hardest level up to `full` the
/// rear allows ([`hardest_clearing`], to 0.01 m/s^2). The least true gap to the leader it keeps
/// (m: its front excess plus the front margin) and the braking; `None` where none clears the
/// rear.
pub fn best_gentle_then_hard(
    scene: &Scene,
    actuator: EgoActuator,
    know: f32,
    full: f32,
) -> Option<(f32, GentleThenHard)> {
    let lights = earliest_lights(actuator, know, full, scene.lights_deceleration);
    let holds = [0.05f32, 0.2, 0.7, 1.2, 1.7, 2.2, 3.2, 4.7].map(|d| scene.lights_deceleration + d);
    let switches = (0..=((scene.follower.reaction_time + 1.0) / 0.05) as u32)
        .map(|k| lights + k as f32 * 0.05);
    let mut best: Option<(f32, GentleThenHard)> = None;
    for switch_at in switches {
        for &hold in &holds {
            let with = |level: f32| GentleThenHard {
                hold,
                switch_at,
                level,
            };
            let clears = |level: f32| {
                drive(scene, actuator, know, full, with(level)).rear_least - scene.rear_margin
            };
            let Some(level) = hardest_clearing(clears, 0.0, full, 0.01) else {
                continue;
            };
            let gap =
                drive(scene, actuator, know, full, with(level)).front_excess + scene.front_margin;
            if best.is_none_or(|(g, _)| gap < g) {
                best = Some((gap, with(level)));
            }
        }
    }
    best
}

/// The best braking of the firmware's form in `scene`, driven as [`best_gentle_then_hard`]
/// drives its own: one level, ramped to at the build-up from the moment the ego learns of the
/// leader's braking and held, the hardest from 0.2 m/s^2 past the lights' deceleration up to
/// `full` the rear allows ([`hardest_clearing`], to 0.01 m/s^2). The least true gap to the
/// leader it keeps, m, and the level; `None` where not even the least clears the rear. Beside
/// the floor it is what the form costs with the truth known.
pub fn best_level(
    scene: &Scene,
    actuator: EgoActuator,
    know: f32,
    full: f32,
) -> Option<(f32, f32)> {
    let held = |level: f32| GentleThenHard {
        hold: level,
        switch_at: 0.0,
        level,
    };
    let clears =
        |level: f32| drive(scene, actuator, know, full, held(level)).rear_least - scene.rear_margin;
    // No braking leaves the lights off and the follower gaining for ever: the least level
    // tried is one that lights them for sure.
    let least = scene.lights_deceleration + 0.2;
    let level = hardest_clearing(clears, least, full, 0.01)?;
    let gap = drive(scene, actuator, know, full, held(level)).front_excess + scene.front_margin;
    Some((gap, level))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware's follower (its IDM's top for its reaction, then its clip at once) `s`
    /// behind at `v`, a 9.8 m/s^2 leader, the default declaration's margins and lights.
    fn scene(v: f32, follower_gap: f32, follower: ReactingFollower) -> Scene {
        Scene {
            leader_speed: v,
            ego_speed: v,
            follower_speed: v,
            leader_braking: 9.8,
            follower_gap,
            follower,
            lights_deceleration: 1.3,
            front_margin: 0.5,
            rear_margin: 0.0,
        }
    }

    const FIRMWARES: ReactingFollower = ReactingFollower {
        reaction_time: 1.15,
        reaction_acceleration: 1.0,
        braking: 6.0,
        jerk: f32::INFINITY,
        max_speed: 35.0,
    };

    const ACTUATOR: EgoActuator = EgoActuator {
        dead_time: 0.1,
        lag: 0.3,
        jerk: 12.0,
    };

    #[test]
    fn the_followers_stop_is_its_closed_form() {
        // Its reaction's acceleration for 1.8 s, then 6 m/s^2 at once.
        let s = scene(30.0, 32.0, FIRMWARES);
        let t: f32 = 1.8;
        let v = 30.0 + t;
        let exact = -32.0 + 30.0 * t + 0.5 * t * t + v * v / 12.0;
        let integrated = follower_stops_at(&s, t);
        assert!((integrated - exact).abs() < 0.02, "{integrated} vs {exact}");
        // The speed cap holds its speed: from 34.5 m/s it reaches 35 in 0.5 s.
        let capped = scene(34.5, 32.0, FIRMWARES);
        let exact = -32.0 + 34.5 * 0.5 + 0.125 + 35.0 * 1.3 + 35.0 * 35.0 / 12.0;
        let integrated = follower_stops_at(&capped, t);
        assert!((integrated - exact).abs() < 0.02, "{integrated} vs {exact}");
    }

    /// The floor is a lower bound every braking driven by brute force keeps above (to 5 cm: the
    /// brute force's 2 ms steps in `f32`), and the best of the scan comes within 1.5 m of it
    /// (within 2 cm when measured): too high a floor fails the first, too low the second. At
    /// 30 and 20 m/s with the firmware's follower 1 s behind (plus the IDM's jam distance), at
    /// 30 m/s with R157's careful driver 1 s behind and with the firmware's 2 s behind (where
    /// the ego's own braking binds), the leader's braking learnt at once and 0.15 s late.
    #[test]
    fn no_braking_keeps_less_than_the_floor_and_one_comes_close() {
        let careful = ReactingFollower::careful_driver(35.0);
        for (v, follower, behind) in [
            (30.0f32, FIRMWARES, 1.0f32),
            (20.0, FIRMWARES, 1.0),
            (30.0, careful, 1.0),
            (30.0, FIRMWARES, 2.0),
        ] {
            let s = scene(v, 2.0 + behind * v, follower);
            for know in [0.0f32, 0.15] {
                let floor = floor(&s, ACTUATOR, know, 8.0).gap;
                let (best, braking) =
                    best_gentle_then_hard(&s, ACTUATOR, know, 8.0).expect("a braking clears");
                let (held, level) = best_level(&s, ACTUATOR, know, 8.0).expect("a level clears");
                assert!(
                    held >= best - 0.05,
                    "a level {level} keeps {held}, below {best}"
                );
                assert!(
                    best >= floor - 0.05 && best <= floor + 1.5,
                    "{v} m/s, {follower:?}, known after {know} s: floor {floor}, best {best} ({braking:?})"
                );
            }
        }
    }
}
