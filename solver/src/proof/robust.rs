//! The rear certificate under measurement error: which measured rear states pass the
//! firmware's test, and the proof that every true state such a measurement allows is one that
//! `solver::verify` proved.
//!
//! One responsibility: relate the measurement space to the proof's cells. The firmware
//! (`firmware::controller`, `firmware::sensing`) certifies a measured rear state `m = (gap,
//! follower speed, ego speed)` when the table's least value over the **error box** around `m`
//! exceeds the level. The box: the true gap within `(m - a) / (1 + r) .. (m + a) / (1 - r)`
//! (range error `a + r g`), the ego's true speed within its error and what it can gain or lose
//! between its measurement and the track's (`ego_age`, at the band's accelerations), and the
//! follower's speed, `ego - range_rate`, within both errors. The least value is
//! `table_format::Table::least_over_box`, the firmware's own function, exact for the table's
//! multilinear interpolation. So a passing measurement puts every state of its box in the
//! table's certified set `{W > level}`, and this module checks that every cell that box
//! touches is one `verify` proved: then every true state the declared error allows is safe.
//!
//! The grid's nodes are the measurements sampled; the share passing, exact sensors against the
//! declared error, is the certified volume's cost of robustness.

use rayon::prelude::*;
use serde::Serialize;
use table_format::Table;

use crate::proof::verify::{Report, Verdict};

/// The declared measurement error (the firmware's `SensorBounds`; its defaults here).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeasurementError {
    /// Range error, absolute part, m.
    pub range: f32,
    /// Range error, relative part.
    pub range_relative: f32,
    /// Range-rate error, m/s.
    pub range_rate: f32,
    /// Ego-speed error, absolute part, m/s.
    pub ego_speed: f32,
    /// Ego-speed error, relative part.
    pub ego_speed_relative: f32,
    /// The largest time between the ego's speed measurement and the track's, s (the firmware
    /// takes the ego measurement nearest the track's time, 10 ms away at most at a 20 ms
    /// ego-speed cycle).
    pub ego_age: f32,
}

impl Default for MeasurementError {
    /// The firmware's default sensor bounds (a host test checks they agree).
    fn default() -> Self {
        MeasurementError {
            range: 0.1,
            range_relative: 0.015,
            range_rate: 0.14,
            ego_speed: 0.1,
            ego_speed_relative: 0.005,
            ego_age: 0.01,
        }
    }
}

impl MeasurementError {
    /// No error.
    pub const EXACT: MeasurementError = MeasurementError {
        range: 0.0,
        range_relative: 0.0,
        range_rate: 0.0,
        ego_speed: 0.0,
        ego_speed_relative: 0.0,
        ego_age: 0.0,
    };
}

/// The certified volume and the proof under one measurement error.
#[derive(Debug, Clone, Serialize)]
pub struct Robustness {
    /// The error.
    pub error: MeasurementError,
    /// Measured states sampled (the grid's nodes inside the speed domain).
    pub measurements: usize,
    /// Of those, the ones the firmware's test passes.
    pub passing: usize,
    /// `passing / measurements`.
    pub passing_share: f64,
    /// Passing measurements whose box touches a cell `verify` did not prove (must be 0).
    pub unproven: usize,
    /// Passing measurements whose box could not be evaluated (wider than the lookup takes).
    pub too_wide: usize,
    /// Whether each node, taken as a measurement, passes (C order; not written to the JSON).
    #[serde(skip)]
    pub passes: Vec<bool>,
}

/// The error box around the measured rear state `(gap, follower_speed, ego_speed)`, clipped to
/// the grid's speeds `[0, vmax]` and gaps: `None` when it leaves the grid below, or its speeds
/// lie entirely above `vmax`.
fn error_box(
    e: &MeasurementError,
    [gap, follower, ego]: [f32; 3],
    band: (f32, f32),
    grid: ([f32; 2], f32),
) -> Option<([f32; 3], [f32; 3])> {
    let ([gap_min, gap_max], vmax) = grid;
    let gap_lo = (gap - e.range) / (1.0 + e.range_relative);
    let gap_hi = ((gap + e.range) / (1.0 - e.range_relative)).min(gap_max);
    let ego_lo = ((ego - e.ego_speed) / (1.0 + e.ego_speed_relative) + band.0 * e.ego_age).max(0.0);
    let ego_hi = (ego + e.ego_speed) / (1.0 - e.ego_speed_relative) + band.1 * e.ego_age;
    // The measured range rate is `ego - follower`.
    let rate = ego - follower;
    let follower_lo = (ego_lo - rate - e.range_rate).max(0.0);
    let follower_hi = (ego_hi - rate + e.range_rate).min(vmax);
    if gap_lo < gap_min || ego_hi > vmax || follower_lo > vmax {
        return None;
    }
    Some((
        [gap_lo, follower_lo, ego_lo],
        [gap_hi.max(gap_lo), follower_hi, ego_hi],
    ))
}

/// The cells `[lo, hi]` on an axis of breakpoints `axis` touch: first and last cell index.
fn cells_touched(axis: &[f64], lo: f32, hi: f32) -> (usize, usize) {
    let cells = axis.len() - 1;
    let first = axis
        .partition_point(|&b| b <= f64::from(lo))
        .clamp(1, cells)
        - 1;
    let last = axis.partition_point(|&b| b < f64::from(hi)).clamp(1, cells) - 1;
    (first, last.max(first))
}

