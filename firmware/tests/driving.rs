//! The driving interface on the controller alone: engagement from the actuator's reported state,
//! the driver's controls at run time, stop and go, and the gap policy against the certificate. Each
//! plant here is ideal (the command is the acceleration) and the sensors exact, so that what is
//! checked is the controller's own behaviour.

use firmware::{
    CertificateConfig, Config, Controller, DriverError, DriverRequest, Event, Inputs, LawConfig,
    Measurement, Mode, SensorBounds, Track, DEFAULT_TABLE,
};

const NOW: u64 = 10_000_000;
const H: f32 = 0.02;

fn exact() -> Config {
    Config {
        sensors: SensorBounds::EXACT,
        ..Config::default()
    }
}

/// A closed loop with an ideal plant: the leader at `leader` (gap, speed), the ego at `speed`,
/// no follower; `acceleration` is what the actuator reports.
struct Loop {
    gap: f32,
    leader_speed: f32,
    speed: f32,
    k: u64,
    reported: Option<f32>,
}

impl Loop {
    fn inputs(&self) -> Inputs {
        let now = NOW + self.k * 20_000;
        let track = |gap: f32, rel_speed: f32| Measurement::new(Track { gap, rel_speed }, now);
        Inputs {
            leader: track(self.gap, self.leader_speed - self.speed),
            follower: track(f32::INFINITY, 0.0),
            ego_speed: Measurement::new(self.speed, now),
            ego_acceleration: Measurement {
                value: self.reported.unwrap_or(f32::NAN),
                timestamp_us: now,
                valid: self.reported.is_some(),
            },
            driver: None,
            now_us: now,
        }
    }

    /// One period: the controller's command is the ego's acceleration; the leader holds
    /// `leader_acceleration`.
    fn step(&mut self, c: &mut Controller<'_>, leader_acceleration: f32) -> firmware::Command {
        let cmd = c.step(&self.inputs());
        let a = if cmd.mode == Mode::Standby {
            0.0
        } else {
            cmd.acceleration
        };
        let travel = |v: f32, a: f32| {
            let t = if a < 0.0 { (v / -a).min(H) } else { H };
            (v * t + 0.5 * a * t * t, (v + a * t).max(0.0))
        };
        let (dl, vl) = travel(self.leader_speed, leader_acceleration);
        let (de, ve) = travel(self.speed, a);
        self.gap += dl - de;
        self.leader_speed = vl;
        self.speed = ve;
        self.reported = self.reported.map(|_| a);
        self.k += 1;
        cmd
    }
}

/// No jab at engagement: engaged at the gap policy's distance behind a car at
/// 20 m/s, with the actuator reporting that the car neither accelerates nor brakes, the first
/// 0.8 s stay within ISO 15622's braking jerk at 20 m/s (2.5 m/s^3, 0.05 m/s^2 a period) of
/// that. Not reported, the band's top (2 m/s^2) must be assumed, and the same engagement
/// brakes harder at once (the cause of the jab before).
#[test]
fn engagement_starts_from_what_the_car_is_doing() {
    let probe = Controller::new(DEFAULT_TABLE, exact());
    let gap = probe.desired_gap(20.0);
    let run = |reported: Option<f32>| {
        let mut c = Controller::new(DEFAULT_TABLE, exact());
        let mut l = Loop {
            gap,
            leader_speed: 20.0,
            speed: 20.0,
            k: 0,
            reported,
        };
        (0..40)
            .map(|_| l.step(&mut c, 0.0).acceleration)
            .collect::<Vec<f32>>()
    };
    let known = run(Some(0.0));
    let mut last = 0.0f32;
    for (k, a) in known.iter().enumerate() {
        assert!(*a >= last - 0.05 - 1e-5, "{k}: {a} after {last}");
        last = *a;
    }
    assert!(known.iter().all(|a| *a > -0.5), "{known:?}");
    let unknown = run(None);
    assert!(unknown[0] < -1.0, "{unknown:?}");
}

