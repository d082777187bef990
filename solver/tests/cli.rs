//! The command line's answers to a config given to the wrong door: one line, the file, the hint
//! of the right flag, and a non-zero exit.

fn refused(args: &[&str], hint: &str) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_solver"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["--quiet", "--out"])
        .arg(std::env::temp_dir().join("hjacc-wrong-door"))
        .args(args)
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} was accepted: {stderr}");
    assert!(stderr.contains(hint), "{args:?}: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
}

#[test]
fn a_config_given_to_the_wrong_door_names_the_right_one() {
    refused(
        &["--config", "configs/rear/deployment.toml"],
        "it is a rear-game config; give it with --rear",
    );
    refused(
        &["--rear", "configs/two-car.toml"],
        "it is a level-set game config; give it with --config",
    );
}
