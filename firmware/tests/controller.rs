//! The controller on the host, with the default table: modes, faults, and a closed loop.

use firmware::table_format::{self, Game, MeasurementError, Table};
use firmware::{
    Braking, CertificateConfig, Command, Config, Controller, EmergencyDeclaration, FallbackConfig,
    Fault, Inputs, LawConfig, Measurement, Mode, PlantConfig, SensorBounds, Track, DEFAULT_TABLE,
};
use proptest::prelude::*;

mod common;
use common::{ideal, table_for};

const NOW: u64 = 10_000_000;

fn inputs(leader: (f32, f32), follower: (f32, f32), ego_speed: f32) -> Inputs {
    Inputs {
        leader: Measurement::new(
            Track {
                gap: leader.0,
                rel_speed: leader.1,
            },
            NOW - 5_000,
        ),
        follower: Measurement::new(
            Track {
                gap: follower.0,
                rel_speed: follower.1,
            },
            NOW - 5_000,
        ),
        ego_speed: Measurement::new(ego_speed, NOW - 1_000),
        ego_acceleration: Measurement::new(0.0, NOW - 1_000),
        driver: None,
        now_us: NOW,
    }
}

fn controller() -> Controller<'static> {
    Controller::new(DEFAULT_TABLE, ideal())
}

/// `config` without an emergency authority (its level at the band's): for the tests of the
/// band's own certificate, whose first steps (an engagement, with nothing issued yet) would
/// otherwise be answered below the band (tests/emergency.rs).
fn band_only(config: Config) -> Config {
    let (beta, _, _) = band_and_leader();
    Config {
        certificate: CertificateConfig {
            emergency: EmergencyDeclaration {
                braking: Braking {
                    level: -beta,
                    ..config.certificate.emergency.braking
                },
                ..config.certificate.emergency
            },
            ..config.certificate
        },
        ..config
    }
}

/// A controller for `config` on the default table with `config`'s emergency declaration.
fn declared(config: Config) -> Controller<'static> {
    Controller::new(table_for(&config), config)
}

fn fault_of(c: Command) -> Fault {
    assert_eq!(c.mode, Mode::MinimumRisk, "{c:?}");
    c.fault.expect("a minimum-risk manoeuvre names its fault")
}

/// The default table's band `[-beta, a_max]` and the leader's hardest braking.
fn band_and_leader() -> (f32, f32, f32) {
    match Table::parse(DEFAULT_TABLE).unwrap().header().game {
        Game::ThreeCarSplit { ego, leader, .. } => (ego.min, ego.max, -leader.min),
        g => panic!("not a split table: {g:?}"),
    }
}

#[test]
fn the_default_table_is_accepted() {
    let c = controller();
    let t = c.table().expect("default table parses");
    assert_eq!(t.dims(), 3);
    assert!(matches!(t.header().game, Game::ThreeCarSplit { .. }));
    // Table and code fit an STM32F407's 1 MiB of flash.
    assert!(DEFAULT_TABLE.len() <= 768 * 1024);
    // The solver stopped at the first iterate `solver verify` proved, and recorded the proof.
    assert!(matches!(
        t.header().horizon.status,
        table_format::HorizonStatus::Proven { .. }
    ));
    assert!(t.header().verification.is_some_and(|v| v.is_complete()));
}

#[test]
fn cruising_with_room_runs_the_nominal_law() {
    let mut c = controller();
    let cmd = c.step(&inputs((100.0, 0.0), (40.0, 0.0), 25.0));
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    assert!(cmd.fault.is_none());
    assert!(cmd.margin.unwrap() > 0.0);
    // The nominal law closes in on a distant leader, towards the set speed: it accelerates.
    assert!(cmd.acceleration > 0.0, "{cmd:?}");
}

#[test]
fn at_standstill_behind_a_stopped_leader_the_certificate_holds() {
    // Everyone stopped: 3 m to the leader, the follower at its jam distance behind.
    let mut c = controller();
    let cmd = c.step(&inputs((3.0, 0.0), (2.5, 0.0), 0.0));
    assert!(cmd.fault.is_none(), "{cmd:?}");
    assert!(cmd.margin.unwrap() > 0.0, "{cmd:?}");
}

#[test]
fn closing_fast_on_the_leader_brakes_at_the_certificates_level() {
    let (beta, _, _) = band_and_leader();
    // 25 m/s, the leader 30 m ahead at 15 m/s: the nominal law's -3.5 m/s^2 at most would not
    // keep the front value above the margin for another period, so the override brakes at beta
    // without an emergency authority,
    let mut c = declared(band_only(ideal()));
    let cmd = c.step(&inputs((30.0, -10.0), (40.0, 0.0), 25.0));
    assert_eq!(cmd.mode, Mode::Override, "{cmd:?}");
    assert_eq!(cmd.acceleration, beta);
    // and harder with one (the follower 40 m back at the same speed allows it), flagged an
    // emergency with the rear half unknown after it.
    let cmd = controller().step(&inputs((30.0, -10.0), (40.0, 0.0), 25.0));
    assert!(
        cmd.acceleration < beta && cmd.emergency && cmd.takeover,
        "{cmd:?}"
    );
    assert_eq!(cmd.fault, Some(Fault::AfterEmergencyBraking), "{cmd:?}");
}

/// The jerk limit is inside the certificate, so near the margin the car starts
/// braking earlier, not harder. Both at 25 m/s, the gap 0.05 m above the margin for a braking
/// ramp from the last command (zero), and the leader brakes at its model's hardest (6 m/s^2)
/// to a stop: every command is within the ramp's 2.5 m/s^3 (0.05 m/s^2 per period), never
/// an emergency, and the front stays certified throughout (ideal plant).
#[test]
fn near_the_margin_a_hard_braking_leader_is_answered_within_the_jerk_limit() {
    let (_, _, leader_braking) = band_and_leader();
    let c = controller();
    let offset = c.certificate([0.0, 25.0, 1e9, 0.0, 25.0]).unwrap().front;
    let gap = 0.05 - offset;
    let mut c = controller();
    let (mut gap_now, mut speed, mut leader, h) = (gap as f64, 25.0f64, 25.0f64, 0.02f64);
    let mut last = 0.0f32;
    let mut overrides = 0;
    for k in 0..1_000u64 {
        let state = inputs(
            (gap_now as f32, (leader - speed) as f32),
            (40.0, 0.0),
            speed as f32,
        );
        let cmd = c.step(&at(state, NOW + k * 20_000));
        assert!(!cmd.emergency, "{k}: {cmd:?}");
        assert!(
            cmd.acceleration >= last - 0.05 - 1e-5,
            "{k}: {cmd:?} after {last}"
        );
        assert!(
            cmd.margin.unwrap() > -firmware::CERTIFICATE_TOLERANCE,
            "{k}: {cmd:?}"
        );
        overrides += usize::from(cmd.mode == Mode::Override);
        last = cmd.acceleration;
        let (dl, vl) = travel(leader, -f64::from(leader_braking), h);
        let (d, v) = travel(speed, f64::from(cmd.acceleration), h);
        gap_now += dl - d;
        leader = vl;
        speed = v;
        if speed == 0.0 {
            break;
        }
    }
    assert_eq!(speed, 0.0);
    assert!(gap_now > 0.5, "{gap_now}");
    assert!(overrides > 0);
}

#[test]
fn a_margin_larger_than_the_front_value_overrides_the_same_state() {
    let state = inputs((60.0, 0.0), (40.0, 0.0), 25.0);
    let cmd = controller().step(&state);
    assert_eq!(cmd.mode, Mode::Nominal);
    let c = controller();
    let front = c.certificate([60.0, 25.0, 40.0, 25.0, 25.0]).unwrap().front
        + Config::default().certificate.front_margin;
    let strict = Config {
        certificate: CertificateConfig {
            front_margin: front + 1.0,
            ..ideal().certificate
        },
        ..ideal()
    };
    let cmd = Controller::new(DEFAULT_TABLE, strict).step(&state);
    assert_eq!(cmd.mode, Mode::Override, "{cmd:?}");
    assert!(cmd.margin.unwrap() < 0.0);
}

