//! What a level-set run writes: `value.npy` with its coordinates in `axes.json`.

use solver::config::Config;
use solver::run::run;

#[test]
fn a_run_writes_the_value_and_its_coordinates() {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/two-car.toml"))
            .unwrap()
            .replace("points = 201", "points = 21")
            .replace("name = \"two-car\"", "name = \"two-car-small\"");
    let config = Config::from_toml(&text).unwrap();
    let out = std::env::temp_dir().join(format!("hjacc-output-{}", std::process::id()));
    run(&config, &out, &mut |_| {}).unwrap();
    let dir = out.join("two-car-small");
    let axes: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("axes.json")).unwrap()).unwrap();
    let expected = [
        ("gap_leader", -5.0, 45.0),
        ("rel_speed_leader", -15.0, 15.0),
    ];
    for (k, (name, min, max)) in expected.into_iter().enumerate() {
        let a = &axes["axes"][k];
        assert_eq!(a["name"], name);
        let c: Vec<f64> = a["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(c.len(), 21);
        assert!(
            (c[0] - min).abs() < 1e-12 && (c[20] - max).abs() < 1e-12,
            "{c:?}"
        );
        assert!(c.windows(2).all(|w| w[1] > w[0]));
    }
    // value.npy holds 21 x 21 values.
    let npy = std::fs::read(dir.join("value.npy")).unwrap();
    let header = String::from_utf8_lossy(&npy[..128]);
    assert!(header.contains("(21, 21, )"), "{header}");
    std::fs::remove_dir_all(&out).ok();
}
