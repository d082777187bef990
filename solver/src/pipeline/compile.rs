//! Compiling a value function into a firmware table, with a sound interpolation error bound.
//!
//! # The table grid
//! The table's nodes are a subset of the solver's: every `s_k`-th node on axis `k`, where
//! `s_k = (solver points - 1) / (table points - 1)`. The table stores the solver's values there
//! (quantized by [`table_format::encode`], which rounds down) and the policy bit of the solver's
//! gradient there.
//!
//! # The interpolation error bound
//! The solver's value function between its nodes is its multilinear interpolant `V_s`. The
//! table's is the multilinear interpolant `I` of `V_s` at the coarser nodes. Because every table
//! grid line is a solver grid line, `I - V_s` is multilinear inside every *solver* cell, and a
//! multilinear function on a box takes its extreme values at the box's corners (it is linear in
//! each coordinate separately). So
//!
//! `max_{z in box} |I(z) - V_s(z)| = max over solver nodes in the box of |I - V_s|`,
//!
//! which the compiler evaluates exactly, over the trusted box. This is not an estimate from
//! Lipschitz constants but the maximum itself; it is zero when the table grid is the solver
//! grid. (It bounds the distance to the solver's interpolant; the distance from that to the
//! true value function is the discretisation error, measured by the convergence studies.)
//!
//! Values below `clip_below` (a negative level) are stored as `clip_below`. Every statement
//! above holds for the clipped value function `max(V_s, clip_below)`, which has the same sign as
//! `V_s`, so a state the table certifies (`V_table - bounds > 0`) is one where `V_s > 0`.
//!
//! # The certified ratio
//! Inside the trusted box, at the solver's nodes: the share of the states the solver calls safe
//! (`V_s > 0`) that the table certifies (`V_table - quantization - interpolation > 0`). The
//! compiler also counts states the table certifies but the solver does not; there must be none.

use rayon::prelude::*;
use table_format::{Axis, Bounds, Horizon, Table, TableContents, ValueBits};

use crate::engine::grid::{Grid, MAX_DIMS};
use crate::error::SolverError;
use crate::proof::trusted::IndexBox;

/// What the compiler measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CompileReport {
    /// Table bytes.
    pub bytes: usize,
    /// Table nodes per axis.
    pub points: Vec<usize>,
    /// Bits per value.
    pub bits: u8,
    /// Quantization error bound (largest rounding), m.
    #[serde(rename = "quantization_error_m")]
    pub quantization_error: f32,
    /// Interpolation error bound inside the trusted box, m.
    #[serde(rename = "interpolation_error_m")]
    pub interpolation_error: f32,
    /// Solver nodes inside the trusted box that the solver calls safe.
    pub solver_safe_nodes: usize,
    /// Of those, the ones the table certifies safe.
    pub certified_nodes: usize,
    /// `certified / solver_safe` (0 when the solver calls nothing safe).
    pub certified_ratio: f64,
    /// Nodes the table certifies that the solver does not call safe (must be 0).
    pub unsound_nodes: usize,
}

/// Everything the compiler needs.
pub struct CompileInput<'a> {
    /// The game description for the header.
    pub game: table_format::Game,
    /// `l = min(gaps) - min_gap`.
    pub min_gap: f32,
    /// Horizon and convergence.
    pub horizon: Horizon,
    /// The solver grid.
    pub grid: &'a Grid,
    /// The solver's values.
    pub values: &'a [f32],
    /// The ego's policy bit at every solver node.
    pub accelerate: &'a [bool],
    /// The trusted box on the solver grid.
    pub trusted: &'a IndexBox,
    /// Table nodes per axis (`None`: the solver grid).
    pub table_points: Option<&'a [usize]>,
    /// 8 or 16.
    pub bits: u8,
    /// Values below this (negative) level are stored as it: they are all unsafe by a wide
    /// margin, and clipping them keeps the quantization step fine where it matters.
    pub clip_below: f32,
}

