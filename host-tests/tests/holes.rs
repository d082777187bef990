//! Regression tests for the holes at the domain's edge: each reproduction from the
//! issue, in the closed loop with the firmware, on the default table. Each failed before its
//! fix: (A) certified a start that collides, (B) ran the nominal law unchecked above 35 m/s,
//! (C) left the domain on a follower at exactly 35 m/s seen through measurements of different
//! ages. (D) is `solver verify`'s sample bound (its own tests), (E) the simulator's clock
//! (`host_tests::sim`'s tests).

use firmware::{Config, Controller, PlantConfig, DEFAULT_TABLE};
use host_tests::falsify::{Case, FollowerRule, Method, Schedule, Setting, StartKind};
use host_tests::humans::HumanModel;
use host_tests::sim::{ActuatorModel, Car, SensorModel};
use host_tests::world::{state_of, Score, Start};
use table_format::Table;

/// The delays the default configuration covers at their limits.
const ACTUATOR: ActuatorModel = ActuatorModel {
    dead_time: 0.1,
    lag: 0.3,
};

fn table() -> Table<'static> {
    Table::parse(DEFAULT_TABLE).unwrap()
}

fn run(table: &Table<'_>, case: &Case) -> Score {
    let setting = Setting::within_model(
        DEFAULT_TABLE,
        table,
        HumanModel::of(table).unwrap(),
        Config::default(),
    );
    setting.run(case, None)
}

