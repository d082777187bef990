//! The host tests' plots: an episode's trace and the gap policy, drawn in the solver's palette
//! and font.

use std::path::Path;

use anyhow::Result;
use plotters::prelude::*;
use solver::palette::{BLUE, GREEN, MID_GREY, ORANGE, PURPLE, SKY_BLUE, VERMILLION};

use crate::campaign::{ModeName, Trace};

/// Draws an episode's trace: the gaps, the speeds, and the command with its mode.
pub fn trace(path: &Path, title: &str, trace: &Trace) -> Result<()> {
    solver::output::register_plot_font()?;
    let root = BitMapBackend::new(path, (1000, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((3, 1));
    let t_max = trace.last().map_or(1.0, |p| p.t).max(0.1);
    let g_max = trace
        .iter()
        .map(|p| p.gap_leader.max(p.gap_follower))
        .fold(1.0f32, f32::max)
        * 1.1;
    macro_rules! legend {
        ($chart:expr) => {
            $chart
                .configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE)
                .position(SeriesLabelPosition::UpperRight)
                .draw()?
        };
    }
    let line = |c: RGBColor| {
        move |(x, y): (i32, i32)| PathElement::new(vec![(x, y), (x + 14, y)], c.stroke_width(2))
    };

    let mut chart = ChartBuilder::on(&panels[0])
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0f32..t_max, 0f32..g_max)?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("gap [m]")
        .draw()?;
    for (label, colour, f) in [
        (
            "gap to leader [m]",
            BLUE,
            (|p: &crate::campaign::TracePoint| p.gap_leader) as fn(&_) -> f32,
        ),
        ("gap to follower [m]", VERMILLION, |p| p.gap_follower),
    ] {
        chart
            .draw_series(LineSeries::new(
                trace.iter().map(|p| (p.t, f(p))),
                colour.stroke_width(2),
            ))?
            .label(label)
            .legend(line(colour));
    }
    legend!(chart);

    let v_max = trace
        .iter()
        .map(|p| p.speeds[0].max(p.speeds[1]).max(p.speeds[2]))
        .fold(1.0f32, f32::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&panels[1])
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0f32..t_max, 0f32..v_max)?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("speed [m/s]")
        .draw()?;
    for (k, label, colour) in [
        (0, "leader [m/s]", BLUE),
        (1, "ego [m/s]", BLACK),
        (2, "follower [m/s]", VERMILLION),
    ] {
        chart
            .draw_series(LineSeries::new(
                trace.iter().map(|p| (p.t, p.speeds[k])),
                colour.stroke_width(2),
            ))?
            .label(label)
            .legend(line(colour));
    }
    legend!(chart);

    let m_max = trace
        .iter()
        .map(|p| p.margin)
        .filter(|m| m.is_finite())
        .fold(1.0f32, f32::max)
        .min(10.0);
    let mut chart = ChartBuilder::on(&panels[2])
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f32..t_max, -4.5f32..m_max.max(2.5))?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("command [m/s^2], margin [m]")
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            trace.iter().map(|p| (p.t, p.command)),
            // One pixel: plotters joins wider lines with mitres, which at the command's sharp
            // turns draw spikes beyond the values (a spike to -3.9 under braking at -3.5).
            BLACK.stroke_width(1),
        ))?
        .label("ego command [m/s^2]")
        .legend(line(BLACK));
    chart
        .draw_series(LineSeries::new(
            trace
                .iter()
                .filter(|p| p.margin.is_finite())
                .map(|p| (p.t, p.margin.min(m_max))),
            GREEN.stroke_width(1),
        ))?
        .label("certificate margin [m]")
        .legend(line(GREEN));
    for (mode, colour, label) in [
        (ModeName::Override, PURPLE, "override"),
        (ModeName::MinimumRisk, SKY_BLUE, "minimum-risk manoeuvre"),
        (ModeName::Uncertified, ORANGE, "outside the domain"),
    ] {
        chart
            .draw_series(
                trace
                    .iter()
                    .filter(|p| p.mode == mode)
                    .map(|p| Circle::new((p.t, p.command), 2, colour.filled())),
            )?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 7, y), 3, colour.filled()));
    }
    legend!(chart);
    root.present()?;
    Ok(())
}

