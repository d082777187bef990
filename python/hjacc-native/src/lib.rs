//! `hjacc`, the Python module: the solver's runs and the table reader, from Python.
//!
//! Why bindings beside the pure-Python reader (`python/hjacc_table`): a notebook can solve a
//! config and read its table in one process, with the solver's own code and the Rust reader's
//! own arithmetic, instead of shelling out to `cargo run` and re-implementing lookups. The
//! pure-Python reader stays for those who cannot build a native module; CI checks that the two
//! agree bit for bit.
//!
//! - `hjacc.run(config_path, out="out")`: solves a level-set config (as
//!   `cargo run -p solver -- --config FILE`), writes its folder under `out`, returns the
//!   summary as a dict.
//! - `hjacc.run_rear(config_path, out="out")`: a rear config (`--rear FILE`), proof included.
//! - `hjacc.Table(data)` / `hjacc.Table.open(path)`: a table, checked whole on construction;
//!   `value_at(state)`, `policy_at(state)`, `lookup(state)`, `contains(state)`, `dims`,
//!   `header` (a dict), `error_bound`.
//!
//! Every error (a bad config, naming its key and line; a corrupt table; a state outside the
//! grid) raises `ValueError` with the Rust error's message; an unwritable output folder raises
//! `OSError`.

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
#[pyclass(frozen, module = "hjacc")]
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

    /// The number of axes.
    #[getter]
    fn dims(&self) -> usize {
        self.parsed.borrow_dependent().dims()
    }

    /// The header, as a dict (the fields of `table-format/README.md`).
    #[getter]
    fn header(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json_to_python(py, self.parsed.borrow_dependent().header())
    }

    /// The table's error bound (quantization plus interpolation), m: the firmware certifies a
    /// state whose value exceeds it.
    #[getter]
    fn error_bound(&self) -> f32 {
        self.parsed.borrow_dependent().header().error_bound.total()
    }

    /// The interpolated value at `state` (one coordinate per axis).
    fn value_at(&self, state: Vec<f32>) -> PyResult<f32> {
        self.parsed
            .borrow_dependent()
            .value_at(&state)
            .map_err(value_error)
    }

    /// The policy at `state`: "accelerate" or "brake".
    fn policy_at(&self, state: Vec<f32>) -> PyResult<&'static str> {
        self.parsed
            .borrow_dependent()
            .policy_at(&state)
            .map(action_name)
            .map_err(value_error)
    }

    /// `(value, policy)` at `state`.
    fn lookup(&self, state: Vec<f32>) -> PyResult<(f32, &'static str)> {
        self.parsed
            .borrow_dependent()
            .lookup(&state)
            .map(|l| (l.value, action_name(l.action)))
            .map_err(value_error)
    }

    /// Whether `state` lies on the table's grid.
    fn contains(&self, state: Vec<f32>) -> bool {
        self.parsed.borrow_dependent().contains(&state)
    }

    fn __len__(&self) -> usize {
        self.parsed.borrow_owner().len()
    }

    fn __repr__(&self) -> String {
        let t = self.parsed.borrow_dependent();
        format!(
            "hjacc.Table({:?}, {} axes, {} nodes, {} bytes)",
            t.header().game.kind(),
            t.dims(),
            t.node_count(),
            self.parsed.borrow_owner().len()
        )
    }
}

fn action_name(action: EgoAction) -> &'static str {
    match action {
        EgoAction::Accelerate => "accelerate",
        EgoAction::Brake => "brake",
    }
}

fn read_config(path: &PathBuf) -> PyResult<String> {
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
    let text = read_config(&config_path)?;
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
    let text = read_config(&config_path)?;
    let config = solver::rear::RearConfig::from_toml(&text)
        .map_err(|e| value_error(format!("{}: {e}", config_path.display())))?;
    writable(&out)?;
    let summary = py
        .detach(|| solver::rear::run_rear(&config, &out))
        .map_err(value_error)?;
    json_to_python(py, &summary)
}

/// hjacc from Python: solve a config, read a safety table.
#[pymodule]
fn hjacc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Table>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(run_rear, m)?)?;
    m.add("FORMAT_VERSION", table_format::FORMAT_VERSION)?;
    Ok(())
}
