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

use super::palette::{BLUE, DARK_GREY, LIGHT_GREY, PURPLE, VERMILLION, YELLOW};

/// The label of the cells outside the trusted box, in every map: no colour there says "safe"
/// or "certified".
const UNTRUSTED: (&str, RGBColor) = (
    "outside the trusted box: no claim (the solver's numbers disagree)",
    DARK_GREY,
);

/// The categories of a safe-set map.
pub(crate) const SET_LEGEND: [(&str, RGBColor); 3] = [
    ("gaps above the minimum (l >= 0), not safe", LIGHT_GREY),
    (
        "safe: V > 0 (a safe input exists against every human input)",
        BLUE,
    ),
    UNTRUSTED,
];

/// The categories of a policy map: the ego's input where the state is safe, grey where not.
const POLICY_LEGEND: [(&str, RGBColor); 5] = [
    ("safe; u2* accelerates (a_max)", VERMILLION),
    ("safe; u2* brakes (a_min)", BLUE),
    ("gaps above the minimum, not safe", LIGHT_GREY),
    ("safe; either input keeps it safe (a tie)", YELLOW),
    UNTRUSTED,
];

/// The categories of the compiled table's map: what the firmware reads at a state. Where the
/// solver has a tie, the stored bit is arbitrary and is drawn as a tie.
const TABLE_LEGEND: [(&str, RGBColor); 5] = [
    ("certified, the bit says accelerate (a_max)", VERMILLION),
    ("certified, the bit says brake (a_min)", BLUE),
    ("gaps above the minimum, not certified", LIGHT_GREY),
    (
        "certified, either input (a tie; the bit is arbitrary)",
        YELLOW,
    ),
    UNTRUSTED,
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
/// table's error bound) with its policy bit, or drawn as a tie where the solver has one (the
/// stored bit is then arbitrary); not certified; the untrusted category outside the trusted
/// box; `None` outside the table's grid or the constraint set.
fn table_category(
    table: &table_format::Table<'_>,
    state: &[f32],
    in_constraint: bool,
    tie: bool,
    trusted: bool,
) -> Option<usize> {
    let lookup = table.lookup(state).ok()?;
    if !in_constraint {
        None
    } else if !trusted {
        Some(4)
    } else if lookup.value > table.header().error_bound.total() {
        Some(match (tie, lookup.action) {
            (true, _) => 3,
            (false, table_format::EgoAction::Accelerate) => 0,
            (false, table_format::EgoAction::Brake) => 1,
        })
    } else {
        Some(2)
    }
}

/// The ego's policy per node (the table's bit, and whether it is a tie: either input), and the
/// table compiled from it, if any.
pub(crate) struct Policy<'a> {
    pub(crate) accelerate: &'a [bool],
    pub(crate) tie: &'a [bool],
    pub(crate) table: Option<&'a [u8]>,
}

/// A safe-set map's category: `None` outside the constraint set; the untrusted category
/// outside the trusted box, whatever the value says.
pub(crate) fn set_category(safe: bool, in_constraint: bool, trusted: bool) -> Option<usize> {
    if !in_constraint {
        None
    } else if !trusted {
        Some(2)
    } else {
        Some(usize::from(safe))
    }
}

/// A policy map's category: the policy where safe (a tie apart), grey in the rest of the
/// constraint set, the untrusted category outside the trusted box.
fn policy_category(
    safe: bool,
    in_constraint: bool,
    accelerate: bool,
    tie: bool,
    trusted: bool,
) -> Option<usize> {
    if !in_constraint {
        None
    } else if !trusted {
        Some(4)
    } else if !safe {
        Some(2)
    } else if tie {
        Some(3)
    } else {
        Some(if accelerate { 0 } else { 1 })
    }
}

