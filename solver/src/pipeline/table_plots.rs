//! The plots of a split (rear) table, the firmware's own kind: what it certifies, read as the
//! firmware reads it.
//!
//! One responsibility: turn a compiled table (and its proof's report) into PNG files. The
//! level-set runs' maps are the `plots` module's; verify's verdicts are drawn by
//! [`super::proof_plots::verdicts`], called from here over the table's whole extent.
//!
//! - `certified-rear-ego-<v>.png`: the rear certificate on `(gap to the follower, follower
//!   speed)` at ego speeds 0, 5, 15, 25 and 35 m/s (those within the table's speed limit): a state
//!   is certified where the interpolated rear value exceeds the table's error bound;
//! - `front-certified-gap.png`: the closed-form front certificate (the firmware evaluates it,
//!   the table stores only its parameters): the smallest gap to the leader it certifies,
//!   against the ego's speed, for a stopped leader, one 10 m/s slower, and one at the ego's
//!   speed;
//! - `verdicts-ego-<v>.png` and `verdicts-worst.png`: the proof's verdicts per cell.

use std::path::{Path, PathBuf};

use table_format::front::front_value;
use table_format::{Game, Table};

use super::output::{self, CellMap, PlotAxis};
use super::palette::{BLUE, GREEN, LIGHT_GREY, ORANGE, VERMILLION};
use crate::error::SolverError;
use crate::proof::verify::{RearTable, Report};

/// The ego speeds of the rear maps, m/s: the edge of the deployed domain (35 m/s) included,
/// where the domain's edge is.
const EGO_SPEEDS: [f32; 5] = [0.0, 5.0, 15.0, 25.0, 35.0];

/// The front value a certified state exceeds, m: the firmware's default `front_margin`.
const FRONT_LEVEL: f32 = 0.5;

/// Draws a split table's plots into `dir` and returns the files written. A table of another
/// game has none of them.
pub fn deployed_table_plots(
    table: &Table<'_>,
    rear: &RearTable,
    report: &Report,
    dir: &Path,
) -> Result<Vec<PathBuf>, SolverError> {
    let game = table.header().game;
    let (Game::ThreeCarSplit { max_speed, .. }, Some(model)) = (game, game.front_model(0.0, 0.0))
    else {
        return Ok(Vec::new());
    };
    let mut written = Vec::new();
    let bound = table.header().error_bound.total();
    let (Some(gaps), Some(speeds)) = (table.axis_bounds(0), table.axis_bounds(1)) else {
        return Ok(written);
    };
    let sample = |lo: f32, hi: f32, n: usize| -> Vec<f64> {
        (0..n)
            .map(|i| f64::from(lo) + f64::from(hi - lo) * i as f64 / (n - 1) as f64)
            .collect()
    };
    let gap_axis = sample(gaps.min, gaps.max, 301);
    let speed_axis = sample(speeds.min, speeds.max.min(max_speed), 141);
    let legend = [
        (
            "certified: the rear value exceeds the table's error bound",
            BLUE,
        ),
        ("not certified", LIGHT_GREY),
    ];
    for ve in EGO_SPEEDS.into_iter().filter(|&v| v <= max_speed) {
        let cell = |i: usize, j: usize| {
            let state = [gap_axis[i] as f32, speed_axis[j] as f32, ve];
            table.value_at(&state).ok().map(|w| usize::from(w <= bound))
        };
        let path = dir.join(format!("certified-rear-ego-{ve:.0}.png"));
        // A uniform map says so in its title.
        let cells = (0..gap_axis.len()).flat_map(|i| (0..speed_axis.len()).map(move |j| (i, j)));
        let certified = cells.filter(|&(i, j)| cell(i, j) == Some(0)).count();
        let all = gap_axis.len() * speed_axis.len();
        let note = match certified {
            0 => ": NOTHING certified on this slice",
            c if c == all => ": EVERY state on this slice certified",
            _ => "",
        };
        let title = format!(
            "the table's rear certificate, ego at {ve:.0} m/s (certified: value > {bound:.3} m){note}"
        );
        output::draw_cell_map(
            &path,
            &CellMap {
                title: &title,
                x: PlotAxis {
                    label: "gap to the follower [m]",
                    coords: &gap_axis,
                },
                y: PlotAxis {
                    label: "follower's speed [m/s]",
                    coords: &speed_axis,
                },
                cell: &cell,
                legend: &legend,
                curves: &[],
                frame: None,
            },
        )?;
        written.push(path);
    }

    let smallest_gap = |leader_speed: f32, ego_speed: f32| -> Option<f64> {
        // `front_value` is non-decreasing in the gap: bisection to 1 mm.
        let certified = |g: f32| front_value(g, leader_speed, ego_speed, &model) > FRONT_LEVEL;
        let (mut lo, mut hi) = (0.0f32, 1000.0f32);
        if !certified(hi) {
            return None;
        }
        if certified(lo) {
            return Some(0.0);
        }
        while hi - lo > 1e-3 {
            let mid = 0.5 * (lo + hi);
            if certified(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(f64::from(hi))
    };
    let ego_speeds: Vec<f32> = (0..=350).map(|i| max_speed * i as f32 / 350.0).collect();
    let curve = |leader: &dyn Fn(f32) -> f32| -> Vec<(f64, f64)> {
        ego_speeds
            .iter()
            .filter_map(|&v| smallest_gap(leader(v), v).map(|g| (f64::from(v), g)))
            .collect()
    };
    let path = dir.join("front-certified-gap.png");
    output::draw_curves(
        &path,
        &format!(
            "front certificate: the smallest certified gap (leader brakes at {:.1}, ego at {:.1} m/s^2)",
            model.leader_braking, model.ego_braking
        ),
        "ego's speed [m/s]",
        "smallest certified gap to the leader [m]",
        &[
            ("leader stopped", VERMILLION, curve(&|_| 0.0)),
            (
                "leader 10 m/s slower than the ego",
                ORANGE,
                curve(&|v| (v - 10.0).max(0.0)),
            ),
            ("leader at the ego's speed", GREEN, curve(&|v| v)),
        ],
    )?;
    written.push(path);

    let verdict_speeds: Vec<f64> = EGO_SPEEDS
        .iter()
        .filter(|&&v| v <= max_speed)
        .map(|&v| f64::from(v))
        .collect();
    written.extend(super::proof_plots::verdicts(
        rear,
        report,
        dir,
        &verdict_speeds,
    )?);
    Ok(written)
}
