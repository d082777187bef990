//! No phantom braking: measurement noise within the declared bounds never makes an emergency
//! while the true state is certified. The reproductions of an outside search, as regression
//! tests.

use firmware::{Config, DriverRequest};
use host_tests::humans::HumanModel;
use host_tests::sim::{ActuatorModel, Car, Channel, Noise};
use host_tests::world::{Start, Tolerances, World};
use host_tests::SensorModel;
use table_format::Table;

/// The firmware's declared actuator limits: 100 ms dead time, 0.3 s lag.
const ACTUATOR_AT_LIMITS: ActuatorModel = ActuatorModel {
    dead_time: 0.1,
    lag: 0.3,
};

/// Cars from `(gap_leader, v_leader, gap_follower, v_follower, v_ego)`, the ego at 0.
fn cars([gap_leader, v_leader, gap_follower, v_follower, v_ego]: [f32; 5]) -> [Car; 3] {
    [
        Car {
            x: gap_leader,
            v: v_leader,
        },
        Car { x: 0.0, v: v_ego },
        Car {
            x: -gap_follower,
            v: v_follower,
        },
    ]
}

/// What an episode showed: the first emergency (time, and the true certificate's margin there)
/// and whether the true state ever left the certified set.
#[derive(Debug)]
struct Seen {
    first_emergency: Option<(f32, f32)>,
    lost: bool,
    collided: bool,
}

/// Drives `world` for `seconds` with the leader and follower accelerations `humans` gives, and
/// records the first emergency with the true state's certificate margin at that step.
fn drive(
    world: &mut World<'_>,
    seconds: f32,
    mut humans: impl FnMut(&World<'_>) -> (f32, f32),
) -> Seen {
    let mut first_emergency = None;
    let steps = (seconds / world.period_seconds()).round() as usize;
    for _ in 0..steps {
        let t = world.time();
        let (a_leader, a_follower) = humans(world);
        if !world.step(a_leader, a_follower, None) {
            break;
        }
        if let Some((command, certificate)) = world.last() {
            if command.emergency && first_emergency.is_none() {
                first_emergency = Some((t, certificate.map_or(f32::NAN, |c| c.margin())));
            }
        }
    }
    let score = world.score();
    Seen {
        first_emergency,
        lost: score.certificate_lost.is_some(),
        collided: score.collision_time.is_some(),
    }
}

/// Tracks `latency_us` old on every delivery, refreshed every period; the ego's speed fresh.
fn sensors(noise: Noise, latency_us: u32) -> SensorModel {
    let track = Channel {
        latency_us,
        ..Channel::IDEAL
    };
    SensorModel {
        noise,
        bounds: Config::default().sensors,
        channels: [track, track, Channel::IDEAL],
    }
}

/// The first reproduction: a fast ego far behind a stopped leader, engaged accelerating, the
/// set speed at the top, the tracks nearly at their covered age, every error at the front's
/// worst corner except the ego's speed, whose error flips between its ends every 100 ms. The
/// measured ego speed's top end pushed the speed headroom below zero while the truth kept
/// +0.65 m/s of it, and the step braked at beta at once (-0.21 to -3.5 m/s^2 in one period).
#[test]
fn ego_speed_error_flipping_at_the_domains_top_makes_no_emergency() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let model = HumanModel::of(&table).unwrap();
    let start = Start {
        cars: cars([222.957, 0.0, 23.4839, 1.52636, 33.5992]),
        engaged_acceleration: 1.1905,
    };
    for latency_us in [900_000, 960_000, 980_000] {
        let mut world = World::new(
            firmware::DEFAULT_TABLE,
            Config::default(),
            model,
            start,
            sensors(Noise::EgoSpeedFlipping { period_us: 100_000 }, latency_us),
            ACTUATOR_AT_LIMITS,
            Tolerances::default(),
            1,
        );
        world.request(DriverRequest::SetSpeed(35.0)).ok();
        let seen = drive(&mut world, 20.0, |w| {
            let [leader, _, follower] = w.cars();
            let ego = w.cars()[1];
            let a_follower =
                model.follower_acceleration(follower.v, ego.v, ego.x - follower.x, 1.0);
            let _ = leader;
            (0.0, a_follower)
        });
        println!("tracks {latency_us} us old: {seen:?}");
        assert!(!seen.lost && !seen.collided, "{seen:?}");
        assert!(
            seen.first_emergency.is_none(),
            "tracks {} ms old: an emergency at {:?} while the truth stayed certified",
            latency_us / 1000,
            seen.first_emergency
        );
    }
}

