//! The rear table as `verify` reads it, and the exact least and largest value of its
//! interpolant over a box.

use table_format::Table;

use super::interval::{Interval, StateBox};
use super::model::RearModel;
use crate::error::SolverError;

/// The rear table as `verify` reads it: breakpoints and dequantized node values in `f64`.
#[derive(Debug, Clone)]
pub struct RearTable {
    axes: [Vec<f64>; 3],
    values: Vec<f64>,
    /// The value of a follower beyond the grid's last gap (the last face's least value).
    pub beyond_grid: f64,
    /// The header's error bound, m.
    pub error_bound: f64,
    /// The model.
    pub model: RearModel,
}

impl RearTable {
    /// Reads a split table; refuses any other game.
    pub fn from_table(table: &Table<'_>) -> Result<Self, SolverError> {
        let header = table.header();
        let model = RearModel::from_game(&header.game, header.min_gap).ok_or_else(|| {
            SolverError::Verify("the table is not a ThreeCarSplit (rear) table".into())
        })?;
        let mut axes: [Vec<f64>; 3] = Default::default();
        for (k, axis) in axes.iter_mut().enumerate() {
            let n = header.axes[k].points as usize;
            *axis = (0..n)
                .map(|i| table.breakpoint(k, i).map(f64::from))
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| SolverError::Verify(format!("axis {k}: missing breakpoints")))?;
        }
        let values = (0..table.node_count())
            .map(|n| table.value_at_node(n).map(f64::from))
            .collect::<Option<Vec<f64>>>()
            .ok_or_else(|| SolverError::Verify("missing node values".into()))?;
        RearTable::new(model, axes, values, f64::from(header.error_bound.total()))
            .ok_or_else(|| SolverError::Verify("the grid and the values disagree".into()))
    }

    /// A table from breakpoints and node values in C order (last axis fastest): hand-made
    /// tables for tests. `None` if the sizes disagree or an axis has fewer than two points.
    pub fn new(
        model: RearModel,
        axes: [Vec<f64>; 3],
        values: Vec<f64>,
        error_bound: f64,
    ) -> Option<Self> {
        let ok = axes
            .iter()
            .all(|a| a.len() >= 2 && a.windows(2).all(|w| w[0] < w[1]))
            && values.len() == axes.iter().map(Vec::len).product::<usize>();
        if !ok {
            return None;
        }
        let face = axes[1].len() * axes[2].len();
        let beyond_grid = values[values.len() - face..]
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        Some(RearTable {
            axes,
            values,
            beyond_grid,
            error_bound,
            model,
        })
    }

    /// The breakpoints of axis `k`.
    pub fn axis(&self, k: usize) -> &[f64] {
        &self.axes[k]
    }

    /// The node value at indices `(i, j, k)`.
    pub fn node(&self, i: usize, j: usize, k: usize) -> f64 {
        self.values[(i * self.axes[1].len() + j) * self.axes[2].len() + k]
    }

    /// Overwrites one node value (tests mutate tables this way).
    pub fn set_node(&mut self, i: usize, j: usize, k: usize, value: f64) {
        let n = (i * self.axes[1].len() + j) * self.axes[2].len() + k;
        self.values[n] = value;
    }

    /// `W` at a state inside the grid's speed range, as the firmware reads it: interpolated
    /// inside the grid, `beyond_grid` past its last gap, `-inf` below its first gap.
    pub fn value_at(&self, x: [f64; 3]) -> f64 {
        let gaps = &self.axes[0];
        if x[0] < gaps[0] {
            return f64::NEG_INFINITY;
        }
        if x[0] > gaps[gaps.len() - 1] {
            return self.beyond_grid;
        }
        let mut base = [0usize; 3];
        let mut frac = [0f64; 3];
        for k in 0..3 {
            let a = &self.axes[k];
            let v = x[k].clamp(a[0], a[a.len() - 1]);
            let i = a.partition_point(|&b| b <= v).clamp(1, a.len() - 1) - 1;
            base[k] = i;
            frac[k] = ((v - a[i]) / (a[i + 1] - a[i])).clamp(0.0, 1.0);
        }
        let mut w = 0.0;
        for corner in 0..8 {
            let mut weight = 1.0;
            let mut idx = [0usize; 3];
            for k in 0..3 {
                let up = (corner >> k) & 1 == 1;
                weight *= if up { frac[k] } else { 1.0 - frac[k] };
                idx[k] = base[k] + usize::from(up);
            }
            if weight != 0.0 {
                w += weight * self.node(idx[0], idx[1], idx[2]);
            }
        }
        w
    }

    /// The least and largest `W` over a box (exact, module docs).
    ///
    /// On each piece between breakpoints `W` is multilinear, so its extremes over the box are
    /// among the points whose coordinates are, per axis, the box's ends or a breakpoint inside
    /// it. Each candidate is located once per axis ([`AxisCandidates`]) and the interpolant is
    /// evaluated on their tensor product, with no search per point. Speeds outside an axis are
    /// clamped to it, a gap past the last breakpoint reads [`RearTable::beyond_grid`] and one
    /// below the first reads `-inf`, as in [`RearTable::value_at`].
    pub fn extremes(&self, b: &StateBox) -> Interval {
        let mut out = Interval::new(f64::INFINITY, f64::NEG_INFINITY);
        let Some([c0, c1, c2]) = self.inside(b, &mut out) else {
            return out;
        };
        let [n1, n2] = [self.axes[1].len(), self.axes[2].len()];
        let v = &self.values;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        for m0 in 0..c0.len() {
            let (i, t) = c0.get(m0);
            for m1 in 0..c1.len() {
                let (j, s) = c1.get(m1);
                let rows = [
                    (i * n1 + j) * n2,
                    (i * n1 + j + 1) * n2,
                    ((i + 1) * n1 + j) * n2,
                    ((i + 1) * n1 + j + 1) * n2,
                ];
                for m2 in 0..c2.len() {
                    let (k, r) = c2.get(m2);
                    let row = |o: usize| lerp(v[o + k], v[o + k + 1], r);
                    let w = lerp(
                        lerp(row(rows[0]), row(rows[1]), s),
                        lerp(row(rows[2]), row(rows[3]), s),
                        t,
                    );
                    out.lo = out.lo.min(w);
                    out.hi = out.hi.max(w);
                }
            }
        }
        out
    }

    /// Bounds of `W` over a box from the node values alone: the least and largest node of every
    /// cell the box touches (a multilinear interpolant is a convex combination of its cell's
    /// corners). Cheaper than [`RearTable::extremes`] by the interpolation, and as sound:
    /// `lo <= extremes.lo` and `hi >= extremes.hi`, equal on a box that is one cell.
    pub fn node_bounds(&self, b: &StateBox) -> Interval {
        let mut out = Interval::new(f64::INFINITY, f64::NEG_INFINITY);
        let Some([c0, c1, c2]) = self.inside(b, &mut out) else {
            return out;
        };
        let [n1, n2] = [self.axes[1].len(), self.axes[2].len()];
        let (k0, k1) = (c2.first_cell(), c2.last_cell() + 1);
        for i in c0.first_cell()..=c0.last_cell() + 1 {
            for j in c1.first_cell()..=c1.last_cell() + 1 {
                let row = (i * n1 + j) * n2;
                for &w in &self.values[row + k0..=row + k1] {
                    out.lo = out.lo.min(w);
                    out.hi = out.hi.max(w);
                }
            }
        }
        out
    }

    /// The part of a box inside the grid, as candidates per axis, after folding what lies
    /// outside its gaps into `out` (`-inf` below the first gap, `beyond_grid` past the last);
    /// `None` when no gap of the box is inside the grid.
    fn inside(&self, b: &StateBox, out: &mut Interval) -> Option<[AxisCandidates<'_>; 3]> {
        let gaps = &self.axes[0];
        let (first, last) = (gaps[0], gaps[gaps.len() - 1]);
        if b.gap.lo < first {
            out.lo = f64::NEG_INFINITY;
        }
        if b.gap.hi > last {
            out.lo = out.lo.min(self.beyond_grid);
            out.hi = out.hi.max(self.beyond_grid);
        }
        let gap = Interval::new(b.gap.lo.max(first), b.gap.hi.min(last));
        if gap.lo > gap.hi {
            return None;
        }
        Some([
            AxisCandidates::new(gaps, gap),
            AxisCandidates::new(&self.axes[1], b.follower_speed),
            AxisCandidates::new(&self.axes[2], b.ego_speed),
        ])
    }

    /// The cell between breakpoints `(i, i+1)`, `(j, j+1)`, `(k, k+1)`.
    pub fn cell(&self, i: usize, j: usize, k: usize) -> StateBox {
        let a = &self.axes;
        StateBox {
            gap: Interval::new(a[0][i], a[0][i + 1]),
            follower_speed: Interval::new(a[1][j], a[1][j + 1]),
            ego_speed: Interval::new(a[2][k], a[2][k + 1]),
        }
    }

    /// Cells per axis.
    pub fn cells(&self) -> [usize; 3] {
        [
            self.axes[0].len() - 1,
            self.axes[1].len() - 1,
            self.axes[2].len() - 1,
        ]
    }
}