#[test]
fn every_bad_input_has_its_fault() {
    let good = inputs((100.0, 0.0), (30.0, 0.0), 25.0);
    let mut c = controller();
    assert_eq!(c.step(&good).mode, Mode::Nominal);

    let mut bad = good;
    bad.leader.value.gap = f32::NAN;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    let mut bad = good;
    bad.leader.valid = false;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    // Past the covered age (1 s): the certified fallback, reported as the minimum-risk
    // manoeuvre with its margin.
    let mut bad = good;
    bad.leader.timestamp_us = NOW - 1_100_000;
    let cmd = controller().step(&bad);
    assert_eq!(fault_of(cmd), Fault::LeaderStale);
    assert!(
        cmd.takeover && cmd.leader == firmware::TrackState::Lost,
        "{cmd:?}"
    );
    // Aged within it: the nominal law, the track reported aging.
    let mut aged = good;
    aged.leader.timestamp_us = NOW - 500_000;
    let cmd = controller().step(&aged);
    assert_eq!(cmd.leader, firmware::TrackState::Aging, "{cmd:?}");
    assert_ne!(cmd.mode, Mode::MinimumRisk, "{cmd:?}");

    // A measurement from the future is not plausible.
    let mut bad = good;
    bad.leader.timestamp_us = NOW + 1;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    let mut bad = good;
    bad.follower.value.rel_speed = f32::INFINITY;
    assert_eq!(fault_of(controller().step(&bad)), Fault::FollowerInvalid);

    let mut bad = good;
    bad.follower.timestamp_us = 0;
    assert_eq!(fault_of(controller().step(&bad)), Fault::FollowerStale);

    let mut bad = good;
    bad.ego_speed.value = -1.0;
    assert_eq!(fault_of(controller().step(&bad)), Fault::EgoSpeedInvalid);

    let mut bad = good;
    bad.ego_speed.timestamp_us = NOW - 1_000_000;
    assert_eq!(fault_of(controller().step(&bad)), Fault::EgoSpeedStale);

    // Faster than the table's speed range: the nominal law, uncertified, with the reason.
    let mut fast = good;
    fast.ego_speed.value = 36.0;
    fast.follower.value.rel_speed = 6.0;
    let cmd = controller().step(&fast);
    assert_eq!(cmd.mode, Mode::Uncertified);
    assert_eq!(cmd.fault, Some(Fault::OutsideDomain { axis: 2 }));
    assert!(
        cmd.takeover,
        "without its rear half the driver is asked to take over"
    );
    let mut fast_follower = good;
    fast_follower.follower.value.rel_speed = -11.0; // 36 m/s behind an ego at 25
    let cmd = controller().step(&fast_follower);
    assert_eq!(cmd.fault, Some(Fault::OutsideDomain { axis: 1 }));
    // Slow is not a fault any more: the ego speed is a state.
    let mut slow = good;
    slow.ego_speed.value = 2.0;
    slow.leader.value.rel_speed = -2.0;
    slow.follower.value.rel_speed = 2.0;
    assert!(controller().step(&slow).fault.is_none());

    let mut bad = good;
    bad.leader.value.gap = -6.0;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    // The clock going backwards.
    let mut c = controller();
    c.step(&good);
    let mut earlier = good;
    earlier.now_us = NOW - 1;
    earlier.leader.timestamp_us = NOW - 10;
    earlier.follower.timestamp_us = NOW - 10;
    earlier.ego_speed.timestamp_us = NOW - 10;
    earlier.ego_acceleration.timestamp_us = NOW - 10;
    assert_eq!(fault_of(c.step(&earlier)), Fault::ClockWentBackwards);
}

#[test]
fn no_vehicle_or_one_beyond_the_grid_is_certified_not_refused() {
    let mut c = controller();
    // No vehicle ahead (infinite gap) and a follower far behind the grid's last gap.
    let cmd = c.step(&inputs((f32::INFINITY, 0.0), (500.0, 0.0), 25.0));
    assert!(cmd.fault.is_none(), "{cmd:?}");
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    // Beyond the grid the rear value is the smallest on its last gap face: at most the value at
    // any state of that face.
    let table = Table::parse(DEFAULT_TABLE).unwrap();
    let far = c.certificate([1e9, 20.0, 500.0, 35.0, 0.0]).unwrap().rear;
    let face = table.axis_bounds(0).unwrap().max;
    for (vf, ve) in [(0.0, 0.0), (35.0, 0.0), (20.0, 20.0), (0.0, 35.0)] {
        let w = table.value_at(&[face, vf, ve]).unwrap();
        assert!(
            far <= w - table.header().error_bound.total() + 1e-6,
            "{far} vs {w}"
        );
    }
    // And no vehicle at all on either side.
    let cmd = c.step(&inputs((f32::INFINITY, 0.0), (f32::INFINITY, 0.0), 25.0));
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
}

#[test]
fn a_corrupt_or_foreign_table_means_minimum_risk_for_good() {
    let mut corrupt = DEFAULT_TABLE.to_vec();
    corrupt[1000] ^= 0x04;
    let mut c = Controller::new(&corrupt, Config::default());
    assert!(c.table().is_none());
    let f = fault_of(c.step(&inputs((40.0, 0.0), (30.0, 0.0), 25.0)));
    assert!(
        matches!(f, Fault::Table(table_format::Error::Checksum { .. })),
        "{f:?}"
    );

    let truncated = &DEFAULT_TABLE[..DEFAULT_TABLE.len() / 2];
    let mut c = Controller::new(truncated, Config::default());
    assert!(matches!(
        fault_of(c.step(&inputs((40.0, 0.0), (30.0, 0.0), 25.0))),
        Fault::Table(_)
    ));

    // A valid two-car table is the wrong game for this controller.
    let axes = [
        table_format::Axis {
            name: "gap_leader",
            unit: "m",
            min: -5.0,
            max: 45.0,
            points: 3,
            spacing: table_format::Spacing::Uniform,
        },
        table_format::Axis {
            name: "rel_speed_leader",
            unit: "m/s",
            min: -10.0,
            max: 10.0,
            points: 3,
            spacing: table_format::Spacing::Uniform,
        },
    ];
    let trusted = [
        table_format::Bounds::new(-5.0, 45.0),
        table_format::Bounds::new(-10.0, 10.0),
    ];
    let two_car = table_format::encode(&table_format::TableContents {
        game: table_format::Game::TwoCar {
            ego: table_format::Bounds::new(-2.0, 2.0),
            leader: table_format::Bounds::new(-1.5, 1.5),
        },
        min_gap: 0.0,
        horizon: table_format::Horizon {
            seconds: 3.0,
            status: table_format::HorizonStatus::Fixed,
        },
        axes: &axes,
        breakpoints: &[],
        trusted_box: &trusted,
        interpolation_error: 0.0,
        value_bits: table_format::ValueBits::Sixteen,
        values: &[1.0; 9],
        accelerate: &[false; 9],
    })
    .unwrap();
    let mut c = Controller::new(&two_car, Config::default());
    assert_eq!(
        fault_of(c.step(&inputs((40.0, 0.0), (30.0, 0.0), 25.0))),
        Fault::WrongGame
    );
}

