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

/// Draws a [`CellMap`] into a PNG.
pub fn draw_cell_map(path: &Path, map: &CellMap<'_>) -> Result<(), SolverError> {
    draw_cell_maps(path, std::slice::from_ref(map))
}

/// Draws [`CellMap`]s side by side into one PNG, each 900 x 760 pixels.
pub fn draw_cell_maps(path: &Path, maps: &[CellMap<'_>]) -> Result<(), SolverError> {
    register_plot_font()?;
    let width = 900 * u32::try_from(maps.len().max(1)).unwrap_or(1);
    let root = BitMapBackend::new(path, (width, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    for (area, map) in root.split_evenly((1, maps.len().max(1))).iter().zip(maps) {
        draw_cell_map_on(area, path, map)?;
    }
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

fn draw_cell_map_on(
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    path: &Path,
    map: &CellMap<'_>,
) -> Result<(), SolverError> {
    let (x0, x1) = (map.x.coords[0], *map.x.coords.last().unwrap_or(&1.0));
    let (y0, y1) = (map.y.coords[0], *map.y.coords.last().unwrap_or(&1.0));
    let mut chart = ChartBuilder::on(root)
        .caption(map.title, ("sans-serif", 18))
        .margin(12)
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
    for (label, color) in map.legend {
        let color = *color;
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(|e| plot_err(path, e))?
            .label(*label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], color.filled()));
    }
    for (label, color, points) in map.curves {
        let color = *color;
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                color.stroke_width(3),
            ))
            .map_err(|e| plot_err(path, e))?
            .label(*label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 14, y)], color.stroke_width(3))
            });
    }
    if let Some((a, b, c, d)) = map.frame {
        let outline = vec![(a, c), (b, c), (b, d), (a, d), (a, c)];
        chart
            .draw_series(DashedLineSeries::new(outline, 8, 5, BLACK.stroke_width(2)))
            .map_err(|e| plot_err(path, e))?
            .label("trusted box")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], BLACK.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| plot_err(path, e))?;
    Ok(())
}

/// Draws `y(x)` curves (e.g. safe fraction against horizon).
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
    let xs = curves.iter().flat_map(|c| c.2.iter().map(|p| p.0));
    let ys = curves.iter().flat_map(|c| c.2.iter().map(|p| p.1));
    let x1 = xs.fold(1e-9f64, f64::max);
    let y1 = ys.fold(1e-9f64, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..x1, 0.0..y1)
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for (label, color, points) in curves {
        let color = *color;
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                color.stroke_width(3),
            ))
            .map_err(|e| plot_err(path, e))?
            .label(*label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 14, y)], color.stroke_width(3))
            });
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| plot_err(path, e))?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}
