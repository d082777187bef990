//! One run of a configuration: solve, find the trusted box, extract the policy, compile the
//! table, measure, and write the run's folder.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use table_format::{Horizon, HorizonStatus};

use crate::engine::grid::{Grid, GridAxis, MAX_DIMS};
use crate::engine::hji::{self, Boundary, Numerics, Outcome, Solution, Stop};
use crate::error::SolverError;
use crate::games::{with_game, AnyGame, Vector, TIE_TOLERANCE};
use crate::pipeline::compile::{compile, CompileInput, CompileReport};
use crate::pipeline::config::{Config, GameKindConfig};
use crate::pipeline::output;
use crate::pipeline::plots;
use crate::proof::exact::{self, ExactComparison};
use crate::proof::trusted::{agreement_box, IndexBox};

/// Progress events for the command line.
pub enum Event<'a> {
    /// A solve starts: label and backward time to reach.
    SolveStarted(&'a str, f64),
    /// A step finished: backward time and `max |dV/dt|`.
    Step(f64, f64),
    /// A solve finished.
    SolveFinished,
}

/// The grid a config describes.
pub fn grid_of(config: &Config) -> Result<Grid, SolverError> {
    let axes = config
        .axes()
        .into_iter()
        .map(|(name, a)| GridAxis::new(name, a.min, a.max, a.points))
        .collect();
    Ok(Grid::new(axes)?)
}

/// Solves with whichever concrete game `game` is (monomorphised engine).
pub fn solve_any(
    game: &AnyGame,
    grid: &Grid,
    numerics: Numerics,
    stop: Stop,
    progress: impl FnMut(f64, f64, &[f32]),
) -> Result<Solution, SolverError> {
    with_game!(game, g => hji::solve(g, grid, numerics, stop, progress))
}

/// The scheme's gradient with whichever concrete game `game` is.
pub fn gradient_any(
    game: &AnyGame,
    grid: &Grid,
    numerics: Numerics,
    values: &[f32],
) -> Vec<Vec<f32>> {
    with_game!(game, g => hji::gradient(g, grid, numerics, values))
}

/// The run's summary, written as `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Config name.
    pub name: String,
    /// Config description.
    pub description: String,
    /// The config as run.
    pub config: Config,
    /// Nodes per axis.
    pub grid_shape: Vec<usize>,
    /// Backward time reached, s.
    #[serde(rename = "horizon_s")]
    pub time: f64,
    /// Time steps.
    pub steps: usize,
    /// Time step, s.
    #[serde(rename = "time_step_s")]
    pub dt: f64,
    /// `fixed_horizon`, `converged` or `not_converged`.
    pub convergence: String,
    /// Last `max |dV/dt|`, m/s.
    #[serde(rename = "residual_m_per_s")]
    pub residual: f64,
    /// Wall time of the main solve, s.
    #[serde(rename = "solve_s")]
    pub solve_seconds: f64,
    /// Wall time of the whole run, s.
    #[serde(rename = "total_s")]
    pub total_seconds: f64,
    /// Share of all nodes with `V > 0`.
    pub safe_fraction: f64,
    /// Share of the trusted box's nodes with `V > 0`.
    pub safe_fraction_trusted: f64,
    /// Share of all nodes with `V > 1 mm` (hj_reachability's reference figure).
    pub share_above_1mm: f64,
    /// The share of nodes with `V > 0` along the solve, by horizon.
    #[serde(serialize_with = "horizon_shares", rename = "safe_fraction_by_horizon")]
    pub safe_fraction_history: Vec<(f64, f64)>,
    /// Trusted box per axis `(min, max)` in the axis' unit (`axes.json`), or `None` if empty.
    pub trusted_box: Option<Vec<(f64, f64)>>,
    /// The configured slices not drawn because their held speeds lie outside the trusted box
    /// (nothing there may be drawn as safe), by file tag.
    pub slices_not_drawn_untrusted: Vec<String>,
    /// The table compiler's figures.
    pub table: Option<CompileReport>,
    /// Two-car only: accuracy against the exact value.
    pub exact: Option<ExactComparison>,
}