/// Set speed and time gap change at run time, through the API and through the inputs, and the
/// command history is kept: no jab, no override, the same controller.
#[test]
fn the_drivers_controls_change_the_law_not_the_history() {
    let mut c = Controller::new(DEFAULT_TABLE, exact());
    let mut l = Loop {
        gap: 1e4,
        leader_speed: 30.0,
        speed: 25.0,
        k: 0,
        reported: Some(0.0),
    };
    for _ in 0..500 {
        l.step(&mut c, 0.0);
    }
    assert!((l.speed - 30.0).abs() < 0.3, "{}", l.speed);
    c.request(DriverRequest::SetSpeed(20.0)).unwrap();
    assert_eq!(c.driver().set_speed, 20.0);
    let mut last = c.step(&l.inputs()).acceleration;
    l.k += 1;
    for k in 0..1_500 {
        let cmd = l.step(&mut c, 0.0);
        assert_eq!(cmd.mode, Mode::Nominal, "{k}: {cmd:?}");
        // ISO 15622's jerk at these speeds, and the speed law's 1.5 m/s^2 at most (plus the
        // little its integral holds).
        assert!(cmd.acceleration >= last - 0.05 - 1e-5, "{k}: {cmd:?}");
        assert!(cmd.acceleration >= -1.6, "{k}: {cmd:?}");
        last = cmd.acceleration;
    }
    assert!((l.speed - 20.0).abs() < 0.3, "{}", l.speed);
    // The time gap through the inputs; a setting that does not exist is refused and logged.
    let mut i = l.inputs();
    i.driver = Some(DriverRequest::TimeGap(0));
    c.step(&i);
    assert_eq!(c.driver().time_gap_setting, 0);
    let mut i = l.inputs();
    i.now_us += 20_000;
    i.driver = Some(DriverRequest::TimeGap(9));
    c.step(&i);
    assert_eq!(c.driver().time_gap_setting, 0);
    assert!(c.events().any(|e| matches!(
        e,
        Event::DriverRequestRefused {
            error: DriverError::NoSuchTimeGap,
            ..
        }
    )));
    assert_eq!(
        c.request(DriverRequest::SetSpeed(f32::NAN)),
        Err(DriverError::SetSpeedOutOfRange)
    );
    assert_eq!(
        c.request(DriverRequest::SetSpeed(60.0)),
        Err(DriverError::SetSpeedOutOfRange)
    );
    assert_eq!(c.driver().set_speed, 20.0);
}

/// Cancel: standby, nothing for the actuator; resume: engaged again from the actuator's
/// reported state, with the set speed kept; SET: engaged at the speed driven.
#[test]
fn cancel_resume_and_set() {
    let mut c = Controller::new(DEFAULT_TABLE, exact());
    let mut l = Loop {
        gap: 1e4,
        leader_speed: 30.0,
        speed: 25.0,
        k: 0,
        reported: Some(0.0),
    };
    for _ in 0..50 {
        l.step(&mut c, 0.0);
    }
    c.request(DriverRequest::Cancel).unwrap();
    for _ in 0..50 {
        let cmd = l.step(&mut c, 0.0);
        assert_eq!(cmd.mode, Mode::Standby);
        assert_eq!(cmd.acceleration, 0.0);
    }
    assert!(!c.driver().engaged);
    c.request(DriverRequest::Resume).unwrap();
    let cmd = l.step(&mut c, 0.0);
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    assert!(cmd.acceleration.abs() <= 0.2 + 0.05 + 1e-5, "{cmd:?}");
    assert_eq!(c.driver().set_speed, Config::default().law.set_speed);
    let mut i = l.inputs();
    i.driver = Some(DriverRequest::Engage);
    c.step(&i);
    assert!((c.driver().set_speed - l.speed).abs() < 1e-3);
}

/// Stop and go (ISO 15622's full-speed-range type): behind a car that stops, the ego stops at
/// the standstill gap without a crawl and holds; a leader that moves off within
/// `auto_resume_us` is followed at once, one that waits longer needs the driver's resume.
#[test]
fn stop_hold_and_go() {
    let stop = |wait: f32, resume: bool| {
        let mut c = Controller::new(DEFAULT_TABLE, exact());
        let mut l = Loop {
            gap: c.desired_gap(10.0),
            leader_speed: 10.0,
            speed: 10.0,
            k: 0,
            reported: Some(0.0),
        };
        // The leader brakes at 1 m/s^2 to a stop.
        let mut slow_since = None;
        let mut stopped_at = None;
        for k in 0..3_000u64 {
            let a = if l.leader_speed > 0.0 { -1.0 } else { 0.0 };
            l.step(&mut c, a);
            if l.speed <= 1.0 && slow_since.is_none() && l.leader_speed == 0.0 {
                slow_since = Some(k);
            }
            if l.speed == 0.0 {
                stopped_at = Some(k);
                break;
            }
        }
        let (from, at) = (slow_since.unwrap(), stopped_at.unwrap());
        let standstill = Config::default().law.standstill_gap;
        assert!(
            (at - from) as f32 * H < 3.0,
            "{} s below 1 m/s",
            (at - from) as f32 * H
        );
        assert!((l.gap - standstill).abs() <= 0.5, "{}", l.gap);
        // Held for `wait` seconds, then the leader moves off at 1.5 m/s^2.
        for _ in 0..(wait / H) as u64 {
            let cmd = l.step(&mut c, 0.0);
            assert!(cmd.acceleration < 0.0, "{cmd:?}");
            assert_eq!(l.speed, 0.0);
        }
        if resume {
            c.request(DriverRequest::Resume).unwrap();
        }
        for _ in 0..150 {
            l.step(&mut c, 1.5);
        }
        l.speed
    };
    assert!(stop(1.0, false) > 0.5);
    assert_eq!(stop(5.0, false), 0.0);
    assert!(stop(5.0, true) > 0.5);
}