/// The certified volume under `error` and the check that every passing measurement's box lies
/// in proven cells (module docs). `report` is `verify`'s on `table`; `axes` its breakpoints.
pub fn robustness(
    table: &Table<'_>,
    report: &Report,
    axes: [&[f64]; 3],
    error: &MeasurementError,
) -> Robustness {
    let level = report.level as f32;
    let header = table.header();
    let (band, vmax) = match header.game {
        table_format::Game::ThreeCarSplit { ego, max_speed, .. } => ((ego.min, ego.max), max_speed),
        _ => ((0.0, 0.0), 0.0),
    };
    let gaps = table.axis_bounds(0).map_or([0.0, 0.0], |b| [b.min, b.max]);
    let [ni, nj, nk] = [axes[0].len(), axes[1].len(), axes[2].len()];
    let (cj, ck) = (nj - 1, nk - 1);
    let results: Vec<(bool, bool, bool, bool)> = (0..ni * nj * nk)
        .into_par_iter()
        .map(|n| {
            let (i, j, k) = (n / (nj * nk), (n / nk) % nj, n % nk);
            let m = [axes[0][i] as f32, axes[1][j] as f32, axes[2][k] as f32];
            let inside = m[1] <= vmax && m[2] <= vmax;
            let Some((lo, hi)) = error_box(error, m, band, (gaps, vmax)) else {
                return (inside, false, false, false);
            };
            let least = match table.least_over_box(&lo, &hi) {
                Ok(w) => w,
                Err(table_format::Error::BoxTooWide { .. }) => return (inside, false, false, true),
                Err(_) => return (inside, false, false, false),
            };
            if least.is_nan() || least <= level {
                return (inside, false, false, false);
            }
            let (i0, i1) = cells_touched(axes[0], lo[0], hi[0]);
            let (j0, j1) = cells_touched(axes[1], lo[1], hi[1]);
            let (k0, k1) = cells_touched(axes[2], lo[2], hi[2]);
            let all_proven = (i0..=i1).all(|a| {
                (j0..=j1).all(|b| {
                    (k0..=k1).all(|c| {
                        matches!(
                            report.verdicts[(a * cj + b) * ck + c],
                            Verdict::Proven | Verdict::ProvenAtStandstill
                        )
                    })
                })
            });
            (inside, true, !all_proven, false)
        })
        .collect();
    let measurements = results.iter().filter(|r| r.0).count();
    let passing = results.iter().filter(|r| r.1).count();
    Robustness {
        error: *error,
        measurements,
        passing,
        passing_share: passing as f64 / measurements.max(1) as f64,
        unproven: results.iter().filter(|r| r.2).count(),
        too_wide: results.iter().filter(|r| r.3).count(),
        passes: results.iter().map(|r| r.1).collect(),
    }
}

/// Draws the measured rear states at the ego speed nearest `ego_speed` on `(gap_follower,
/// follower_speed)` nodes: passing with every error in `runs` (the last is the declared one),
/// passing only with the first (exact sensors), or passing with neither. Writes
/// `robustness-ego-<v>.png`.
pub fn plot(
    axes: [&[f64]; 3],
    runs: &[&Robustness],
    dir: &std::path::Path,
    ego_speed: f64,
) -> Result<std::path::PathBuf, crate::error::SolverError> {
    use crate::pipeline::output::{draw_cell_map, CellMap, PlotAxis};
    use plotters::style::RGBColor;
    let (nj, nk) = (axes[1].len(), axes[2].len());
    let k = axes[2].partition_point(|&b| b < ego_speed).min(nk - 1);
    let passes = |r: &Robustness, i: usize, j: usize| {
        r.passes
            .get((i * nj + j) * nk + k)
            .copied()
            .unwrap_or(false)
    };
    let (Some(first), Some(last)) = (runs.first(), runs.last()) else {
        return Ok(dir.to_path_buf());
    };
    let legend: [(&str, RGBColor); 3] = [
        // Okabe and Ito's colour-blind-safe palette.
        ("not certified", RGBColor(222, 222, 222)),
        ("certified with exact sensors only", RGBColor(230, 159, 0)),
        ("certified with the declared error", RGBColor(0, 114, 178)),
    ];
    let cell = |i: usize, j: usize| {
        Some(if passes(last, i, j) {
            2
        } else if passes(first, i, j) {
            1
        } else {
            0
        })
    };
    let title = format!(
        "measured rear states at ego speed {:.1} m/s (whole table: {:.1}% certified exact, {:.1}% with the error)",
        axes[2][k],
        100.0 * first.passing_share,
        100.0 * last.passing_share
    );
    let path = dir.join(format!("robustness-ego-{:.0}.png", axes[2][k]));
    draw_cell_map(
        &path,
        &CellMap {
            title: &title,
            x: PlotAxis {
                label: "measured gap to the follower (m)",
                coords: axes[0],
            },
            y: PlotAxis {
                label: "measured follower speed (m/s)",
                coords: axes[1],
            },
            cell: &cell,
            legend: &legend,
            curves: &[],
            frame: None,
        },
    )?;
    Ok(path)
}