/// A board restarted by its watchdog or a fault latches the minimum-risk manoeuvre, whatever
/// the inputs, and still minds the follower.
#[test]
fn a_latched_controller_stays_in_minimum_risk_on_good_inputs() {
    let mut c = controller();
    let good = inputs((100.0, 0.0), (40.0, 0.0), 25.0);
    assert_eq!(c.step(&good).mode, Mode::Nominal);
    c.latch_minimum_risk(Fault::RestartedAfterFault);
    let mut last = c.step(&good).acceleration;
    for k in 1..=500u64 {
        let mut later = good;
        later.now_us = NOW + k * 20_000;
        later.leader.timestamp_us = later.now_us;
        later.follower.timestamp_us = later.now_us;
        later.ego_speed.timestamp_us = later.now_us;
        later.ego_acceleration.timestamp_us = later.now_us;
        let command = c.step(&later);
        assert_eq!(fault_of(command), Fault::RestartedAfterFault, "step {k}");
        // Reached at ISO 15622's jerk limit at 25 m/s (2.5 m/s^3), then held.
        assert!(
            command.acceleration >= last - 0.05 - 1e-5,
            "step {k}: {command:?}"
        );
        if k > 50 {
            assert_eq!(command.acceleration, -2.0);
        }
        last = command.acceleration;
    }
    let mut close = inputs((60.0, 0.0), (8.0, -2.0), 25.0);
    close.now_us = NOW + 501 * 20_000;
    close.leader.timestamp_us = close.now_us;
    close.follower.timestamp_us = close.now_us;
    close.ego_speed.timestamp_us = close.now_us;
    close.ego_acceleration.timestamp_us = close.now_us;
    assert_eq!(c.step(&close).acceleration, -1.0);
    assert!(c.table().is_none());
}

#[test]
fn minimum_risk_minds_the_follower_and_its_limits() {
    let mut bad = inputs((f32::NAN, 0.0), (40.0, 0.0), 25.0);
    assert_eq!(controller().step(&bad).acceleration, -2.0);
    bad.follower.value = Track {
        gap: 8.0,
        rel_speed: -2.0,
    };
    assert_eq!(controller().step(&bad).acceleration, -1.0);
    let harsh = Config {
        fallback: FallbackConfig {
            mrm_deceleration: 9.0,
            ..ideal().fallback
        },
        ..ideal()
    };
    let mut c = Controller::new(DEFAULT_TABLE, harsh);
    assert_eq!(c.config().fallback.mrm_deceleration, 4.0);
    // ... and then into the band, like every command.
    let bad = inputs((f32::NAN, 0.0), (40.0, 0.0), 25.0);
    assert_eq!(c.step(&bad).acceleration, band_and_leader().0);
}

#[test]
fn mode_changes_are_logged() {
    let mut c = controller();
    c.step(&inputs((50.0, 0.0), (40.0, 0.0), 25.0));
    c.step(&inputs((50.0, 0.0), (40.0, 0.0), f32::NAN));
    let events: Vec<_> = c.events().collect();
    assert!(events.len() >= 2, "{events:?}");
}

proptest! {
    #[test]
    fn any_inputs_give_a_finite_bounded_command(
        lg in prop_oneof![any::<f32>(), -10.0f32..120.0],
        lv in prop_oneof![any::<f32>(), -20.0f32..20.0],
        fg in prop_oneof![any::<f32>(), -10.0f32..120.0],
        fv in prop_oneof![any::<f32>(), -20.0f32..20.0],
        speed in prop_oneof![any::<f32>(), 0.0f32..45.0],
        valid in any::<[bool; 3]>(),
        age in 0u64..400_000,
    ) {
        let mut i = inputs((lg, lv), (fg, fv), speed);
        i.leader.valid = valid[0];
        i.follower.valid = valid[1];
        i.ego_speed.valid = valid[2];
        i.leader.timestamp_us = NOW - age;
        let cmd = controller().step(&i);
        prop_assert!(cmd.acceleration.is_finite());
        // Within the band, or below it down to the emergency authority's level, flagged.
        let (lo, hi, _) = band_and_leader();
        let emergency = -ideal().certificate.emergency.braking.level;
        prop_assert!((emergency..=hi).contains(&cmd.acceleration));
        prop_assert!(cmd.acceleration >= lo || (cmd.emergency && cmd.takeover), "{:?}", cmd);
        prop_assert_eq!(
            cmd.fault.is_some(),
            matches!(cmd.mode, Mode::MinimumRisk | Mode::Uncertified)
        );
    }
}

/// The exact motion of a car under constant acceleration for `t` seconds, stopping at rest:
/// (distance, final speed), in f64.
fn travel(v: f64, a: f64, t: f64) -> (f64, f64) {
    let t = if a < 0.0 { t.min(v / -a) } else { t };
    (v * t + 0.5 * a * t * t, (v + a * t).max(0.0))
}

proptest! {
    /// The look-ahead's claim, checked against leaders it did not assume: from a certified
    /// state, after one period under the firmware's command and *any* constant leader
    /// acceleration in its bounds, the front value is still above the margin (up to f32
    /// rounding), whether the command was the nominal law's or the override's.
    #[test]
    fn the_front_value_stays_above_the_margin_through_a_period(
        above in prop_oneof![0.0f32..0.05, 0.0f32..2.0, 0.0f32..100.0],
        leader_speed in prop_oneof![Just(0.0f32), 0.0f32..35.0],
        ego_speed in prop_oneof![Just(0.0f32), 0.0f32..35.0],
        leader_accel in 0.0f32..=1.0,
    ) {
        let (beta, a_max, leader_braking) = band_and_leader();
        let config = ideal();
        let mut c = controller();
        // The front value is the gap plus a function of the speeds: place the state `above`
        // metres over the margin, where the look-ahead's work is.
        let offset = c.certificate([0.0, leader_speed, 1e9, 0.0, ego_speed]).unwrap().front;
        let gap = -offset + above;
        prop_assume!(gap > 0.0);
        let state = inputs((gap, leader_speed - ego_speed), (f32::INFINITY, 0.0), ego_speed);
        let cmd = c.step(&state);
        let certificate = c.certificate([gap, leader_speed, 1e9, 0.0, ego_speed]).unwrap();
        prop_assume!(certificate.front > 0.0);
        let u = f64::from(cmd.acceleration);
        prop_assert!(u >= f64::from(beta) && u <= f64::from(a_max));
        let a_leader = -f64::from(leader_braking) + leader_accel as f64 * (f64::from(leader_braking) + 2.0);
        let h = f64::from(config.period_us) * 1e-6;
        let (dl, vl) = travel(f64::from(leader_speed), a_leader, h);
        let (de, ve) = travel(f64::from(ego_speed), u, h);
        let gap_after = f64::from(gap) + dl - de;
        // The next step's certificate: the braking ramp from the command just issued.
        let after = [gap_after as f32, vl.min(35.0) as f32, 1e9, 0.0, ve as f32];
        let front_after = c.certificate_with_response(after, 0.0, cmd.acceleration).unwrap().front;
        prop_assert!(
            front_after > -firmware::CERTIFICATE_TOLERANCE,
            "{:?} from {:?} to front margin {}", cmd, (gap, leader_speed, ego_speed), front_after
        );
        // The look-ahead is not vacuous: the nominal law drives where there is room.
        if certificate.front > 20.0 && ego_speed < 30.0 {
            prop_assert_eq!(cmd.mode, Mode::Nominal);
        }
    }
}

#[test]
fn actuator_delays_make_the_look_ahead_cautious_until_the_commands_are_known() {
    // Cruising 10 m above the front margin: the ideal plant drives nominally at once.
    let offset = controller()
        .certificate([0.0, 25.0, 1e9, 0.0, 25.0])
        .unwrap()
        .front;
    let state = inputs((10.0 - offset, 0.0), (40.0, 0.0), 25.0);
    assert_eq!(controller().step(&state).mode, Mode::Nominal);
    // With the default dead time (100 ms) and lag (0.3 s), a controller that has issued no
    // command yet must assume the actuator may still be accelerating at a_max for half a
    // second: at 25 m/s that costs about 20 m of front value, and it brakes.
    let exact = Config {
        sensors: SensorBounds::EXACT,
        ..Config::default()
    };
    let mut c = Controller::new(DEFAULT_TABLE, exact);
    let first = c.step(&state);
    assert_eq!(first.mode, Mode::Override, "{first:?}");
    // Once its own commands cover the dead time, five lag time constants and the stale limit
    // (1.7 s), it knows better; the same gap, kept, is driven nominally again.
    let mut last = first;
    for k in 1..=150u64 {
        let mut i = state;
        i.now_us = NOW + k * 20_000;
        i.leader.timestamp_us = i.now_us;
        i.follower.timestamp_us = i.now_us;
        i.ego_speed.timestamp_us = i.now_us;
        i.ego_acceleration.timestamp_us = i.now_us;
        last = c.step(&i);
    }
    assert_eq!(last.mode, Mode::Nominal, "{last:?}");
}

