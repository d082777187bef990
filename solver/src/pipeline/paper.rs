//! The paper's headline figure, from two runs: Fig. 3, the baseline's empty safe set beside the
//! IDM formulation's, on the same slice, with the safe share against the horizon.
//!
//! The slice is the IDM run's slice through its safe set's boundary (the trusted slice split
//! most evenly between safe and not safe), so that the reader sees where safe turns unsafe;
//! the baseline is drawn on the same held speeds. Each run's own trusted box decides what may
//! be drawn as safe.
//!
//! The baseline's emptiness needs no trusted box: with the follower free to accelerate, the sum
//! of the two gaps obeys `(x1 + x2)'' = u1 - u3` whatever the ego does, so the leader braking
//! at `-leader.min` and the follower accelerating at `follower.max` close it from every state
//! of the grid (the sum at most `X`, its rate at most `W`) within
//! `t* = (W + sqrt(W^2 + 2 a (X - 2 min_gap))) / a`, `a = follower.max - leader.min`: at a
//! horizon of `t*` or more every state of the grid is lost, exactly ([`baseline_lost_by`]).
//! Where that holds the baseline's panel draws every state not safe, and says why.

use std::path::{Path, PathBuf};

use crate::engine::grid::Grid;
use crate::error::SolverError;
use crate::pipeline::config::{GameConfig, GameKindConfig};
use crate::pipeline::output::{self, CellMap, CurvePanel, PlotAxis};
use crate::pipeline::palette::{BLUE, VERMILLION};
use crate::pipeline::plots::{boundary_slice, relative_speeds_text, set_category, SET_LEGEND};
use crate::pipeline::run::Summary;

/// A solved level-set run: its summary, grid and values.
pub struct Solved<'a> {
    /// The run's summary.
    pub summary: &'a Summary,
    /// Its grid.
    pub grid: &'a Grid,
    /// Its values (C order).
    pub values: &'a [f32],
}

/// One panel's cells, axes, title and trusted box.
struct Panel {
    xs: Vec<f64>,
    ys: Vec<f64>,
    title: String,
    cells: Vec<Vec<Option<usize>>>,
    frame: Option<(f64, f64, f64, f64)>,
}

/// The file [`fig3`] writes under the output folder.
pub const FIG3: &str = "paper-fig3.png";

/// Draws Fig. 3 into `out/paper-fig3.png` from the baseline's and the IDM formulation's 4-D
/// runs. `None` when the IDM run's trusted box holds no slice through its boundary (nothing
/// to compare on), or the runs are not 4-D.
pub fn fig3(
    out: &Path,
    baseline: &Solved<'_>,
    idm: &Solved<'_>,
) -> Result<Option<PathBuf>, SolverError> {
    if baseline.grid.dims() != 4 || idm.grid.dims() != 4 {
        return Ok(None);
    }
    let min_gap = idm.summary.config.game.min_gap;
    let Some(slice) = boundary_slice(
        idm.grid,
        idm.values,
        idm.summary.trusted_box.as_deref(),
        min_gap,
    ) else {
        return Ok(None);
    };
    let speeds = slice.point(false, 0.0, 0.0);
    let speeds_text = relative_speeds_text(speeds[1], speeds[3]);
    let coords = |g: &Grid, k: usize| -> Vec<f64> {
        let a = &g.axes()[k];
        (0..a.points).map(|i| a.coordinate(i)).collect()
    };
    let panel = |run: &Solved<'_>, label: &str| -> Panel {
        let (xs, ys) = (coords(run.grid, 0), coords(run.grid, 2));
        let bounds = run
            .summary
            .trusted_box
            .clone()
            .unwrap_or_else(|| vec![(f64::INFINITY, f64::NEG_INFINITY); 4]);
        let inside = |k: usize, x: f64| (bounds[k].0..=bounds[k].1).contains(&x);
        let held_inside = inside(1, speeds[1]) && inside(3, speeds[3]);
        let mut safe_nodes = 0usize;
        let cells: Vec<Vec<Option<usize>>> = xs
            .iter()
            .map(|&x| {
                ys.iter()
                    .map(|&y| {
                        let value = run.grid.interpolate(run.values, &slice.point(false, x, y));
                        let trusted = held_inside && inside(0, x) && inside(2, y);
                        safe_nodes += usize::from(trusted && value > 0.0);
                        set_category(value > 0.0, x.min(y) - min_gap >= 0.0, trusted)
                    })
                    .collect()
            })
            .collect();
        let verdict = if safe_nodes == 0 {
            "EMPTY: no safe state"
        } else {
            "a non-empty safe set"
        };
        let title = format!("{label}, horizon {:.1} s: {verdict}", run.summary.time);
        let frame = run
            .summary
            .trusted_box
            .as_ref()
            .map(|b| (b[0].0, b[0].1, b[2].0, b[2].1));
        Panel {
            xs,
            ys,
            title,
            cells,
            frame,
        }
    };
    let exact_empty = baseline_lost_by(&baseline.summary.config.game, baseline.grid)
        .filter(|&t| baseline.summary.time >= t);
    let mut a = panel(
        baseline,
        "(a) baseline: a follower with any bounded acceleration",
    );
    if let Some(t) = exact_empty {
        for (i, column) in a.cells.iter_mut().enumerate() {
            for (j, cell) in column.iter_mut().enumerate() {
                let (x, y) = (a.xs[i], a.ys[j]);
                *cell = set_category(false, x.min(y) - min_gap >= 0.0, true);
            }
        }
        a.title = format!(
            "(a) baseline: a follower with any bounded acceleration, horizon {:.1} s: EMPTY, \
             every state of the grid is lost within {t:.1} s whatever the ego does",
            baseline.summary.time
        );
    }
    let b = panel(idm, "(b) the IDM follower with an adversarial time gap");
    fn cells_of(p: &Panel) -> impl Fn(usize, usize) -> Option<usize> + '_ {
        move |i, j| p.cells.get(i)?.get(j).copied().flatten()
    }
    fn axes_of(p: &Panel) -> (PlotAxis<'_>, PlotAxis<'_>) {
        (
            PlotAxis {
                label: "gap to the leader [m]",
                coords: &p.xs,
            },
            PlotAxis {
                label: "gap to the follower [m]",
                coords: &p.ys,
            },
        )
    }
    let (cells_a, cells_b) = (cells_of(&a), cells_of(&b));
    let (axes_a, axes_b) = (axes_of(&a), axes_of(&b));
    let maps = [
        CellMap {
            title: &a.title,
            x: axes_a.0,
            y: axes_a.1,
            cell: &cells_a,
            legend: &SET_LEGEND,
            curves: &[],
            frame: a.frame,
        },
        CellMap {
            title: &b.title,
            x: axes_b.0,
            y: axes_b.1,
            cell: &cells_b,
            legend: &SET_LEGEND,
            curves: &[],
            frame: b.frame,
        },
    ];
    let curves = [
        (
            "(a) baseline",
            VERMILLION,
            baseline.summary.safe_fraction_history.clone(),
        ),
        (
            "(b) IDM follower",
            BLUE,
            idm.summary.safe_fraction_history.clone(),
        ),
    ];
    let path = out.join(FIG3);
    let title = format!("Invariant safe states of the three-car game, {speeds_text} (Fig. 3 of Bahati, Gibson & Bayen)");
    output::draw_figure(
        &path,
        Some(&title),
        &maps,
        Some(&CurvePanel {
            title: "(c) share of all grid nodes with V > 0 against the horizon (trusted or not)",
            x_label: "horizon [s]",
            y_label: "share of nodes",
            curves: &curves,
        }),
    )?;
    Ok(Some(path))
}