/// A stop-and-go leader that brakes at `braking` to standstill, waits 2 s, pulls away at
/// 1.5 m/s^2 to 20 m/s and cruises 5 s, again and again: its acceleration for the car `leader`
/// at `t` seconds into a cycle that `phase` keeps.
struct StopAndGo {
    braking: f32,
    /// 0 cruise, 1 brake, 2 wait, 3 pull away; and when the phase began, s.
    phase: (u8, f32),
}

impl StopAndGo {
    fn acceleration(&mut self, leader: Car, t: f32) -> f32 {
        let (phase, since) = self.phase;
        let next = match phase {
            0 if t - since >= 5.0 => Some(1),
            1 if leader.v <= 0.0 => Some(2),
            2 if t - since >= 2.0 => Some(3),
            3 if leader.v >= 20.0 => Some(0),
            _ => None,
        };
        if let Some(p) = next {
            self.phase = (p, t);
        }
        match self.phase.0 {
            1 if leader.v > 0.0 => -self.braking,
            3 => 1.5,
            _ => 0.0,
        }
    }
}

/// A search around the second reproduction (stop-and-go at 3.5 m/s^2, tracks jittering up to
/// 1 s, the errors' corners flipping, emergencies with 3.1 m and 40 m of true front margin; its
/// exact settings were not recorded): steady following into a stop-and-go leader braking at
/// 3.5 m/s^2, 60 ms track cycles with 100 ms latency and 0.3, 0.9 or 1.1 s of jitter (the last
/// past the covered age: lost tracks and the fallback), the ego speed's error or every error
/// switching corners every 20, 100 or 500 ms, or random corners per measurement. 540 episodes
/// of 120 s: no emergency, no collision, no certificate loss. (Without the noise rule, every
/// episode has an emergency.)
#[test]
fn flipping_corners_in_stop_and_go_make_no_emergency() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let model = HumanModel::of(&table).unwrap();
    let probe = firmware::Controller::new(firmware::DEFAULT_TABLE, Config::default());
    let v = 20.0;
    let start = Start {
        cars: cars([probe.desired_gap(v) + 5.0, v, 40.0, v, v]),
        engaged_acceleration: 0.0,
    };
    let (mut emergencies, mut episodes, mut stops) = (Vec::new(), 0, 0);
    for period_us in [20_000, 100_000, 500_000] {
        let noises = [
            Noise::EgoSpeedFlipping { period_us },
            Noise::CornersFlipping { period_us },
            Noise::RandomCorners,
        ];
        for jitter_us in [300_000, 900_000, 1_100_000] {
            for noise in noises {
                for seed in 0..20 {
                    let track = Channel {
                        cycle_us: 60_000,
                        latency_us: 100_000,
                        jitter_us,
                        ..Channel::IDEAL
                    };
                    let sensors = SensorModel {
                        noise,
                        bounds: Config::default().sensors,
                        channels: [track, track, Channel::IDEAL],
                    };
                    let mut world = World::new(
                        firmware::DEFAULT_TABLE,
                        Config::default(),
                        model,
                        start,
                        sensors,
                        ACTUATOR_AT_LIMITS,
                        Tolerances::default(),
                        seed,
                    );
                    let mut leader = StopAndGo {
                        braking: 3.5,
                        phase: (0, 0.0),
                    };
                    let seen = drive(&mut world, 120.0, |w| {
                        let [l, e, f] = w.cars();
                        let a_follower = model.follower_acceleration(f.v, e.v, e.x - f.x, 1.0);
                        (leader.acceleration(l, w.time()), a_follower)
                    });
                    episodes += 1;
                    assert!(!seen.lost && !seen.collided, "{noise:?} {seed}: {seen:?}");
                    assert!(world.time() >= 119.9, "ended at {} s", world.time());
                    stops += world.score().leader_stops;
                    if let Some(e) = seen.first_emergency {
                        emergencies.push((noise, jitter_us, seed, e));
                    }
                }
            }
        }
    }
    println!(
        "{} emergencies in {episodes} episodes ({stops} leader stops)",
        emergencies.len()
    );
    assert!(stops >= 4 * episodes, "the leader stopped {stops} times");
    assert!(
        emergencies.is_empty(),
        "emergencies with the truth certified (noise, jitter, seed, (time, true margin)): {:?}",
        &emergencies[..emergencies.len().min(5)]
    );
}