/// Solves `config` and writes its folder under `out`. Returns the summary.
pub fn run(
    config: &Config,
    out: &Path,
    events: &mut dyn FnMut(Event<'_>),
) -> Result<Summary, SolverError> {
    run_solved(config, out, events).map(|(summary, _, _)| summary)
}

/// [`run`], also returning the grid and the values (C order), for figures that combine runs.
pub fn run_solved(
    config: &Config,
    out: &Path,
    events: &mut dyn FnMut(Event<'_>),
) -> Result<(Summary, Grid, Vec<f32>), SolverError> {
    config.validate()?;
    let started = Instant::now();
    let grid = grid_of(config)?;
    let game = AnyGame::from_description(&config.game_description(), config.game.min_gap as f32);
    let numerics = config.numerics();
    let stop = config.stop();
    let limit = match stop {
        Stop::Horizon(t) => t,
        Stop::Converge { max_time, .. } => max_time,
    };

    // The main solve, recording the safe fraction every half second of horizon: V is
    // non-increasing in the horizon, so this curve must be non-increasing too.
    let constraint = constraint_any(&game, &grid);
    let mut safe_fraction_history = vec![(0.0, share_positive(&constraint))];
    let mut next_mark = 0.5;
    events(Event::SolveStarted("solve", limit));
    let t0 = Instant::now();
    let solution = solve_any(&game, &grid, numerics, stop, |t, r, values| {
        events(Event::Step(t, r));
        if t + 1e-9 >= next_mark {
            safe_fraction_history.push((t, share_positive(values)));
            next_mark += 0.5;
        }
    })?;
    let solve_seconds = t0.elapsed().as_secs_f64();
    events(Event::SolveFinished);

    // The trusted box: where the optimistic solve does not disagree (see `trusted`).
    let trusted = if config.trusted_box.measure {
        let optimistic = Numerics {
            boundary: Boundary::Optimistic,
            ..numerics
        };
        events(Event::SolveStarted("trusted box", solution.time));
        let upper = solve_any(
            &game,
            &grid,
            optimistic,
            Stop::Horizon(solution.time),
            |t, r, _| events(Event::Step(t, r)),
        )?;
        events(Event::SolveFinished);
        agreement_box(
            &grid,
            &solution.values,
            &upper.values,
            config.trusted_box.tolerance,
        )
    } else {
        Some(IndexBox::full(&grid))
    };

    let grads = gradient_any(&game, &grid, numerics, &solution.values);
    let dynamics = game.dynamics();
    let d = grid.dims();
    let (accelerate, tie): (Vec<bool>, Vec<bool>) = (0..grid.len())
        .map(|node| {
            let mut p: Vector = [0.0; MAX_DIMS];
            for k in 0..d {
                p[k] = grads[k][node];
            }
            (
                dynamics.ego_accelerates(&p),
                dynamics.ego_switching(&p).abs() < TIE_TOLERANCE,
            )
        })
        .unzip();

    let horizon = Horizon {
        seconds: solution.time as f32,
        status: match (solution.outcome, config.horizon.converge_tolerance) {
            (Outcome::Horizon, _) => HorizonStatus::Fixed,
            (Outcome::Converged, tol) => HorizonStatus::Converged {
                tolerance: tol.unwrap_or(0.0) as f32,
                residual: solution.residual as f32,
            },
            (Outcome::NotConverged, tol) => HorizonStatus::NotConverged {
                tolerance: tol.unwrap_or(0.0) as f32,
                residual: solution.residual as f32,
            },
        },
    };
    let table = match &trusted {
        Some(bx) => Some(compile(&CompileInput {
            game: config.game_description(),
            min_gap: config.game.min_gap as f32,
            horizon,
            grid: &grid,
            values: &solution.values,
            accelerate: &accelerate,
            trusted: bx,
            table_points: config.table.points.as_deref(),
            bits: config.table.bits,
            clip_below: constraint.iter().copied().fold(-1.0f32, f32::min),
        })?),
        None => None,
    };

    let dir = out.join(&config.name);
    std::fs::create_dir_all(&dir).map_err(|e| SolverError::Io {
        path: dir.display().to_string(),
        source: e,
    })?;
    output::write_npy(&dir.join("value.npy"), &solution.values, &grid.shape())?;
    let axes: Vec<output::AxisCoordinates> = grid
        .axes()
        .iter()
        .map(|a| output::AxisCoordinates {
            name: a.name.clone(),
            unit: a.unit.clone(),
            coordinates: (0..a.points).map(|i| a.coordinate(i)).collect(),
        })
        .collect();
    output::write_axes(&dir.join("axes.json"), &axes)?;
    if let Some((bytes, _)) = &table {
        output::write_bytes(&dir.join("table.bin"), bytes)?;
    }

    let n = solution.values.len() as f64;
    let safe_fraction = share_positive(&solution.values);
    let share_above_1mm = solution.values.iter().filter(|&&v| v > 1e-3).count() as f64 / n;
    let safe_fraction_trusted = match &trusted {
        Some(bx) => {
            use rayon::prelude::*;
            let (inside, safe) = bx
                .par_nodes(&grid)
                .map(|(node, _)| (1usize, usize::from(solution.values[node] > 0.0)))
                .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
            safe as f64 / inside.max(1) as f64
        }
        None => 0.0,
    };
    let exact = if config.game.kind == GameKindConfig::TwoCar {
        trusted
            .as_ref()
            .map(|bx| two_car_comparison(config, &grid, &solution.values, solution.time, bx))
    } else {
        None
    };

    let slices_not_drawn_untrusted = plots::plots(
        config,
        &grid,
        &solution,
        &plots::Policy {
            accelerate: &accelerate,
            tie: &tie,
            table: table.as_ref().map(|(bytes, _)| bytes.as_slice()),
        },
        trusted.as_ref(),
        &dir,
        &safe_fraction_history,
    )?;

    let summary = Summary {
        name: config.name.clone(),
        description: config.description.clone(),
        config: config.clone(),
        grid_shape: grid.shape(),
        time: solution.time,
        steps: solution.steps,
        dt: solution.dt,
        convergence: match solution.outcome {
            Outcome::Horizon => "fixed_horizon",
            Outcome::Converged => "converged",
            Outcome::NotConverged => "not_converged",
        }
        .into(),
        residual: solution.residual,
        solve_seconds,
        total_seconds: started.elapsed().as_secs_f64(),
        safe_fraction,
        safe_fraction_trusted,
        share_above_1mm,
        safe_fraction_history,
        trusted_box: trusted.as_ref().map(|b| b.bounds(&grid)),
        table: table.map(|t| t.1),
        exact,
        slices_not_drawn_untrusted,
    };
    output::write_json(&dir.join("summary.json"), &summary)?;
    Ok((summary, grid, solution.values))
}

/// `(horizon, share)` pairs written as `{"horizon_s": .., "share": ..}` objects, not
/// unlabelled pairs.
fn horizon_shares<S: serde::Serializer>(history: &[(f64, f64)], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    #[derive(serde::Serialize)]
    struct Point {
        horizon_s: f64,
        share: f64,
    }
    let mut seq = s.serialize_seq(Some(history.len()))?;
    for &(horizon_s, share) in history {
        seq.serialize_element(&Point { horizon_s, share })?;
    }
    seq.end()
}

/// The share of values above zero.
fn share_positive(values: &[f32]) -> f64 {
    use rayon::prelude::*;
    values.par_iter().filter(|&&v| v > 0.0).count() as f64 / values.len().max(1) as f64
}

/// The constraint at every node.
fn constraint_any(game: &AnyGame, grid: &Grid) -> Vec<f32> {
    with_game!(game, g => hji::constraint_values(g, grid))
}

fn two_car_comparison(
    config: &Config,
    grid: &Grid,
    values: &[f32],
    time: f64,
    bx: &IndexBox,
) -> ExactComparison {
    let g = &config.game;
    exact::two_car_errors(grid, values, time, g.ego.min, g.leader.min, g.min_gap, bx)
}

/// The output folder of a config.
pub fn folder(out: &Path, config: &Config) -> PathBuf {
    out.join(&config.name)
}