/// The candidate coordinates of one axis for the extremes over an interval (clamped to the
/// axis): its two ends and every breakpoint strictly between them, each as `(cell, fraction)`.
/// No allocation: the breakpoints inside are a range of the axis.
#[derive(Debug, Clone)]
struct AxisCandidates<'a> {
    axis: &'a [f64],
    lo: (usize, f64),
    hi: (usize, f64),
    inner: std::ops::Range<usize>,
}

impl<'a> AxisCandidates<'a> {
    fn new(axis: &'a [f64], i: Interval) -> Self {
        let n = axis.len();
        let (x, y) = (
            i.lo.clamp(axis[0], axis[n - 1]),
            i.hi.clamp(axis[0], axis[n - 1]),
        );
        let locate = |x: f64| {
            let c = axis.partition_point(|&b| b <= x).clamp(1, n - 1) - 1;
            (c, ((x - axis[c]) / (axis[c + 1] - axis[c])).clamp(0.0, 1.0))
        };
        let start = axis.partition_point(|&b| b <= x);
        let end = axis.partition_point(|&b| b < y).max(start);
        AxisCandidates {
            axis,
            lo: locate(x),
            hi: locate(y),
            inner: start..end,
        }
    }

    fn len(&self) -> usize {
        2 + self.inner.len()
    }

    /// The `m`-th candidate: the lower end, the breakpoints inside, the upper end.
    fn get(&self, m: usize) -> (usize, f64) {
        if m == 0 {
            return self.lo;
        }
        if m > self.inner.len() {
            return self.hi;
        }
        let j = self.inner.start + m - 1;
        if j + 1 == self.axis.len() {
            (j - 1, 1.0)
        } else {
            (j, 0.0)
        }
    }

    /// The cells holding the lowest and the highest candidate.
    fn first_cell(&self) -> usize {
        self.lo.0
    }

    /// (A candidate on a breakpoint belongs to the cell below it too, which is the one the box
    /// needs when the breakpoint is its upper end.)
    fn last_cell(&self) -> usize {
        if self.hi.1 == 0.0 && self.hi.0 > self.lo.0 {
            self.hi.0 - 1
        } else {
            self.hi.0
        }
    }
}
