//! `host-tests move-off`: what a committed move-off ([`table_format::rear::rear_gap_moving_off`])
//! would certify at a standstill with a follower stopped close behind, where no release of
//! the brakes is certified today, printed and written to `move-off.json`.
//!
//! For each follower's stopping distance and each commitment (the least command the ego
//! keeps until the commitment's end), the shortest commitment that keeps the rear margin
//! against the firmware's own follower ([`firmware::Certifier::reacting_follower`]: up to its
//! IDM's largest acceleration, blind until it reacts to lights that come on after the
//! commitment's end), judged at the worst corner of the declared measurement errors; and the
//! leader's room the front then needs, the ego accelerating at the commitment all that time
//! and braking after it at the level the rear was certified for; and the same with a
//! follower that holds its speed until it reacts (UN R157's careful driver), for which a
//! release at once is the shortest commitment.

use anyhow::{Context, Result};
use table_format::front::{front_value, FrontModel};
use table_format::rear::{rear_gap_moving_off, MoveOff, ReactingFollower};

use crate::gap_policy::{learnt_after, EgoActuator, RearBox};

/// The gaps at which the follower stands behind the ego, m: about the IDM's jam distance (2 m),
/// and more.
pub const FOLLOWER_GAPS: [f32; 5] = [1.5, 2.0, 2.5, 3.0, 4.0];

/// The commitments tried, m/s^2: just above the IDM's largest acceleration (1 m/s^2), up to
/// ISO 15622's largest acceleration (2 m/s^2).
pub const COMMITMENTS: [f32; 4] = [1.2, 1.5, 1.75, 2.0];

/// The braking levels a commitment must leave the ego at its end, m/s^2: the lights'
/// command's and the comfort band's floor.
pub const LEVELS: [f32; 2] = [1.5, 3.5];

/// The leaders' hardest braking reported, m/s^2: the deployed table's and 1 g.
pub const LEADER_BRAKING: [f32; 2] = [6.0, 9.8];

/// The leaders' speeds at the move-off, m/s: stopped, and pulling away.
pub const LEADER_SPEEDS: [f32; 3] = [0.0, 1.0, 2.0];

/// The commitments' resolution, s.
const WINDOW_STEP: f32 = 0.05;

/// The longest commitment tried, s.
pub const LONGEST_WINDOW: f32 = 10.0;

/// One follower gap, commitment and braking level after it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MoveOffRow {
    /// The follower until it reacts: the firmware's (up to its IDM's largest acceleration) or
    /// one that holds its speed (UN R157's careful driver).
    pub follower: &'static str,
    /// The true gap to the stopped follower, m.
    pub follower_gap: f32,
    /// The least command kept, m/s^2.
    pub commitment: f32,
    /// The braking level after the commitment, m/s^2.
    pub level: f32,
    /// The shortest commitment (s from the first committed command) that keeps the rear
    /// margin, if any up to [`LONGEST_WINDOW`].
    pub window: Option<f32>,
    /// The rear value there, m.
    pub rear_value: Option<f32>,
    /// The ego's least speed at the commitment's end, m/s.
    pub ego_speed: Option<f32>,
    /// The true gap ahead the front then needs, m, per leader braking and speed
    /// ([`LEADER_BRAKING`] by [`LEADER_SPEEDS`]), the measurement's errors included.
    pub leader_room: Vec<Vec<f32>>,
}

/// The scene's fixed parts, from the default configuration.
#[derive(Clone, Copy)]
struct Scene {
    config: firmware::Config,
    actuator: EgoActuator,
    follower: ReactingFollower,
    /// From the measurement to the first committed command's issue, s: the track's age and a
    /// period.
    learnt_after: f32,
}

impl Scene {
    fn deployed() -> Result<Self> {
        let config = firmware::Config::default();
        let controller = firmware::Controller::new(firmware::DEFAULT_TABLE, config);
        let follower = controller
            .certifier()
            .map(|c| c.reacting_follower())
            .ok_or_else(|| anyhow::anyhow!("the default table is refused"))?;
        Ok(Scene {
            config,
            actuator: EgoActuator::declared(&config),
            follower,
            learnt_after: learnt_after(&config),
        })
    }

    /// The scene with a follower that holds its speed until it reacts (UN R157's careful
    /// driver, [`ReactingFollower::careful_driver`]) instead of the firmware's.
    fn holding_its_speed(&self) -> Self {
        Scene {
            follower: ReactingFollower {
                reaction_acceleration: 0.0,
                ..self.follower
            },
            ..*self
        }
    }

