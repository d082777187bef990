//! The committed firmware table is the one `solver/configs/rear/deployment.toml` describes: the
//! firmware never runs a table no one can rebuild. Solving it takes about 3.5 minutes on two
//! cores, so the byte-for-byte check is a benchmark (`solver/benches/deployment.sh`); here the
//! header is checked against the config (game, axes, breakpoints, convergence), and
//! `tests/rear.rs` runs the same pipeline on a reduced grid.

use solver::rear::RearConfig;
use table_format::{HorizonStatus, Spacing, Table};

#[test]
fn the_committed_firmware_table_is_the_deployment_configs() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let config = RearConfig::from_toml(
        &std::fs::read_to_string(format!("{root}/solver/configs/rear/deployment.toml")).unwrap(),
    )
    .unwrap();
    let bytes = std::fs::read(format!("{root}/firmware/tables/default.bin")).unwrap();
    let table = Table::parse(&bytes).unwrap();
    let header = table.header();
    let stale = "firmware/tables/default.bin is stale: regenerate it with \
         `cargo run -p solver --release -- --rear solver/configs/rear/deployment.toml` \
         and copy out/deployment/table.bin over it";
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
    let HorizonStatus::Converged {
        tolerance,
        residual,
    } = header.horizon.status
    else {
        panic!(
            "the firmware's table is not converged: {:?}",
            header.horizon
        );
    };
    assert!(residual <= tolerance && tolerance <= config.solve.tolerance as f32);
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
