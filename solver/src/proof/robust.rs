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
use table_format::{MeasurementError, Table};

use crate::proof::verify::{Report, Verdict};

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

/// The error box around the measured rear state `(gap, follower_speed, ego_speed)`
/// ([`MeasurementError::rear_box`], the firmware's), the ego's speed within its error and moved
/// within the band over `ego_age`, clipped to the grid's speeds `[0, vmax]` and gaps: `None`
/// when it leaves the grid below, or its speeds lie entirely above `vmax`.
fn error_box(
    e: &MeasurementError,
    [gap, follower, ego]: [f32; 3],
    band: (f32, f32),
    grid: ([f32; 2], f32),
) -> Option<([f32; 3], [f32; 3])> {
    let ([gap_min, gap_max], vmax) = grid;
    let (ego_lo, ego_hi) = e.ego_speed(ego);
    let ego_at_track = (
        (ego_lo + band.0 * e.ego_age).max(0.0),
        ego_hi + band.1 * e.ego_age,
    );
    // The measured range rate is `ego - follower`.
    let (lo, hi) = e.rear_box(gap, ego - follower, ego_at_track);
    let gap_hi = hi[0].min(gap_max);
    let follower_hi = hi[1].min(vmax);
    if lo[0] < gap_min || hi[2] > vmax || lo[1] > vmax {
        return None;
    }
    Some((lo, [gap_hi.max(lo[0]), follower_hi, hi[2]]))
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