/// The gap policy keeps the law's room over the certificate's steady-following gap at every
/// speed and setting, and the braking ramp's cost is in that gap.
#[test]
fn the_gap_policy_keeps_room_over_the_certificate() {
    for setting in 0..firmware::controller::TIME_GAP_SETTINGS as u8 {
        let config = Config {
            law: LawConfig {
                time_gap_setting: setting,
                ..Config::default().law
            },
            ..Config::default()
        };
        let c = Controller::new(DEFAULT_TABLE, config);
        for k in 0..=140 {
            let v = k as f32 * 0.25;
            // The room is the gap for closing at `gap_room_speed`: at least what that closing
            // speed covers through the actuator's dead time and lag where the leader braking
            // at its hardest does not stop within them (slower, the room is the difference of
            // the leader's stopping distances, less).
            let certified = c.law_certified_gap(v);
            let response =
                (config.plant.actuator_dead_time_us + config.plant.actuator_lag_us) as f32 * 1e-6;
            if v >= 10.0 {
                assert!(
                    certified - c.steady_gap(v) >= config.law.gap_room_speed * response,
                    "{v}"
                );
            }
            assert!(
                c.desired_gap(v) >= certified + config.law.gap_room - 1e-3,
                "{v}"
            );
            assert!(c.desired_gap(v) >= config.law.standstill_gap + config.time_gap(setting) * v);
        }
    }
    let step = Controller::new(
        DEFAULT_TABLE,
        Config {
            certificate: CertificateConfig {
                brake_jerk: f32::INFINITY,
                ..Config::default().certificate
            },
            ..Config::default()
        },
    );
    let ramp = Controller::new(DEFAULT_TABLE, Config::default());
    // At 30 m/s the ramp from 0 to -3.5 m/s^2 at 2.5 m/s^3 lasts 1.4 s: about 0.7 s of speed.
    let cost = ramp.steady_gap(30.0) - step.steady_gap(30.0);
    assert!((15.0..30.0).contains(&cost), "{cost}");
}

/// The steady gap for another leader or braking, against figures worked out by hand: with the
/// ego braking no harder than either leader, both cars stop before the closest point is passed,
/// so the gap needed against a leader at 9.8 m/s^2 exceeds the one at 6 m/s^2 by what the
/// leader no longer covers, `v_L^2 / 2 (1/6 - 1/9.8)` (for the worst corner's leader speed
/// `v_L`), scaled by the range error's `1 + r`; the table's own model gives `steady_gap`; a
/// harder braking needs less room.
#[test]
fn the_steady_gap_for_another_leader_or_braking_matches_the_figures_by_hand() {
    let config = Config::default();
    let c = Controller::new(DEFAULT_TABLE, config);
    let comfort = firmware::Braking {
        level: 3.5,
        jerk: config.certificate.brake_jerk,
    };
    let sensors = config.sensors;
    for v in [10.0f32, 20.0, 30.0] {
        assert_eq!(c.steady_gap_with(v, 6.0, comfort), c.steady_gap(v));
        let v_l = sensors.ego_speed(v).0 + sensors.range_rate(0.0).0;
        let by_hand =
            (1.0 + sensors.error.range_relative) * v_l * v_l / 2.0 * (1.0 / 6.0 - 1.0 / 9.8);
        let more = c.steady_gap_with(v, 9.8, comfort) - c.steady_gap(v);
        assert!(
            (more - by_hand).abs() < 1e-3 * (1.0 + by_hand),
            "{v}: {more} vs {by_hand}"
        );
        let emergency = firmware::Braking {
            level: 8.0,
            jerk: 12.0,
        };
        assert!(c.steady_gap_with(v, 9.8, emergency) < c.steady_gap_with(v, 9.8, comfort) - 10.0);
    }
}

