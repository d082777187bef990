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

/// The deployed table was checked under the firmware's declared error, and says so in its
/// record: the firmware's default configuration loads it, and its declared error is the one
/// `solver verify` checks under by default.
#[test]
fn the_deployed_table_records_the_error_the_firmware_declares() {
    let table = table_format::Table::parse(firmware::DEFAULT_TABLE).expect("parses");
    let record = table.header().verification.expect("verified");
    let declared = firmware::Config::default().sensors.error;
    assert_eq!(record.measurement_error, declared);
    assert_eq!(
        solver::verify_table::VerifyOptions::default().measurement_error(),
        declared
    );
    assert!(
        firmware::Controller::new(firmware::DEFAULT_TABLE, firmware::Config::default())
            .table()
            .is_some()
    );
}

/// What the standstill lemma proves, and what it does not, on the deployed table: the audit's
/// state `(gap 0.048633 m, follower 0.742819 m/s, ego 0.304971 m/s)` is certified and lies in
/// the lemma's region (gap at most `G / 2`). With the ego braking at `beta` and the follower at
/// its clip (the IDM asks for at least that much below `G`), both come to rest 1.59 cm apart:
/// the gap never reaches zero (the lemma's claim), but the state they rest in is not certified
/// (its value is below the level), and nothing re-certifies it. The docs claim exactly this
/// (docs/certificate.md, `firmware::controller`'s `REAR_SAMPLE_TOLERANCE`).
#[test]
fn the_standstill_lemma_keeps_the_gap_but_not_the_certificate() {
    let table = Table::parse(firmware::DEFAULT_TABLE).expect("parses");
    let header = table.header();
    let model = solver::verify::RearModel::from_game(&header.game, header.min_gap).expect("split");
    let level = header.error_bound.total();
    let (gap, follower, ego) = (0.048_633f32, 0.742_819f32, 0.304_971f32);
    let value = |g: f32, vf: f32, ve: f32| table.value_at(&[g, vf, ve]).expect("in the grid");
    assert!(
        value(gap, follower, ego) > level,
        "the audit's state is certified"
    );
    let region = solver::verify::standstill_gap(&model).expect("the lemma applies");
    assert!((region - 0.756).abs() < 1e-3 && f64::from(gap) <= 0.5 * region);
    // Both brake to rest: the ego at beta, the follower at its clip.
    let beta = -model.ego_min;
    let clip = -model.clip_min();
    let (ve, vf) = (f64::from(ego), f64::from(follower));
    let rest = f64::from(gap) + ve * ve / (2.0 * beta) - vf * vf / (2.0 * clip);
    // The gap's least value is at the rest (the follower is the faster until it stops).
    assert!(rest > model.min_gap, "the lemma: the gap stays above zero");
    assert!((rest - 0.0159).abs() < 2e-4, "{rest}");
    let at_rest = value(rest as f32, 0.0, 0.0);
    assert!(
        at_rest <= level && at_rest > level - 0.01,
        "the rest state is safe but not certified: {at_rest} against {level}"
    );
}
