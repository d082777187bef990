//! The committed firmware table is exactly what the solver makes from
//! `solver/configs/firmware-default.toml`: the firmware never runs a table no one can rebuild.

use solver::config::Config;
use solver::run::run;

#[test]
fn the_committed_firmware_table_is_reproduced_byte_for_byte() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let config = Config::from_toml(
        &std::fs::read_to_string(format!("{root}/solver/configs/firmware-default.toml")).unwrap(),
    )
    .unwrap();
    let out = std::env::temp_dir().join(format!("hjacc-firmware-table-{}", std::process::id()));
    run(&config, &out, &mut |_| {}).unwrap();
    let made = std::fs::read(out.join("firmware-default/table.bin")).unwrap();
    let committed = std::fs::read(format!("{root}/firmware/tables/default.bin")).unwrap();
    let _ = std::fs::remove_dir_all(&out);
    assert!(
        made == committed,
        "firmware/tables/default.bin is stale: regenerate it with \
         `cargo run -p solver --release -- --config solver/configs/firmware-default.toml` \
         and copy out/firmware-default/table.bin over it"
    );
}
