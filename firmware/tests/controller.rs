//! The controller on the host, with the default table: modes, faults, and a closed loop.

use firmware::table_format::{self, Table};
use firmware::{
    Command, Config, Controller, Fault, Inputs, Measurement, Mode, Track, DEFAULT_TABLE,
};
use proptest::prelude::*;

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
        now_us: NOW,
    }
}

fn controller() -> Controller<'static> {
    Controller::new(DEFAULT_TABLE, Config::default())
}

fn fault_of(c: Command) -> Fault {
    assert_eq!(c.mode, Mode::MinimumRisk, "{c:?}");
    c.fault.expect("a minimum-risk manoeuvre names its fault")
}

#[test]
fn the_default_table_is_accepted() {
    let c = controller();
    let t = c.table().expect("default table parses");
    assert_eq!(t.dims(), 4);
    assert!(matches!(
        t.header().game,
        table_format::Game::ThreeCarIdm { .. }
    ));
    assert!(DEFAULT_TABLE.len() <= 256 * 1024);
}

#[test]
fn cruising_with_room_runs_the_nominal_law() {
    let mut c = controller();
    let cmd = c.step(&inputs((60.0, 0.0), (40.0, 0.0), 25.0));
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    assert!(cmd.fault.is_none());
    assert!(cmd.value.unwrap() > 0.0);
    assert!((-2.0..=2.0).contains(&cmd.acceleration));
    // The nominal law closes in on a distant leader, towards the set speed: it accelerates.
    assert!(cmd.acceleration > 0.0, "{cmd:?}");
}

#[test]
fn near_the_boundary_the_table_input_takes_over() {
    let mut c = controller();
    // Closing on the leader fast, follower comfortable.
    let state = inputs((8.0, -4.0), (30.0, 0.0), 25.0);
    let cmd = c.step(&state);
    assert_eq!(cmd.mode, Mode::Override, "{cmd:?}");
    let table = c.table().unwrap();
    let expected = match table.policy_at(&[8.0, -4.0, 30.0, 0.0]).unwrap() {
        table_format::EgoAction::Accelerate => 2.0,
        table_format::EgoAction::Brake => -2.0,
    };
    assert_eq!(cmd.acceleration, expected);
    // Here that means braking.
    assert_eq!(cmd.acceleration, -2.0);
}

#[test]
fn below_the_trusted_box_the_nominal_law_needs_a_larger_margin() {
    let table = Table::parse(DEFAULT_TABLE).unwrap();
    let below = table.trusted_bounds(1).unwrap().min - 1.0; // the leader slower than the box
    let err = table.header().error_bound.total();
    let value = table.value_at(&[60.0, below, 40.0, 0.0]).unwrap();
    assert!(
        value - err > 2.5 + 1.0,
        "choose a state deep inside the safe set ({value})"
    );
    let cmd = controller().step(&inputs((60.0, below), (40.0, 0.0), 25.0));
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    // With a margin larger than the value, the same state is overridden.
    let strict = Config {
        untrusted_margin: value,
        ..Config::default()
    };
    let cmd =
        Controller::new(DEFAULT_TABLE, strict).step(&inputs((60.0, below), (40.0, 0.0), 25.0));
    assert_eq!(cmd.mode, Mode::Override, "{cmd:?}");
}

#[test]
fn every_bad_input_has_its_fault() {
    let good = inputs((40.0, 0.0), (30.0, 0.0), 25.0);
    let mut c = controller();
    assert_eq!(c.step(&good).mode, Mode::Nominal);

    let mut bad = good;
    bad.leader.value.gap = f32::NAN;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    let mut bad = good;
    bad.leader.valid = false;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    let mut bad = good;
    bad.leader.timestamp_us = NOW - 200_000;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderStale);

    let mut bad = good;
    bad.leader.timestamp_us = NOW + 1;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderStale);

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

    // Slower than the table assumes: the nominal law, uncertified, with the reason.
    let mut slow = good;
    slow.ego_speed.value = 10.0;
    let cmd = controller().step(&slow);
    assert_eq!(cmd.mode, Mode::Uncertified);
    assert_eq!(cmd.fault, Some(Fault::BelowAssumedSpeed));

    let mut bad = good;
    bad.leader.value.gap = -6.0;
    assert_eq!(fault_of(controller().step(&bad)), Fault::LeaderInvalid);

    // A closing speed beyond the grid: the table has no value, and none may be made up.
    let mut bad = good;
    bad.leader.value.rel_speed = -20.0;
    assert_eq!(
        fault_of(controller().step(&bad)),
        Fault::OutsideGrid { axis: 1 }
    );

    // The clock going backwards.
    let mut c = controller();
    c.step(&good);
    let mut earlier = good;
    earlier.now_us = NOW - 1;
    earlier.leader.timestamp_us = NOW - 10;
    earlier.follower.timestamp_us = NOW - 10;
    earlier.ego_speed.timestamp_us = NOW - 10;
    assert_eq!(fault_of(c.step(&earlier)), Fault::ClockWentBackwards);
}

