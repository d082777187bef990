//! `solver verify` as a run: a table file in, its proof, its cost of measurement error, the
//! report and the plots out. The command line and the Python module both call
//! [`verify_table`].
//!
//! One responsibility: the files of a proof. The proof is [`crate::proof::verify`], the
//! measurement error's cost [`crate::proof::robust`].

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{ConfigError, SolverError};
use crate::pipeline::output;
use crate::proof::robust::{self, MeasurementError, Robustness};
use crate::proof::verify::{self, Report, Settings};

/// What `verify` proved of a table file, and where it wrote it.
#[derive(Debug, Clone, Serialize)]
pub struct VerifiedTable {
    /// The table file.
    pub table: PathBuf,
    /// The folder written: `verify.json`, `robustness.json` and the plots.
    pub dir: PathBuf,
    /// The proof.
    pub report: Report,
    /// The rear half with exact sensors, over the table's nodes taken as measurements.
    pub exact: Robustness,
    /// The same under the declared measurement error.
    pub declared: Robustness,
    /// The table's bytes with the proof's record in its header (not written to the JSON).
    #[serde(skip)]
    pub recorded: Vec<u8>,
}

impl VerifiedTable {
    /// Why the firmware must not run the table, if so: certified cells not proven (the
    /// budget's unchecked ones included), or a passing measurement whose error box touches an
    /// unproven cell.
    pub fn failure(&self) -> Option<String> {
        let r = &self.report;
        if r.proven < r.certified {
            return Some(format!(
                "{} certified cells are not proven{} (see {})",
                r.certified - r.proven,
                if r.unchecked > 0 {
                    format!(", {} of them not checked within the budget", r.unchecked)
                } else {
                    String::new()
                },
                self.dir.join("verify.json").display()
            ));
        }
        let touching = self.declared.unproven + self.exact.unproven;
        (touching > 0).then(|| {
            format!(
                "{touching} passing measurements have a box that touches an unproven cell (see {})",
                self.dir.join("robustness.json").display()
            )
        })
    }
}

/// Checks what a run cannot use, before it starts: periods, the budget, the error bounds.
pub fn check_settings(settings: &Settings, error: &MeasurementError) -> Result<(), ConfigError> {
    if settings.periods.is_empty()
        || settings
            .periods
            .iter()
            .any(|p| !(p.is_finite() && *p > 0.0))
    {
        return Err(ConfigError::new(
            "periods",
            "every period must be a positive number of seconds",
        ));
    }
    if settings
        .budget
        .seconds
        .is_some_and(|s| !(s.is_finite() && s > 0.0))
    {
        return Err(ConfigError::new(
            "budget seconds",
            "must be a positive, finite number of seconds",
        ));
    }
    if !settings.rear_margin.is_finite() {
        return Err(ConfigError::new(
            "rear margin",
            "must be a finite number of metres",
        ));
    }
    for (name, x) in [
        ("range error", error.range),
        ("relative range error", error.range_relative),
        ("range-rate error", error.range_rate),
        ("ego-speed error", error.ego_speed),
        ("relative ego-speed error", error.ego_speed_relative),
        ("ego measurement age", error.ego_age),
    ] {
        if !(x.is_finite() && (0.0..1.0).contains(&x)) {
            return Err(ConfigError::new(
                name,
                format!("an error bound must be a finite number in [0, 1) (got {x})"),
            ));
        }
    }
    Ok(())
}

/// Proves the table at `path` and measures it under `error`; writes
/// `out/verify/<file stem>/`: `verify.json` (the proof's report), `robustness.json` (exact
/// sensors and the declared error) and the plots. `progress` sees `(cells checked, cells)`.
pub fn verify_table(
    path: &Path,
    settings: &Settings,
    error: &MeasurementError,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<VerifiedTable, SolverError> {
    check_settings(settings, error)?;
    let bytes = std::fs::read(path).map_err(|e| SolverError::Io {
        path: path.display().to_string(),
        source: e,
    })?;
    let (rear, report, recorded) =
        verify::verify_bytes_with_progress(&bytes, settings, &[], progress)?;
    let stem = path
        .file_stem()
        .map_or_else(|| "table".to_string(), |s| s.to_string_lossy().into_owned());
    let dir = out.join("verify").join(stem);
    std::fs::create_dir_all(&dir).map_err(|e| SolverError::Io {
        path: dir.display().to_string(),
        source: e,
    })?;
    output::write_json(&dir.join("verify.json"), &report)?;
    let table = table_format::Table::parse(&bytes)?;
    super::table_plots::deployed_table_plots(&table, &rear, &report, &dir)?;
    let axes = [rear.axis(0), rear.axis(1), rear.axis(2)];
    let exact = robust::robustness(&table, &report, axes, &MeasurementError::EXACT);
    let declared = robust::robustness(&table, &report, axes, error);
    output::write_json(
        &dir.join("robustness.json"),
        &serde_json::json!({ "exact": exact, "declared": declared }),
    )?;
    robust::plot(axes, &[&exact, &declared], &dir, 20.0)?;
    Ok(VerifiedTable {
        table: path.to_path_buf(),
        dir,
        report,
        exact,
        declared,
        recorded,
    })
}
