//! Sweeps: a file of points made from one rear config, solved, proven and measured.

use std::path::Path;

use solver::sweep::{run_sweep, run_task, write_summary, Sweep, SweepConfig, SweepTask};
use table_format::{Game, Table};

const BASE: &str = include_str!("sweep/base.toml");

fn sweep(extra: &str) -> Result<Sweep, solver::SolverError> {
    let text = format!("name = \"sweep-test\"\nbase = \"base.toml\"\n{extra}");
    let config: SweepConfig = toml::from_str(&text)
        .map_err(|e| solver::SolverError::Config(solver::ConfigError::new("test", e.message())))?;
    Sweep::from_parts(config, BASE)
}

const TWO_BY_TWO: &str = r#"
[[points]]

[[points]]
game.follower = { min = -8.0, max = 2.0 }

[[vary]]
key = "front.leader_braking"
values = [3.5, 8.0]
"#;

/// Points that differ only in how a table is measured share its solve; each point's table has
/// its overrides; the summary holds every point, and a harder-braking leader certifies less.
#[test]
fn a_sweep_solves_each_table_once_and_measures_every_point() {
    let s = sweep(TWO_BY_TWO).expect("a valid sweep");
    assert_eq!((s.points(), s.tasks.len()), (4, 2));
    assert_eq!(s.tasks[1].points[0].overrides[0].0, "game.follower");
    let out = std::env::temp_dir().join(format!("hjacc-sweep-{}", std::process::id()));
    let summary = run_sweep(&s, &out, &|_| {}).expect("the sweep runs");
    assert_eq!(summary.points.len(), 4);
    assert_eq!(summary.keys, ["game.follower", "front.leader_braking"]);
    for p in &summary.points {
        assert!(p.table.proven, "{p:?}");
        assert!(p.volume.certified_ego_0_35 > 0.0);
    }
    let [a, b, c, d] = &summary.points[..] else {
        panic!("four points")
    };
    assert!(a.volume.certified_ego_0_35 > b.volume.certified_ego_0_35);
    assert!(c.volume.certified_ego_0_35 > d.volume.certified_ego_0_35);
    assert_eq!(a.table.name, b.table.name);
    assert_ne!(a.table.name, c.table.name);
    // The second table was solved with the follower braking at 8.
    let bytes = std::fs::read(out.join("sweep-test").join(&c.table.name).join("table.bin"))
        .expect("the table");
    let Game::ThreeCarSplit { follower, .. } = Table::parse(&bytes).unwrap().header().game else {
        panic!("a split table")
    };
    assert_eq!(follower.clip().min, -8.0);
    let dir = out.join("sweep-test");
    let csv = std::fs::read_to_string(dir.join("sweep.csv")).expect("sweep.csv");
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(csv.starts_with("point,game.follower,front.leader_braking,table,proven,"));
    assert!(dir.join("sweep.json").exists() && dir.join("sweep.png").exists());
    std::fs::remove_dir_all(&out).ok();
}

/// A task is what a cluster's worker gets: it goes through JSON and back, and its results make
/// the same summary wherever they were computed.
#[test]
fn a_task_travels_as_json_and_its_results_make_the_summary() {
    let s = sweep("[[vary]]\nkey = \"sensors.range\"\nvalues = [0.1, 1.0]\n").expect("valid");
    assert_eq!(s.tasks.len(), 1);
    let json = serde_json::to_string(&s.tasks[0]).expect("serialises");
    let task: SweepTask = serde_json::from_str(&json).expect("deserialises");
    let out = std::env::temp_dir().join(format!("hjacc-sweep-task-{}", std::process::id()));
    let results = run_task(&task, &out.join("sweep-test"), &mut |_| {}).expect("the task runs");
    // A larger range error passes fewer measured states.
    assert!(results[0].measured_rear.declared_share > results[1].measured_rear.declared_share);
    assert_eq!(results[0].measured_rear.declared_unproven, 0);
    let summary = write_summary(&s, results, &out, 0.0).expect("the summary");
    assert_eq!(summary.points.len(), 2);
    // Results that are not one per point are refused.
    assert!(write_summary(&s, Vec::new(), &out, 0.0).is_err());
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn bad_sweeps_name_the_point_and_the_key() {
    for (extra, names) in [
        (
            "[[vary]]\nkey = \"game.ego.min\"\nvalues = []\n",
            "vary[0].values",
        ),
        (
            "[[vary]]\nkey = \"game.max_speed\"\nvalues = [-1.0]\n",
            "game.max_speed",
        ),
        (
            "[[vary]]\nkey = \"game.nonsense\"\nvalues = [1.0]\n",
            "nonsense",
        ),
        (
            "[[vary]]\nkey = \"front.jerk\"\nvalues = [-1.0]\n",
            "front.jerk",
        ),
        (
            "[[vary]]\nkey = \"sensors.range\"\nvalues = [\"far\"]\n",
            "sensors",
        ),
        ("[volume]\nsamples = 0\n", "volume.samples"),
    ] {
        let err = sweep(extra).expect_err(extra).to_string();
        assert!(err.contains(names), "{extra}: {err}");
        if extra.contains("values = [") && !extra.contains("[]") {
            assert!(err.contains("point 0"), "{extra}: {err}");
        }
    }
    // A base that is missing is named.
    let err = Sweep::open(Path::new("no/such/sweep.toml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("no/such/sweep.toml"), "{err}");
}
