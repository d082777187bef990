//! The plots of a level-set run: the constraint and safe sets, the ego's input over the safe
//! set, and the compiled table as the firmware reads it, on 2-D slices of the grid.
//!
//! One responsibility: turn a solved run into PNG files. What is drawn where, and in which
//! colour, is decided here; the drawing itself is [`crate::pipeline::output`]'s.

use std::path::Path;

use plotters::style::RGBColor;

use crate::engine::grid::Grid;
use crate::engine::hji::Solution;
use crate::error::SolverError;
use crate::pipeline::config::{Config, GameKindConfig};
use crate::pipeline::output::{self, CellMap, PlotAxis};
use crate::proof::exact;
use crate::proof::trusted::IndexBox;

const GREEN: RGBColor = RGBColor(140, 210, 140);
const BLUE: RGBColor = RGBColor(60, 110, 220);
const RED: RGBColor = RGBColor(230, 120, 100);
const ORANGE: RGBColor = RGBColor(245, 170, 60);
const PURPLE: RGBColor = RGBColor(130, 90, 190);
const GREY: RGBColor = RGBColor(215, 215, 215);
const PALE_GREEN: RGBColor = RGBColor(205, 235, 205);
const PALE_BLUE: RGBColor = RGBColor(175, 195, 240);
const PALE_YELLOW: RGBColor = RGBColor(250, 230, 130);

/// The categories of a safe-set map: inside the trusted box, then outside it (paler).
const SET_LEGEND: [(&str, RGBColor); 4] = [
    ("constraint set l >= 0", GREEN),
    ("safe set V > 0", BLUE),
    ("constraint set, untrusted", PALE_GREEN),
    ("safe set, untrusted", PALE_BLUE),
];

/// The categories of a policy map: the policy where the state is safe, grey where it is not.
const POLICY_LEGEND: [(&str, RGBColor); 4] = [
    ("safe, u2* = a_max", ORANGE),
    ("safe, u2* = a_min", PURPLE),
    ("constraint set, not safe", GREY),
    ("safe, either input (tie)", PALE_YELLOW),
];

/// The categories of the compiled table's map: what the firmware reads at a state.
const TABLE_LEGEND: [(&str, RGBColor); 3] = [
    ("certified, policy bit a_max", ORANGE),
    ("certified, policy bit a_min", PURPLE),
    ("constraint set, not certified", GREY),
];

/// A [`CellMap`] on `axes` (horizontal, vertical).
fn cell_map<'a>(
    axes: (PlotAxis<'a>, PlotAxis<'a>),
    title: &'a str,
    cell: &'a dyn Fn(usize, usize) -> Option<usize>,
    legend: &'a [(&'a str, RGBColor)],
    curves: &'a [output::Curve<'a>],
    frame: Option<(f64, f64, f64, f64)>,
) -> CellMap<'a> {
    CellMap {
        title,
        x: axes.0,
        y: axes.1,
        cell,
        legend,
        curves,
        frame,
    }
}

/// The firmware's reading of `table` at `state`: certified (the interpolated value above the
/// table's error bound) with its policy bit, not certified, or `None` outside the table's grid
/// or the constraint set.
fn table_category(
    table: &table_format::Table<'_>,
    state: &[f32],
    in_constraint: bool,
) -> Option<usize> {
    let lookup = table.lookup(state).ok()?;
    if lookup.value > table.header().error_bound.total() {
        Some(match lookup.action {
            table_format::EgoAction::Accelerate => 0,
            table_format::EgoAction::Brake => 1,
        })
    } else if in_constraint {
        Some(2)
    } else {
        None
    }
}

/// The ego's policy per node (the table's bit, and whether it is a tie: either input), and the
/// table compiled from it, if any.
pub(crate) struct Policy<'a> {
    pub(crate) accelerate: &'a [bool],
    pub(crate) tie: &'a [bool],
    pub(crate) table: Option<&'a [u8]>,
}

/// A safe-set map's category: `None` outside the constraint set; 2 and 3 where untrusted.
fn set_category(safe: bool, in_constraint: bool, trusted: bool) -> Option<usize> {
    let base = if safe {
        1
    } else if in_constraint {
        0
    } else {
        return None;
    };
    Some(if trusted { base } else { base + 2 })
}

