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

/// A refused run leaves nothing behind: the `--out` folder is probed, not created, before the
/// configs are read.
#[test]
fn a_refused_run_creates_no_output_folder() {
    let out = std::env::temp_dir().join(format!("hjacc-refused-{}/deeper", std::process::id()));
    for args in [
        vec!["--config", "configs/rear/deployment.toml"],
        vec!["verify", "no/such/table.bin"],
        vec![
            "verify",
            "../firmware/tables/default.bin",
            "--period-ms",
            "0",
        ],
    ] {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_solver"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(["--quiet", "--out"])
            .arg(&out)
            .args(&args)
            .output()
            .expect("the binary runs")
            .status;
        assert!(!status.success(), "{args:?}");
        assert!(
            !out.parent().unwrap().exists(),
            "{args:?} created {}",
            out.display()
        );
    }
    // An --out below a file is refused, naming it.
    let file = std::env::temp_dir().join(format!("hjacc-refused-file-{}", std::process::id()));
    std::fs::write(&file, b"").unwrap();
    let refusal = std::process::Command::new(env!("CARGO_BIN_EXE_solver"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["--quiet", "--config", "configs/two-car.toml", "--out"])
        .arg(file.join("x"))
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&refusal.stderr);
    assert!(
        !refusal.status.success() && stderr.contains("is not a folder"),
        "{stderr}"
    );
    std::fs::remove_file(&file).ok();
}

/// `verify` refuses options that mean nothing before it proves anything, whatever their
/// order, naming the option; `--out` after the subcommand is taken.
#[test]
fn verify_refuses_nonsense_before_it_runs() {
    let table = "../firmware/tables/default.bin";
    for (args, names) in [
        (vec!["verify", table, "--range-error", "6"], "--range-error"),
        (vec!["verify", table, "--ego-age", "-0.01"], "--ego-age"),
        (
            vec!["verify", "--range-error-relative", "nan", table],
            "--range-error-relative",
        ),
        (vec!["verify", table, "--period-ms", "0"], "--period-ms"),
        (vec!["verify", table, "--period-ms", "20,-5"], "--period-ms"),
        (
            vec!["verify", table, "--budget-seconds", "-1"],
            "--budget-seconds",
        ),
        (
            vec!["verify", table, "--rear-margin", "inf"],
            "--rear-margin",
        ),
        (vec!["verify", table, "--depth", "many"], "--depth"),
        (vec!["verify", "no/such/table.bin"], "no/such/table.bin"),
    ] {
        let started = std::time::Instant::now();
        refused(&args, names);
        // Refused before the proof (about 14 s) started: not a timing target, a sign of order.
        assert!(
            started.elapsed().as_secs() < 5,
            "{args:?} ran before it refused"
        );
    }
}

/// A sweep file with a bad field is refused before any solve, naming the field.
#[test]
fn sweep_refuses_a_bad_file_naming_the_field() {
    let dir = std::env::temp_dir().join(format!("hjacc-bad-sweep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.toml");
    let base = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/rear/deployment.toml");
    std::fs::write(
        &file,
        format!("name = \"bad\"\nbase = \"{base}\"\n[[vary]]\nkey = \"game.ego.max\"\nvalues = [-1.0]\n"),
    )
    .unwrap();
    refused(&["sweep", file.to_str().unwrap()], "game.ego");
    std::fs::remove_dir_all(&dir).ok();
}
