//! Output files: the value function as `.npy`, the table, and PNG plots.

use std::path::Path;

use npyz::WriterBuilder;
use plotters::prelude::*;

use crate::error::SolverError;

fn io_err(path: &Path, source: std::io::Error) -> SolverError {
    SolverError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// The plots' font, DejaVu Sans, shipped with the build (`assets/fonts`): no system font and
/// no fontconfig are needed.
pub static PLOT_FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Registers [`PLOT_FONT`] as plotters' `sans-serif` (once; every plot calls it first).
pub fn register_plot_font() -> Result<(), SolverError> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, PLOT_FONT)
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(SolverError::Plot {
            path: "assets/fonts/DejaVuSans.ttf".into(),
            message: "the bundled font does not parse".into(),
        })
    }
}

/// One axis of `value.npy`, as `axes.json` records it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AxisCoordinates {
    /// The state variable.
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// The coordinate of every node along the axis, in index order.
    pub coordinates: Vec<f64>,
}

/// Writes `axes.json` beside `value.npy`: the array's axes in order, with their coordinates,
/// so that `value[i, j, ...]` is the value at `(axes[0].coordinates[i], axes[1].coordinates[j],
/// ...)` without rebuilding the grid from `summary.json`.
pub fn write_axes(path: &Path, axes: &[AxisCoordinates]) -> Result<(), SolverError> {
    write_json(
        path,
        &serde_json::json!({ "order": "C (the last axis varies fastest)", "axes": axes }),
    )
}

/// Writes `values` as a little-endian f32 `.npy` array of `shape` (C order).
pub fn write_npy(path: &Path, values: &[f32], shape: &[usize]) -> Result<(), SolverError> {
    let shape: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    let file = std::fs::File::create(path).map_err(|e| io_err(path, e))?;
    let mut writer = npyz::WriteOptions::<f32>::new()
        .default_dtype()
        .shape(&shape)
        .writer(std::io::BufWriter::new(file))
        .begin_nd()
        .map_err(|e| io_err(path, e))?;
    writer
        .extend(values.iter().copied())
        .map_err(|e| io_err(path, e))?;
    writer.finish().map_err(|e| io_err(path, e))?;
    Ok(())
}

/// Writes bytes to a file.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), SolverError> {
    std::fs::write(path, bytes).map_err(|e| io_err(path, e))
}

/// Writes `value` as pretty-printed JSON.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<(), SolverError> {
    let json = serde_json::to_string_pretty(value).map_err(|e| io_err(path, e.into()))?;
    write_bytes(path, json.as_bytes())
}

/// A curve to draw: legend label, colour, points.
pub type Curve<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

/// A named axis of a plot: label and node coordinates.
#[derive(Debug, Clone, Copy)]
pub struct PlotAxis<'a> {
    /// Label with unit.
    pub label: &'a str,
    /// Node coordinates, increasing.
    pub coords: &'a [f64],
}