/// A policy map's category: the policy where safe (a tie apart), grey in the rest of the
/// constraint set.
fn policy_category(safe: bool, in_constraint: bool, accelerate: bool, tie: bool) -> Option<usize> {
    if safe && tie {
        Some(3)
    } else if safe {
        Some(if accelerate { 0 } else { 1 })
    } else if in_constraint {
        Some(2)
    } else {
        None
    }
}

pub(crate) fn plots(
    config: &Config,
    grid: &Grid,
    solution: &Solution,
    policy_bits: &Policy<'_>,
    trusted: Option<&IndexBox>,
    dir: &Path,
    history: &[(f64, f64)],
) -> Result<(), SolverError> {
    let coords: Vec<Vec<f64>> = grid
        .axes()
        .iter()
        .map(|a| (0..a.points).map(|i| a.coordinate(i)).collect())
        .collect();
    let bounds = trusted.map(|b| b.bounds(grid));
    let values = &solution.values;
    let table = match policy_bits.table.map(table_format::Table::parse) {
        Some(Ok(t)) => Some(t),
        Some(Err(e)) => return Err(SolverError::Table(e)),
        None => None,
    };
    let table_title = |what: &str| {
        table.as_ref().map_or_else(String::new, |t| {
            format!(
                "{what}: the table as the firmware reads it (V > {:.4} m)",
                t.header().error_bound.total()
            )
        })
    };
    let horizon_text = format!("{:.1} s", solution.time);
    if grid.dims() == 2 {
        let n1 = grid.axes()[1].points;
        let g = &config.game;
        let boundary: Vec<(f64, f64)> = coords[1]
            .iter()
            .map(|&v| {
                (
                    exact::two_car_boundary(v, solution.time, g.ego.min, g.leader.min, g.min_gap),
                    v,
                )
            })
            .filter(|(x, _)| *x >= coords[0][0] && *x <= *coords[0].last().unwrap_or(&0.0))
            .collect();
        let frame = bounds.as_ref().map(|b| (b[0].0, b[0].1, b[1].0, b[1].1));
        let axes = (
            PlotAxis {
                label: "gap_leader [m]",
                coords: &coords[0],
            },
            PlotAxis {
                label: "rel_speed_leader = v_leader - v_ego [m/s]",
                coords: &coords[1],
            },
        );
        let inside = |x: f64, y: f64| {
            frame.is_none_or(|(a, b, c, d)| (a..=b).contains(&x) && (c..=d).contains(&y))
        };
        let sets = |i: usize, j: usize| {
            set_category(
                values[i * n1 + j] > 0.0,
                coords[0][i] - g.min_gap >= 0.0,
                inside(coords[0][i], coords[1][j]),
            )
        };
        output::draw_cell_map(
            &dir.join("safe_set.png"),
            &cell_map(
                axes,
                &format!(
                    "{}: constraint and safe sets, horizon {horizon_text}",
                    config.name
                ),
                &sets,
                &SET_LEGEND,
                &[("exact safe-set boundary", RED, boundary.clone())],
                frame,
            ),
        )?;
        let policy = |i: usize, j: usize| {
            let node = i * n1 + j;
            policy_category(
                values[node] > 0.0,
                coords[0][i] - g.min_gap >= 0.0,
                policy_bits.accelerate[node],
                policy_bits.tie[node],
            )
        };
        output::draw_cell_map(
            &dir.join("policy.png"),
            &cell_map(
                axes,
                &format!("{}: ego input u2* over the safe set", config.name),
                &policy,
                &POLICY_LEGEND,
                &[("exact safe-set boundary", RED, boundary.clone())],
                frame,
            ),
        )?;
        if let Some(t) = &table {
            let firmware = |i: usize, j: usize| {
                table_category(
                    t,
                    &[coords[0][i] as f32, coords[1][j] as f32],
                    coords[0][i] - g.min_gap >= 0.0,
                )
            };
            let solver_title = format!("{}: the solver's value and policy", config.name);
            let table_title = table_title(&config.name);
            let curves = [("exact safe-set boundary", RED, boundary)];
            output::draw_cell_maps(
                &dir.join("table_vs_solver.png"),
                &[
                    cell_map(axes, &solver_title, &policy, &POLICY_LEGEND, &curves, frame),
                    cell_map(axes, &table_title, &firmware, &TABLE_LEGEND, &curves, frame),
                ],
            )?;
        }
    } else {
        let configured = if config.slices.is_empty() {
            vec![crate::pipeline::config::SliceConfig::default()]
        } else {
            config.slices.clone()
        };
        let min_gap = config.game.min_gap;
        let five = grid.dims() == 5;
        // Besides the configured slices, the trusted slice with the most safe states, so that
        // a reader sees the set where it is not empty (when it is anywhere).
        let mut slices: Vec<(crate::pipeline::config::SliceConfig, bool)> =
            configured.into_iter().map(|s| (s, false)).collect();
        if let Some(widest) = widest_slice(grid, values, bounds.as_deref(), min_gap) {
            if !slices.iter().any(|(s, _)| s.tag(five) == widest.tag(five)) {
                slices.push((widest, true));
            }
        }
        for (s, widest) in &slices {
            let at = |i: usize, j: usize| -> f64 {
                grid.interpolate(values, &s.point(five, coords[0][i], coords[2][j]))
            };
            let speeds = s.point(five, 0.0, 0.0);
            let policy_at = |i: usize, j: usize| -> (bool, bool) {
                // The policy of the nearest node in speed.
                let nearest = |k: usize, x: f64| -> usize {
                    let a = &grid.axes()[k];
                    (((x - a.min) / a.spacing()).round().max(0.0) as usize).min(a.points - 1)
                };
                let st = grid.strides();
                let mut node = i * st[0] + j * st[2];
                for k in [1, 3, 4] {
                    if let Some(&x) = speeds.get(k) {
                        node += nearest(k, x) * st[k];
                    }
                }
                (policy_bits.accelerate[node], policy_bits.tie[node])
            };
            // The trusted box on the slice: its gap extents, when the slice's held speeds lie
            // inside it; otherwise the whole slice is untrusted.
            let held_inside = bounds.as_ref().is_none_or(|b| {
                [1, 3, 4].iter().all(|&k| {
                    speeds
                        .get(k)
                        .is_none_or(|&x| k >= b.len() || (b[k].0..=b[k].1).contains(&x))
                })
            });
            let frame = bounds
                .as_ref()
                .filter(|_| held_inside)
                .map(|b| (b[0].0, b[0].1, b[2].0, b[2].1));
            let axes = (
                PlotAxis {
                    label: "gap_leader x_g1 [m]",
                    coords: &coords[0],
                },
                PlotAxis {
                    label: "gap_follower x_g2 [m]",
                    coords: &coords[2],
                },
            );
            let trusted_at = |i: usize, j: usize| {
                held_inside
                    && frame.is_none_or(|(a, b, c, d)| {
                        (a..=b).contains(&coords[0][i]) && (c..=d).contains(&coords[2][j])
                    })
            };
            let in_constraint =
                |i: usize, j: usize| coords[0][i].min(coords[2][j]) - min_gap >= 0.0;
            let sets = |i: usize, j: usize| {
                set_category(at(i, j) > 0.0, in_constraint(i, j), trusted_at(i, j))
            };
            let safe_nodes = (0..coords[0].len())
                .flat_map(|i| (0..coords[2].len()).map(move |j| (i, j)))
                .filter(|&(i, j)| at(i, j) > 0.0)
                .count();
            let notes = match (held_inside, safe_nodes, widest) {
                (true, 0, _) => " (empty)".to_string(),
                (true, _, true) => " (the slice with the most safe states)".to_string(),
                (true, _, false) => String::new(),
                (false, 0, _) => " (untrusted, empty)".to_string(),
                (false, _, _) => " (untrusted slice)".to_string(),
            };
            let tag = s.tag(five);
            let speeds_text = if five {
                format!(
                    "v1 = {:.1}, v3 = {:.1}, v_ego = {:.1} m/s",
                    speeds[1], speeds[3], speeds[4]
                )
            } else {
                format!("v_g1 = {:.1}, v_g2 = {:.1} m/s", speeds[1], speeds[3])
            };
            let kind = match config.game.kind {
                GameKindConfig::ThreeCarBaseline => "baseline",
                _ => "IDM",
            };
            output::draw_cell_map(
                &dir.join(format!("safe_set_{tag}.png")),
                &cell_map(
                    axes,
                    &format!(
                        "{} ({kind}): {speeds_text}, {horizon_text}{notes}",
                        config.name
                    ),
                    &sets,
                    &SET_LEGEND,
                    &[],
                    frame,
                ),
            )?;
            let policy = |i: usize, j: usize| {
                let (accelerate, tie) = policy_at(i, j);
                policy_category(at(i, j) > 0.0, in_constraint(i, j), accelerate, tie)
            };
            let policy_title = format!("{}: u2* where safe, {speeds_text}{notes}", config.name);
            let policy_map = cell_map(axes, &policy_title, &policy, &POLICY_LEGEND, &[], frame);
            output::draw_cell_map(&dir.join(format!("policy_{tag}.png")), &policy_map)?;
            if let Some(t) = &table {
                let firmware = |i: usize, j: usize| {
                    let state: Vec<f32> = s
                        .point(five, coords[0][i], coords[2][j])
                        .iter()
                        .map(|&x| x as f32)
                        .collect();
                    table_category(t, &state, in_constraint(i, j))
                };
                let title = table_title(&format!("{}, {speeds_text}", config.name));
                let table_map = cell_map(axes, &title, &firmware, &TABLE_LEGEND, &[], frame);
                output::draw_cell_maps(
                    &dir.join(format!("table_vs_solver_{tag}.png")),
                    &[policy_map, table_map],
                )?;
            }
        }
    }
    if history.len() > 1 {
        output::draw_curves(
            &dir.join("safe_fraction.png"),
            "Share of grid nodes with V > 0 against the horizon",
            "horizon [s]",
            "share of nodes",
            &[("V > 0", BLUE, history.to_vec())],
        )?;
    }
    Ok(())
}