#[test]
fn the_measurements_age_is_inside_the_look_ahead() {
    // The same measurement, fresh or 100 ms old (the stale limit): the older one leaves the
    // leader 100 ms more to brake unseen, so its front margin is smaller.
    let fresh = inputs((40.0, -3.0), (40.0, 0.0), 25.0);
    let mut old = fresh;
    old.leader.timestamp_us = NOW - 100_000;
    old.ego_speed.timestamp_us = NOW - 100_000;
    old.ego_acceleration.timestamp_us = NOW - 100_000;
    let band = || declared(band_only(ideal()));
    let m_fresh = band().step(&fresh).margin.unwrap();
    let m_old = band().step(&old).margin.unwrap();
    assert!(m_old < m_fresh - 0.5, "{m_old} vs {m_fresh}");
}

#[test]
fn a_configuration_outside_the_certificates_limits_is_refused() {
    for bad in [
        Config {
            plant: PlantConfig {
                actuator_dead_time_us: 150_000,
                ..Config::default().plant
            },
            ..Config::default()
        },
        Config {
            plant: PlantConfig {
                actuator_lag_us: 400_000,
                ..Config::default().plant
            },
            ..Config::default()
        },
        Config {
            period_us: 1_000,
            ..Config::default()
        },
        Config {
            stale_periods: 0,
            ..Config::default()
        },
        Config {
            certificate: CertificateConfig {
                front_margin: -1e9,
                ..Config::default().certificate
            },
            ..Config::default()
        },
        Config {
            certificate: CertificateConfig {
                rear_margin: f32::NAN,
                ..Config::default().certificate
            },
            ..Config::default()
        },
    ] {
        assert!(!bad.is_valid(), "{bad:?}");
        let mut c = Controller::new(DEFAULT_TABLE, bad);
        assert_eq!(
            fault_of(c.step(&inputs((60.0, 0.0), (40.0, 0.0), 25.0))),
            Fault::InvalidConfig
        );
    }
    assert!(Config::default().is_valid());
}

/// The inputs of `state` measured at `now_us`.
fn at(state: Inputs, now_us: u64) -> Inputs {
    let mut i = state;
    i.now_us = now_us;
    i.leader.timestamp_us = now_us;
    i.follower.timestamp_us = now_us;
    i.ego_speed.timestamp_us = now_us;
    i.ego_acceleration.timestamp_us = now_us;
    i.ego_acceleration.timestamp_us = now_us;
    i
}

#[test]
fn a_clock_jump_is_a_fault_that_recovers_never_latches() {
    let state = inputs((60.0, 0.0), (40.0, 0.0), 25.0);
    for jump in [3_600_000_000u64, u64::MAX - NOW - 1_000_000] {
        let mut c = controller();
        let mut now = NOW;
        assert_eq!(c.step(&at(state, now)).mode, Mode::Nominal);
        // Forwards by an hour (or to the end of time): a fault, then CLOCK_RECOVERY_PERIODS
        // good periods of the minimum-risk manoeuvre, then the nominal law again.
        now += jump;
        assert_eq!(fault_of(c.step(&at(state, now))), Fault::ClockJumped);
        for _ in 0..firmware::controller::CLOCK_RECOVERY_PERIODS {
            now += 20_000;
            assert_eq!(fault_of(c.step(&at(state, now))), Fault::ClockJumped);
        }
        now += 20_000;
        let back = c.step(&at(state, now));
        assert_ne!(back.mode, Mode::MinimumRisk, "{back:?}");
        // And backwards, to where it was: the same.
        now = NOW + 40_000;
        assert_eq!(fault_of(c.step(&at(state, now))), Fault::ClockWentBackwards);
        let mut last = None;
        for _ in 0..=firmware::controller::CLOCK_RECOVERY_PERIODS {
            now += 20_000;
            last = Some(c.step(&at(state, now)));
        }
        assert_ne!(last.unwrap().mode, Mode::MinimumRisk, "{last:?}");
    }
}

/// A table certifies for the vehicle and the follower it declares: one that declares another
/// emergency authority, follower reaction or lights' command than the configuration is
/// refused with its reason, in both modes; declared alike, it loads.
#[test]
fn a_table_declaring_another_emergency_authority_or_follower_is_refused() {
    let d = ideal().certificate.emergency;
    let others = [
        EmergencyDeclaration {
            braking: Braking {
                level: 7.0,
                ..d.braking
            },
            ..d
        },
        EmergencyDeclaration {
            braking: Braking {
                jerk: 10.0,
                ..d.braking
            },
            ..d
        },
        EmergencyDeclaration {
            follower_reaction_time: 0.0,
            ..d
        },
        EmergencyDeclaration {
            lights_command: -2.0,
            ..d
        },
        EmergencyDeclaration {
            lights_deceleration: 0.7,
            ..d
        },
    ];
    let state = inputs((100.0, 0.0), (40.0, 0.0), 25.0);
    for authorities in [
        firmware::Authorities::ComfortBand,
        firmware::Authorities::Two,
    ] {
        let mut config = ideal();
        config.certificate.authorities = authorities;
        assert!(Controller::new(DEFAULT_TABLE, config).table().is_some());
        for other in others {
            let bytes = table_format::with_emergency(DEFAULT_TABLE, other).unwrap();
            let mut c = Controller::new(&bytes, config);
            assert!(c.table().is_none(), "{other:?}");
            assert_eq!(
                fault_of(c.step(&state)),
                Fault::EmergencyDeclarationDiffers,
                "{other:?}"
            );
            // The configuration that declares the same loads it.
            let mut same = config;
            same.certificate.emergency = other;
            assert!(Controller::new(&bytes, same).table().is_some(), "{other:?}");
        }
    }
}

