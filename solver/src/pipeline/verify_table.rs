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
use table_format::MeasurementError;

use crate::proof::robust::{self, Robustness};
use crate::proof::verify::{self, Budget, Report, Settings};

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

/// `verify`'s options, as the command line and the Python module both take them: one place
/// names each option, gives its default and checks it ([`VerifyOptions::resolve`]).
#[derive(Debug, Clone, PartialEq, clap::Args)]
// A negative number is a value (refused with a reason), not an unknown flag.
#[command(allow_negative_numbers = true)]
pub struct VerifyOptions {
    /// The periods a box may be advanced by, ms, comma-separated (`solver::verify`).
    #[arg(long, value_delimiter = ',', default_values_t = [20.0, 100.0, 200.0, 300.0])]
    pub period_ms: Vec<f64>,
    /// The firmware's `rear_margin`, m (the level is the table's error bound plus this).
    #[arg(long, default_value_t = 0.0)]
    pub rear_margin: f64,
    /// How many times a cell may be halved (axes in turn).
    #[arg(long, default_value_t = 21)]
    pub depth: u32,
    /// Stop after this many seconds; the cells not checked by then are reported and the
    /// table's record is incomplete (0: no limit).
    #[arg(long, default_value_t = 600.0)]
    pub budget_seconds: f64,
    /// Stop once this many certified cells are found unproven, naming them (0: no limit).
    #[arg(long, default_value_t = 1000)]
    pub max_unproven: usize,
    /// Search every sub-box of an unproven cell for its largest deficit (slower on a table
    /// with many unproven cells; the verdicts are the same).
    #[arg(long)]
    pub exhaustive: bool,
    /// The declared range error's absolute part, m (`table_format::MeasurementError`).
    #[arg(long, default_value_t = MeasurementError::default().range)]
    pub range_error: f32,
    /// The declared range error's relative part.
    #[arg(long, default_value_t = MeasurementError::default().range_relative)]
    pub range_error_relative: f32,
    /// The declared range-rate error, m/s.
    #[arg(long, default_value_t = MeasurementError::default().range_rate)]
    pub range_rate_error: f32,
    /// The declared ego-speed error's absolute part, m/s.
    #[arg(long, default_value_t = MeasurementError::default().ego_speed)]
    pub ego_speed_error: f32,
    /// The declared ego-speed error's relative part.
    #[arg(long, default_value_t = MeasurementError::default().ego_speed_relative)]
    pub ego_speed_error_relative: f32,
    /// The longest time between a track and the ego-speed measurement paired with it, s.
    #[arg(long, default_value_t = MeasurementError::default().ego_age)]
    pub ego_age: f32,
}

impl Default for VerifyOptions {
    /// The command line's defaults.
    fn default() -> Self {
        use clap::FromArgMatches;
        let matches = <Self as clap::Args>::augment_args(clap::Command::new("verify"))
            .no_binary_name(true)
            .get_matches_from(std::iter::empty::<String>());
        // The defaults parse by construction.
        Self::from_arg_matches(&matches).unwrap_or_else(|e| unreachable!("{e}"))
    }
}

/// An option `verify` refuses, named as the command line and as Python name it.
#[derive(Debug, Clone, PartialEq)]
pub struct OptionError {
    /// The option's field in [`VerifyOptions`] (the flag is it in kebab case, after `--`).
    pub option: &'static str,
    /// Why it is refused.
    pub reason: String,
}

impl OptionError {
    /// The command line's flag, e.g. `--range-error`.
    pub fn flag(&self) -> String {
        format!("--{}", self.option.replace('_', "-"))
    }

    /// The Python module's keyword (`periods_ms` for `period_ms`, else the field).
    pub fn keyword(&self) -> &'static str {
        match self.option {
            "period_ms" => "periods_ms",
            other => other,
        }
    }
}

impl VerifyOptions {
    /// The declared measurement error.
    pub fn measurement_error(&self) -> MeasurementError {
        MeasurementError {
            range: self.range_error,
            range_relative: self.range_error_relative,
            range_rate: self.range_rate_error,
            ego_speed: self.ego_speed_error,
            ego_speed_relative: self.ego_speed_error_relative,
            ego_age: self.ego_age,
        }
    }