    /// A commitment at `commitment` for `window` seconds from its first command: the brake
    /// held before it no harder than the comfort band's floor (ISO 15622's -3.5 m/s^2: a stop
    /// is planned and held well above it, bar the emergency ramp's steps at a standstill; a
    /// harder hold only delays the ego's start), the commitment in force after the longest
    /// dead time, its last command in force until the window's end after the shortest (none).
    fn move_off(&self, commitment: f32, window: f32) -> MoveOff {
        MoveOff {
            from: firmware::config::ISO_15622_LIMITS.0,
            delay: self.learnt_after + self.actuator.dead_time,
            commitment,
            until: self.learnt_after + window,
            lag: self.actuator.lag,
        }
    }

    /// The rear value of a commitment `window` seconds long at `commitment`, then `level`,
    /// behind a follower stopped `gap` metres back, at the worst corner of the errors
    /// ([`RearBox`]: the gap read short and taken shorter, the follower as fast as the
    /// stopped ego's speed read high and two range-rate errors), the ego at rest.
    fn rear_value(&self, gap: f32, commitment: f32, window: f32, level: f32) -> f32 {
        let worst = RearBox::around_gap(&self.config, gap, 0.0);
        let (least_gap, follower_speed) = (worst.gap.0, worst.follower.1);
        let a = &self.actuator;
        let m = self.move_off(commitment, window);
        // The lights come on after the commitment along the braking ramp from it.
        let dark = self.config.certificate.emergency.lights_on_within(
            a.dead_time,
            a.lag,
            commitment,
            commitment,
            commitment,
            self.config.certificate.brake_jerk,
            level,
        );
        let follower = ReactingFollower {
            reaction_time: self.follower.reaction_time + dark,
            ..self.follower
        };
        rear_gap_moving_off(least_gap, follower_speed, &m, level, &follower)
            - self.config.certificate.rear_margin
    }