#[test]
fn the_envelope_bounds_every_command_and_refuses_a_table_that_does_not_fit() {
    use firmware::controller::Envelope;
    // A vehicle that may brake at only 3 m/s^2 (and so declares no emergency authority beyond
    // it): the table's 3.5 does not fit, and clamping it would void the certificate, so the
    // table is refused.
    let no_emergency = CertificateConfig {
        emergency: EmergencyDeclaration {
            braking: Braking {
                level: 3.0,
                ..ideal().certificate.emergency.braking
            },
            ..ideal().certificate.emergency
        },
        ..ideal().certificate
    };
    let soft = Config {
        certificate: no_emergency,
        plant: PlantConfig {
            envelope: Envelope {
                min_acceleration: -3.0,
                ..Envelope::default()
            },
            ..ideal().plant
        },
        ..ideal()
    };
    let mut c = Controller::new(DEFAULT_TABLE, soft);
    assert!(c.table().is_none());
    let cmd = c.step(&inputs((100.0, 0.0), (40.0, 0.0), 25.0));
    assert_eq!(fault_of(cmd), Fault::TableOutsideEnvelope);
    // A harsh minimum-risk deceleration (4 m/s^2) is held to the envelope too, table or not.
    let harsh = Config {
        fallback: FallbackConfig {
            mrm_deceleration: 4.0,
            ..ideal().fallback
        },
        certificate: no_emergency,
        plant: PlantConfig {
            envelope: Envelope {
                min_acceleration: -3.0,
                ..Envelope::default()
            },
            ..ideal().plant
        },
        ..ideal()
    };
    let mut c = Controller::new(DEFAULT_TABLE, harsh);
    assert_eq!(
        c.step(&inputs((60.0, 0.0), (40.0, 0.0), 25.0)).acceleration,
        -3.0
    );
    // The envelope's speed limit narrows the certified domain below the table's 35 m/s.
    let slow = Config {
        plant: PlantConfig {
            envelope: Envelope {
                max_speed: 20.0,
                ..Envelope::default()
            },
            ..ideal().plant
        },
        ..ideal()
    };
    let cmd = Controller::new(DEFAULT_TABLE, slow).step(&inputs((60.0, 0.0), (40.0, 0.0), 25.0));
    assert_eq!(cmd.fault, Some(Fault::OutsideDomain { axis: 2 }));
    // An envelope that cannot brake is not a configuration.
    let bad = Config {
        plant: PlantConfig {
            envelope: Envelope {
                min_acceleration: 0.0,
                ..Envelope::default()
            },
            ..ideal().plant
        },
        ..ideal()
    };
    assert!(!bad.is_valid());
    // An emergency authority beyond the envelope's braking is not a configuration either.
    let beyond = Config {
        certificate: CertificateConfig {
            emergency: EmergencyDeclaration {
                braking: Braking {
                    level: 8.5,
                    ..ideal().certificate.emergency.braking
                },
                ..ideal().certificate.emergency
            },
            ..ideal().certificate
        },
        ..ideal()
    };
    assert!(!beyond.is_valid());
    // A lights' command short of the lights' deceleration or harder than ISO 15622's braking
    // is not one either, and one harder than the table's band is refused with the table.
    for lights in [0.0, 0.1, -1.3, -3.6, f32::NAN] {
        let mut bad = ideal();
        bad.certificate.emergency.lights_command = lights;
        assert!(!bad.is_valid(), "{lights}");
    }
    let mut soft_band = ideal();
    soft_band.certificate.emergency.lights_command = -3.5;
    assert!(soft_band.is_valid());
    let bytes =
        table_format::with_emergency(&split_table((-3.0, 2.0)), soft_band.certificate.emergency)
            .unwrap();
    let cmd = Controller::new(&bytes, soft_band).step(&inputs((60.0, 0.0), (40.0, 0.0), 25.0));
    assert_eq!(fault_of(cmd), Fault::InvalidConfig);
    assert!(ideal().is_valid());
}

/// A valid, correctly checksummed split table with the given band (all values 1 m), with a
/// stand-in for solver verify's record (these tests are about the other load checks).
fn split_table(ego: (f32, f32)) -> Vec<u8> {
    table_format::with_verification(&split_table_unverified(ego), complete_record(0.0)).unwrap()
}

/// [`split_table`] as the solver writes it before `verify`: no record.
fn split_table_unverified(ego: (f32, f32)) -> Vec<u8> {
    use table_format::{Axis, Bounds, Horizon, HorizonStatus, Spacing, TableContents, ValueBits};
    let axis = |name, unit, min, max| Axis {
        name,
        unit,
        min,
        max,
        points: 3,
        spacing: Spacing::Uniform,
    };
    let axes = [
        axis("gap_follower", "m", -1.0, 149.0),
        axis("follower_speed", "m/s", 0.0, 35.0),
        axis("ego_speed", "m/s", 0.0, 35.0),
    ];
    let trusted: Vec<Bounds> = axes.iter().map(|a| Bounds::new(a.min, a.max)).collect();
    let Game::ThreeCarSplit {
        leader,
        follower,
        max_speed,
        emergency,
        ..
    } = Table::parse(DEFAULT_TABLE).unwrap().header().game
    else {
        panic!("not a split table")
    };
    table_format::encode(&TableContents {
        game: Game::ThreeCarSplit {
            ego: Bounds::new(ego.0, ego.1),
            leader,
            follower,
            max_speed,
            emergency,
        },
        min_gap: 0.0,
        horizon: Horizon {
            seconds: 1.0,
            status: HorizonStatus::Converged {
                tolerance: 1e-5,
                residual: 1e-6,
            },
        },
        axes: &axes,
        breakpoints: &[],
        trusted_box: &trusted,
        interpolation_error: 0.0,
        value_bits: ValueBits::Sixteen,
        values: &[1.0; 27],
        accelerate: &[],
    })
    .unwrap()
}

/// A record of a proof that covered every certified cell, for `rear_margin`.
fn complete_record(rear_margin: f32) -> table_format::Verification {
    table_format::Verification {
        verifier: table_format::REAR_SAMPLE_VERIFIER,
        rear_margin,
        certified_cells: 10,
        proven_cells: 10,
        shortest_period: 0.02,
        longest_period: 0.3,
        measurement_error: table_format::MeasurementError::default(),
    }
}

#[test]
fn a_table_without_a_complete_proof_for_the_configured_margin_is_refused() {
    // The committed table carries solver verify's record: every certified cell proven.
    let record = Table::parse(DEFAULT_TABLE)
        .unwrap()
        .header()
        .verification
        .expect("the default table is verified");
    assert!(
        record.is_complete() && record.certified_cells > 500_000,
        "{record:?}"
    );
    let split = split_table((-3.5, 2.0));
    assert!(Controller::new(&split, ideal()).table().is_some());
    let incomplete = table_format::Verification {
        proven_cells: 9,
        ..complete_record(0.0)
    };
    let cases = [
        // The same table re-encoded without the record (what the solver wrote before verify).
        split_table_unverified((-3.5, 2.0)),
        table_format::with_verification(&split, incomplete).unwrap(),
        // A proof for another level.
        table_format::with_verification(&split, complete_record(0.2)).unwrap(),
        // A proof by a verify that did not bound the samples between its periods.
        table_format::with_verification(
            &split,
            table_format::Verification {
                verifier: 1,
                ..complete_record(0.0)
            },
        )
        .unwrap(),
    ];
    for bytes in &cases {
        let mut c = Controller::new(bytes, ideal());
        assert!(c.table().is_none());
        let cmd = c.step(&inputs((8.0, -4.0), (30.0, 0.0), 25.0));
        assert_eq!(fault_of(cmd), Fault::TableNotVerified);
    }
    // With the margin the proof was for, it loads.
    let at_margin = table_format::with_verification(&split, complete_record(0.2)).unwrap();
    let config = Config {
        certificate: CertificateConfig {
            rear_margin: 0.2,
            ..ideal().certificate
        },
        ..ideal()
    };
    assert!(Controller::new(&at_margin, config).table().is_some());
}

#[test]
fn a_table_checked_for_less_error_than_declared_is_refused() {
    // The committed table was checked under the declared default error.
    let record = Table::parse(DEFAULT_TABLE)
        .unwrap()
        .header()
        .verification
        .expect("the default table is verified");
    assert_eq!(record.measurement_error, MeasurementError::default());
    assert!(Controller::new(DEFAULT_TABLE, Config::default())
        .table()
        .is_some());
    let split = split_table((-3.5, 2.0));
    // Each bound in turn declared larger than the table's record: refused, naming why.
    for k in 0..6 {
        let mut error = MeasurementError::default();
        match k {
            0 => error.range += 0.05,
            1 => error.range_relative += 0.005,
            2 => error.range_rate += 0.02,
            3 => error.ego_speed += 0.02,
            4 => error.ego_speed_relative += 0.001,
            _ => error.ego_age += 0.005,
        }
        let config = Config {
            sensors: SensorBounds {
                error,
                ..SensorBounds::default()
            },
            ..ideal()
        };
        let mut c = Controller::new(&split, config);
        assert!(c.table().is_none(), "bound {k}");
        let cmd = c.step(&inputs((8.0, -4.0), (30.0, 0.0), 25.0));
        assert_eq!(fault_of(cmd), Fault::TableCheckedForLessError, "bound {k}");
    }
    // Declaring less error than the table was checked for is fine.
    assert!(Controller::new(&split, ideal()).table().is_some());
}