#[test]
fn states_above_the_grid_are_clamped_not_refused() {
    let mut c = controller();
    // No vehicle ahead (infinite gap) and a follower far behind, pulling away.
    let cmd = c.step(&inputs((f32::INFINITY, 0.0), (500.0, 30.0), 25.0));
    assert!(cmd.fault.is_none(), "{cmd:?}");
    assert_ne!(cmd.mode, Mode::MinimumRisk);
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
        mrm_deceleration: 9.0,
        ..Config::default()
    };
    let mut c = Controller::new(DEFAULT_TABLE, harsh);
    assert_eq!(c.config().mrm_deceleration, 4.0);
    let bad = inputs((f32::NAN, 0.0), (40.0, 0.0), 25.0);
    assert_eq!(c.step(&bad).acceleration, -4.0);
}

#[test]
fn mode_changes_are_logged() {
    let mut c = controller();
    c.step(&inputs((50.0, 0.0), (40.0, 0.0), 25.0));
    c.step(&inputs((f32::NAN, 0.0), (40.0, 0.0), 25.0));
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
        prop_assert!((-4.0..=2.0).contains(&cmd.acceleration));
        prop_assert_eq!(
            cmd.fault.is_some(),
            matches!(cmd.mode, Mode::MinimumRisk | Mode::Uncertified)
        );
    }
}

/// The table agrees with itself: wherever the controller runs the nominal law, the lowest state
/// reachable in one period under it has a certified value.
#[test]
fn nominal_mode_is_certified_one_period_ahead() {
    let table = Table::parse(DEFAULT_TABLE).unwrap();
    let margin = table.header().error_bound.total();
    let mut c = controller();
    let mut nominal = 0;
    for i in 0..40 {
        for j in 0..12 {
            for k in 0..12 {
                let gap = 2.0 + 1.7 * i as f32;
                let rel = -6.0 + j as f32;
                let fgap = 4.0 + 6.0 * k as f32;
                let state = inputs((gap, rel), (fgap, 0.0), 25.0);
                let cmd = c.step(&state);
                if cmd.mode == Mode::Nominal {
                    nominal += 1;
                    assert!(table.value_at(&[gap, rel, fgap, 0.0]).unwrap() > margin);
                }
            }
        }
    }
    assert!(nominal > 100, "nominal in {nominal} states");
}

#[test]
fn below_the_assumed_speed_the_ego_spares_the_follower_unless_the_leader_forbids_it() {
    // 10 m/s, the leader stopped 15 m ahead, the follower close and closing: stopping behind
    // the leader takes 10^2 / (2 (15 - 2)) = 3.8 m/s^2, more than the follower can match (1.5):
    // the leader decides, and the ego brakes at its limit (2).
    let mut c = controller();
    let tight = c.step(&inputs((15.0, -10.0), (8.0, -3.0), 10.0));
    assert_eq!(tight.mode, Mode::Uncertified);
    assert_eq!(tight.acceleration, -2.0, "{tight:?}");
    // With 40 m to a stopped leader the ego needs 10^2 / (2 * 38) = 1.3 m/s^2 only: the
    // nominal law's harder braking is capped at what the follower can match.
    let roomy = c.step(&inputs((40.0, -10.0), (8.0, -3.0), 10.0));
    assert_eq!(roomy.mode, Mode::Uncertified);
    assert_eq!(roomy.acceleration, -1.5, "{roomy:?}");
    // In between, exactly what the leader needs: 30 m to a stopped leader takes
    // 10^2 / (2 * 28) = 1.79 m/s^2, gentler than the nominal law's 2.
    let needed = 10.0f32 * 10.0 / (2.0 * 28.0);
    let cmd = c.step(&inputs((30.0, -10.0), (8.0, -3.0), 10.0));
    assert!(cmd.acceleration <= -needed, "{cmd:?}");
}
