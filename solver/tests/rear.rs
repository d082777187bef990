//! The rear-game pipeline: config -> sampled-data value -> table -> proof.

use solver::rear::{run_rear, RearConfig, RearStopped};
use table_format::{Game, HorizonStatus, PolicyEncoding, Spacing, Table};

const SMALL: &str = r#"
name = "rear-small"
table_bits = 16

[game]
ego = { min = -3.5, max = 2.0 }
leader = { min = -6.0, max = 2.0 }
follower = { min = -6.0, max = 2.0 }
time_gap = { min = 1.0, max = 2.0 }
max_speed = 10.0

[grid]
gap_follower = { start = -1.0, pieces = [[1.0, 0.5], [4.0, 0.5], [30.0, 1.0]] }
follower_speed = { start = 0.0, pieces = [[1.0, 0.5], [10.0, 1.0]] }
ego_speed = { start = 0.0, pieces = [[1.0, 0.5], [10.0, 1.0]] }

[solve]
period = 0.2
stop = "residual"
tolerance = 1e-4
max_iterations = 20000
"#;

/// The deployment's game and spacing, on speeds up to 10 m/s and gaps up to 30 m, with the
/// follower pushed 0.2 m/s^2 beyond its model: a table `verify` proves after about 100
/// iterations.
const PROVABLE: &str = r#"
name = "rear-provable"
table_bits = 8

[game]
ego = { min = -3.5, max = 2.0 }
leader = { min = -6.0, max = 2.0 }
follower = { min = -6.0, max = 2.0 }
time_gap = { min = 1.0, max = 2.0 }
max_speed = 10.0
follower_robustness = 0.2

[grid]
gap_follower = { start = -1.0, pieces = [[1.0, 0.25], [4.0, 0.25], [10.0, 0.5], [30.0, 1.0]] }
follower_speed = { start = 0.0, pieces = [[1.0, 0.25], [10.0, 0.5]] }
ego_speed = { start = 0.0, pieces = [[1.0, 0.25], [10.0, 0.5]] }

[solve]
period = 0.1
tolerance = 1e-4
max_iterations = 20000
check_every = 20
"#;

