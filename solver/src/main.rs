//! `cargo run -p solver --release [-- --config FILE ... --out DIR]`
//!
//! With no `--config` and no `--rear`, runs the built-in configs (`solver/configs/*.toml`): the
//! paper's results, the former 4-D firmware table, and the firmware's deployed table
//! (`solver/configs/rear/deployment.toml`, written to `DIR/deployment/table.bin`). `--rear FILE`
//! runs a rear-game config (`solver/configs/rear/*.toml`) through the sampled-data iteration
//! into a version-2 table.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use solver::config::GameKindConfig;
use solver::config::{builtin, builtin_rear, Config};
use solver::rear::{run_rear_with, RearConfig, RearEvent, RearStopped};
use solver::run::{run_solved, Event};

/// HJI safety analysis of car following, compiled into firmware tables.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// A TOML config (repeatable). Default: the built-in paper configs.
    #[arg(long = "config", value_name = "FILE")]
    configs: Vec<PathBuf>,
    /// Output folder; each config writes `DIR/<name>/`, `verify` writes `DIR/verify/<table>/`
    /// (before or after the subcommand).
    #[arg(long, default_value = "out", global = true)]
    out: PathBuf,
    /// A rear-game config (repeatable), solved by the sampled-data iteration.
    #[arg(long = "rear", value_name = "FILE")]
    rears: Vec<PathBuf>,
    /// No progress bars.
    #[arg(long, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Proves, cell by cell, that a rear table's certificate survives one control period
    /// (`solver::verify`); writes `DIR/verify/<table>/verify.json` and a plot of the
    /// unproven cells.
    Verify(VerifyArgs),
    /// Runs a sweep of rear configs made from one (`solver::sweep`; e.g.
    /// solver/configs/sweeps/sensitivity.toml): each table solved, proven and measured, in
    /// parallel; writes DIR/<name>/sweep.json, sweep.csv and sweep.png beside the tables.
    Sweep {
        /// The sweep file.
        file: PathBuf,
    },
}

#[derive(clap::Args, Debug)]
// A negative number is a value (refused with a reason), not an unknown flag.
#[command(allow_negative_numbers = true)]
struct VerifyArgs {
    /// The table (a ThreeCarSplit table, e.g. firmware/tables/default.bin).
    table: PathBuf,
    /// Also write the table with the proof's record in its header to FILE (the firmware
    /// refuses a split table without a complete one).
    #[arg(long, value_name = "FILE")]
    write: Option<PathBuf>,
    #[command(flatten)]
    options: solver::verify_table::VerifyOptions,
}

