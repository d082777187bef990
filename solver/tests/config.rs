//! Configs: the built-in ones parse, bad ones are refused with the field named.

use solver::config::{builtin, Config};

#[test]
fn builtin_configs_are_valid() {
    let names: Vec<&str> = builtin().iter().map(|(n, _)| *n).collect();
    // Every file under solver/configs/ is built in, so `cargo run -p solver` runs them all.
    let mut files: Vec<String> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/configs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    files.sort();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(sorted, files);
    for (name, text) in builtin() {
        Config::from_toml(text).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// The rear-game configs (run with `--rear`, not built in) parse and validate.
#[test]
fn rear_configs_are_valid() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/rear");
    let mut count = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        solver::rear::RearConfig::from_toml(&text)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        count += 1;
    }
    assert!(count > 0, "no rear configs in {dir}");
}

fn idm() -> String {
    builtin()
        .into_iter()
        .find(|(n, _)| *n == "three-car-idm.toml")
        .map(|(_, t)| t.to_string())
        .unwrap()
}

fn refused_field(text: &str) -> String {
    Config::from_toml(text).unwrap_err().field
}

#[test]
fn bad_values_name_their_field() {
    let base = idm();
    let cases = [
        (
            "time_gap = { min = 1.0, max = 2.0 }",
            "time_gap = { min = 2.0, max = 1.0 }",
            "game.time_gap",
        ),
        (
            "time_gap = { min = 1.0, max = 2.0 }",
            "time_gap = { min = -1.0, max = 2.0 }",
            "game.time_gap.min",
        ),
        (
            "ego = { min = -2.0, max = 2.0 }",
            "ego = { min = 1.0, max = 2.0 }",
            "game.ego",
        ),
        (
            "comfortable_deceleration = 1.5",
            "comfortable_deceleration = -1.5",
            "game.idm.comfortable_deceleration",
        ),
        ("time = 40.0", "time = 0.0", "horizon.time"),
        (
            "converge_tolerance = 0.05",
            "converge_tolerance = -1.0",
            "horizon.converge_tolerance",
        ),
        (
            "gap_follower = { min = -5.0, max = 75.0, points = 31 }",
            "gap_follower = { min = -5.0, max = 75.0, points = 3 }",
            "grid.gap_follower.points",
        ),
        (
            "follower_speed = { kind = \"nominal_ego_speed\", ego_speed = 20.0 }",
            "follower_speed = { kind = \"adversarial\", min_ego_speed = 30.0, max_speed = 20.0 }",
            "game.follower_speed.max_speed",
        ),
        ("name = \"three-car-idm\"", "name = \"Three Car\"", "name"),
    ];
    for (from, to, field) in cases {
        assert!(base.contains(from), "{from}");
        let text = base.replace(from, to);
        assert_eq!(refused_field(&text), field, "{to}");
    }
    let with_numerics = format!("{base}\n[numerics]\ncfl = 1.5\n");
    assert_eq!(refused_field(&with_numerics), "numerics.cfl");
    let optimistic = format!("{base}\n[numerics]\nboundary = \"optimistic\"\n");
    assert_eq!(refused_field(&optimistic), "numerics.boundary");
    let table = format!("{base}\n[table]\npoints = [16, 16, 16, 17]\n");
    assert_eq!(refused_field(&table), "table.points");
}

#[test]
fn the_five_d_game_names_its_axes_and_speed_limit() {
    let text = include_str!("../configs/three-car-idm-speeds.toml");
    let config = Config::from_toml(text).unwrap();
    let names: Vec<_> = config.axes().iter().map(|(n, _)| *n).collect();
    assert_eq!(
        names,
        [
            "gap_leader",
            "leader_speed",
            "gap_follower",
            "follower_speed",
            "ego_speed"
        ]
    );
    let cases = [
        ("max_speed = 35.0\n", "", "game.max_speed"),
        (
            "ego_speed = { min = 0.0, max = 35.0, points = 9 }\n",
            "",
            "grid.ego_speed",
        ),
        (
            "leader_speed = { min = 0.0,",
            "leader_speed = { min = -5.0,",
            "grid.leader_speed",
        ),
        (
            "[grid]\n",
            "[grid]\nrel_speed_leader = { min = -5.0, max = 5.0, points = 5 }\n",
            "grid.rel_speed_leader",
        ),
        (
            "max_speed = 35.0\n",
            "max_speed = 35.0\nfollower_speed = { kind = \"adversarial\", max_speed = 35.0 }\n",
            "game.follower_speed",
        ),
    ];
    for (from, to, field) in cases {
        assert!(text.contains(from), "{from}");
        assert_eq!(refused_field(&text.replacen(from, to, 1)), field, "{to}");
    }
}