#[test]
fn a_checksummed_table_with_wild_ego_bounds_is_refused() {
    // The audit's table: a valid CRC, the ego's bounds [-512, 131072] m/s^2. Before the
    // envelope, the override commanded -512 and the nominal law +2; now it never loads.
    for band in [(-512.0, 131_072.0), (-50.0, 50.0), (-3.5, 2.5), (-9.0, 2.0)] {
        let bytes = split_table(band);
        let mut c = Controller::new(&bytes, ideal());
        assert!(c.table().is_none(), "{band:?}");
        let cmd = c.step(&inputs((8.0, -4.0), (30.0, 0.0), 25.0));
        assert_eq!(fault_of(cmd), Fault::TableOutsideEnvelope, "{band:?}");
        assert!((-3.5..=2.0).contains(&cmd.acceleration), "{cmd:?}");
    }
    // The same table with the default table's band loads.
    let bytes = split_table((-3.5, 2.0));
    assert!(Controller::new(&bytes, ideal()).table().is_some());
}

/// The default table's front model for an ego braking at beta from now (no delays).
fn braking_now() -> table_format::front::FrontModel {
    let (beta, _, leader_braking) = band_and_leader();
    table_format::front::FrontModel::step(leader_braking, -beta, 0.0, 0.0, 35.0)
}

/// Above the speed domain the rear half is unknown, not the front. An ego at
/// 35.2 m/s, 0.05 m of front value above the margin behind a leader at 33 m/s: the nominal law
/// asks for about -1.6 m/s^2, which the look-ahead refuses. Before, the command was that
/// nominal law, uncertified; now it is the override's braking, still reported uncertified.
#[test]
fn above_the_speed_domain_the_front_override_still_acts() {
    use table_format::front::front_value;
    let model = braking_now();
    let ego = 35.2;
    let offset = front_value(0.0, 33.0, ego, &model);
    let gap = 0.55 - offset;
    let mut c = controller();
    let cmd = c.step(&inputs((gap, 33.0 - ego), (60.0, 1.0), ego));
    assert_eq!(cmd.mode, Mode::Uncertified, "{cmd:?}");
    assert_eq!(cmd.fault, Some(Fault::OutsideDomain { axis: 2 }), "{cmd:?}");
    assert!(cmd.acceleration < -2.0, "{cmd:?}");
}

/// The look-ahead keeps the ego's speed in the domain. A controller that has
/// issued nothing yet must assume the actuator may accelerate at the band's top through its
/// dead time and lag (about 0.42 s): at 34.5 m/s that could reach 35.4 m/s, so even with the
/// road clear it brakes; at 30 m/s it drives.
#[test]
fn no_command_may_take_the_ego_past_the_speed_domain() {
    let clear = |ego: f32| {
        let mut i = inputs((f32::INFINITY, 0.0), (120.0, 0.0), ego);
        i.ego_speed.timestamp_us = NOW;
        // The actuator's state not reported: the band's top is assumed.
        i.ego_acceleration.valid = false;
        i
    };
    let config = Config {
        sensors: SensorBounds::EXACT,
        law: LawConfig {
            set_speed: 40.0,
            ..Config::default().law
        },
        ..Config::default()
    };
    let cmd = Controller::new(DEFAULT_TABLE, config).step(&clear(34.5));
    assert_eq!(cmd.mode, Mode::Override, "{cmd:?}");
    let cmd = Controller::new(DEFAULT_TABLE, config).step(&clear(30.0));
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    // Once its own commands are known, the law's set speed stays below the domain's top by
    // three of the speed's errors (none here) and 0.1 m/s: from 34.95 m/s with a set speed of
    // 40 the car settles at 34.9 m/s, and steady cruising never leans on the speed cap.
    let mut c = Controller::new(DEFAULT_TABLE, config);
    let (mut v, h) = (34.95f32, 0.02f32);
    let mut largest_speed = 0.0f32;
    for k in 0..1_500u64 {
        let cmd = c.step(&at(clear(v), NOW + k * 20_000));
        // Until its own commands cover the dead time and the lag (1.6 s), the actuator is not
        // known (its state not reported here): the band's top is assumed and the cap brakes;
        // on the way back up the cap trims the law's acceleration; settled, it does not act.
        if k > 1_000 {
            assert_ne!(cmd.mode, Mode::Override, "{k}: {cmd:?}");
        }
        v += cmd.acceleration * h;
        if k > 1_000 {
            largest_speed = largest_speed.max(v);
        }
    }
    assert!((largest_speed - 34.9).abs() < 0.02, "{largest_speed}");
}

/// A follower at exactly 35 m/s, its track 60 ms older than the ego's speed,
/// behind an ego accelerating at 0.85 m/s^2. Subtracting the two as if taken at once gives
/// 35.05 m/s, outside the domain; moved to the track's time within the ego's possible
/// accelerations, the follower's speed is an interval inside it, and the state is certified.
#[test]
fn the_follower_speed_is_taken_at_the_follower_tracks_time() {
    let ego_now = 26.9;
    let ego_then = ego_now - 0.85 * 0.06;
    let mut i = inputs((f32::INFINITY, 0.0), (45.0, ego_then - 35.0), ego_now);
    i.follower.timestamp_us = NOW - 60_000;
    i.ego_speed.timestamp_us = NOW;
    i.ego_acceleration = Measurement::new(0.85, NOW);
    let cmd = controller().step(&i);
    assert_eq!(cmd.fault, None, "{cmd:?}");
    assert!(cmd.margin.is_some_and(|m| m > 0.0), "{cmd:?}");
    // A follower really beyond the domain at its own time is still refused.
    let mut beyond = i;
    beyond.follower.value.rel_speed = ego_now - 35.6;
    beyond.follower.timestamp_us = NOW;
    let cmd = controller().step(&beyond);
    assert_eq!(cmd.fault, Some(Fault::OutsideDomain { axis: 1 }), "{cmd:?}");
}

/// The front half is enforced in the minimum-risk manoeuvre too, where its inputs are good: a
/// stale follower track is a fault, yet the leader 0.05 m of front value above the margin and
/// braking needs more than the manoeuvre's 2 m/s^2. Before, the manoeuvre braked at 2 m/s^2
/// whatever the leader did.
#[test]
fn the_minimum_risk_manoeuvre_brakes_harder_when_the_front_needs_it() {
    use table_format::front::front_value;
    let model = braking_now();
    let (ego, leader) = (25.0, 20.0);
    let gap = 0.55 - front_value(0.0, leader, ego, &model);
    let mut i = inputs((gap, leader - ego), (40.0, 0.0), ego);
    i.follower.timestamp_us = NOW - 1_100_000;
    let cmd = controller().step(&i);
    assert_eq!(fault_of(cmd), Fault::FollowerStale);
    assert!(cmd.acceleration < -2.5, "{cmd:?}");
    // With room ahead it is the planned manoeuvre.
    let mut i = inputs((200.0, 0.0), (40.0, 0.0), ego);
    i.follower.timestamp_us = NOW - 1_100_000;
    let cmd = controller().step(&i);
    assert_eq!(cmd.acceleration, -2.0, "{cmd:?}");
}

// Real sensors inside the argument.

/// The default configuration's sensors on the ideal plant.
fn datasheet() -> Config {
    Config {
        sensors: SensorBounds::default(),
        ..ideal()
    }
}