/// A 4-D slice's held speeds in words: `rel_speed_leader = v_leader - v_ego` and
/// `rel_speed_follower = v_ego - v_follower`.
pub(crate) fn relative_speeds_text(rel_speed_leader: f64, rel_speed_follower: f64) -> String {
    let say = |who: &str, faster_by: f64| {
        if faster_by.abs() < 0.05 {
            format!("{who} at the ego's speed")
        } else if faster_by > 0.0 {
            format!("{who} {faster_by:.1} m/s faster than the ego")
        } else {
            format!("{who} {:.1} m/s slower than the ego", -faster_by)
        }
    };
    format!(
        "{}, {}",
        say("leader", rel_speed_leader),
        say("follower", -rel_speed_follower)
    )
}

/// Draws the level-set run's maps into `dir` and returns the names of the slices it left out
/// (untrusted ones: nothing there may be drawn as safe), for the run to report.
///
/// `trusted` is the trusted box, `None` when it is empty (every node untrusted).
pub(crate) fn plots(
    config: &Config,
    grid: &Grid,
    solution: &Solution,
    policy_bits: &Policy<'_>,
    trusted: Option<&IndexBox>,
    dir: &Path,
    history: &[(f64, f64)],
) -> Result<Vec<String>, SolverError> {
    let coords: Vec<Vec<f64>> = grid
        .axes()
        .iter()
        .map(|a| (0..a.points).map(|i| a.coordinate(i)).collect())
        .collect();
    // An empty trusted box is an empty range on every axis: nothing is inside it.
    let bounds: Vec<(f64, f64)> = trusted.map_or_else(
        || vec![(f64::INFINITY, f64::NEG_INFINITY); grid.dims()],
        |b| b.bounds(grid),
    );
    let inside = |k: usize, x: f64| (bounds[k].0..=bounds[k].1).contains(&x);
    let values = &solution.values;
    let table = match policy_bits.table.map(table_format::Table::parse) {
        Some(Ok(t)) => Some(t),
        Some(Err(e)) => return Err(SolverError::Table(e)),
        None => None,
    };
    let table_title = |what: &str| {
        table.as_ref().map_or_else(String::new, |t| {
            format!(
                "{what}: the compiled table as the firmware reads it (certified: V > {:.4} m)",
                t.header().error_bound.total()
            )
        })
    };
    let horizon_text = format!("horizon {:.1} s", solution.time);
    let mut left_out = Vec::new();
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
        let frame = trusted.map(|_| (bounds[0].0, bounds[0].1, bounds[1].0, bounds[1].1));
        let axes = (
            PlotAxis {
                label: "gap to the leader [m]",
                coords: &coords[0],
            },
            PlotAxis {
                label: "leader's speed minus the ego's [m/s]",
                coords: &coords[1],
            },
        );
        let trusted_at = |i: usize, j: usize| inside(0, coords[0][i]) && inside(1, coords[1][j]);
        let in_constraint = |i: usize| coords[0][i] - g.min_gap >= 0.0;
        let sets = |i: usize, j: usize| {
            set_category(values[i * n1 + j] > 0.0, in_constraint(i), trusted_at(i, j))
        };
        let curves = [("exact boundary of the safe set", PURPLE, boundary)];
        output::draw_cell_map(
            &dir.join("safe_set.png"),
            &cell_map(
                axes,
                &format!(
                    "{}: where a safe input exists (V > 0), {horizon_text}",
                    config.name
                ),
                &sets,
                &SET_LEGEND,
                &curves,
                frame,
            ),
        )?;
        let policy = |i: usize, j: usize| {
            let node = i * n1 + j;
            policy_category(
                values[node] > 0.0,
                in_constraint(i),
                policy_bits.accelerate[node],
                policy_bits.tie[node],
                trusted_at(i, j),
            )
        };
        let policy_title = format!("{}: the ego's safe input u2*", config.name);
        let policy_map = cell_map(axes, &policy_title, &policy, &POLICY_LEGEND, &curves, frame);
        output::draw_cell_map(&dir.join("policy.png"), &policy_map)?;
        if let Some(t) = &table {
            let firmware = |i: usize, j: usize| {
                table_category(
                    t,
                    &[coords[0][i] as f32, coords[1][j] as f32],
                    in_constraint(i),
                    policy_bits.tie[i * n1 + j],
                    trusted_at(i, j),
                )
            };
            let table_title = table_title(&config.name);
            output::draw_cell_maps(
                &dir.join("table_vs_solver.png"),
                &[
                    policy_map,
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
        // Besides the configured slices, the trusted slice through the set's boundary (the
        // most nodes on its rarer side), so that a reader sees where safe turns unsafe.
        let mut slices: Vec<(crate::pipeline::config::SliceConfig, bool)> =
            configured.into_iter().map(|s| (s, false)).collect();
        if let Some(through) = boundary_slice(grid, values, trusted.map(|_| &bounds[..]), min_gap) {
            if let Some(same) = slices
                .iter_mut()
                .find(|(s, _)| s.tag(five) == through.tag(five))
            {
                same.1 = true;
            } else {
                slices.push((through, true));
            }
        }
        for (s, through_boundary) in &slices {
            let tag = s.tag(five);
            let speeds = s.point(five, 0.0, 0.0);
            // The slice is trusted where its held speeds lie inside the box; an untrusted
            // slice carries no claim at all and is not drawn.
            let held_inside = [1, 3, 4]
                .iter()
                .all(|&k| speeds.get(k).is_none_or(|&x| inside(k, x)));
            if !held_inside {
                left_out.push(tag);
                continue;
            }
            let at = |i: usize, j: usize| -> f64 {
                grid.interpolate(values, &s.point(five, coords[0][i], coords[2][j]))
            };
            let policy_at = |i: usize, j: usize| -> (bool, bool) {
                // The policy of the nearest node in speed.
                let nearest = |k: usize, x: f64| -> usize {
                    let a = &grid.axes()[k];
                    let i = ((x - a.min) / a.spacing()).round();
                    if i.is_finite() && i > 0.0 {
                        (i as usize).min(a.points - 1)
                    } else {
                        0
                    }
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
            let frame = Some((bounds[0].0, bounds[0].1, bounds[2].0, bounds[2].1));
            let axes = (
                PlotAxis {
                    label: "gap to the leader [m]",
                    coords: &coords[0],
                },
                PlotAxis {
                    label: "gap to the follower [m]",
                    coords: &coords[2],
                },
            );
            let trusted_at =
                |i: usize, j: usize| inside(0, coords[0][i]) && inside(2, coords[2][j]);
            let in_constraint =
                |i: usize, j: usize| coords[0][i].min(coords[2][j]) - min_gap >= 0.0;
            let sets = |i: usize, j: usize| {
                set_category(at(i, j) > 0.0, in_constraint(i, j), trusted_at(i, j))
            };
            let safe_nodes = (0..coords[0].len())
                .flat_map(|i| (0..coords[2].len()).map(move |j| (i, j)))
                .filter(|&(i, j)| trusted_at(i, j) && at(i, j) > 0.0)
                .count();
            let speeds_text = if five {
                format!(
                    "leader {:.1}, follower {:.1}, ego {:.1} m/s",
                    speeds[1], speeds[3], speeds[4]
                )
            } else {
                relative_speeds_text(speeds[1], speeds[3])
            };
            let kind = match config.game.kind {
                GameKindConfig::ThreeCarBaseline => "any bounded follower",
                _ => "IDM follower",
            };
            let note = match (safe_nodes, through_boundary) {
                (0, _) => ": EMPTY, no safe state on this slice",
                (_, true) => " (the slice through the set's boundary)",
                _ => "",
            };
            output::draw_cell_map(
                &dir.join(format!("safe_set_{tag}.png")),
                &cell_map(
                    axes,
                    &format!(
                        "{} ({kind}), {horizon_text}: V > 0 with {speeds_text}{note}",
                        config.name
                    ),
                    &sets,
                    &SET_LEGEND,
                    &[],
                    frame,
                ),
            )?;
            // An empty slice's policy and table maps would be uniform grey: the safe-set map
            // says it is empty, once.
            if safe_nodes == 0 {
                continue;
            }
            let policy = |i: usize, j: usize| {
                let (accelerate, tie) = policy_at(i, j);
                policy_category(
                    at(i, j) > 0.0,
                    in_constraint(i, j),
                    accelerate,
                    tie,
                    trusted_at(i, j),
                )
            };
            let policy_title = format!("{}: the ego's safe input u2*, {speeds_text}", config.name);
            let policy_map = cell_map(axes, &policy_title, &policy, &POLICY_LEGEND, &[], frame);
            output::draw_cell_map(&dir.join(format!("policy_{tag}.png")), &policy_map)?;
            if let Some(t) = &table {
                let firmware = |i: usize, j: usize| {
                    let state: Vec<f32> = s
                        .point(five, coords[0][i], coords[2][j])
                        .iter()
                        .map(|&x| x as f32)
                        .collect();
                    table_category(
                        t,
                        &state,
                        in_constraint(i, j),
                        policy_at(i, j).1,
                        trusted_at(i, j),
                    )
                };
                let title = table_title(&config.name);
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
            "Share of all grid nodes with V > 0 against the horizon (trusted or not)",
            "horizon [s]",
            "share of nodes",
            &[("V > 0", BLUE, history.to_vec())],
        )?;
    }
    Ok(left_out)
}

/// The slice of a 4-D or 5-D grid, at node speeds inside the trusted box, through the safe
/// set's boundary: the one whose trusted gap nodes in the constraint set are split most evenly
/// between safe and not safe (the most nodes on the rarer side). `None` when no slice has
/// both. Speeds are the nodes' own (axes 1 and 3, and 4 on a 5-D grid), so the count is exact.
pub(crate) fn boundary_slice(
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
            let rarer = safe.min(gap_nodes.len() - safe);
            if rarer > 0 && best.as_ref().is_none_or(|(n, _)| rarer > *n) {
                best = Some((rarer, index.clone()));
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

    /// Nothing is drawn as safe or certified outside the trusted box, and the
    /// policy is shown only where the state is safe.
    #[test]
    fn untrusted_cells_take_one_category_and_policy_shows_only_where_safe() {
        assert_eq!(set_category(true, true, true), Some(1));
        assert_eq!(set_category(false, true, true), Some(0));
        assert_eq!(set_category(true, true, false), Some(2));
        assert_eq!(set_category(false, true, false), Some(2));
        assert_eq!(set_category(false, false, true), None);
        assert_eq!(SET_LEGEND[2], UNTRUSTED);
        assert_eq!(policy_category(true, true, true, false, true), Some(0));
        assert_eq!(policy_category(true, true, false, false, true), Some(1));
        assert_eq!(policy_category(false, true, true, false, true), Some(2));
        assert_eq!(policy_category(false, false, false, false, true), None);
        // A tie is shown as such where safe, whatever the bit says.
        assert_eq!(policy_category(true, true, false, true, true), Some(3));
        assert_eq!(policy_category(false, true, false, true, true), Some(2));
        for (safe, accelerate, tie) in [
            (true, true, false),
            (true, false, true),
            (false, true, true),
        ] {
            assert_eq!(policy_category(safe, true, accelerate, tie, false), Some(4));
        }
        assert_eq!(POLICY_LEGEND[4], UNTRUSTED);
        assert_eq!(TABLE_LEGEND[4], UNTRUSTED);
        // No legend entry outside the untrusted one is drawn in its colour, and no label of
        // the untrusted category says safe or certified.
        for legend in [&SET_LEGEND[..], &POLICY_LEGEND[..], &TABLE_LEGEND[..]] {
            let untrusted: Vec<_> = legend.iter().filter(|(_, c)| *c == DARK_GREY).collect();
            assert_eq!(untrusted.len(), 1);
        }
        assert!(!UNTRUSTED.0.contains("safe") && !UNTRUSTED.0.contains("certified"));
    }

    #[test]
    fn held_speeds_are_said_in_words() {
        assert_eq!(
            relative_speeds_text(-3.0, 0.0),
            "leader 3.0 m/s slower than the ego, follower at the ego's speed"
        );
        // rel_speed_follower = v_ego - v_follower: positive is a slower follower.
        assert_eq!(
            relative_speeds_text(4.0, -1.0),
            "leader 4.0 m/s faster than the ego, follower 1.0 m/s faster than the ego"
        );
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
        assert_eq!(
            table_category(&table, &[20.0, -14.0], true, false, true),
            Some(2)
        );
        // Closing at 2 m/s from 20 m: certified, and the bit brakes.
        assert_eq!(
            table_category(&table, &[20.0, -2.0], true, false, true),
            Some(1)
        );
        // Where the solver has a tie, the stored bit is not shown as a decision.
        assert_eq!(
            table_category(&table, &[20.0, 5.0], true, true, true),
            Some(3)
        );
        // Untrusted: no claim, whatever the table says.
        assert_eq!(
            table_category(&table, &[20.0, -2.0], true, false, false),
            Some(4)
        );
        // Outside the constraint set, and outside the grid.
        assert_eq!(
            table_category(&table, &[-3.0, 0.0], false, false, true),
            None
        );
        assert_eq!(
            table_category(&table, &[100.0, 0.0], true, false, true),
            None
        );
        let png = std::fs::read(dir.join("table_vs_solver.png")).unwrap();
        // Two maps side by side: the PNG's IHDR width is 1800.
        assert_eq!(
            u32::from_be_bytes([png[16], png[17], png[18], png[19]]),
            1800
        );
        std::fs::remove_dir_all(&out).ok();
    }

    /// A 4-D grid whose safe states sit at known speed nodes: the slice through the boundary is
    /// the one split most evenly (not the one with the most safe states, which may be all
    /// safe), inside the trusted box, and none when no slice has both kinds.
    #[test]
    fn the_boundary_slice_is_the_one_split_most_evenly() {
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
        // 16 gap nodes at or above a 2 m minimum gap (gaps 10..40 on both axes).
        let mut mark = |v1: usize, v3: usize, n: usize| {
            let cells = (1..5).flat_map(|i| (1..5).map(move |j| (i, j)));
            for (i, j) in cells.take(n) {
                values[i * st[0] + v1 * st[1] + j * st[2] + v3 * st[3]] = 1.0;
            }
        };
        mark(3, 1, 6); // 6 safe, 10 not: 6 on the rarer side
        mark(0, 2, 9); // 9 safe, 7 not: 7, but outside the trusted box below
        mark(4, 4, 16); // all safe: nothing on the rarer side
        let through = boundary_slice(&grid, &values, None, 2.0).unwrap();
        assert_eq!(
            (through.rel_speed_leader, through.rel_speed_follower),
            (-10.0, 0.0)
        );
        let trusted = [(0.0, 40.0), (-5.0, 10.0), (0.0, 40.0), (-10.0, 10.0)];
        let through = boundary_slice(&grid, &values, Some(&trusted), 2.0).unwrap();
        assert_eq!(
            (through.rel_speed_leader, through.rel_speed_follower),
            (5.0, -5.0)
        );
        // Safe nodes below the minimum gap do not count.
        assert!(boundary_slice(&grid, &values, None, 100.0).is_none());
        assert!(boundary_slice(&grid, &vec![-1.0; grid.len()], None, 2.0).is_none());
        assert!(boundary_slice(&grid, &vec![1.0; grid.len()], None, 2.0).is_none());
    }
}