    /// The proof's settings, or the first option a run cannot use, before anything runs.
    pub fn resolve(&self) -> Result<Settings, OptionError> {
        let refuse = |option, reason: String| OptionError { option, reason };
        // 0 means no limit here, so the budget's sign is checked before it becomes an Option.
        if !(self.budget_seconds.is_finite() && self.budget_seconds >= 0.0) {
            return Err(refuse(
                "budget_seconds",
                format!(
                    "must be a finite number of seconds, 0 for no limit (got {})",
                    self.budget_seconds
                ),
            ));
        }
        let settings = Settings {
            periods: self.period_ms.iter().map(|p| p * 1e-3).collect(),
            rear_margin: self.rear_margin,
            max_depth: self.depth,
            budget: Budget {
                seconds: (self.budget_seconds > 0.0).then_some(self.budget_seconds),
                unproven_cells: (self.max_unproven > 0).then_some(self.max_unproven),
            },
            exhaustive: self.exhaustive,
            measurement_error: self.measurement_error(),
        };
        match invalid_setting(&settings) {
            None => Ok(settings),
            Some((setting, reason)) => Err(refuse(
                match setting {
                    Setting::Periods => "period_ms",
                    Setting::Budget => "budget_seconds",
                    Setting::RearMargin => "rear_margin",
                    Setting::Error("range") => "range_error",
                    Setting::Error("range_relative") => "range_error_relative",
                    Setting::Error("range_rate") => "range_rate_error",
                    Setting::Error("ego_speed") => "ego_speed_error",
                    Setting::Error("ego_speed_relative") => "ego_speed_error_relative",
                    Setting::Error(_) => "ego_age",
                },
                reason,
            )),
        }
    }
}

/// A setting a run cannot use ([`invalid_setting`]).
enum Setting {
    Periods,
    Budget,
    RearMargin,
    /// A bound of the measurement error, by its name in [`MeasurementError::named`].
    Error(&'static str),
}

/// The first setting a run cannot use, and why: the one check behind [`check_settings`] and
/// [`VerifyOptions::resolve`], each of which names the setting its own way.
fn invalid_setting(settings: &Settings) -> Option<(Setting, String)> {
    if settings.periods.is_empty()
        || settings
            .periods
            .iter()
            .any(|p| !(p.is_finite() && *p > 0.0))
    {
        return Some((Setting::Periods, "every period must be positive".into()));
    }
    if settings
        .budget
        .seconds
        .is_some_and(|s| !(s.is_finite() && s > 0.0))
    {
        return Some((
            Setting::Budget,
            "must be a positive, finite number of seconds".into(),
        ));
    }
    if !settings.rear_margin.is_finite() {
        return Some((
            Setting::RearMargin,
            "must be a finite number of metres".into(),
        ));
    }
    let error = &settings.measurement_error;
    let bound = error.invalid_bound()?;
    let value = error
        .named()
        .iter()
        .find(|(name, _)| *name == bound)
        .map_or(f32::NAN, |b| b.1);
    Some((
        Setting::Error(bound),
        format!(
            "a measurement error bound must be finite, not negative and within the limits \
             table_format::sensing declares (got {value})"
        ),
    ))
}

/// Checks what a run cannot use, before it starts: periods, the budget, the error bounds (for
/// settings made without [`VerifyOptions`]).
pub fn check_settings(settings: &Settings) -> Result<(), ConfigError> {
    match invalid_setting(settings) {
        None => Ok(()),
        Some((setting, reason)) => Err(ConfigError::new(
            match setting {
                Setting::Periods => "periods".to_string(),
                Setting::Budget => "budget seconds".to_string(),
                Setting::RearMargin => "rear margin".to_string(),
                Setting::Error(bound) => format!("measurement error {bound}"),
            },
            reason,
        )),
    }
}

/// Proves the table at `path` and measures it under the settings' measurement error; writes
/// `out/verify/<file stem>/`: `verify.json` (the proof's report), `robustness.json` (exact
/// sensors and the declared error) and the plots. `progress` sees `(cells checked, cells)`.
pub fn verify_table(
    path: &Path,
    settings: &Settings,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<VerifiedTable, SolverError> {
    check_settings(settings)?;
    let error = &settings.measurement_error;
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
    super::proof_plots::robustness(axes, &[&exact, &declared], &dir, 20.0)?;
    Ok(VerifiedTable {
        table: path.to_path_buf(),
        dir,
        report,
        exact,
        declared,
        recorded,
    })
}