/// The world tells emergencies apart by cause, with the truth the firmware cannot see: an
/// engagement whose state is not certified, a cut-in, and (with the paper's bang-bang policy,
/// which jumps to beta whenever its look-ahead refuses) emergencies the true state did not need.
#[test]
fn emergencies_are_told_apart_by_cause() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let model = HumanModel::of(&table).unwrap();
    let world = |config: Config, state: [f32; 5]| {
        World::new(
            firmware::DEFAULT_TABLE,
            config,
            model,
            Start {
                cars: cars(state),
                engaged_acceleration: 0.0,
            },
            SensorModel::IDEAL,
            ACTUATOR_AT_LIMITS,
            Tolerances::default(),
            1,
        )
    };
    let follow = |w: &World<'_>| {
        let [_, e, f] = w.cars();
        model.follower_acceleration(f.v, e.v, e.x - f.x, 1.0)
    };
    // Engaged 40 m behind a stopped car at 20 m/s: not certified, beta at once.
    let mut w = world(Config::default(), [40.0, 0.0, 1e3, 20.0, 20.0]);
    drive(&mut w, 3.0, |w| (0.0, follow(w)));
    let e = w.score().emergencies;
    assert!(e.engagement > 0, "{e:?}");
    assert_eq!((e.cut_in, e.certified_truth), (0, 0), "{e:?}");
    // Steady following, then a car cuts in 8 m ahead, 5 m/s slower.
    let probe = firmware::Controller::new(firmware::DEFAULT_TABLE, Config::default());
    let mut w = world(
        Config::default(),
        [probe.desired_gap(20.0), 20.0, 1e3, 20.0, 20.0],
    );
    drive(&mut w, 5.0, |w| (0.0, follow(w)));
    w.cut_in(host_tests::world::CutInKind::Leader, 8.0, -5.0);
    drive(&mut w, 5.0, |w| (0.0, follow(w)));
    let e = w.score().emergencies;
    assert!(e.cut_in > 0, "{e:?}");
    assert_eq!((e.engagement, e.certified_truth), (0, 0), "{e:?}");
    // The bang-bang policy behind a leader braking as hard as the model allows, from the gap
    // policy's distance: its override jumps to beta while the truth is certified.
    let mut w = world(
        Config::bang_bang(),
        [probe.desired_gap(20.0), 20.0, 1e3, 20.0, 20.0],
    );
    let seen = drive(&mut w, 20.0, |w| {
        let leader = w.cars()[0];
        (if leader.v > 0.0 { -6.0 } else { 0.0 }, follow(w))
    });
    let e = w.score().emergencies;
    assert!(!seen.lost && !seen.collided, "{seen:?}");
    assert!(e.certified_truth > 0, "{e:?}");
    assert_eq!(
        (e.engagement, e.cut_in, e.uncertified_truth),
        (0, 0, 0),
        "{e:?}"
    );
    // A leader braking at 9.8 m/s^2, beyond its model's 6, 1 m beyond the certificate's
    // steady gap: the truth leaves the certified set and the firmware, seeing that not even
    // the best corner is certified, brakes at beta.
    let mut w = world(
        Config::default(),
        [probe.steady_gap(20.0) + 1.0, 20.0, 1e3, 20.0, 20.0],
    );
    drive(&mut w, 10.0, |w| {
        let leader = w.cars()[0];
        (if leader.v > 0.0 { -9.8 } else { 0.0 }, follow(w))
    });
    let e = w.score().emergencies;
    assert!(e.uncertified_truth > 0, "{e:?}");
    assert_eq!(
        (e.engagement, e.cut_in, e.certified_truth),
        (0, 0, 0),
        "{e:?}"
    );
}

/// Campaign episodes (a leader braking as hard as its model allows, the datasheet radars) that
/// braked at beta while the true state was certified: seeds 1, 35, 120 and 179, because the
/// test of the truth re-applied the delays' hold of the largest recent command (+2 m/s^2, while
/// the ramp was down at -1.7) from every new measurement; seed 321, because a measurement on
/// the exact edge of what the leader could have closed to was taken, by `f32` rounding, for a
/// new vehicle, and the certified chain was dropped.
#[test]
fn campaign_episodes_that_braked_with_the_truth_certified_no_longer_do() {
    use host_tests::campaign::{run_episode, Episode, Sensing};
    use host_tests::{Follower, Leader};
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    for seed in [1, 35, 120, 179, 321] {
        let e = Episode {
            leader: Leader::HardBrake,
            follower: Follower::IdmFixed,
            seconds: 20.0,
            sensors: Sensing::Datasheet,
            cut_in: None,
            actuator: ACTUATOR_AT_LIMITS,
            config: Config::default(),
            seed,
        };
        let o = run_episode(&table, firmware::DEFAULT_TABLE, &e, None).unwrap();
        assert!(!o.collided && o.certificate_lost.is_none(), "seed {seed}");
        assert_eq!(
            o.emergencies.certified_truth, 0,
            "seed {seed}: {:?}",
            o.emergencies
        );
    }
}