/// A categorical map over a 2-D grid of cells, with a legend and optional curves.
pub struct CellMap<'a> {
    /// Plot title.
    pub title: &'a str,
    /// Horizontal axis.
    pub x: PlotAxis<'a>,
    /// Vertical axis.
    pub y: PlotAxis<'a>,
    /// Colour index of cell `(i, j)` (`i` along x), into `legend`; `None` leaves it white.
    pub cell: &'a dyn Fn(usize, usize) -> Option<usize>,
    /// Label and colour of each category.
    pub legend: &'a [(&'a str, RGBColor)],
    /// Curves drawn on top: label, colour, points.
    pub curves: &'a [Curve<'a>],
    /// An optional dashed rectangle (the trusted box): `(x0, x1, y0, y1)`.
    pub frame: Option<(f64, f64, f64, f64)>,
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> SolverError {
    SolverError::Plot {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// The size of a plot's title, px, unless a word alone is wider than the image.
pub const TITLE_SIZE: f64 = 18.0;

/// The size of a legend's labels, px.
const LEGEND_SIZE: f64 = 14.0;

/// One line of a legend, px.
const LEGEND_LINE: u32 = 22;

/// The margin around a panel, px.
const MARGIN: u32 = 12;

/// `title` laid out in `width` pixels: the words wrapped greedily into lines that each fit,
/// at `size` px, or smaller (down to 10 px) where a single word is wider than the width.
/// `measure(text, size)` is a text's width in pixels. Every line returned fits (the test
/// `titles_fit_their_images` checks the main job's titles with the plots' own font).
pub fn title_lines(
    title: &str,
    width: u32,
    size: f64,
    measure: &dyn Fn(&str, f64) -> u32,
) -> (Vec<String>, f64) {
    let mut size = size;
    loop {
        let mut lines: Vec<String> = Vec::new();
        let mut fits = true;
        for word in title.split_whitespace() {
            let joined = match lines.last() {
                Some(last) => format!("{last} {word}"),
                None => word.to_string(),
            };
            if lines.is_empty() || measure(&joined, size) <= width {
                match lines.last_mut() {
                    Some(last) => *last = joined,
                    None => lines.push(joined),
                }
            } else {
                lines.push(word.to_string());
            }
            fits &= lines.last().is_some_and(|l| measure(l, size) <= width);
        }
        if fits || size <= 10.0 {
            return (lines, size);
        }
        size -= 1.0;
    }
}

/// The width of `text` at `size` px in the plots' font, px (`u32::MAX` if it cannot be
/// measured).
fn text_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    text: &str,
    size: f64,
) -> u32 {
    area.estimate_text_size(text, &TextStyle::from(("sans-serif", size).into_font()))
        .map_or(u32::MAX, |s| s.0)
}

type Area<'b> = DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>;

/// Draws `title` across the top of `area`, wrapped to its width, and returns the area below it.
fn titled<'b>(area: &Area<'b>, path: &Path, title: &str) -> Result<Area<'b>, SolverError> {
    let width = area.dim_in_pixel().0.saturating_sub(2 * MARGIN);
    let (lines, size) = title_lines(title, width, TITLE_SIZE, &|t, s| text_width(area, t, s));
    let line_height = (size * 1.35).ceil() as u32;
    let centre = i32::try_from(area.dim_in_pixel().0 / 2).unwrap_or(0);
    let style = TextStyle::from(("sans-serif", size).into_font()).pos(
        plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Top,
        ),
    );
    for (k, line) in lines.iter().enumerate() {
        let y = i32::try_from(MARGIN + line_height * k as u32).unwrap_or(0);
        area.draw_text(line, &style, (centre, y))
            .map_err(|e| plot_err(path, e))?;
    }
    let used = MARGIN + line_height * lines.len() as u32 + 4;
    Ok(area.split_vertically(used).1)
}

/// A legend entry's mark.
#[derive(Clone, Copy)]
enum Mark {
    Fill(RGBColor),
    Line(RGBColor),
    Dashed,
}

/// Splits `area` into the chart above and a legend below it, in two columns, so that no
/// legend covers data; draws the legend and returns the chart's area.
fn with_legend_below<'b>(
    area: &Area<'b>,
    path: &Path,
    entries: &[(&str, Mark)],
) -> Result<Area<'b>, SolverError> {
    if entries.is_empty() {
        return Ok(area.clone());
    }
    let rows = u32::try_from(entries.len().div_ceil(2)).unwrap_or(1);
    let height = area.dim_in_pixel().1;
    let legend_height = rows * LEGEND_LINE + MARGIN;
    let (chart, legend) = area.split_vertically(height.saturating_sub(legend_height));
    let column = i32::try_from(legend.dim_in_pixel().0 / 2).unwrap_or(0);
    let font = ("sans-serif", LEGEND_SIZE).into_font();
    for (k, (label, mark)) in entries.iter().enumerate() {
        let x = i32::try_from(MARGIN).unwrap_or(0) + column * i32::from(k % 2 == 1);
        let y = i32::try_from((k / 2) as u32 * LEGEND_LINE + 4).unwrap_or(0);
        let centre = y + 8;
        match *mark {
            Mark::Fill(c) => {
                legend.draw(&Rectangle::new([(x, y + 1), (x + 16, y + 15)], c.filled()))
            }
            Mark::Line(c) => legend.draw(&PathElement::new(
                vec![(x, centre), (x + 16, centre)],
                c.stroke_width(3),
            )),
            Mark::Dashed => legend
                .draw(&PathElement::new(
                    vec![(x, centre), (x + 6, centre)],
                    BLACK.stroke_width(2),
                ))
                .and_then(|()| {
                    legend.draw(&PathElement::new(
                        vec![(x + 10, centre), (x + 16, centre)],
                        BLACK.stroke_width(2),
                    ))
                }),
        }
        .map_err(|e| plot_err(path, e))?;
        legend
            .draw_text(label, &TextStyle::from(font.clone()), (x + 22, y))
            .map_err(|e| plot_err(path, e))?;
    }
    Ok(chart)
}