/// The leader's gap at which the true start's front margin is `margin` (bisection), the
/// engaged acceleration held through the dead time and lag.
fn gap_for_front_margin(start: Start, margin: f32) -> f32 {
    let c = Controller::new(DEFAULT_TABLE, Config::default());
    let front = |gap: f32| {
        let mut cars = start.cars;
        cars[0].x = cars[1].x + gap;
        c.certificate_with_response(
            state_of(cars),
            ACTUATOR.dead_time + ACTUATOR.lag,
            start.engaged_acceleration,
        )
        .unwrap()
        .front
    };
    let (mut lo, mut hi) = (0.0f32, 500.0f32);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if front(mid) < margin {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

fn case(start: Start, leader: f32, sensors: SensorModel, seconds: f32) -> Case {
    Case {
        method: Method::Structured,
        start_kind: StartKind::FastEgo,
        start,
        schedule: Schedule {
            segment_s: 1e9,
            leader: vec![leader],
            time_gap: vec![0.5],
        },
        follower_rule: FollowerRule::Schedule,
        follower_reacts: false,
        follower_after_reaction: Default::default(),
        leader_brakes_at_authority_change: false,
        sensors,
        actuator: ACTUATOR,
        seconds,
        seed: 7,
        refused_starts: 0,
    }
}

fn certified(start: &Start) -> bool {
    let c = Controller::new(DEFAULT_TABLE, Config::default());
    c.certificate_with_response(
        state_of(start.cars),
        ACTUATOR.dead_time + ACTUATOR.lag,
        start.engaged_acceleration,
    )
    .is_some_and(|c| c.is_certified())
}

/// (A) The ego at 34.8 m/s engaged accelerating at +0.8 m/s^2 reaches 35.12 m/s before the
/// braking takes effect. The front value held it at 35 m/s and certified a start 0.05 m above
/// the margin that collided at 9.9 s. Now that start is not certified (its speed headroom is
/// -0.12 m/s), and the same engagement at 34 m/s, certified at the front's boundary, neither
/// collides nor loses its certificate.
#[test]
fn a_an_ego_accelerating_at_the_speed_limit_is_not_certified_and_its_neighbour_holds() {
    let table = table();
    let far_follower = Car { x: -300.0, v: 20.0 };
    let at = |ego: f32| Start {
        cars: [
            Car { x: 0.0, v: 17.8 },
            Car { x: 0.0, v: ego },
            far_follower,
        ],
        engaged_acceleration: 0.8,
    };
    let mut hole = at(34.8);
    hole.cars[0].x = gap_for_front_margin(hole, 0.05);
    assert!(!certified(&hole), "the reported start is still certified");
    let mut near = at(34.0);
    near.cars[0].x = gap_for_front_margin(near, 0.05);
    assert!(certified(&near));
    let s = run(&table, &case(near, -1.0, SensorModel::IDEAL, 30.0));
    assert!(!s.failed(), "{s:?}");
    assert!(s.max_ego_speed <= 35.0, "{}", s.max_ego_speed);
}

/// (B) Above 35 m/s the firmware returned the nominal law uncertified before the front
/// look-ahead ran: an ego at 34.97 m/s accelerating at +1.2 m/s^2 behind a stopped leader went
/// to 35.14 m/s and braked at the nominal -1.5 m/s^2 into the leader. Now the front is enforced
/// in every mode: from that start, with the leader placed where the front half holds, there is
/// no collision, and the front margin stays above its tolerance.
#[test]
fn b_the_front_is_enforced_above_the_speed_limit() {
    let table = table();
    let mut start = Start {
        cars: [
            Car { x: 0.0, v: 0.0 },
            Car { x: 0.0, v: 34.97 },
            Car { x: -400.0, v: 0.0 },
        ],
        engaged_acceleration: 1.2,
    };
    start.cars[0].x = gap_for_front_margin(start, 0.05);
    // Not certified: the commands in the pipeline take the ego past 35 m/s.
    assert!(!certified(&start));
    let s = run(
        &table,
        &case(start, 0.0, SensorModel::exact_with_latency(5), 30.0),
    );
    assert!(s.collision_time.is_none(), "{s:?}");
    assert!(
        s.min_front > -firmware::CERTIFICATE_TOLERANCE,
        "{}",
        s.min_front
    );
}

/// (C) A follower at exactly 35 m/s, its track 60 ms old, behind an ego at 26.9 m/s engaged
/// accelerating at +0.85 m/s^2 and measured fresh: the follower's speed was taken as
/// `ego_speed - rel_speed` from two times, read 35.05 m/s, and the firmware ran uncertified for
/// 3 periods at +0.92 m/s^2, into a collision with the leader at 8.0 s. Now the rear state is
/// moved to the follower track's time: no period is uncertified, nothing is lost.
#[test]
fn c_measurements_of_different_ages_are_moved_to_one_time() {
    let table = table();
    let mut start = Start {
        cars: [
            Car { x: 0.0, v: 20.0 },
            Car { x: 0.0, v: 26.9 },
            Car { x: -45.0, v: 35.0 },
        ],
        engaged_acceleration: 0.85,
    };
    start.cars[0].x = gap_for_front_margin(start, 0.05);
    assert!(certified(&start));
    let sensors = SensorModel::exact_with_latencies([0, 3, 0]);
    let s = run(&table, &case(start, -1.0, sensors, 30.0));
    assert_eq!(s.periods_by_mode[3], 0, "uncertified periods: {s:?}");
    assert!(!s.failed(), "{s:?}");
}

/// The search has teeth: with a planted hole it must find it. The firmware declares an actuator
/// lag of 0.1 s while the plant's is up to 0.3 s (outside the model): the look-ahead then
/// underestimates how long the ego keeps accelerating, and a search of a few hundred episodes
/// finds collisions or losses.
#[test]
fn the_search_finds_a_planted_hole() {
    use host_tests::falsify::{search, Budget};
    let table = table();
    let config = Config {
        plant: PlantConfig {
            actuator_lag_us: 100_000,
            ..Config::default().plant
        },
        ..Config::default()
    };
    let mut setting = Setting::within_model(
        DEFAULT_TABLE,
        &table,
        HumanModel::of(&table).unwrap(),
        config,
    );
    setting.plant = ACTUATOR;
    let report = search(&setting, &Budget::scaled(400, 60.0), 3, &|_| {});
    let (collisions, losses) = report.failures();
    eprintln!(
        "planted hole: {collisions} collisions, {losses} losses in {} episodes",
        report.episodes()
    );
    assert!(collisions + losses > 0, "{:?}", report.methods);
    // And within the model the same budget finds nothing.
    let setting = Setting::within_model(
        DEFAULT_TABLE,
        &table,
        HumanModel::of(&table).unwrap(),
        Config::default(),
    );
    let report = search(&setting, &Budget::scaled(400, 60.0), 3, &|_| {});
    assert_eq!(report.failures(), (0, 0), "{:?}", report.findings);
}

/// The search is deterministic for its seed (its cases are drawn in order and run in
/// parallel): two runs write the same findings, and another seed searches elsewhere.
#[test]
fn the_search_is_deterministic_per_seed() {
    use host_tests::falsify::{search, Budget};
    let table = table();
    let setting = Setting::within_model(
        DEFAULT_TABLE,
        &table,
        HumanModel::of(&table).unwrap(),
        Config::default(),
    );
    let budget = Budget::scaled(150, 20.0);
    let json = |seed: u64| {
        let r = search(&setting, &budget, seed, &|_| {});
        serde_json::to_string(&(&r.methods, &r.worst, &r.findings)).unwrap()
    };
    let first = json(5);
    assert_eq!(first, json(5));
    assert_ne!(first, json(6));
}