/// Fails at once, naming the folder, if `out` cannot be written: a solve takes minutes, and
/// its results must not be lost to a typo in `--out`. Nothing is created here (a run
/// refused for a bad config must not leave an empty folder behind); the nearest existing
/// folder on the path is probed instead, and the run creates `out` when it writes.
fn ensure_writable(out: &std::path::Path) -> Result<()> {
    let mut existing = out;
    while !existing.as_os_str().is_empty() && !existing.exists() {
        existing = existing.parent().unwrap_or(std::path::Path::new(""));
    }
    let existing = if existing.as_os_str().is_empty() {
        std::path::Path::new(".")
    } else {
        existing
    };
    if !existing.is_dir() {
        anyhow::bail!(
            "--out {}: {} is not a folder",
            out.display(),
            existing.display()
        );
    }
    let probe = existing.join(format!(".hjacc-write-probe-{}", std::process::id()));
    std::fs::write(&probe, b"").with_context(|| {
        format!(
            "--out {}: {} is not writable",
            out.display(),
            existing.display()
        )
    })?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

/// A progress display that is never silent: a bar on a terminal, and otherwise (CI, a pipe, a
/// notebook) a plain line on stderr at most every ten seconds, so that an hour-long run shows
/// that it is alive.
struct Progress {
    bar: ProgressBar,
    plain: Option<std::sync::Mutex<std::time::Instant>>,
    label: String,
}

impl Progress {
    fn new(quiet: bool, label: &str) -> Self {
        use std::io::IsTerminal;
        let terminal = std::io::stderr().is_terminal();
        let bar = if quiet || !terminal {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(1000)
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:>12} [{bar:40}] {msg} ({elapsed_precise}, eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        bar.set_prefix(label.to_string());
        Progress {
            bar,
            plain: (!quiet && !terminal).then(|| std::sync::Mutex::new(std::time::Instant::now())),
            label: label.to_string(),
        }
    }

    /// Starts over with a new label.
    fn restart(&mut self, label: &str) {
        self.bar.reset();
        self.bar.set_prefix(label.to_string());
        self.label = label.to_string();
    }

    /// `fraction` of the work is done; `message` says what.
    fn set(&self, fraction: f64, message: &str) {
        self.bar
            .set_position((1000.0 * fraction.clamp(0.0, 1.0)) as u64);
        self.bar.set_message(message.to_string());
        if let Some(last) = &self.plain {
            let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
            if last.elapsed().as_secs_f64() >= 10.0 {
                *last = std::time::Instant::now();
                eprintln!("{}: {:.0}% ({message})", self.label, 100.0 * fraction);
            }
        }
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Runs [`real_main`]; a user error (a bad config, an unwritable folder, an unproven table) is
/// one clean message on stderr and exit code 1, with or without `RUST_BACKTRACE` (anyhow's
/// `Debug` output would print a backtrace of this function, which tells a user nothing).
fn main() -> std::process::ExitCode {
    match real_main() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn real_main() -> Result<()> {
    let args: Args = solver::cli::parse_args();
    ensure_writable(&args.out)?;
    match &args.command {
        Some(Command::Verify(v)) => return run_verify(v, &args.out, args.quiet),
        Some(Command::Sweep { file }) => return run_sweep(file, &args.out, args.quiet),
        None => {}
    }
    let defaults = args.rears.is_empty() && args.configs.is_empty();
    let mut rears: Vec<(String, String)> = args
        .rears
        .iter()
        .map(|path| {
            std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))
                .map(|text| (path.display().to_string(), text))
        })
        .collect::<Result<_>>()?;
    let rears_first = !rears.is_empty();
    if defaults {
        rears = builtin_rear()
            .into_iter()
            .map(|(name, text)| (format!("built-in {name}"), text.to_string()))
            .collect();
    }
    if !rears_first {
        run_configs(&args)?;
    }
    for (source, text) in &rears {
        let config = RearConfig::from_toml(text).map_err(|e| {
            let hint = if Config::from_toml(text).is_ok() {
                ": it is a level-set game config; give it with --config"
            } else {
                ""
            };
            anyhow::anyhow!("in {source}{hint}: {e}")
        })?;
        eprintln!("== {} ({source})", config.name);
        let mut progress = Progress::new(args.quiet, "rear");
        let max = config.solve.max_iterations;
        let s = run_rear_with(&config, &args.out, &mut |event| match event {
            RearEvent::Iteration(k, residual) => progress.set(
                k as f64 / max as f64,
                &format!("iteration {k}, largest change {residual:.2e} m"),
            ),
            RearEvent::ProofStarted(k) => progress.restart(&format!("proof at {k}")),
            RearEvent::ProofProgress(done, total) => progress.set(
                done as f64 / total as f64,
                &format!("{done} of {total} cells"),
            ),
            RearEvent::ProofFinished(_) => progress.restart("rear"),
        })?;
        progress.finish();
        println!(
            "{}: {} x {} x {} breakpoints, {} iterations ({} s of horizon), stopped: {}; \
             {:.1} s, {} attempts at the proof; over the last {} iterations the value moved \
             {:.4} m at most (the plateau {:.4} m); plateau {:.3} m; beyond the grid {:.3} m; \
             table {} bytes (quantization {:.4} m)",
            s.name,
            s.points[0],
            s.points[1],
            s.points[2],
            s.iterations,
            s.horizon_s,
            match s.stopped {
                RearStopped::Proven => "proven",
                RearStopped::Residual => "largest change below the tolerance",
                RearStopped::MaxIterations => "max_iterations",
            },
            s.solve_s,
            s.proof_attempts.len(),
            s.drift.iterations,
            s.drift.max_change_m,
            s.drift.plateau_change_m,
            s.plateau_m,
            s.beyond_grid_m,
            s.table_bytes,
            s.quantization_error_m
        );
        println!(
            "  verify: {} of {} certified cells proven ({:.1} s){}",
            s.verification.proven_cells,
            s.verification.certified_cells,
            s.verify_s,
            if s.verification.is_complete() {
                ""
            } else {
                "; the firmware will refuse this table (see verify.json)"
            }
        );
        println!("  wrote {}", args.out.join(&config.name).display());
    }
    if rears_first && !args.configs.is_empty() {
        run_configs(&args)?;
    }
    Ok(())
}

/// Runs the level-set configs: `--config` files, or the built-in ones when neither `--config`
/// nor `--rear` is given.
fn run_configs(args: &Args) -> Result<()> {
    let configs: Vec<(String, Config)> = if args.configs.is_empty() {
        builtin()
            .into_iter()
            .map(|(name, text)| {
                Config::from_toml(text)
                    .with_context(|| format!("built-in config {name}"))
                    .map(|c| (name.to_string(), c))
            })
            .collect::<Result<_>>()?
    } else {
        args.configs
            .iter()
            .map(|path| {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                let config = Config::from_toml(&text).map_err(|e| {
                    let hint = if RearConfig::from_toml(&text).is_ok() {
                        ": it is a rear-game config; give it with --rear"
                    } else {
                        ""
                    };
                    anyhow::anyhow!("in {}{hint}: {e}", path.display())
                })?;
                Ok((path.display().to_string(), config))
            })
            .collect::<Result<_>>()?
    };
    // The paper's Fig. 3 needs the baseline's and the IDM formulation's runs on one grid.
    let mut baseline = None;
    let mut idm = None;
    for (source, config) in &configs {
        eprintln!("== {} ({source})", config.name);
        let mut progress = Progress::new(args.quiet, "solve");
        let mut limit = 1.0;
        let (summary, grid, values) = run_solved(config, &args.out, &mut |event| match event {
            Event::SolveStarted(label, until) => {
                limit = until;
                progress.restart(label);
            }
            Event::Step(t, residual) => progress.set(
                t / limit,
                &format!("t = {t:6.2} s of {limit} s, max|dV/dt| = {residual:.2e}"),
            ),
            Event::SolveFinished => {}
        })?;
        progress.finish();
        println!(
            "{}: {} steps to t = {:.2} s ({}), solve {:.1} s; safe share {:.3} (trusted box {:.3})",
            summary.name,
            summary.steps,
            summary.time,
            summary.convergence,
            summary.solve_seconds,
            summary.safe_fraction,
            summary.safe_fraction_trusted
        );
        if let Some(t) = &summary.table {
            println!(
                "  table: {} bytes, {:?} nodes x {} bits, error bound {:.4} + {:.4} m, certified {:.3} of the solver's safe set",
                t.bytes, t.points, t.bits, t.quantization_error, t.interpolation_error, t.certified_ratio
            );
        } else {
            println!("  table: none (the trusted box is empty)");
        }
        if let Some(e) = &summary.exact {
            println!(
                "  vs exact: max |V - V*| = {:.4} m, mean {:.4} m, boundary error {:.4} m",
                e.max_value_error, e.mean_value_error, e.max_boundary_error
            );
        }
        if !summary.slices_not_drawn_untrusted.is_empty() {
            println!(
                "  slices not drawn (outside the trusted box, no claim there): {}",
                summary.slices_not_drawn_untrusted.join(", ")
            );
        }
        println!(
            "  wrote {}",
            solver::run::folder(&args.out, config).display()
        );
        let slot = match config.game.kind {
            GameKindConfig::ThreeCarBaseline => &mut baseline,
            GameKindConfig::ThreeCarIdm => &mut idm,
            _ => continue,
        };
        if slot.is_none() {
            *slot = Some((summary, grid, values));
        }
    }
    if let (Some(b), Some(i)) = (&baseline, &idm) {
        fn solved(
            r: &(solver::run::Summary, solver::grid::Grid, Vec<f32>),
        ) -> solver::paper::Solved<'_> {
            solver::paper::Solved {
                summary: &r.0,
                grid: &r.1,
                values: &r.2,
            }
        }
        match solver::paper::fig3(&args.out, &solved(b), &solved(i))? {
            Some(path) => println!(
                "== the paper's Fig. 3 ({} beside {}): wrote {}",
                b.0.name,
                i.0.name,
                path.display()
            ),
            None => println!(
                "== the paper's Fig. 3: not drawn ({} has no trusted slice through its boundary)",
                i.0.name
            ),
        }
    }
    Ok(())
}

/// `verify`: reads the table, checks every cell, writes the report, and fails (non-zero exit)
/// when a certified cell is unproven.
fn run_verify(v: &VerifyArgs, out: &std::path::Path, quiet: bool) -> Result<()> {
    // Every option is checked before anything runs, named as the command line names it.
    let settings = v
        .options
        .resolve()
        .map_err(|e| anyhow::anyhow!("{}: {}", e.flag(), e.reason))?;
    let progress = Progress::new(quiet, "verify");
    let run = solver::verify_table::verify_table(&v.table, &settings, out, &mut |done, total| {
        progress.set(
            done as f64 / total as f64,
            &format!("{done} of {total} cells"),
        )
    })
    .with_context(|| v.table.display().to_string())?;
    progress.finish();
    let report = &run.report;
    println!(
        "{}: periods {:?} ms, level {:.4} m: {} of {} certified cells proven ({:.3}%; {} with the standstill lemma); \
         unproven: {} tangency, {} resolution, {} collision{}; largest deficit found {:.4} m; {:.1} s",
        v.table.display(),
        v.options.period_ms,
        report.level,
        report.proven,
        report.certified,
        100.0 * report.proven_share,
        report.proven_at_standstill,
        report.unproven_by_reason.tangency,
        report.unproven_by_reason.resolution,
        report.unproven_by_reason.collision,
        match report.stopped {
            None => String::new(),
            Some(why) => format!(
                "; {} cells not checked: the budget ran out ({})",
                report.unchecked,
                match why {
                    solver::verify::Stopped::Time => "--budget-seconds",
                    solver::verify::Stopped::UnprovenCells => "--max-unproven",
                }
            ),
        },
        report.dip,
        report.seconds
    );
    for r in [&run.exact, &run.declared] {
        println!(
            "  measurement error {:?}: {} of {} measured rear states pass the firmware's test ({:.2}%), \
             {} of them with a box touching an unproven cell, {} too wide to evaluate",
            r.error,
            r.passing,
            r.measurements,
            100.0 * r.passing_share,
            r.unproven,
            r.too_wide
        );
    }
    println!("  wrote {}", run.dir.display());
    if let Some(path) = &v.write {
        std::fs::write(path, &run.recorded)
            .with_context(|| format!("writing {}", path.display()))?;
        println!("  wrote {} (with the record)", path.display());
    }
    if let Some(failure) = run.failure() {
        anyhow::bail!("{failure}");
    }
    Ok(())
}

/// `sweep`: every task in parallel, a progress line, the summary table.
fn run_sweep(file: &std::path::Path, out: &std::path::Path, quiet: bool) -> Result<()> {
    use solver::sweep::{run_sweep, Sweep, SweepEvent};
    let sweep = Sweep::open(file).with_context(|| format!("in {}", file.display()))?;
    eprintln!(
        "== sweep {} ({}): {} points, {} tables to solve and prove",
        sweep.config.name,
        file.display(),
        sweep.points(),
        sweep.tasks.len()
    );
    let progress = std::sync::Mutex::new((Progress::new(quiet, "sweep"), 0usize));
    let tables = sweep.tasks.len();
    let summary = run_sweep(&sweep, out, &|event| {
        let mut guard = progress.lock().unwrap_or_else(|e| e.into_inner());
        let (p, finished) = &mut *guard;
        let fraction = *finished as f64 / tables as f64;
        match event {
            SweepEvent::Rear(k, RearEvent::Iteration(i, r)) => p.set(
                fraction,
                &format!("table {k}: iteration {i}, largest change {r:.2e} m"),
            ),
            SweepEvent::Rear(k, RearEvent::ProofProgress(done, total)) => p.set(
                fraction,
                &format!("table {k}: proof, {done} of {total} cells"),
            ),
            SweepEvent::TaskFinished(k, n, _) => {
                *finished = n;
                p.set(
                    n as f64 / tables as f64,
                    &format!("table {k} done, {n} of {tables} tables"),
                )
            }
            SweepEvent::Rear(..) => {}
        }
    })?;
    progress
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .0
        .finish();
    println!(
        "| point | {} | table proven | certified, ego 0-35 m/s | ego 15-35 m/s | rear nodes, exact / declared error |",
        summary.keys.join(" | ")
    );
    println!("|---|{}---|---|---|---|", "---|".repeat(summary.keys.len()));
    for p in &summary.points {
        let set: std::collections::BTreeMap<&str, String> = p
            .point
            .overrides
            .iter()
            .map(|(k, v)| (k.as_str(), solver::sweep::show_value(v)))
            .collect();
        let values: Vec<String> = summary
            .keys
            .iter()
            .map(|k| set.get(k.as_str()).cloned().unwrap_or_default())
            .collect();
        println!(
            "| {} | {} | {} of {}{} | {:.1}% | {:.1}% | {:.1}% / {:.1}% |",
            p.point.index,
            values.join(" | "),
            p.table.proven_cells,
            p.table.certified_cells,
            if p.table.proven { "" } else { " (refused)" },
            100.0 * p.volume.certified_ego_0_35,
            100.0 * p.volume.certified_ego_15_35,
            100.0 * p.measured_rear.exact_share,
            100.0 * p.measured_rear.declared_share
        );
    }
    println!(
        "{} points, {} tables, {:.1} s; wrote {}",
        summary.points.len(),
        summary.tables,
        summary.seconds,
        out.join(&summary.name).display()
    );
    Ok(())
}