/// An engagement from standby into a state the certificate does not certify (here a stopped
/// car 30 m ahead at 25 m/s) is refused with its reason, and the car stays in standby: engaged,
/// the certificate would have nothing to keep and the first step would brake at beta. The
/// standby commands carry the certificate's margin, so that the driver sees when the car can be
/// engaged; once the road ahead is clear again, the same resume is taken.
#[test]
fn an_engagement_into_an_uncertified_state_is_refused_and_the_car_stays_in_standby() {
    let mut c = Controller::new(DEFAULT_TABLE, exact());
    let mut l = Loop {
        gap: 1e4,
        leader_speed: 25.0,
        speed: 25.0,
        k: 0,
        reported: Some(0.0),
    };
    for _ in 0..50 {
        l.step(&mut c, 0.0);
    }
    c.request(DriverRequest::Cancel).unwrap();
    // No standby period since the cancel: nothing to judge an engagement by.
    assert_eq!(
        c.request(DriverRequest::Resume),
        Err(DriverError::CertificateUnknown)
    );
    let cmd = l.step(&mut c, 0.0);
    assert_eq!(cmd.mode, Mode::Standby);
    assert!(cmd.margin.is_some_and(|m| m > 0.0), "{cmd:?}");
    // A stopped car 30 m ahead.
    l.gap = 30.0;
    l.leader_speed = 0.0;
    let cmd = l.step(&mut c, 0.0);
    assert!(cmd.margin.is_some_and(|m| m <= 0.0), "{cmd:?}");
    for request in [DriverRequest::Resume, DriverRequest::Engage] {
        assert_eq!(c.request(request), Err(DriverError::NotCertified));
    }
    assert!(!c.driver().engaged);
    // Through the step's inputs (CAN) too: refused, logged, and the step stays in standby.
    let mut i = l.inputs();
    i.driver = Some(DriverRequest::Resume);
    let cmd = c.step(&i);
    assert_eq!((cmd.mode, cmd.acceleration), (Mode::Standby, 0.0));
    assert!(c.events().any(|e| matches!(
        e,
        Event::DriverRequestRefused {
            error: DriverError::NotCertified,
            ..
        }
    )));
    // A SET speed is not an engagement: taken in standby.
    c.request(DriverRequest::SetSpeed(20.0)).unwrap();
    // The road clears: the resume is taken, and the next step drives.
    l.gap = 1e4;
    l.leader_speed = 25.0;
    l.step(&mut c, 0.0);
    c.request(DriverRequest::Resume).unwrap();
    let cmd = l.step(&mut c, 0.0);
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    assert!(!cmd.emergency);
}

/// Every refusal and every fault reads as a sentence for the driver's display and the log: each
/// message is non-empty and no two are the same (the table's own error is carried into its
/// fault's).
#[test]
fn refusals_and_faults_say_what_is_wrong() {
    use firmware::Fault;
    let driver = [
        DriverError::SetSpeedOutOfRange,
        DriverError::NoSuchTimeGap,
        DriverError::NotCertified,
        DriverError::CertificateUnknown,
        DriverError::NeedsEmergencyBraking,
    ]
    .map(|e| e.to_string());
    let faults = [
        Fault::Table(firmware::table_format::Error::BadMagic),
        Fault::WrongGame,
        Fault::LeaderInvalid,
        Fault::LeaderStale,
        Fault::FollowerInvalid,
        Fault::FollowerStale,
        Fault::EgoSpeedInvalid,
        Fault::EgoSpeedStale,
        Fault::OutsideDomain { axis: 1 },
        Fault::RearBoxTooWide { axis: 2 },
        Fault::ClockWentBackwards,
        Fault::InvalidConfig,
        Fault::TableOutsideEnvelope,
        Fault::EmergencyDeclarationDiffers,
        Fault::ClockJumped,
        Fault::TableNotVerified,
        Fault::TableCheckedForLessError,
        Fault::AfterEmergencyBraking,
        Fault::RestartedAfterFault,
    ]
    .map(|e| e.to_string());
    let all: Vec<&String> = driver.iter().chain(&faults).collect();
    for (k, m) in all.iter().enumerate() {
        assert!(!m.is_empty(), "{k}");
        assert!(all[..k].iter().all(|o| o != m), "{m} twice");
    }
    assert!(faults[0].contains("bad magic"), "{}", faults[0]);
    assert!(faults[8].contains("axis 1"), "{}", faults[8]);
}