    /// The true gap ahead the front needs for a commitment `window` seconds long at
    /// `commitment` (the ego accelerating at it, then braking at `level`, the level the rear
    /// was certified for, along the braking ramp),
    /// behind a leader at `leader_speed` that may brake at `leader_braking`: the least gap
    /// whose worst measurement keeps the front margin, by bisection to a centimetre.
    fn leader_room(
        &self,
        (commitment, window, level): (f32, f32, f32),
        leader_braking: f32,
        leader_speed: f32,
    ) -> f32 {
        let c = &self.config;
        let error = c.sensors.error;
        let a = &self.actuator;
        // The response as the firmware's front takes it: the track's age, a period, the dead
        // time and the lag at the commitment, then the braking ramp.
        let model = FrontModel {
            leader_braking,
            ego_braking: level,
            response_time: self.learnt_after + window + a.dead_time + a.lag,
            response_acceleration: commitment,
            ramp_from: commitment,
            jerk: c.certificate.brake_jerk,
            max_speed: self.follower.max_speed,
        };
        // The stopped ego read fast, then the box around that reading ([`RearBox`]).
        let ego_high = RearBox::around_gap(c, 0.0, 0.0).ego.1.max(0.0);
        let leader_low = (leader_speed - 2.0 * error.range_rate).max(0.0);
        let keeps = |gap: f32| {
            let measured = gap - (error.range + error.range_relative * gap);
            let least = error.range(measured).0;
            front_value(least, leader_low, ego_high, &model) >= c.certificate.front_margin
        };
        let (mut lo, mut hi) = (0.0f32, 200.0f32);
        while hi - lo > 0.01 {
            let mid = 0.5 * (lo + hi);
            if keeps(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }
}

/// Every row ([`FOLLOWER_GAPS`] by [`COMMITMENTS`] by [`LEVELS`]).
pub fn survey() -> Result<Vec<MoveOffRow>> {
    let deployed = Scene::deployed()?;
    let mut rows = Vec::new();
    for (follower, scene) in [
        ("IDM's accel.", deployed),
        ("speed held", deployed.holding_its_speed()),
    ] {
        for gap in FOLLOWER_GAPS {
            for commitment in COMMITMENTS {
                for level in LEVELS {
                    // From a commitment whose last command takes force as its first may (a release
                    // braked again at once) on.
                    let shortest = (scene.actuator.dead_time / WINDOW_STEP).ceil() as usize;
                    let steps = (LONGEST_WINDOW / WINDOW_STEP) as usize;
                    let found = (shortest..=steps)
                        .map(|k| k as f32 * WINDOW_STEP)
                        .map(|w| (w, scene.rear_value(gap, commitment, w, level)))
                        .find(|&(_, value)| value >= 0.0);
                    let window = found.map(|(w, _)| w);
                    let leader_room = match window {
                        Some(w) => LEADER_BRAKING
                            .iter()
                            .map(|&b| {
                                LEADER_SPEEDS
                                    .iter()
                                    .map(|&v| scene.leader_room((commitment, w, level), b, v))
                                    .collect()
                            })
                            .collect(),
                        None => Vec::new(),
                    };
                    rows.push(MoveOffRow {
                        follower,
                        follower_gap: gap,
                        commitment,
                        level,
                        window,
                        rear_value: found.map(|(_, value)| value),
                        ego_speed: window.map(|w| {
                            scene
                                .move_off(commitment, w)
                                .least_ego(scene.learnt_after + w)
                                .1
                        }),
                        leader_room,
                    });
                }
            }
        }
    }
    Ok(rows)
}

/// Prints the survey and writes `out/move-off.json`.
pub fn run(out: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let rows = survey()?;
    println!(
        "committed move-off from a standstill, follower stopped behind (worst corner of the \
         declared errors; rear margin kept)"
    );
    println!(
        "{:>13} {:>9} {:>10} {:>6} {:>8} {:>8} {:>8}  leader room (m) at 6 m/s^2: v=0/1/2 | at 9.8",
        "follower", "stopped at", "commit", "level", "window", "rear", "v_ego"
    );
    for r in &rows {
        let cell = |x: Option<f32>, unit: &str| {
            x.map_or_else(|| "never".to_string(), |v| format!("{v:.2}{unit}"))
        };
        let rooms: Vec<String> = r
            .leader_room
            .iter()
            .map(|per| {
                per.iter()
                    .map(|g| format!("{g:.1}"))
                    .collect::<Vec<_>>()
                    .join("/")
            })
            .collect();
        println!(
            "{:>13} {:>8.1}m {:>7.2}m/s2 {:>6.1} {:>8} {:>8} {:>8}  {}",
            r.follower,
            r.follower_gap,
            r.commitment,
            r.level,
            cell(r.window, "s"),
            cell(r.rear_value, "m"),
            cell(r.ego_speed, ""),
            rooms.join(" | ")
        );
    }
    let path = out.join("move-off.json");
    std::fs::write(&path, serde_json::to_string_pretty(&rows)?)
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row<'r>(
        rows: &'r [MoveOffRow],
        follower: &str,
        gap: f32,
        commitment: f32,
        level: f32,
    ) -> &'r MoveOffRow {
        rows.iter()
            .find(|r| {
                r.follower == follower
                    && r.follower_gap == gap
                    && r.commitment == commitment
                    && r.level == level
            })
            .expect("a surveyed row")
    }

    /// The survey's two findings. Against the firmware's follower (blind at its IDM's largest
    /// acceleration, 1 m/s^2), a commitment only just above it never certifies, and one at
    /// ISO 15622's largest acceleration needs seconds and a leader far ahead; against a
    /// follower that holds its speed until it reacts, a release braked again at once
    /// certifies behind a follower stopped 2 m back (the IDM's jam distance) or more, with the
    /// leader a few metres ahead; 1.5 m back it does not (the follower's speed at the worst
    /// corner carries the ego speed's error too), but a commitment under 2 s does, with the
    /// leader under 20 m ahead.
    #[test]
    fn a_commitment_outruns_only_a_follower_that_holds_its_speed() {
        let rows = survey().expect("the default table");
        for gap in FOLLOWER_GAPS {
            for level in LEVELS {
                assert_eq!(row(&rows, "IDM's accel.", gap, 1.2, level).window, None);
            }
        }
        let full = row(&rows, "IDM's accel.", 2.0, 2.0, 1.5);
        let window = full.window.expect("certified");
        assert!((4.0..6.0).contains(&window), "{window}");
        assert!(full.leader_room.iter().flatten().all(|&g| g > 50.0));
        for r in rows.iter().filter(|r| r.follower == "speed held") {
            if r.follower_gap >= 2.0 {
                assert_eq!(r.window, Some(WINDOW_STEP * 2.0), "{r:?}");
                assert!(r.leader_room.iter().flatten().all(|&g| g < 6.0), "{r:?}");
            } else {
                assert!(
                    r.window.is_some_and(|w| w > WINDOW_STEP * 2.0 && w < 2.0),
                    "{r:?}"
                );
                assert!(r.leader_room.iter().flatten().all(|&g| g < 20.0), "{r:?}");
            }
        }
    }
}