/// The slice of a 4-D or 5-D grid, at node speeds inside the trusted box, with the most nodes
/// that are safe, in the constraint set and trusted in gap; `None` when no such node exists.
/// Speeds are the nodes' own (axes 1 and 3, and 4 on a 5-D grid), so the count is exact.
fn widest_slice(
    grid: &Grid,
    values: &[f32],
    trusted: Option<&[(f64, f64)]>,
    min_gap: f64,
) -> Option<crate::pipeline::config::SliceConfig> {
    let axes = grid.axes();
    let strides = grid.strides();
    let five = grid.dims() == 5;
    let in_box = |k: usize, i: usize| {
        trusted.is_none_or(|b| {
            b.get(k)
                .is_none_or(|r| (r.0..=r.1).contains(&axes[k].coordinate(i)))
        })
    };
    let speed_axes: &[usize] = if five { &[1, 3, 4] } else { &[1, 3] };
    let gap_nodes: Vec<(usize, usize)> = (0..axes[0].points)
        .filter(|&i| in_box(0, i))
        .flat_map(|i| {
            (0..axes[2].points)
                .filter(|&j| in_box(2, j))
                .map(move |j| (i, j))
        })
        .filter(|&(i, j)| axes[0].coordinate(i).min(axes[2].coordinate(j)) >= min_gap)
        .collect();
    let mut best: Option<(usize, Vec<usize>)> = None;
    let mut index = vec![0usize; speed_axes.len()];
    loop {
        if speed_axes.iter().zip(&index).all(|(&k, &i)| in_box(k, i)) {
            let base: usize = speed_axes
                .iter()
                .zip(&index)
                .map(|(&k, &i)| i * strides[k])
                .sum();
            let safe = gap_nodes
                .iter()
                .filter(|&&(i, j)| values[base + i * strides[0] + j * strides[2]] > 0.0)
                .count();
            if safe > 0 && best.as_ref().is_none_or(|(n, _)| safe > *n) {
                best = Some((safe, index.clone()));
            }
        }
        // The next combination of speed nodes, odometer style.
        let mut k = 0;
        loop {
            if k == index.len() {
                return best.map(|(_, idx)| {
                    let at = |n: usize| axes[speed_axes[n]].coordinate(idx[n]);
                    if five {
                        crate::pipeline::config::SliceConfig {
                            leader_speed: Some(at(0)),
                            follower_speed: Some(at(1)),
                            ego_speed: Some(at(2)),
                            ..Default::default()
                        }
                    } else {
                        crate::pipeline::config::SliceConfig {
                            rel_speed_leader: at(0),
                            rel_speed_follower: at(1),
                            ..Default::default()
                        }
                    }
                });
            }
            index[k] += 1;
            if index[k] < axes[speed_axes[k]].points {
                break;
            }
            index[k] = 0;
            k += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::run::run;

    #[test]
    fn untrusted_cells_take_the_pale_categories_and_policy_shows_only_where_safe() {
        assert_eq!(set_category(true, true, true), Some(1));
        assert_eq!(set_category(false, true, true), Some(0));
        assert_eq!(set_category(true, true, false), Some(3));
        assert_eq!(set_category(false, true, false), Some(2));
        assert_eq!(set_category(false, false, true), None);
        assert_eq!(SET_LEGEND[3].0, "safe set, untrusted");
        // The policy bit is shown only where the state is safe.
        assert_eq!(policy_category(true, true, true, false), Some(0));
        assert_eq!(policy_category(true, true, false, false), Some(1));
        assert_eq!(policy_category(false, true, true, false), Some(2));
        assert_eq!(policy_category(false, false, false, false), None);
        // A tie is shown as such where safe, whatever the bit says.
        assert_eq!(policy_category(true, true, false, true), Some(3));
        assert_eq!(policy_category(false, true, false, true), Some(2));
        assert_eq!(POLICY_LEGEND[3].1, PALE_YELLOW);
    }

    /// The compiled table's map reads the table as the firmware does: certified states with
    /// their bit, uncertified ones in the constraint set, nothing outside the grid; and the run
    /// draws it beside the solver's.
    #[test]
    fn the_table_map_is_the_firmwares_reading() {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/two-car.toml"))
                .unwrap()
                .replace("points = 201", "points = 41")
                .replace("name = \"two-car\"", "name = \"two-car-table-map\"");
        let config = Config::from_toml(&text).unwrap();
        let out = std::env::temp_dir().join(format!("hjacc-table-map-{}", std::process::id()));
        run(&config, &out, &mut |_| {}).unwrap();
        let dir = out.join("two-car-table-map");
        let bytes = std::fs::read(dir.join("table.bin")).unwrap();
        let table = table_format::Table::parse(&bytes).unwrap();
        // Closing at 14 m/s from 20 m: no braking saves it.
        assert_eq!(table_category(&table, &[20.0, -14.0], true), Some(2));
        // Closing at 2 m/s from 20 m: certified, and the bit brakes.
        assert_eq!(table_category(&table, &[20.0, -2.0], true), Some(1));
        // Outside the constraint set, and outside the grid.
        assert_eq!(table_category(&table, &[-3.0, 0.0], false), None);
        assert_eq!(table_category(&table, &[100.0, 0.0], true), None);
        let png = std::fs::read(dir.join("table_vs_solver.png")).unwrap();
        // Two maps side by side: the PNG's IHDR width is 1800.
        assert_eq!(
            u32::from_be_bytes([png[16], png[17], png[18], png[19]]),
            1800
        );
        std::fs::remove_dir_all(&out).ok();
    }

    /// A 4-D grid whose safe states sit at known speed nodes: the widest slice is found there,
    /// inside the trusted box, and nowhere when nothing is safe.
    #[test]
    fn the_widest_slice_is_the_one_with_the_most_safe_states() {
        use crate::engine::grid::GridAxis;
        let grid = Grid::new(vec![
            GridAxis::new("gap_leader", 0.0, 40.0, 5),
            GridAxis::new("rel_speed_leader", -10.0, 10.0, 5),
            GridAxis::new("gap_follower", 0.0, 40.0, 5),
            GridAxis::new("rel_speed_follower", -10.0, 10.0, 5),
        ])
        .unwrap();
        let st = grid.strides();
        let mut values = vec![-1.0f32; grid.len()];
        // Speeds (5, -5): 6 safe nodes; speeds (-10, 0): 9, but outside the trusted box below.
        let mut mark = |v1: usize, v3: usize, n: usize| {
            let cells = (1..5).flat_map(|i| (1..5).map(move |j| (i, j)));
            for (i, j) in cells.take(n) {
                values[i * st[0] + v1 * st[1] + j * st[2] + v3 * st[3]] = 1.0;
            }
        };
        mark(3, 1, 6);
        mark(0, 2, 9);
        let widest = widest_slice(&grid, &values, None, 2.0).unwrap();
        assert_eq!(
            (widest.rel_speed_leader, widest.rel_speed_follower),
            (-10.0, 0.0)
        );
        let trusted = [(0.0, 40.0), (-5.0, 10.0), (0.0, 40.0), (-10.0, 10.0)];
        let widest = widest_slice(&grid, &values, Some(&trusted), 2.0).unwrap();
        assert_eq!(
            (widest.rel_speed_leader, widest.rel_speed_follower),
            (5.0, -5.0)
        );
        // Safe nodes below the minimum gap do not count.
        assert!(widest_slice(&grid, &values, None, 100.0).is_none());
        assert!(widest_slice(&grid, &vec![-1.0; grid.len()], None, 2.0).is_none());
    }
}