/// Draws the gap policy at each time-gap setting (`policies`: the time gap and its gaps by
/// speed) beside the certificate's steady-following gap (`series`: a name and its gaps by
/// speed) to `file`.
pub fn gap_policy(
    file: &Path,
    series: &[(String, Vec<(f32, f32)>)],
    policies: &[(f32, Vec<(f32, f32)>)],
) -> Result<()> {
    solver::output::register_plot_font()?;
    let root = BitMapBackend::new(file, (1000, 650)).into_drawing_area();
    root.fill(&WHITE)?;
    let g_max = policies
        .iter()
        .flat_map(|p| p.1.iter().map(|x| x.1))
        .fold(0.0f32, f32::max)
        * 1.05;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Gap policy (driver's settings) beside the certificate's steady-following gap",
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(0f32..35f32, 0f32..g_max)?;
    chart
        .configure_mesh()
        .x_desc("speed, ego and leader alike [m/s]")
        .y_desc("gap to the leader [m]")
        .draw()?;
    let certified_colours = [MID_GREY, ORANGE, VERMILLION];
    let policy_colours = [SKY_BLUE, GREEN, BLUE, PURPLE];
    for ((name, points), colour) in series.iter().zip(certified_colours) {
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(3),
            ))?
            .label(name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 14, y)], colour.stroke_width(3))
            });
    }
    for ((time_gap, points), colour) in policies.iter().zip(policy_colours) {
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(2),
            ))?
            .label(format!("gap policy, time gap {time_gap} s"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 14, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

/// One panel of [`gap_policy_panels`]: its title, the certified steady gap (with the follower
/// as it is), the comfort band's alone, and the gap policy at each time-gap setting (the time
/// gap and its gaps), each by speed. A gap that is not finite (no braking certified) is left
/// out.
pub struct GapPanel {
    /// The panel's title.
    pub title: String,
    /// The certified steady gap by speed, m.
    pub certified: Vec<(f32, f32)>,
    /// The comfort band's certified steady gap by speed, m.
    pub comfort_only: Vec<(f32, f32)>,
    /// The gap policy at each setting: its time gap, s, and its gaps by speed, m.
    pub policies: Vec<(f32, Vec<(f32, f32)>)>,
    /// The floor under every certificate of the model by speed (true gap), m
    /// ([`crate::floor`]).
    pub floor: Vec<(f32, f32)>,
}

/// Draws `panels` in a grid of `rows` rows to `file`, under `title`, on one gap scale.
pub fn gap_policy_panels(file: &Path, title: &str, rows: usize, panels: &[GapPanel]) -> Result<()> {
    solver::output::register_plot_font()?;
    let columns = panels.len().div_ceil(rows.max(1)).max(1);
    let root = BitMapBackend::new(file, (380 * columns as u32, 360 * rows as u32 + 40))
        .into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let finite = |points: &[(f32, f32)]| -> Vec<(f32, f32)> {
        points.iter().copied().filter(|p| p.1.is_finite()).collect()
    };
    let g_max = panels
        .iter()
        .flat_map(|p| p.policies.iter().flat_map(|q| finite(&q.1)))
        .chain(panels.iter().flat_map(|p| finite(&p.comfort_only)))
        .map(|p| p.1)
        .fold(1.0f32, f32::max)
        * 1.05;
    let policy_colours = [SKY_BLUE, GREEN, BLUE, PURPLE];
    for (area, panel) in root.split_evenly((rows.max(1), columns)).iter().zip(panels) {
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(40)
            .build_cartesian_2d(0f32..35f32, 0f32..g_max)?;
        chart
            .configure_mesh()
            .x_desc("speed [m/s]")
            .y_desc("gap to the leader [m]")
            .draw()?;
        chart
            .draw_series(LineSeries::new(
                finite(&panel.comfort_only),
                MID_GREY.stroke_width(2),
            ))?
            .label("certified, comfort band only")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], MID_GREY.stroke_width(2)));
        chart
            .draw_series(LineSeries::new(
                finite(&panel.certified),
                VERMILLION.stroke_width(3),
            ))?
            .label("certified, two authorities")
            .legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 14, y)], VERMILLION.stroke_width(3))
            });
        chart
            .draw_series(DashedLineSeries::new(
                finite(&panel.floor),
                6,
                4,
                BLACK.stroke_width(2),
            ))?
            .label("floor under every certificate (true gap)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], BLACK.stroke_width(2)));
        for ((time_gap, points), colour) in panel.policies.iter().zip(policy_colours) {
            chart
                .draw_series(LineSeries::new(finite(points), colour.stroke_width(1)))?
                .label(format!("policy at {time_gap} s"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 14, y)], colour.stroke_width(1))
                });
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE)
            .label_font(("sans-serif", 11))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()?;
    }
    root.present()?;
    Ok(())
}