#[test]
fn unknown_keys_and_syntax_errors_are_refused_with_a_location() {
    let base = idm();
    let text = base.replace("min_gap = 0.0", "min_gapp = 0.0");
    let err = Config::from_toml(&text).unwrap_err();
    assert!(err.reason.contains("min_gapp"), "{err}");
    let line = text
        .lines()
        .position(|l| l.starts_with("min_gapp"))
        .unwrap()
        + 1;
    assert_eq!(err.field, "game.min_gapp", "{err}");
    assert!(
        err.reason.contains(&format!("(line {line}, column 1)")),
        "{err}"
    );
    // A value of the wrong type: the key path and where it is.
    let text = base.replacen("min = 1.0, max = 2.0", "min = \"one\", max = 2.0", 1);
    let err = Config::from_toml(&text).unwrap_err();
    let line = text.lines().position(|l| l.contains("\"one\"")).unwrap() + 1;
    assert_eq!(err.field, "game.time_gap", "{err}");
    assert!(
        err.reason.contains(&format!("(line {line}, column ")),
        "{err}"
    );
    // The expected type in words, not Rust's names.
    assert!(
        err.reason.contains("expected a number") && !err.reason.contains("f64"),
        "{err}"
    );
    let negative = with_negative_points(&base);
    let err = Config::from_toml(&negative).unwrap_err();
    assert!(
        err.reason.contains("expected a whole number of at least 0")
            && !err.reason.contains("usize"),
        "{err}"
    );
    let missing = base.replace("time_gap = { min = 1.0, max = 2.0 }\n", "");
    assert_eq!(refused_field(&missing), "game.time_gap");
}

/// A value that parses but is refused by the checks after parsing is located like a parse error:
/// the line and the column of its key, or of the element of an array; a required field left out is
/// located at the table that lacks it.
#[test]
fn refusals_after_parsing_carry_the_line_and_the_column() {
    let line_of =
        |text: &str, needle: &str| text.lines().position(|l| l.contains(needle)).unwrap() + 1;
    let base = idm();
    let text = base.replacen("min = 1.0, max = 2.0", "min = 2.0, max = 1.0", 1);
    let err = Config::from_toml(&text).unwrap_err();
    let line = line_of(&text, "min = 2.0, max = 1.0");
    assert_eq!(err.field, "game.time_gap", "{err}");
    assert!(
        err.reason.ends_with(&format!("(line {line}, column 1)")),
        "{err}"
    );
    // A grid axis' point count, below WENO5's five: located at the axis' key.
    let at = base.find("points = ").unwrap();
    let end = at
        + "points = ".len()
        + base[at + "points = ".len()..]
            .find(|c: char| !c.is_ascii_digit())
            .unwrap();
    let text = format!("{}points = 3{}", &base[..at], &base[end..]);
    let err = Config::from_toml(&text).unwrap_err();
    assert!(
        err.field.starts_with("grid.") && err.field.ends_with(".points"),
        "{err}"
    );
    let line = line_of(&text, "points = 3");
    assert!(
        err.reason.contains(&format!("(line {line}, column ")),
        "{err}"
    );
    // The rear schema: an element of an axis' pieces, at its own column.
    let rear = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/configs/reference/rear.toml"
    ))
    .unwrap();
    let text = rear.replacen("[[4.0, 0.25], [10.0, 0.5]", "[[4.0, 0.25], [3.0, 0.5]", 1);
    let err = solver::rear::RearConfig::from_toml(&text).unwrap_err();
    let line = line_of(&text, "[3.0, 0.5]");
    let column = text
        .lines()
        .nth(line - 1)
        .unwrap()
        .find("[3.0, 0.5]")
        .unwrap()
        + 1;
    assert_eq!(err.field, "grid.gap_follower.pieces[1]", "{err}");
    assert!(
        err.reason
            .ends_with(&format!("(line {line}, column {column})")),
        "{err}"
    );
    // A required field left out: where it belongs, the `[game]` table's key.
    let missing = base.replace("time_gap = { min = 1.0, max = 2.0 }\n", "");
    let err = Config::from_toml(&missing).unwrap_err();
    let line = line_of(&missing, "[game]");
    assert!(
        err.reason.ends_with(&format!("(line {line}, column 2)")),
        "{err}"
    );
}