/// A measurement `error` (each in `[-1, 1]`, a share of its bound) away from the true values.
fn measured(
    sensors: &SensorBounds,
    [gap_leader, leader_speed, gap_follower, follower_speed, ego_speed]: [f32; 5],
    error: [f32; 5],
) -> Inputs {
    let range = |g: f32, e: f32| {
        if g.is_finite() {
            g + e * (sensors.error.range + sensors.error.range_relative * g)
        } else {
            g
        }
    };
    let ego_measured = ego_speed
        + error[4] * (sensors.error.ego_speed + sensors.error.ego_speed_relative * ego_speed);
    let mut i = inputs(
        (
            range(gap_leader, error[0]),
            leader_speed - ego_speed + error[1] * sensors.error.range_rate,
        ),
        (
            range(gap_follower, error[2]),
            ego_speed - follower_speed + error[3] * sensors.error.range_rate,
        ),
        ego_measured.max(0.0),
    );
    // One time for every measurement: the error alone is under test.
    i.leader.timestamp_us = NOW;
    i.follower.timestamp_us = NOW;
    i.ego_speed.timestamp_us = NOW;
    i.ego_acceleration.timestamp_us = NOW;
    i
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// A measurement that passes the firmware's test (a positive margin) certifies
    /// every true state its declared error allows. The true state's certificate is evaluated
    /// exactly; the measurement is anywhere in the error box, corners included. Each half is
    /// put under test on its own boundary: the front with no follower (the rear then far above
    /// its level) and a leader within 3 m of the front's level, the rear with no leader.
    #[test]
    fn a_measurement_that_passes_certifies_every_state_its_error_allows(
        front_half in any::<bool>(), near in 0.0f32..3.0,
        vl in 0.0f32..35.0, gf in 0.0f32..120.0, vf in 0.0f32..35.0, ve in 0.0f32..35.0,
        error in proptest::array::uniform5(prop_oneof![Just(-1.0f32), Just(1.0f32), -1.0f32..1.0]),
    ) {
        use table_format::front::front_value;
        let config = datasheet();
        let state = if front_half {
            // The front value is `gap - c` here: `near` metres above the margin.
            let c = -front_value(0.0, vl, ve, &braking_now());
            [config.certificate.front_margin + near + c.max(0.0), vl, f32::INFINITY, 0.0, ve]
        } else {
            [f32::INFINITY, vl, gf, vf, ve]
        };
        let cmd = Controller::new(DEFAULT_TABLE, config).step(&measured(&config.sensors, state, error));
        let truth = controller().certificate(state);
        if let (Some(m), Some(t)) = (cmd.margin, truth) {
            if m > 0.0 {
                let half = if front_half { t.front } else { t.rear };
                prop_assert!(half >= m - 1e-3,
                    "measured margin {} but the true state has {:?} ({:?}, error {:?})", m, t, state, error);
            }
        }
    }
}

/// The test above is not vacuous: over a sweep of true states, most that are certified with a
/// metre to spare are certified from their measurements too, and the error costs margin.
#[test]
fn the_declared_error_costs_margin_not_the_certificate() {
    let config = datasheet();
    let (mut both, mut exact_only) = (0, 0);
    for gl in [30.0f32, 60.0, 90.0, 120.0] {
        for ve in [5.0f32, 15.0, 25.0] {
            for gf in [20.0f32, 50.0, 80.0] {
                let state = [gl, ve, gf, ve, ve];
                let truth = controller().certificate(state).unwrap();
                if truth.margin() < 1.0 {
                    continue;
                }
                let worst = Controller::new(DEFAULT_TABLE, config).step(&measured(
                    &config.sensors,
                    state,
                    [1.0, 1.0, 1.0, -1.0, -1.0],
                ));
                let m = worst.margin.unwrap();
                assert!(
                    m <= truth.margin() + 1e-4,
                    "{m} against {:?} at {state:?}",
                    truth
                );
                if m > 0.0 {
                    both += 1;
                } else {
                    exact_only += 1;
                }
            }
        }
    }
    assert!(both > 10 * exact_only.max(1) / 2, "{both} {exact_only}");
}

/// The look-ahead grows with the track's age, so an aging track slows the car
/// smoothly: the command never rises as the same measurement ages, the track is reported
/// aging, and no minimum-risk manoeuvre runs within the covered age.
#[test]
fn an_aging_track_slows_the_car_smoothly_within_the_covered_age() {
    let mut previous = f32::INFINITY;
    let mut previous_margin = f32::INFINITY;
    for age_ms in (0..=1_000u64).step_by(50) {
        let mut i = inputs((45.0, 0.0), (40.0, 0.0), 25.0);
        i.leader.timestamp_us = NOW - age_ms * 1_000;
        i.ego_speed.timestamp_us = NOW;
        i.ego_acceleration.timestamp_us = NOW;
        let cmd = declared(band_only(datasheet())).step(&i);
        assert_ne!(cmd.mode, Mode::MinimumRisk, "{age_ms} ms: {cmd:?}");
        assert!(
            cmd.acceleration <= previous + 1e-6,
            "{age_ms} ms: {cmd:?} after {previous}"
        );
        let margin = cmd.margin.unwrap();
        assert!(margin <= previous_margin + 1e-4, "{age_ms} ms: {margin}");
        previous = cmd.acceleration;
        previous_margin = margin;
        if age_ms > 130 {
            assert_eq!(cmd.leader, firmware::TrackState::Aging);
        }
    }
    assert!(previous < 0.0, "a second-old track brakes: {previous}");
    // It is the look-ahead's response that grows, not only the ego's speed interval: with the
    // ego's speed measured every period (so its interval at the track's time stays tight) and
    // the leader's track frozen, the nominal law passes while the track is fresh, and the
    // leader's worst case since the measurement makes the look-ahead refuse it within the
    // covered age.
    let mut c = Controller::new(DEFAULT_TABLE, datasheet());
    let state = inputs((90.0, 0.0), (40.0, 0.0), 25.0);
    let frozen = at(state, NOW).leader;
    let mut modes = Vec::new();
    for k in 0..50u64 {
        let mut i = at(state, NOW + k * 20_000);
        i.leader = frozen;
        modes.push(c.step(&i).mode);
    }
    assert_eq!(modes[0], Mode::Nominal);
    assert!(modes.contains(&Mode::Override), "{modes:?}");
}

/// Beyond the covered age the fallback is certified: the minimum-risk
/// deceleration under the front half of the last good measurement, with its margin, for as
/// long as the track stays lost; a track that comes back is checked, then the nominal law
/// resumes.
#[test]
fn a_lost_track_runs_a_certified_fallback_and_a_track_that_returns_is_checked() {
    let mut c = Controller::new(DEFAULT_TABLE, datasheet());
    let state = inputs((80.0, 0.0), (40.0, 0.0), 25.0);
    let mut last_good = at(state, NOW).leader;
    let mut cmd = c.step(&at(state, NOW));
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    // The leader's detections stop (flagged invalid); the ego and follower go on.
    for k in 1..=150u64 {
        let mut i = at(state, NOW + k * 20_000);
        i.leader = last_good;
        if k % 2 == 0 {
            i.leader.valid = false;
        }
        cmd = c.step(&i);
        if k * 20_000 > 1_000_000 {
            assert_eq!(cmd.mode, Mode::MinimumRisk, "{k}: {cmd:?}");
            assert_eq!(cmd.fault, Some(Fault::LeaderStale));
            assert!(cmd.margin.unwrap() > 0.0, "{k}: {cmd:?}");
            // Reached at ISO 15622's jerk limit (2.5 m/s^3 at 25 m/s): within a second.
            assert!(cmd.takeover, "{k}: {cmd:?}");
            if k * 20_000 > 2_000_000 {
                assert!(cmd.acceleration <= -2.0, "{k}: {cmd:?}");
            }
        } else {
            assert_ne!(cmd.mode, Mode::MinimumRisk, "{k}: {cmd:?}");
        }
    }
    // It comes back, far ahead: checked, and the nominal law resumes at once.
    last_good = at(state, NOW + 151 * 20_000).leader;
    last_good.value.gap = 120.0;
    let mut i = at(state, NOW + 151 * 20_000);
    i.leader = last_good;
    cmd = c.step(&i);
    assert_eq!(cmd.leader, firmware::TrackState::Fresh);
    assert_ne!(cmd.mode, Mode::MinimumRisk, "{cmd:?}");
    assert!(cmd.margin.unwrap() > 0.0);
}

