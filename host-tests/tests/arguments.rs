//! The command line refuses nonsense with one line naming the argument and a non-zero exit,
//! before it runs anything (a safety campaign that passes vacuously is a false green light).

use std::process::Command;

fn refused(args: &[&str], names: &str) {
    let out = Command::new(env!("CARGO_BIN_EXE_host-tests"))
        .args(args)
        .arg("--out")
        .arg(std::env::temp_dir().join("hjacc-refused-arguments"))
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} was accepted: {stderr}");
    assert!(stderr.contains(names), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
}

#[test]
fn the_campaign_refuses_durations_counts_latencies_and_sensors_that_mean_nothing() {
    for (args, name) in [
        (&["campaign", "--seconds=-5"][..], "--seconds"),
        (&["campaign", "--seconds", "0"], "--seconds"),
        (&["campaign", "--seconds", "nan"], "--seconds"),
        (&["campaign", "--seconds", "inf"], "--seconds"),
        (&["campaign", "--episodes", "0"], "--episodes"),
        (
            &["campaign", "--latency", "51", "--sensors", "exact"],
            "--latency",
        ),
        (&["campaign", "--latency", "3"], "--latency"),
        (&["campaign", "--sensors", "perfect"], "--sensors"),
        (&["campaign", "--cut-in", "sideways"], "--cut-in"),
        (&["campaign", "--lag", "nan"], "--lag"),
        (&["campaign", "--dead-time-ms=-1"], "--dead-time-ms"),
    ] {
        refused(args, name);
    }
}

#[test]
fn the_search_refuses_them_too() {
    refused(&["falsify", "--episodes", "0"], "--episodes");
    refused(&["falsify", "--seconds", "0"], "--seconds");
    refused(&["falsify", "--seconds", "nan"], "--seconds");
    refused(&["falsify", "--seconds", "-5"], "--seconds");
    refused(&["campaign", "--seconds", "-5"], "--seconds");
}