/// The time by which every state of a baseline run's grid is lost whatever the ego does (module
/// docs), s; `None` for another game, or a leader and follower that cannot close the gaps.
pub fn baseline_lost_by(g: &GameConfig, grid: &Grid) -> Option<f64> {
    if g.kind != GameKindConfig::ThreeCarBaseline || grid.dims() != 4 {
        return None;
    }
    let a = g.follower?.max - g.leader.min;
    if !(a.is_finite() && a > 0.0) {
        return None;
    }
    let axes = grid.axes();
    let widest = |k: usize| axes[k].coordinate(axes[k].points - 1);
    let gaps = widest(0) + widest(2);
    let opening = (widest(1) + widest(3)).max(0.0);
    let room = (gaps - 2.0 * g.min_gap).max(0.0);
    Some((opening + (opening * opening + 2.0 * a * room).sqrt()) / a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::config::{builtin, Config};
    use crate::pipeline::run::grid_of;

    /// The built-in baseline's grid is lost within 24.1 s, and its 25 s horizon is past that;
    /// from the grid's worst corner (both gaps 75 m, both opening at 15 m/s) the gaps' sum under
    /// the worst inputs reaches zero at that time, integrated step by step.
    #[test]
    fn the_baseline_is_lost_from_every_state_of_its_grid() {
        let (_, text) = builtin()
            .into_iter()
            .find(|(name, _)| name.contains("baseline"))
            .expect("the built-in baseline");
        let config = Config::from_toml(text).expect("parses");
        let grid = grid_of(&config).expect("grid");
        let t = baseline_lost_by(&config.game, &grid).expect("the baseline");
        assert!((t - 24.142).abs() < 1e-3, "{t}");
        assert!(config.horizon.time >= t);
        let (mut sum, mut rate, h) = (150.0f64, 30.0f64, 1e-4);
        let mut time = 0.0;
        while sum > 0.0 {
            sum += rate * h - 1.5 * h * h;
            rate -= 3.0 * h;
            time += h;
        }
        assert!((time - t).abs() < 1e-3, "{time} against {t}");
        // Any other game has no such time.
        let (_, idm) = builtin()
            .into_iter()
            .find(|(name, _)| *name == "three-car-idm.toml")
            .expect("the built-in IDM game");
        let idm = Config::from_toml(idm).expect("parses");
        assert_eq!(
            baseline_lost_by(&idm.game, &grid_of(&idm).expect("grid")),
            None
        );
    }
}