/// A cut-in. A new vehicle 12 m ahead where the last track was 70 m: the
/// firmware takes it as a new vehicle at once, brakes harder than beta in the same period
/// (nothing gentler restores the front, and the follower 40 m back allows it), and raises the
/// takeover request.
#[test]
fn a_cut_in_is_answered_in_the_period_it_is_seen() {
    let (beta, _, _) = band_and_leader();
    let mut c = Controller::new(DEFAULT_TABLE, datasheet());
    let state = inputs((70.0, 0.0), (40.0, 0.0), 25.0);
    for k in 0..20u64 {
        let cmd = c.step(&at(state, NOW + k * 20_000));
        assert!(!cmd.takeover, "{cmd:?}");
    }
    let mut cut_in = at(state, NOW + 20 * 20_000);
    cut_in.leader.value = Track {
        gap: 12.0,
        rel_speed: -2.0,
    };
    let cmd = c.step(&cut_in);
    assert_eq!(cmd.leader, firmware::TrackState::New, "{cmd:?}");
    assert!(cmd.acceleration < beta, "{cmd:?}");
    assert!(cmd.takeover && cmd.emergency, "{cmd:?}");
    assert!(
        c.events()
            .any(|e| matches!(e, firmware::Event::NewLeader { gap, .. } if *gap == 12.0)),
        "{:?}",
        c.events().collect::<Vec<_>>()
    );
    // A leader that merely closes at its own pace is the same vehicle.
    let mut closing = at(state, NOW + 21 * 20_000);
    closing.leader.value = Track {
        gap: 11.96,
        rel_speed: -2.0,
    };
    assert_ne!(c.step(&closing).leader, firmware::TrackState::New);
}

/// The rear value holds for ever from its measurement's time while every command
/// is in the band, so a follower track that is not refreshed keeps it: no uncertified period,
/// the same rear value, however the ego's speed moves meanwhile.
#[test]
fn a_follower_track_that_ages_keeps_its_rear_value() {
    let mut c = Controller::new(DEFAULT_TABLE, datasheet());
    let state = inputs((f32::INFINITY, 0.0), (30.0, -1.0), 20.0);
    let first = c.step(&at(state, NOW));
    let follower = at(state, NOW).follower;
    for k in 1..=45u64 {
        let mut i = at(state, NOW + k * 20_000);
        i.follower = follower;
        i.ego_speed.value = 20.0 + 0.04 * k as f32;
        let cmd = c.step(&i);
        assert_eq!(cmd.mode, Mode::Nominal, "{k}: {cmd:?}");
        let expected = if k * 20_000 <= 130_000 {
            firmware::TrackState::Fresh
        } else {
            firmware::TrackState::Aging
        };
        assert_eq!(cmd.follower, expected, "{k}");
        assert_eq!(cmd.margin, first.margin, "{k}: {cmd:?}");
    }
}

/// Near the domain's top, the ego's speed error and a follower track 8 ms older
/// than the nearest ego measurement leave the rear box above 35 m/s (the ego may have been
/// faster by beta x 8 ms); once the controller has kept the speed headroom at every step since
/// before the track's time, the ego's true speed is known to be in the domain, and the rear
/// half is evaluated instead of left unknown.
#[test]
fn a_speed_kept_in_the_domain_keeps_the_rear_box_in_it() {
    let config = Config {
        law: LawConfig {
            set_speed: 40.0,
            ..datasheet().law
        },
        ..datasheet()
    };
    let s = config.sensors;
    // The measured speed whose highest true speed is 34.975 m/s.
    let measured = 34.975 * (1.0 - s.error.ego_speed_relative) - s.error.ego_speed;
    let mut c = Controller::new(DEFAULT_TABLE, config);
    let step = |c: &mut Controller<'_>, k: u64| {
        let now = NOW + k * 20_000;
        let mut i = at(inputs((f32::INFINITY, 0.0), (80.0, 0.0), measured), now);
        i.follower.timestamp_us = now - 48_000;
        c.step(&i)
    };
    let first = step(&mut c, 0);
    assert_eq!(first.mode, Mode::Uncertified, "{first:?}");
    assert_eq!(first.fault, Some(Fault::OutsideDomain { axis: 2 }));
    // Once the commands are known (the dead time and five lags, 1.6 s) the headroom holds.
    let mut last = first;
    for k in 1..150 {
        last = step(&mut c, k);
    }
    assert!(last.fault.is_none() && last.margin.is_some(), "{last:?}");
}

/// The speed cap counts what the lag still passes on from older commands: the next step's
/// `pending` is the command plus that tail, so a command capped without it left the next
/// step's speed headroom negative within 0.3 m/s of the domain's top. Along a run held at 34.8 m/s
/// with a set speed above the domain, once the commands are known, the headroom never goes below
/// zero.
#[test]
fn the_speed_cap_counts_what_the_lag_still_passes_on() {
    let config = Config {
        sensors: SensorBounds::EXACT,
        law: LawConfig {
            set_speed: 40.0,
            ..Config::default().law
        },
        ..Config::default()
    };
    let mut c = Controller::new(DEFAULT_TABLE, config);
    for k in 0..300u64 {
        let i = at(
            inputs((f32::INFINITY, 0.0), (120.0, 0.0), 34.8),
            NOW + k * 20_000,
        );
        let cmd = c.step(&i);
        if k > 100 {
            assert!(cmd.margin.unwrap() > 0.0, "{k}: {cmd:?}");
        }
    }
}

/// The campaign found it: a follower 1.6 cm behind, measured below zero within the
/// declared range error (0.1 m), was refused as implausible, and the step ran an uncertified
/// minimum-risk manoeuvre. Within the error the measurement is used (its box holds the truth);
/// beyond it, it is refused.
#[test]
fn a_follower_measured_just_below_zero_within_its_error_is_used() {
    let config = Config::default();
    let state = |gap: f32| at(inputs((1e4, 0.0), (gap, 17.8), 17.8), NOW);
    let cmd = Controller::new(DEFAULT_TABLE, config).step(&state(-0.05));
    assert_ne!(cmd.fault, Some(Fault::FollowerInvalid), "{cmd:?}");
    assert_ne!(cmd.mode, Mode::MinimumRisk, "{cmd:?}");
    let cmd = Controller::new(DEFAULT_TABLE, config).step(&state(-0.2));
    assert_eq!(fault_of(cmd), Fault::FollowerInvalid);
}

/// Until the controller's own commands bound the actuator (after an engagement), what it did
/// since the leader's measurement is bounded by the reports since then, not by the latest:
/// after two periods reporting `first_report`, the state measured once, then one period on
/// with the leader's track not refreshed and the actuator reporting -3 m/s^2 since the
/// measurement, certifies less when it reported the band's top before the measurement than
/// when it reported -3 then too (with only the latest report the first would certify no less).
#[test]
fn the_reports_since_the_measurement_bound_the_actuator_after_an_engagement() {
    let base = inputs((40.0, -3.0), (f32::INFINITY, 0.0), 20.0);
    let margin_after = |first_report: f32| {
        let mut c = declared(band_only(Config::default()));
        for now in [NOW - 40_000, NOW - 20_000] {
            let mut earlier = at(base, now);
            earlier.ego_acceleration.value = first_report;
            c.step(&earlier);
        }
        let mut measured = base;
        measured.ego_acceleration.value = -3.0;
        c.step(&measured);
        let mut next = at(base, NOW + 20_000);
        next.leader = base.leader;
        next.ego_acceleration.value = -3.0;
        c.step(&next).margin.unwrap()
    };
    let (accelerating, braking) = (margin_after(2.0), margin_after(-3.0));
    assert!(
        accelerating < braking - 0.5,
        "accelerating then {accelerating}, braking then {braking}"
    );
}