/// The certifier refuses what the controller refuses: a configuration outside the limits the
/// certificate is argued for (here the paper's bang-bang override with two authorities, which
/// grade theirs) gets `Fault::InvalidConfig` from `Certifier::new` as from `Controller::new`,
/// so that no host tool argues with a certificate the firmware would not run.
#[test]
fn the_certifier_refuses_a_configuration_the_controller_refuses() {
    use firmware::{Authorities, Certifier, Fault};
    let bang_bang = Config::bang_bang();
    let config = Config {
        certificate: CertificateConfig {
            authorities: Authorities::Two,
            ..bang_bang.certificate
        },
        ..bang_bang
    };
    assert!(!config.is_valid());
    let table = firmware::table_format::Table::parse(DEFAULT_TABLE).unwrap();
    assert_eq!(
        Certifier::new(table, &config).err(),
        Some(Fault::InvalidConfig)
    );
    assert!(Controller::new(DEFAULT_TABLE, config).table().is_none());
    let table = firmware::table_format::Table::parse(DEFAULT_TABLE).unwrap();
    assert!(Certifier::new(table, &Config::default()).is_ok());
}

/// With two authorities an engagement is taken only where the follower leaves the first
/// engaged commands a comfortable way to brake: as a follower at the ego's speed drops back
/// from 4 to 40 m behind (a leader 100 m ahead, the declared errors at the box's worst corner
/// for the front), SET is refused as uncertified, then for want of a comfortable way
/// (`DriverError::NeedsEmergencyBraking`: the state is certified, but only by commands that
/// would drop faster than ISO 15622's jerk limit), then taken, in that order and each at
/// least once, at 8.3, 15 and 25 m/s. The comfort band alone (the paper's follower, which
/// brakes at once) takes every one of them.
#[test]
fn an_engagement_the_follower_leaves_no_comfortable_way_is_refused() {
    for authorities in [
        firmware::Authorities::ComfortBand,
        firmware::Authorities::Two,
    ] {
        let config = Config {
            certificate: CertificateConfig {
                authorities,
                ..CertificateConfig::default()
            },
            ..Config::default()
        };
        let two = authorities == firmware::Authorities::Two;
        let s = config.sensors;
        let long = |g: f32| g + s.error.range + s.error.range_relative * g;
        let mut c = Controller::new(DEFAULT_TABLE, config);
        let _ = c.request(DriverRequest::Cancel);
        let mut k = 0u64;
        for speed in [8.3f32, 15.0, 25.0] {
            // 0: not certified, 1: no comfortable way, 2: taken.
            let mut verdicts = Vec::new();
            for gap_follower in (0..13).map(|i| 4.0 + 3.0 * i as f32) {
                for _ in 0..2 {
                    let now = NOW + k * 20_000;
                    k += 1;
                    let track = |gap: f32| {
                        Measurement::new(
                            Track {
                                gap: long(gap),
                                rel_speed: s.error.range_rate,
                            },
                            now,
                        )
                    };
                    let measured = speed - s.error.ego_speed - s.error.ego_speed_relative * speed;
                    let cmd = c.step(&Inputs {
                        leader: track(100.0),
                        follower: track(gap_follower),
                        ego_speed: Measurement::new(measured, now),
                        ego_acceleration: Measurement::new(-s.acceleration_error, now),
                        driver: None,
                        now_us: now,
                    });
                    assert_eq!(cmd.mode, Mode::Standby);
                }
                verdicts.push(match c.request(DriverRequest::Engage) {
                    Err(DriverError::NotCertified) => 0,
                    Err(DriverError::NeedsEmergencyBraking) => 1,
                    Ok(()) => {
                        c.request(DriverRequest::Cancel).unwrap();
                        2
                    }
                    Err(e) => panic!("{speed} m/s, {gap_follower} m: {e}"),
                });
            }
            if two {
                assert!(verdicts.is_sorted(), "{speed} m/s: {verdicts:?}");
                for verdict in 0..3 {
                    assert!(verdicts.contains(&verdict), "{speed} m/s: {verdicts:?}");
                }
            } else {
                assert!(
                    verdicts.iter().all(|&v| v == 2),
                    "{speed} m/s: {verdicts:?}"
                );
            }
        }
    }
}
