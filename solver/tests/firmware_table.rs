//! The committed firmware table is the one `solver/configs/rear/deployment.toml` describes: the
//! firmware never runs a table no one can rebuild. The header is checked against the config
//! (game, axes, breakpoints, the stop), and the whole pipeline rebuilds the table byte for byte
//! (about 20 s on two cores; `solver/benches/deployment.sh` times it).

use solver::rear::{run_rear, RearConfig, RearStop, RearStopped};
use table_format::{HorizonStatus, Spacing, Table};

fn deployment() -> RearConfig {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    RearConfig::from_toml(
        &std::fs::read_to_string(format!("{root}/solver/configs/rear/deployment.toml")).unwrap(),
    )
    .unwrap()
}

const STALE: &str = "firmware/tables/default.bin is stale: regenerate it with \
     `cargo run -p solver --release -- --rear solver/configs/rear/deployment.toml` \
     and copy out/deployment/table.bin over it";

#[test]
fn the_committed_firmware_table_is_rebuilt_byte_for_byte() {
    let config = deployment();
    let out = std::env::temp_dir().join(format!("hjacc-deployment-{}", std::process::id()));
    let summary = run_rear(&config, &out).unwrap();
    assert_eq!(summary.stopped, RearStopped::Proven);
    let rebuilt = std::fs::read(out.join("deployment/table.bin")).unwrap();
    let committed = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/tables/default.bin"
    ))
    .unwrap();
    assert!(rebuilt == committed, "{STALE}");
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn the_committed_firmware_table_is_the_deployment_configs() {
    let config = deployment();
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/tables/default.bin"
    ))
    .unwrap();
    let table = Table::parse(&bytes).unwrap();
    let header = table.header();
    let stale = STALE;
    assert_eq!(header.game, config.game_description(), "{stale}");
    assert_eq!(header.min_gap, config.game.min_gap as f32, "{stale}");
    assert_eq!(header.quantization.bits, config.table_bits, "{stale}");
    let grid = config.grid().unwrap();
    assert_eq!(table.dims(), 3);
    for k in 0..3 {
        let axis = &header.axes[k];
        assert_eq!(axis.spacing, Spacing::Listed, "{stale}");
        assert_eq!(axis.name, grid.name(k), "{stale}");
        let stored: Vec<f32> = (0..axis.points as usize)
            .map(|i| table.breakpoint(k, i).unwrap())
            .collect();
        assert_eq!(stored, grid.axis(k), "axis {k}: {stale}");
    }
    // The deployment stops at the first iterate `verify` proves, and its header says so.
    assert_eq!(config.solve.stop, RearStop::Proven);
    assert!(
        matches!(header.horizon.status, HorizonStatus::Proven { .. }),
        "{:?}: {stale}",
        header.horizon
    );
    assert!(header.verification.is_some_and(|v| v.is_complete()));
}

/// `solver verify`'s declared measurement error is the firmware's default sensor bounds, so
/// that the proof under error is about the error the firmware assumes.
#[test]
fn the_declared_measurement_error_is_the_firmwares() {
    let s = firmware::SensorBounds::default();
    let e = solver::robust::MeasurementError::default();
    assert_eq!(
        [
            e.range,
            e.range_relative,
            e.range_rate,
            e.ego_speed,
            e.ego_speed_relative
        ],
        [
            s.range_error,
            s.range_error_relative,
            s.range_rate_error,
            s.ego_speed_error,
            s.ego_speed_error_relative
        ]
    );
    // The ego measurement nearest a track is at most half the ego speed's 20 ms cycle away.
    assert!(e.ego_age >= 0.01);
}
