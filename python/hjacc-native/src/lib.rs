//! `hjacc._native`, the compiled half of the Python package `hjacc`: the solver's runs, the
//! proof, the closed loop and the table reader, with the project's own code.
//!
//! Why bindings beside the pure-Python reader (`python/hjacc_table`): a notebook or a cluster
//! can solve a config, prove its table, drive the firmware against it and read it in one
//! process, with the solver's own code and the Rust reader's own arithmetic, instead of
//! shelling out to the command line and re-implementing lookups. The Python half
//! (`python/hjacc/__init__.py`) gives the table the same interface as the pure reader's and
//! hands a sweep's tasks to Dask.
//!
//! Every function that runs long releases the GIL. Every error raises `ValueError` with the
//! Rust error's message (a bad config names its key and line; a bad argument names it); a
//! missing or unwritable path raises `OSError`.

use std::path::PathBuf;

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use self_cell::self_cell;
use table_format::EgoAction;

type Reader<'a> = table_format::Table<'a>;

self_cell!(
    /// The table's bytes and the reader over them, parsed once.
    struct Parsed {
        owner: Vec<u8>,
        #[covariant]
        dependent: Reader,
    }
);

/// A safety table (`table.bin`), checked whole (magic, version, CRC, header, sizes) when it is
/// made. Lookups use the Rust reader's arithmetic, bit for bit as the firmware's.
#[pyclass(frozen, module = "hjacc._native")]
struct Table {
    parsed: Parsed,
}

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn json_to_python(py: Python<'_>, value: &impl serde::Serialize) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(value).map_err(value_error)?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

impl Table {
    /// Checks `bytes` whole and keeps them with the reader over them.
    fn from_bytes(bytes: Vec<u8>) -> PyResult<Self> {
        let parsed = Parsed::try_new(bytes, |bytes| Reader::parse(bytes)).map_err(value_error)?;
        Ok(Table { parsed })
    }

    fn reader(&self) -> &Reader<'_> {
        self.parsed.borrow_dependent()
    }
}

#[pymethods]
impl Table {
    /// A table from its bytes.
    #[new]
    fn new(data: &Bound<'_, PyBytes>) -> PyResult<Self> {
        Self::from_bytes(data.as_bytes().to_vec())
    }

    /// A table from a file.
    #[staticmethod]
    fn open(path: PathBuf) -> PyResult<Self> {
        let bytes = std::fs::read(&path)
            .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
        Self::from_bytes(bytes)
    }

    /// The header as the Rust reader holds it, in serde's form (dicts, lists, strings), each
    /// `f32` widened to a Python float as the pure-Python reader reads it: an infinite
    /// declaration stays `inf` (JSON, which the other doors go through, has no infinity).
    #[getter]
    fn header(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(pythonize::pythonize(py, self.reader().header())
            .map_err(value_error)?
            .unbind())
    }

    /// The table's error bound (quantization plus interpolation, added as the firmware adds
    /// them), m.
    #[getter]
    fn error_bound(&self) -> f32 {
        self.reader().header().error_bound.total()
    }

    /// The interpolated value at `state` (one coordinate per axis).
    fn value_at(&self, state: Vec<f32>) -> PyResult<f32> {
        self.reader().value_at(&state).map_err(value_error)
    }

    /// The policy at `state`: "accelerate" or "brake".
    fn policy_at(&self, state: Vec<f32>) -> PyResult<&'static str> {
        self.reader()
            .policy_at(&state)
            .map(action_name)
            .map_err(value_error)
    }

    /// Whether `state` lies on the table's grid.
    fn contains(&self, state: Vec<f32>) -> bool {
        self.reader().contains(&state)
    }

    /// The dequantized value at a flat (C-order) node index.
    fn node_value(&self, node: usize) -> PyResult<f32> {
        self.reader()
            .value_at_node(node)
            .ok_or_else(|| value_error(format!("node {node} is not on the grid")))
    }

    /// Every node's dequantized value, C order.
    fn node_values(&self) -> Vec<f32> {
        let t = self.reader();
        (0..t.node_count())
            .map(|n| t.value_at_node(n).unwrap_or(f32::NAN))
            .collect()
    }

    /// The node coordinates of axis `k`.
    fn coordinates(&self, k: usize) -> PyResult<Vec<f32>> {
        let t = self.reader();
        let axis = t
            .header()
            .axes
            .get(k)
            .ok_or_else(|| value_error(format!("axis {k}: the table has {} axes", t.dims())))?;
        (0..axis.points as usize)
            .map(|i| t.breakpoint(k, i))
            .collect::<Option<Vec<f32>>>()
            .ok_or_else(|| value_error(format!("axis {k}: breakpoints missing")))
    }

    fn __len__(&self) -> usize {
        self.parsed.borrow_owner().len()
    }
}