/// Builds the table and measures it.
pub fn compile(input: &CompileInput<'_>) -> Result<(Vec<u8>, CompileReport), SolverError> {
    let grid = input.grid;
    let d = grid.dims();
    let shape = grid.shape();
    let points: Vec<usize> = input
        .table_points
        .map(<[usize]>::to_vec)
        .unwrap_or_else(|| shape.clone());
    let step: Vec<usize> = shape
        .iter()
        .zip(&points)
        .map(|(s, p)| (s - 1) / (p - 1))
        .collect();
    let table_axes: Vec<crate::engine::grid::GridAxis> = grid
        .axes()
        .iter()
        .zip(&points)
        .map(|(a, &p)| crate::engine::grid::GridAxis {
            points: p,
            ..a.clone()
        })
        .collect();
    let table_grid = Grid::new(table_axes)?;

    // Sample the solver's nodes at the table's nodes.
    let mut values = Vec::with_capacity(table_grid.len());
    let mut accelerate = Vec::with_capacity(table_grid.len());
    let mut idx = [0usize; MAX_DIMS];
    for t in 0..table_grid.len() {
        table_grid.multi_index(t, &mut idx[..d]);
        let node: usize = (0..d).map(|k| idx[k] * step[k] * grid.strides()[k]).sum();
        values.push(input.values[node].max(input.clip_below));
        accelerate.push(input.accelerate[node]);
    }

    // The exact interpolation error over the trusted box (see the module docs).
    let interpolation_error = input
        .trusted
        .par_nodes(grid)
        .map(|(node, z)| {
            let i = table_grid.interpolate(&values, &z[..d]);
            (i - f64::from(input.values[node].max(input.clip_below))).abs()
        })
        .reduce(|| 0.0, f64::max);
    // Round the bound up past f32 rounding of the interpolation arithmetic.
    let interpolation_error = if interpolation_error > 0.0 {
        (interpolation_error * (1.0 + 1e-5) + 1e-6) as f32
    } else {
        0.0
    };

    let names: Vec<String> = grid.axes().iter().map(|a| a.name.clone()).collect();
    let units: Vec<String> = grid.axes().iter().map(|a| a.unit.clone()).collect();
    let header_axes: Vec<Axis<'_>> = table_grid
        .axes()
        .iter()
        .enumerate()
        .map(|(k, a)| Axis {
            name: &names[k],
            unit: &units[k],
            min: a.min as f32,
            max: a.max as f32,
            points: a.points as u32,
            spacing: table_format::Spacing::Uniform,
        })
        .collect();
    let trusted: Vec<Bounds> = input
        .trusted
        .bounds(grid)
        .iter()
        .map(|&(lo, hi)| Bounds::new(lo as f32, hi as f32))
        .collect();
    let bytes = table_format::encode(&TableContents {
        game: input.game,
        min_gap: input.min_gap,
        horizon: input.horizon,
        axes: &header_axes,
        breakpoints: &[],
        trusted_box: &trusted,
        interpolation_error,
        value_bits: if input.bits == 8 {
            ValueBits::Eight
        } else {
            ValueBits::Sixteen
        },
        values: &values,
        accelerate: &accelerate,
    })?;

    let report = measure(input, &bytes, points, interpolation_error)?;
    Ok((bytes, report))
}

/// Reads the table back as the firmware would and counts what it certifies.
fn measure(
    input: &CompileInput<'_>,
    bytes: &[u8],
    points: Vec<usize>,
    interpolation_error: f32,
) -> Result<CompileReport, SolverError> {
    let grid = input.grid;
    let d = grid.dims();
    let table = Table::parse(bytes)?;
    let margin = table.header().error_bound.total();
    let (solver_safe, certified, unsound) = input
        .trusted
        .par_nodes(grid)
        .filter_map(|(node, z)| {
            let zf: Vec<f32> = z[..d].iter().map(|&x| x as f32).collect();
            let v_table = table.value_at(&zf).ok()?;
            let safe = input.values[node] > 0.0;
            let cert = v_table - margin > 0.0;
            Some((
                usize::from(safe),
                usize::from(safe && cert),
                usize::from(cert && !safe),
            ))
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    let report = CompileReport {
        bytes: bytes.len(),
        points,
        bits: input.bits,
        quantization_error: table.header().error_bound.quantization,
        interpolation_error,
        solver_safe_nodes: solver_safe,
        certified_nodes: certified,
        certified_ratio: if solver_safe > 0 {
            certified as f64 / solver_safe as f64
        } else {
            0.0
        },
        unsound_nodes: unsound,
    };
    Ok(report)
}
