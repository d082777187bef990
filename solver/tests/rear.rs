//! The rear-game pipeline: config -> sampled-data value -> version-2 table.

use solver::rear::{run_rear, RearConfig};
use table_format::{Game, PolicyEncoding, Spacing, Table};

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
tolerance = 1e-4
max_iterations = 20000
"#;

#[test]
fn a_rear_run_writes_a_table_that_reads_back_its_value() {
    let config = RearConfig::from_toml(SMALL).unwrap();
    let out = std::env::temp_dir().join(format!("hjacc-rear-{}", std::process::id()));
    let summary = run_rear(&config, &out).unwrap();
    assert!(summary.converged, "{summary:?}");
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
    assert!(summary.plateau <= 2.0 + 1e-4, "plateau {}", summary.plateau);
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
        ("max_speed = 10.0", "max_speed = 10.0\n[game.idm]\nmax_acceleration = 1.0\ncomfortable_deceleration = 1.5\ndesired_speed = 33.3\nexponent = 4\njam_distance = 0.0", "game.idm.jam_distance"),
    ];
    for (from, to, key) in cases {
        let text = SMALL.replacen(from, to, 1);
        let err = RearConfig::from_toml(&text).unwrap_err();
        assert!(err.to_string().contains(key), "{key}: {err}");
    }
}