fn action_name(action: EgoAction) -> &'static str {
    match action {
        EgoAction::Accelerate => "accelerate",
        EgoAction::Brake => "brake",
    }
}

fn read_text(path: &PathBuf) -> PyResult<String> {
    std::fs::read_to_string(path)
        .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))
}

fn writable(out: &PathBuf) -> PyResult<()> {
    std::fs::create_dir_all(out).map_err(|e| PyOSError::new_err(format!("{}: {e}", out.display())))
}

/// Solves a level-set config and writes its folder under `out`; returns the summary.
#[pyfunction]
#[pyo3(signature = (config_path, out = PathBuf::from("out")))]
fn run(py: Python<'_>, config_path: PathBuf, out: PathBuf) -> PyResult<Py<PyAny>> {
    let text = read_text(&config_path)?;
    let config = solver::config::Config::from_toml(&text)
        .map_err(|e| value_error(format!("{}: {e}", config_path.display())))?;
    writable(&out)?;
    let summary = py
        .detach(|| solver::run::run(&config, &out, &mut |_| {}))
        .map_err(value_error)?;
    json_to_python(py, &summary)
}

/// Solves a rear config, proves its table (`solver verify`), and writes its folder under
/// `out`; returns the summary.
#[pyfunction]
#[pyo3(signature = (config_path, out = PathBuf::from("out")))]
fn run_rear(py: Python<'_>, config_path: PathBuf, out: PathBuf) -> PyResult<Py<PyAny>> {
    let text = read_text(&config_path)?;
    let config = solver::rear::RearConfig::from_toml(&text)
        .map_err(|e| value_error(format!("{}: {e}", config_path.display())))?;
    writable(&out)?;
    let summary = py
        .detach(|| solver::rear::run_rear(&config, &out))
        .map_err(value_error)?;
    json_to_python(py, &summary)
}

/// Proves a rear table (`solver verify`): writes `out/verify/<stem>/` (verify.json,
/// robustness.json, plots); returns `{"report", "exact", "declared", "dir", "failure"}`, with
/// `failure` None when the firmware may run the table.
#[pyfunction]
#[pyo3(signature = (
    table,
    out = PathBuf::from("out"),
    periods_ms = vec![20.0, 100.0, 200.0, 300.0],
    rear_margin = 0.0,
    depth = 21,
    budget_seconds = Some(600.0),
    max_unproven = Some(1000),
    exhaustive = false,
    range_error = None,
    range_error_relative = None,
    range_rate_error = None,
    ego_speed_error = None,
    ego_speed_error_relative = None,
    ego_age = None,
))]
#[allow(clippy::too_many_arguments)]
fn verify(
    py: Python<'_>,
    table: PathBuf,
    out: PathBuf,
    periods_ms: Vec<f64>,
    rear_margin: f64,
    depth: u32,
    budget_seconds: Option<f64>,
    max_unproven: Option<usize>,
    exhaustive: bool,
    range_error: Option<f32>,
    range_error_relative: Option<f32>,
    range_rate_error: Option<f32>,
    ego_speed_error: Option<f32>,
    ego_speed_error_relative: Option<f32>,
    ego_age: Option<f32>,
) -> PyResult<Py<PyAny>> {
    let defaults = solver::verify_table::VerifyOptions::default();
    let options = solver::verify_table::VerifyOptions {
        period_ms: periods_ms,
        rear_margin,
        depth,
        budget_seconds: budget_seconds.unwrap_or(0.0),
        max_unproven: max_unproven.unwrap_or(0),
        exhaustive,
        range_error: range_error.unwrap_or(defaults.range_error),
        range_error_relative: range_error_relative.unwrap_or(defaults.range_error_relative),
        range_rate_error: range_rate_error.unwrap_or(defaults.range_rate_error),
        ego_speed_error: ego_speed_error.unwrap_or(defaults.ego_speed_error),
        ego_speed_error_relative: ego_speed_error_relative
            .unwrap_or(defaults.ego_speed_error_relative),
        ego_age: ego_age.unwrap_or(defaults.ego_age),
    };
    // Refused before anything runs, as the command line refuses it, named by its keyword.
    let settings = options
        .resolve()
        .map_err(|e| value_error(format!("{}: {}", e.keyword(), e.reason)))?;
    if !table.exists() {
        return Err(PyOSError::new_err(format!(
            "{}: no such file",
            table.display()
        )));
    }
    writable(&out)?;
    let run = py
        .detach(|| solver::verify_table::verify_table(&table, &settings, &out, &mut |_, _| {}))
        .map_err(value_error)?;
    json_to_python(
        py,
        &serde_json::json!({
            "report": run.report,
            "exact": run.exact,
            "declared": run.declared,
            "dir": run.dir,
            "failure": run.failure(),
        }),
    )
}