/// Draws a [`CellMap`] into a PNG.
pub fn draw_cell_map(path: &Path, map: &CellMap<'_>) -> Result<(), SolverError> {
    draw_cell_maps(path, std::slice::from_ref(map))
}

/// Draws [`CellMap`]s side by side into one PNG, each 900 x 760 pixels.
pub fn draw_cell_maps(path: &Path, maps: &[CellMap<'_>]) -> Result<(), SolverError> {
    draw_figure(path, None, maps, None)
}

/// A panel of curves: title, axis labels, curves.
pub struct CurvePanel<'a> {
    /// Panel title.
    pub title: &'a str,
    /// Horizontal axis label.
    pub x_label: &'a str,
    /// Vertical axis label.
    pub y_label: &'a str,
    /// The curves.
    pub curves: &'a [Curve<'a>],
}

/// Draws a figure: an optional title across it, then [`CellMap`]s and an optional
/// [`CurvePanel`] side by side, each 900 x 760 pixels.
pub fn draw_figure(
    path: &Path,
    title: Option<&str>,
    maps: &[CellMap<'_>],
    curves: Option<&CurvePanel<'_>>,
) -> Result<(), SolverError> {
    register_plot_font()?;
    let panels = maps.len() + usize::from(curves.is_some());
    let width = 900 * u32::try_from(panels.max(1)).unwrap_or(1);
    let root = BitMapBackend::new(path, (width, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let body = match title {
        Some(t) => titled(&root, path, t)?,
        None => root.clone(),
    };
    let areas = body.split_evenly((1, panels.max(1)));
    for (area, map) in areas.iter().zip(maps) {
        draw_cell_map_on(area, path, map)?;
    }
    if let (Some(panel), Some(area)) = (curves, areas.get(maps.len())) {
        draw_curves_on(area, path, panel)?;
    }
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

fn draw_cell_map_on(root: &Area<'_>, path: &Path, map: &CellMap<'_>) -> Result<(), SolverError> {
    let (x0, x1) = (map.x.coords[0], *map.x.coords.last().unwrap_or(&1.0));
    let (y0, y1) = (map.y.coords[0], *map.y.coords.last().unwrap_or(&1.0));
    let below_title = titled(root, path, map.title)?;
    let mut entries: Vec<(&str, Mark)> = map
        .legend
        .iter()
        .map(|(l, c)| (*l, Mark::Fill(*c)))
        .collect();
    entries.extend(map.curves.iter().map(|(l, c, _)| (*l, Mark::Line(*c))));
    if map.frame.is_some() {
        entries.push(("trusted box", Mark::Dashed));
    }
    let area = with_legend_below(&below_title, path, &entries)?;
    let mut chart = ChartBuilder::on(&area)
        .margin(MARGIN)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(map.x.label)
        .y_desc(map.y.label)
        .disable_mesh()
        .draw()
        .map_err(|e| plot_err(path, e))?;
    let half = |c: &[f64], i: usize| -> (f64, f64) {
        let lo = if i == 0 {
            c[0]
        } else {
            0.5 * (c[i - 1] + c[i])
        };
        let hi = if i + 1 == c.len() {
            c[i]
        } else {
            0.5 * (c[i] + c[i + 1])
        };
        (lo, hi)
    };
    let mut cells = Vec::new();
    for i in 0..map.x.coords.len() {
        for j in 0..map.y.coords.len() {
            if let Some(c) = (map.cell)(i, j) {
                let (xa, xb) = half(map.x.coords, i);
                let (ya, yb) = half(map.y.coords, j);
                cells.push(Rectangle::new(
                    [(xa, ya), (xb, yb)],
                    map.legend[c].1.filled(),
                ));
            }
        }
    }
    chart.draw_series(cells).map_err(|e| plot_err(path, e))?;
    for (_, color, points) in map.curves {
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                color.stroke_width(3),
            ))
            .map_err(|e| plot_err(path, e))?;
    }
    if let Some((a, b, c, d)) = map.frame {
        let outline = vec![(a, c), (b, c), (b, d), (a, d), (a, c)];
        chart
            .draw_series(DashedLineSeries::new(outline, 8, 5, BLACK.stroke_width(2)))
            .map_err(|e| plot_err(path, e))?;
    }
    Ok(())
}

/// Draws `y(x)` curves (e.g. safe fraction against horizon) into a 900 x 600 PNG.
pub fn draw_curves(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    curves: &[Curve<'_>],
) -> Result<(), SolverError> {
    register_plot_font()?;
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    draw_curves_on(
        &root,
        path,
        &CurvePanel {
            title,
            x_label,
            y_label,
            curves,
        },
    )?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

fn draw_curves_on(root: &Area<'_>, path: &Path, panel: &CurvePanel<'_>) -> Result<(), SolverError> {
    let curves = panel.curves;
    let xs = curves.iter().flat_map(|c| c.2.iter().map(|p| p.0));
    let ys = curves.iter().flat_map(|c| c.2.iter().map(|p| p.1));
    let x1 = xs.fold(1e-9f64, f64::max);
    let y1 = ys.fold(1e-9f64, f64::max) * 1.1;
    let below_title = titled(root, path, panel.title)?;
    let entries: Vec<(&str, Mark)> = curves
        .iter()
        .map(|(l, c, _)| (*l, Mark::Line(*c)))
        .collect();
    let area = with_legend_below(&below_title, path, &entries)?;
    let mut chart = ChartBuilder::on(&area)
        .margin(MARGIN)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..x1, 0.0..y1)
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(panel.x_label)
        .y_desc(panel.y_label)
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for (_, color, points) in curves {
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                color.stroke_width(3),
            ))
            .map_err(|e| plot_err(path, e))?;
    }
    Ok(())
}

#[cfg(test)]
mod title_tests {
    use super::*;

    /// The titles the main job writes at their longest (the slice maps' of the 5-D and 4-D
    /// games, the table maps', the verdicts', the paper's figure), laid out in one 900-pixel
    /// panel with the plots' own font: every line fits, and a long title wraps rather than
    /// running off the image.
    #[test]
    fn titles_fit_their_images() {
        register_plot_font().expect("the font");
        let mut buffer = vec![0u8; 900 * 100 * 3];
        let area = BitMapBackend::with_buffer(&mut buffer, (900, 100)).into_drawing_area();
        let width = 900 - 2 * MARGIN;
        let measure = |t: &str, s: f64| text_width(&area, t, s);
        let titles = [
            "three-car-idm-adversarial-speed (IDM follower), horizon 40.0 s: V > 0 with leader \
             12.0 m/s faster than the ego, follower 11.0 m/s slower than the ego (the slice \
             through the set's boundary)",
            "three-car-idm-speeds (IDM follower), horizon 30.0 s: V > 0 with leader 20.0, \
             follower 20.0, ego 20.0 m/s: EMPTY, no safe state on this slice",
            "three-car-idm-4d-table: the compiled table as the firmware reads it (certified: V > \
             2.0123 m)",
            "measured rear states at ego speed 20.0 m/s (whole table: 77.2% certified exact, 75.0% \
             with the error)",
            "Invariant safe states of the three-car game, leader 2.0 m/s faster than the ego, \
             follower 1.0 m/s faster than the ego (Fig. 3 of Bahati, Gibson & Bayen)",
        ];
        let mut wrapped = 0;
        for title in titles {
            let (lines, size) = title_lines(title, width, TITLE_SIZE, &measure);
            assert_eq!(size, TITLE_SIZE, "{title}");
            assert_eq!(
                lines.join(" "),
                title.split_whitespace().collect::<Vec<_>>().join(" ")
            );
            for line in &lines {
                let w = measure(line, size);
                assert!(w <= width, "{w} px > {width} px: {line}");
            }
            wrapped += usize::from(lines.len() > 1);
        }
        assert!(wrapped >= 2, "the long titles wrap");
        // One word wider than the image: the size comes down until it fits.
        let word = "x".repeat(120);
        let (lines, size) = title_lines(&word, width, TITLE_SIZE, &measure);
        assert!(
            size < TITLE_SIZE && measure(&lines[0], size) <= width,
            "{size}"
        );
    }
}
