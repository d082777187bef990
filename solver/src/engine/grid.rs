//! Cartesian grids: axes, C-order indexing, node coordinates, multilinear interpolation.

use crate::error::ConfigError;

/// The largest number of axes the solver handles (a table may have more).
pub const MAX_DIMS: usize = 5;
const _: () = assert!(MAX_DIMS <= table_format::MAX_DIMS);

/// One grid axis: `points` equally spaced nodes from `min` to `max` inclusive.
#[derive(Debug, Clone, PartialEq)]
pub struct GridAxis {
    /// The state variable, e.g. `gap_leader`.
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// First node.
    pub min: f64,
    /// Last node.
    pub max: f64,
    /// Number of nodes (>= 2).
    pub points: usize,
}

impl GridAxis {
    /// An axis named `name` (unit from the name: `m` for gaps, `m/s` otherwise).
    pub fn new(name: &str, min: f64, max: f64, points: usize) -> Self {
        GridAxis {
            name: name.to_string(),
            unit: if name.starts_with("gap") { "m" } else { "m/s" }.to_string(),
            min,
            max,
            points,
        }
    }

    /// Distance between neighbouring nodes.
    pub fn spacing(&self) -> f64 {
        (self.max - self.min) / (self.points - 1) as f64
    }

    /// Coordinate of node `i`.
    pub fn coordinate(&self, i: usize) -> f64 {
        self.min + i as f64 * self.spacing()
    }
}

/// A Cartesian grid stored in C order (last axis fastest).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    axes: Vec<GridAxis>,
    strides: Vec<usize>,
    len: usize,
}

impl Grid {
    /// A grid over `axes`; refuses 0 or more than [`MAX_DIMS`] axes, axes with fewer than 5
    /// points (the WENO5 stencil), and non-increasing bounds.
    pub fn new(axes: Vec<GridAxis>) -> Result<Self, ConfigError> {
        if axes.is_empty() || axes.len() > MAX_DIMS {
            return Err(ConfigError::new("grid", "needs 1 to 5 axes"));
        }
        for a in &axes {
            if !(a.min.is_finite() && a.max.is_finite() && a.min < a.max) {
                return Err(ConfigError::new(
                    format!("grid.{}", a.name),
                    "min and max must be finite with min < max",
                ));
            }
            if a.points < 5 {
                return Err(ConfigError::new(
                    format!("grid.{}.points", a.name),
                    "needs at least 5 points",
                ));
            }
        }
        let mut strides = vec![1; axes.len()];
        for k in (0..axes.len() - 1).rev() {
            strides[k] = strides[k + 1] * axes[k + 1].points;
        }
        let len = strides[0] * axes[0].points;
        Ok(Grid { axes, strides, len })
    }

    /// The axes in state order.
    pub fn axes(&self) -> &[GridAxis] {
        &self.axes
    }

    /// The number of axes.
    pub fn dims(&self) -> usize {
        self.axes.len()
    }

    /// The number of nodes.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the grid has no nodes (never: every axis has at least 5).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// C-order strides.
    pub fn strides(&self) -> &[usize] {
        &self.strides
    }

    /// Points per axis.
    pub fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(|a| a.points).collect()
    }

    /// The multi-index of flat node `node`.
    pub fn multi_index(&self, mut node: usize, out: &mut [usize]) {
        for (k, s) in self.strides.iter().enumerate() {
            out[k] = node / s;
            node %= s;
        }
    }

    /// The coordinates of flat node `node`.
    pub fn node_coordinates(&self, node: usize, out: &mut [f64]) {
        let mut idx = [0usize; MAX_DIMS];
        self.multi_index(node, &mut idx[..self.dims()]);
        for k in 0..self.dims() {
            out[k] = self.axes[k].coordinate(idx[k]);
        }
    }

    /// The volume of one cell.
    pub fn cell_volume(&self) -> f64 {
        self.axes.iter().map(GridAxis::spacing).product()
    }

    /// Multilinear interpolation of `values` (one per node) at `z`, clamped to the grid.
    pub fn interpolate(&self, values: &[f32], z: &[f64]) -> f64 {
        let d = self.dims();
        let mut base = 0usize;
        let mut frac = [0f64; MAX_DIMS];
        for k in 0..d {
            let a = &self.axes[k];
            let s = ((z[k] - a.min) / a.spacing()).clamp(0.0, (a.points - 1) as f64);
            let i = (s.floor() as usize).min(a.points - 2);
            frac[k] = s - i as f64;
            base += i * self.strides[k];
        }
        let mut sum = 0.0;
        for corner in 0..(1usize << d) {
            let mut w = 1.0;
            let mut node = base;
            for k in 0..d {
                if corner >> k & 1 == 1 {
                    w *= frac[k];
                    node += self.strides[k];
                } else {
                    w *= 1.0 - frac[k];
                }
            }
            if w != 0.0 {
                sum += w * f64::from(values[node]);
            }
        }
        sum
    }
}
