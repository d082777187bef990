//! The proof's plots: its verdicts on `(gap, follower speed)` slices, and the measured rear
//! states the firmware's test passes under measurement error. The proof returns data
//! ([`crate::proof`]); this room draws it.

use super::palette::{BLUE, DARK_GREY, GREEN, LIGHT_GREY, ORANGE, PURPLE, SKY_BLUE, VERMILLION};
use crate::error::SolverError;
use crate::proof::robust::Robustness;
use crate::proof::verify::{RearTable, Reason, Report, Verdict};

/// Draws the verdicts on `(gap_follower, follower_speed)` cells over the table's whole extent:
/// one slice per ego speed in `ego_speeds` (the cell holding it), and the worst verdict over
/// every ego speed.
pub fn verdicts(
    table: &RearTable,
    report: &Report,
    dir: &std::path::Path,
    ego_speeds: &[f64],
) -> Result<Vec<std::path::PathBuf>, SolverError> {
    use super::output::{draw_cell_map, CellMap, PlotAxis};
    use plotters::style::RGBColor;
    let [ni, nj, nk] = table.cells();
    let centre =
        |a: &[f64], n: usize| -> Vec<f64> { (0..n).map(|i| 0.5 * (a[i] + a[i + 1])).collect() };
    let gaps = centre(table.axis(0), ni);
    let speeds = centre(table.axis(1), nj);
    // Severity order: not certified, proven, not checked, tangency, resolution, collision.
    let legend: [(&str, RGBColor); 6] = [
        ("not certified", LIGHT_GREY),
        ("proven", GREEN),
        ("not checked (the budget ran out)", DARK_GREY),
        ("unproven: tangency", ORANGE),
        ("unproven: resolution", VERMILLION),
        ("unproven: collision", PURPLE),
    ];
    let severity = |v: &Verdict| match v {
        Verdict::NotCertified => 0,
        Verdict::Proven | Verdict::ProvenAtStandstill => 1,
        Verdict::Unchecked => 2,
        Verdict::Unproven { reason, .. } => match reason {
            Reason::Tangency => 3,
            Reason::Resolution => 4,
            Reason::Collision => 5,
        },
    };
    let at = |i: usize, j: usize, k: usize| severity(&report.verdicts[(i * nj + j) * nk + k]);
    let mut written = Vec::new();
    let x = PlotAxis {
        label: "gap to the follower (m)",
        coords: &gaps,
    };
    let y = PlotAxis {
        label: "follower speed (m/s)",
        coords: &speeds,
    };
    for &ve in ego_speeds {
        let a = table.axis(2);
        let k = a.partition_point(|&b| b <= ve).clamp(1, nk) - 1;
        let title = format!(
            "verify: rear cells at ego speeds {:.2}-{:.2} m/s",
            a[k],
            a[k + 1]
        );
        let path = dir.join(format!("verdicts-ego-{:.0}.png", a[k]));
        let cell = |i: usize, j: usize| Some(at(i, j, k));
        draw_cell_map(
            &path,
            &CellMap {
                title: &title,
                x: PlotAxis { ..x },
                y: PlotAxis { ..y },
                cell: &cell,
                legend: &legend,
                curves: &[],
                frame: None,
            },
        )?;
        written.push(path);
    }
    // Over every ego speed: an unproven cell at any ego speed shows its reason; otherwise the
    // column says whether it is certified (and proven) at every ego speed, at some, or at none
    // (a "worst" map that left the uncertified cells out looked all proven).
    let title = "verify: (gap, follower speed) columns over every ego speed".to_string();
    let path = dir.join("verdicts-worst.png");
    let over_speeds: [(&str, RGBColor); 7] = [
        ("certified at no ego speed", LIGHT_GREY),
        (
            "proven at some ego speeds, not certified at the others",
            SKY_BLUE,
        ),
        ("proven at every ego speed", BLUE),
        legend[2],
        legend[3],
        legend[4],
        legend[5],
    ];
    let cell = |i: usize, j: usize| {
        let worst = (0..nk).map(|k| at(i, j, k)).max().unwrap_or(0);
        if worst >= 2 {
            return Some(worst + 1);
        }
        let proven = (0..nk).filter(|&k| at(i, j, k) == 1).count();
        Some(match proven {
            0 => 0,
            p if p == nk => 2,
            _ => 1,
        })
    };
    draw_cell_map(
        &path,
        &CellMap {
            title: &title,
            x,
            y,
            cell: &cell,
            legend: &over_speeds,
            curves: &[],
            frame: None,
        },
    )?;
    written.push(path);
    Ok(written)
}

/// Draws the measured rear states at the ego speed nearest `ego_speed` on `(gap_follower,
/// follower_speed)` nodes: passing with every error in `runs` (the last is the declared one),
/// passing only with the first (exact sensors), or passing with neither. Writes
/// `robustness-ego-<v>.png`.
pub fn robustness(
    axes: [&[f64]; 3],
    runs: &[&Robustness],
    dir: &std::path::Path,
    ego_speed: f64,
) -> Result<std::path::PathBuf, crate::error::SolverError> {
    use super::output::{draw_cell_map, CellMap, PlotAxis};
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
        ("not certified", LIGHT_GREY),
        ("certified with exact sensors only", ORANGE),
        ("certified with the declared error", BLUE),
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