/// The table bytes of a path, or the firmware's default table (leaked: they live as long as
/// the interpreter, as the closed loop's tables must).
fn table_bytes(table: Option<PathBuf>) -> PyResult<&'static [u8]> {
    Ok(match table {
        Some(path) => std::fs::read(&path)
            .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?
            .leak(),
        None => firmware::DEFAULT_TABLE,
    })
}

/// A split table and its model of the humans.
fn split_table(
    bytes: &'static [u8],
) -> PyResult<(table_format::Table<'static>, host_tests::humans::HumanModel)> {
    let table = table_format::Table::parse(bytes).map_err(value_error)?;
    let model = host_tests::humans::HumanModel::of(&table).ok_or_else(|| {
        value_error(format!(
            "the closed loop runs split three-car tables (the firmware's); this one is {:?}",
            table.header().game.kind()
        ))
    })?;
    Ok((table, model))
}

/// The closed-loop campaign (`host-tests campaign`): every leader against every follower,
/// `episodes` episodes each from certified starts, the firmware's `Controller` in the loop.
/// Writes `out/campaign.json`; returns it, with `failure` None unless a group drew no
/// certified start or, where the certificate covers the settings, humans within the model
/// collided or took the state out of the certified set.
#[pyfunction]
#[pyo3(signature = (
    episodes = 500,
    seconds = 120.0,
    seed = 1,
    sensors = "datasheet",
    latency = 0,
    cut_in = None,
    dead_time_ms = 100.0,
    lag = 0.3,
    table = None,
    out = PathBuf::from("out/campaign"),
))]
#[allow(clippy::too_many_arguments)]
fn campaign(
    py: Python<'_>,
    episodes: usize,
    seconds: f32,
    seed: u64,
    sensors: &str,
    latency: u32,
    cut_in: Option<&str>,
    dead_time_ms: f32,
    lag: f32,
    table: Option<PathBuf>,
    out: PathBuf,
) -> PyResult<Py<PyAny>> {
    use host_tests::campaign::{run_campaign, CampaignSettings, CutInKind, Sensing};
    let sensing = match (sensors, latency) {
        ("datasheet", 0) => Sensing::Datasheet,
        ("datasheet", _) => {
            return Err(value_error(
                "latency: for sensors=\"exact\"; the datasheet sensors draw their own",
            ))
        }
        ("exact", l) => Sensing::Fixed(host_tests::SensorModel::exact_with_latency(l)),
        (other, _) => {
            return Err(value_error(format!(
                "sensors: \"datasheet\" or \"exact\" (got {other:?})"
            )))
        }
    };
    let cut_in = match cut_in {
        None => None,
        Some("leader") => Some(CutInKind::Leader),
        Some("steady_leader") => Some(CutInKind::SteadyLeader),
        Some("follower") => Some(CutInKind::Follower),
        Some(other) => {
            return Err(value_error(format!(
                "cut_in: None, \"leader\", \"steady_leader\" or \"follower\" (got {other:?})"
            )))
        }
    };
    let settings = CampaignSettings {
        episodes,
        seconds,
        seed,
        sensing,
        cut_in,
        actuator: host_tests::sim::ActuatorModel {
            dead_time: dead_time_ms * 1e-3,
            lag,
        },
        config: firmware::Config::default(),
    };
    settings
        .check()
        .map_err(|e| value_error(format!("{}: {}", e.field, e.reason)))?;
    let bytes = table_bytes(table)?;
    let (table, _) = split_table(bytes)?;
    writable(&out)?;
    let report = py.detach(|| run_campaign(&table, bytes, &settings, &mut |_, _| {}, &|| {}));
    let path = out.join("campaign.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&report).map_err(value_error)?,
    )
    .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
    let failure = report.failure();
    let mut value = serde_json::to_value(&report).map_err(value_error)?;
    value["failure"] = serde_json::json!(failure);
    json_to_python(py, &value)
}