/// `base` with its first grid axis' point count made negative.
fn with_negative_points(base: &str) -> String {
    let at = base.find("points = ").expect("a grid axis") + "points = ".len();
    let end = at + base[at..].find(|c: char| !c.is_ascii_digit()).unwrap_or(0);
    format!("{}-3{}", &base[..at], &base[end..])
}

#[test]
fn a_grid_too_large_for_memory_is_refused_before_anything_is_allocated() {
    // The 2001-point grid that aborted on a 64 TB allocation: now one line naming the field.
    let base = idm();
    let huge = base.replace("points = 31", "points = 2001");
    assert_ne!(huge, base, "the base config changed: adjust the test");
    let err = Config::from_toml(&huge).unwrap_err();
    assert_eq!(err.field, "grid", "{err}");
    assert!(
        err.reason.contains("TiB") && err.reason.contains("lower"),
        "{err}"
    );
    println!("{err}");
    // A rear config whose spacing would make a billion breakpoints.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/rear");
    let text = std::fs::read_to_string(format!("{dir}/deployment.toml")).unwrap();
    let fine = text.replacen("[150.0, 3.0]", "[150.0, 0.0001]", 1);
    assert_ne!(fine, text);
    let err = solver::rear::RearConfig::from_toml(&fine).unwrap_err();
    assert_eq!(err.field, "grid", "{err}");
    println!("{err}");
}

/// Every key a parsed config serializes to (leaf and section names alike).
fn keys(value: &serde_json::Value, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                out.push(k.clone());
                keys(v, out);
            }
        }
        serde_json::Value::Array(items) => items.iter().for_each(|v| keys(v, out)),
        _ => {}
    }
}

#[test]
fn the_reference_configs_parse_and_name_every_field() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/reference");
    let level_set = std::fs::read_to_string(format!("{dir}/level-set.toml")).unwrap();
    let rear = std::fs::read_to_string(format!("{dir}/rear.toml")).unwrap();
    let sweep = std::fs::read_to_string(format!("{dir}/sweep.toml")).unwrap();
    let a = Config::from_toml(&level_set).unwrap_or_else(|e| panic!("level-set.toml: {e}"));
    let b = solver::rear::RearConfig::from_toml(&rear).unwrap_or_else(|e| panic!("rear.toml: {e}"));
    let c = solver::sweep::Sweep::open(std::path::Path::new(&format!("{dir}/sweep.toml")))
        .unwrap_or_else(|e| panic!("sweep.toml: {e}"));
    let mut c = serde_json::to_value(&c.config).unwrap();
    // A listed point's keys are the rear config's, documented in rear.toml.
    c["points"] = serde_json::json!([]);
    // The level-set file also documents the 5-D game's fields, commented out.
    let five_d = ["max_speed", "leader_speed", "follower_speed", "ego_speed"];
    for (text, value, extra) in [
        (&level_set, serde_json::to_value(&a).unwrap(), &five_d[..]),
        (&rear, serde_json::to_value(&b).unwrap(), &[][..]),
        (&sweep, c, &[][..]),
    ] {
        let mut names: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
        keys(&value, &mut names);
        for name in names {
            assert!(
                text.contains(&format!("{name} ="))
                    || text.contains(&format!("[{name}]"))
                    || text.contains(&format!("[[{name}]]"))
                    || text.contains(&format!("[game.{name}]")),
                "the reference config does not document `{name}`"
            );
        }
    }
}