/// The default stop: the first iterate `verify` proves is the table, its header says so, and
/// every attempt before it failed.
#[test]
fn a_rear_run_stops_at_the_first_iterate_verify_proves() {
    let config = RearConfig::from_toml(PROVABLE).unwrap();
    let out = std::env::temp_dir().join(format!("hjacc-rear-proven-{}", std::process::id()));
    let summary = run_rear(&config, &out).unwrap();
    assert_eq!(summary.stopped, RearStopped::Proven, "{summary:?}");
    let (last, before) = summary.proof_attempts.split_last().expect("attempts");
    assert!(last.proven && last.iterations == summary.iterations);
    assert!(
        !before.is_empty() && before.iter().all(|a| !a.proven),
        "{before:?}"
    );
    assert!(summary.verification.is_complete());
    // The stop is not a fixed point, and the summary and the header say how far from one.
    assert!(summary.drift.max_change_m > 0.0);
    assert_eq!(summary.drift.iterations, 20);
    let bytes = std::fs::read(out.join("rear-provable/table.bin")).unwrap();
    let table = Table::parse(&bytes).unwrap();
    let header = table.header();
    assert_eq!(
        header.horizon.status,
        HorizonStatus::Proven {
            residual: summary.residual_m,
            drift: summary.drift.max_change_m,
            stretch: summary.drift.horizon_s as f32,
        }
    );
    assert_eq!(header.verification, Some(summary.verification));
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn a_rear_run_writes_a_table_that_reads_back_its_value() {
    let config = RearConfig::from_toml(SMALL).unwrap();
    let out = std::env::temp_dir().join(format!("hjacc-rear-{}", std::process::id()));
    let summary = run_rear(&config, &out).unwrap();
    assert_eq!(summary.stopped, RearStopped::Residual, "{summary:?}");
    let bytes = std::fs::read(out.join("rear-small/table.bin")).unwrap();
    let table = Table::parse(&bytes).unwrap();
    let h = table.header();
    assert!(matches!(h.game, Game::ThreeCarSplit { .. }));
    assert_eq!(h.policy, PolicyEncoding::None);
    assert!(h.axes.iter().all(|a| a.spacing == Spacing::Listed));
    assert_eq!(h.error_bound.interpolation, 0.0);
    // Between nodes the table is the solver's value (same nodes, same interpolation), less at
    // most the quantization error, never more.
    let grid = config.grid().unwrap();
    let npy = std::fs::read(out.join("rear-small/value.npy")).unwrap();
    let values: Vec<f32> = npy[npy.len() - 4 * grid.len()..]
        .chunks(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    // axes.json gives value.npy's coordinates: the table's breakpoints, axis by axis.
    let axes: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("rear-small/axes.json")).unwrap()).unwrap();
    for k in 0..3 {
        let a = &axes["axes"][k];
        assert_eq!(a["name"], grid.name(k));
        let coords: Vec<f32> = a["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        assert_eq!(coords, grid.axis(k), "axis {k}");
    }
    let q = h.error_bound.quantization;
    for z in [
        [2.3f32, 0.3, 0.0],
        [17.0, 7.5, 6.2],
        [0.1, 0.0, 9.9],
        [29.0, 10.0, 0.4],
    ] {
        let solver = grid.interpolate(&values, &z);
        let stored = table.value_at(&z).unwrap();
        assert!(
            stored <= solver + 1e-5 && stored >= solver - q - 1e-5,
            "{z:?}: {stored} vs {solver}"
        );
    }
    // The value never exceeds the constraint, and at rest the follower only closes to s0.
    assert!(
        summary.plateau_m <= 2.0 + 1e-4,
        "plateau {}",
        summary.plateau_m
    );
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn bad_rear_configs_name_the_key() {
    let cases = [
        ("ego = { min = -3.5, max = 2.0 }", "ego = { min = 0.5, max = 2.0 }", "game.ego"),
        ("leader = { min = -6.0, max = 2.0 }", "leader = { min = 0.0, max = 2.0 }", "game.leader"),
        ("max_speed = 10.0", "max_speed = 12.0", "grid.follower_speed"),
        ("period = 0.2", "period = 0.0", "solve.period"),
        ("[[1.0, 0.5], [4.0, 0.5], [30.0, 1.0]]", "[[1.0, 0.5], [0.5, 0.5]]", "grid.gap_follower.pieces[1]"),
        ("table_bits = 16", "table_bits = 12", "table_bits"),
        ("stop = \"residual\"", "stop = \"sometimes\"", "stop"),
        ("max_iterations = 20000", "max_iterations = 20000\ncheck_every = 0", "solve.check_every"),
        ("max_speed = 10.0", "max_speed = 10.0\n[game.idm]\nmax_acceleration = 1.0\ncomfortable_deceleration = 1.5\ndesired_speed = 33.3\nexponent = 4\njam_distance = 0.0", "game.idm.jam_distance"),
    ];
    let emergency = |level: &str, jerk: &str, reaction: &str, theta: &str, lights: &str| {
        format!(
            "max_speed = 10.0\n[game.emergency]\nlevel = {level}\njerk = {jerk}\n\
             follower_reaction_time = {reaction}\nlights_deceleration = {theta}\n\
             lights_command = {lights}"
        )
    };
    let declarations = [
        (
            emergency("0.0", "12.0", "1.15", "1.3", "-1.5"),
            "game.emergency.level",
        ),
        (
            emergency("8.0", "0.0", "1.15", "1.3", "-1.5"),
            "game.emergency.jerk",
        ),
        (
            emergency("8.0", "12.0", "5.5", "1.3", "-1.5"),
            "game.emergency.follower_reaction_time",
        ),
        (
            emergency("8.0", "12.0", "1.15", "-0.1", "-1.5"),
            "game.emergency.lights_deceleration",
        ),
        (
            emergency("8.0", "12.0", "1.15", "1.3", "-1.3"),
            "game.emergency.lights_command",
        ),
        (
            "max_speed = 10.0\n[game.emergency]\nlevel = 8.0".to_string(),
            "jerk",
        ),
    ];
    let declarations = declarations
        .iter()
        .map(|(to, key)| ("max_speed = 10.0", to.as_str(), *key));
    for (from, to, key) in cases.into_iter().chain(declarations) {
        let text = SMALL.replacen(from, to, 1);
        let err = RearConfig::from_toml(&text).unwrap_err();
        assert!(err.to_string().contains(key), "{key}: {err}");
    }
}

/// A `[game.emergency]` section is the vehicle's declaration in the table's header; without
/// one the header declares the default, the firmware's default configuration's.
#[test]
fn a_rear_config_declares_the_vehicles_emergency_in_the_header() {
    let declared = |config: &RearConfig| match config.game_description() {
        Game::ThreeCarSplit { emergency, .. } => emergency,
        g => panic!("not a split game: {g:?}"),
    };
    let plain = RearConfig::from_toml(SMALL).unwrap();
    assert_eq!(
        declared(&plain),
        table_format::EmergencyDeclaration::DEFAULT
    );
    let wet = SMALL.replacen(
        "max_speed = 10.0",
        "max_speed = 10.0\n[game.emergency]\nlevel = 5.0\njerk = inf\n\
         follower_reaction_time = 1.5\nlights_deceleration = 0.7\nlights_command = -1.0",
        1,
    );
    let wet = declared(&RearConfig::from_toml(&wet).unwrap());
    assert_eq!(wet.braking.level, 5.0);
    assert_eq!(wet.braking.jerk, f32::INFINITY);
    assert_eq!(wet.follower_reaction_time, 1.5);
    assert_eq!(wet.lights_deceleration, 0.7);
    assert_eq!(wet.lights_command, -1.0);
}