/// The adversarial search (`host-tests falsify`): certified starts on the boundary and at the
/// domain's edges, humans chosen by search within the model. Writes `out/findings.json`;
/// returns it, with `collisions` and `certificate_losses` (both 0 for a sound certificate).
#[pyfunction]
#[pyo3(signature = (episodes = 5000, seconds = 120.0, seed = 1, table = None, out = PathBuf::from("out/falsify")))]
fn falsify(
    py: Python<'_>,
    episodes: usize,
    seconds: f32,
    seed: u64,
    table: Option<PathBuf>,
    out: PathBuf,
) -> PyResult<Py<PyAny>> {
    use host_tests::falsify::{search, Budget, Setting};
    if episodes == 0 {
        return Err(value_error(
            "episodes: must be at least 1 (got 0): nothing would be tested",
        ));
    }
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err(value_error(format!(
            "seconds: must be a finite number of seconds above 0 (got {seconds})"
        )));
    }
    let bytes = table_bytes(table)?;
    let (table, model) = split_table(bytes)?;
    writable(&out)?;
    let setting = Setting::within_model(bytes, &table, model, firmware::Config::default());
    let budget = Budget::scaled(episodes, seconds);
    let report = py.detach(|| search(&setting, &budget, seed, &|_| {}));
    let path = out.join("findings.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&report).map_err(value_error)?,
    )
    .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
    let (collisions, losses) = report.failures();
    let mut value = serde_json::to_value(&report).map_err(value_error)?;
    value["collisions"] = serde_json::json!(collisions);
    value["certificate_losses"] = serde_json::json!(losses);
    json_to_python(py, &value)
}

/// Runs a sweep file on this machine, its tables in parallel (`solver sweep`); returns the
/// summary (`out/<name>/sweep.json`).
#[pyfunction]
#[pyo3(signature = (path, out = PathBuf::from("out")))]
fn sweep(py: Python<'_>, path: PathBuf, out: PathBuf) -> PyResult<Py<PyAny>> {
    let s = solver::sweep::Sweep::open(&path)
        .map_err(|e| value_error(format!("{}: {e}", path.display())))?;
    writable(&out)?;
    let summary = py
        .detach(|| solver::sweep::run_sweep(&s, &out, &|_| {}))
        .map_err(value_error)?;
    json_to_python(py, &summary)
}

/// A sweep's name and its tasks, each a JSON text a worker hands to `run_sweep_task`: one per
/// distinct rear config, with its points.
#[pyfunction]
fn sweep_tasks(path: PathBuf) -> PyResult<(String, Vec<String>)> {
    let s = solver::sweep::Sweep::open(&path)
        .map_err(|e| value_error(format!("{}: {e}", path.display())))?;
    let tasks = s
        .tasks
        .iter()
        .map(|t| serde_json::to_string(t).map_err(value_error))
        .collect::<PyResult<Vec<String>>>()?;
    Ok((s.config.name, tasks))
}

/// Runs one task of a sweep (its JSON text) into `out/<sweep name>/`; returns its points'
/// results as JSON text, for `write_sweep_summary`.
#[pyfunction]
fn run_sweep_task(py: Python<'_>, task: &str, sweep_name: &str, out: PathBuf) -> PyResult<String> {
    let task: solver::sweep::SweepTask = serde_json::from_str(task).map_err(value_error)?;
    let dir = out.join(sweep_name);
    writable(&dir)?;
    let results = py
        .detach(|| solver::sweep::run_task(&task, &dir, &mut |_| {}))
        .map_err(value_error)?;
    serde_json::to_string(&results).map_err(value_error)
}

/// Writes a sweep's summary (`sweep.json`, `sweep.csv`, `sweep.png` under `out/<name>/`) from
/// its tasks' results (the JSON texts `run_sweep_task` returned); returns it.
#[pyfunction]
#[pyo3(signature = (path, results, out = PathBuf::from("out"), seconds = 0.0))]
fn write_sweep_summary(
    py: Python<'_>,
    path: PathBuf,
    results: Vec<String>,
    out: PathBuf,
    seconds: f64,
) -> PyResult<Py<PyAny>> {
    let s = solver::sweep::Sweep::open(&path)
        .map_err(|e| value_error(format!("{}: {e}", path.display())))?;
    let mut points = Vec::new();
    for r in &results {
        let part: Vec<solver::sweep::PointResult> = serde_json::from_str(r).map_err(value_error)?;
        points.extend(part);
    }
    let summary = solver::sweep::write_summary(&s, points, &out, seconds).map_err(value_error)?;
    json_to_python(py, &summary)
}

/// hjacc's compiled half: the solver, the proof, the closed loop, the table reader.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Table>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(run_rear, m)?)?;
    m.add_function(wrap_pyfunction!(verify, m)?)?;
    m.add_function(wrap_pyfunction!(campaign, m)?)?;
    m.add_function(wrap_pyfunction!(falsify, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_tasks, m)?)?;
    m.add_function(wrap_pyfunction!(run_sweep_task, m)?)?;
    m.add_function(wrap_pyfunction!(write_sweep_summary, m)?)?;
    m.add("FORMAT_VERSION", table_format::FORMAT_VERSION)?;
    Ok(())
}
