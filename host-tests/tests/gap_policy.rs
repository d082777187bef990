//! The gap policy's analysis of two braking authorities (`host_tests::gap_policy`).

use firmware::Config;
use host_tests::gap_policy::braking_a_follower_allows;
use host_tests::humans::HumanModel;
use table_format::rear::ReactingFollower;
use table_format::{MeasurementError, Table};

/// A follower 1 s behind (the IDM's 2 m jam distance plus 30 m) at 30 m/s that holds its speed
/// for 1.15 s and then brakes at the IDM's clip at once: with exact sensors and no delay it
/// allows the 5.806 m/s^2 worked out by hand in `table_format::rear`; the declared errors and
/// 0.55 s before the braking shows (the track's age, a period, and 0.40 s until the emergency
/// ramp brings the deceleration past the lights' 1.3 m/s^2; and the IDM's acceleration at the
/// box's most inviting corner until it reacts) take it down to 4.27 m/s^2 (4.70 with the
/// 0.25 s of lights counted from zero deceleration); a follower 2 s behind allows more, one
/// 0.6 s behind less.
#[test]
fn the_braking_a_follower_allows_matches_the_figures() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let model = HumanModel::of(&table).unwrap();
    let follower = ReactingFollower {
        braking: -model.follower_clip().0,
        jerk: f32::INFINITY,
        ..ReactingFollower::careful_driver(model.max_speed)
    };
    let mut exact = Config::default();
    exact.sensors.error = MeasurementError {
        range: 0.0,
        range_relative: 0.0,
        range_rate: 0.0,
        ego_speed: 0.0,
        ego_speed_relative: 0.0,
        ..exact.sensors.error
    };
    let b = braking_a_follower_allows(&exact, &model, &follower, 0.0, 1.0, 30.0).unwrap();
    assert!((b - 5.806).abs() < 0.005, "{b}");
    let declared = Config::default();
    let allows = |time_gap: f32, delay: f32| {
        braking_a_follower_allows(&declared, &model, &follower, delay, time_gap, 30.0).unwrap()
    };
    assert!(
        (allows(1.0, 0.25) - 4.70).abs() < 0.01,
        "{}",
        allows(1.0, 0.25)
    );
    assert!(
        (allows(1.0, 0.55) - 4.27).abs() < 0.01,
        "{}",
        allows(1.0, 0.55)
    );
    let allows = |time_gap: f32| allows(time_gap, 0.55);
    assert!(allows(0.6) < allows(1.0) && allows(1.0) < allows(2.0));
}
