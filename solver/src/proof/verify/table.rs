//! The rear table as `verify` reads it, and the exact least and largest value of its
//! interpolant over a box.

use table_format::Table;

use super::interval::{Interval, StateBox};
use super::model::RearModel;
use crate::error::SolverError;

/// The rear table as `verify` reads it: breakpoints and dequantized node values in `f64`.
#[derive(Debug, Clone)]
pub struct RearTable {
    axes: [BreakpointAxis; 3],
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
            axes: axes.map(BreakpointAxis::new),
            values,
            beyond_grid,
            error_bound,
            model,
        })
    }

    /// The breakpoints of axis `k`.
    pub fn axis(&self, k: usize) -> &[f64] {
        &self.axes[k].points
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
        let point = |x: f64| Interval::new(x, x);
        self.locate(&StateBox {
            gap: point(x[0]),
            follower_speed: point(x[1]),
            ego_speed: point(x[2]),
        })
        .extremes()
        .lo
    }

    /// The least and largest `W` over a box (exact, module docs): [`Located::extremes`].
    pub fn extremes(&self, b: &StateBox) -> Interval {
        self.locate(b).extremes()
    }

    /// Bounds of `W` over a box from its nodes alone: [`Located::bounds`].
    pub fn node_bounds(&self, b: &StateBox) -> Interval {
        self.locate(b).bounds()
    }

    /// A box located on the grid once, for [`Located::bounds`] and [`Located::extremes`]. Speeds
    /// outside an axis are clamped to it, a gap past the last breakpoint reads
    /// [`RearTable::beyond_grid`] and one below the first reads `-inf`, as the firmware reads
    /// the table.
    pub fn locate(&self, b: &StateBox) -> Located<'_> {
        let gaps = &self.axes[0].points;
        let (first, last) = (gaps[0], gaps[gaps.len() - 1]);
        let mut outside = Interval::new(f64::INFINITY, f64::NEG_INFINITY);
        if b.gap.lo < first {
            outside.lo = f64::NEG_INFINITY;
        }
        if b.gap.hi > last {
            outside.lo = outside.lo.min(self.beyond_grid);
            outside.hi = outside.hi.max(self.beyond_grid);
        }
        let gap = Interval::new(b.gap.lo.max(first), b.gap.hi.min(last));
        let inside = (gap.lo <= gap.hi).then(|| {
            [
                AxisCandidates::new(&self.axes[0], gap),
                AxisCandidates::new(&self.axes[1], b.follower_speed),
                AxisCandidates::new(&self.axes[2], b.ego_speed),
            ]
        });
        Located {
            table: self,
            outside,
            inside,
        }
    }

    /// The cell between breakpoints `(i, i+1)`, `(j, j+1)`, `(k, k+1)`.
    pub fn cell(&self, i: usize, j: usize, k: usize) -> StateBox {
        let a = [
            &self.axes[0].points,
            &self.axes[1].points,
            &self.axes[2].points,
        ];
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

/// A box located on the grid ([`RearTable::locate`]).
#[derive(Debug, Clone)]
pub struct Located<'a> {
    table: &'a RearTable,
    /// What the parts of the box outside the grid's gaps read (`lo > hi` when none).
    outside: Interval,
    /// The candidates per axis of the part inside the grid's gaps, if any.
    inside: Option<[AxisCandidates<'a>; 3]>,
}

impl Located<'_> {
    /// The same box with axis `k`'s interval replaced (of the gap axis, only within the grid's
    /// gaps): the other axes are not located again.
    pub fn with_axis(&self, k: usize, i: Interval) -> Self {
        let mut out = self.clone();
        if let Some(axes) = &mut out.inside {
            axes[k] = AxisCandidates::new(&self.table.axes[k], i);
        }
        out
    }

    /// `W` at the box's eight corners, corner `c` taking the upper end of the gap where bit 4
    /// is set, of the follower's speed where bit 2 is, of the ego's where bit 1 is; `None` when
    /// the box reaches outside the grid's gaps.
    pub fn corners(&self) -> Option<[f64; 8]> {
        let [c0, c1, c2] = self
            .inside
            .as_ref()
            .filter(|_| self.outside.lo > self.outside.hi)?;
        let t = self.table;
        let [n1, n2] = [t.axes[1].len(), t.axes[2].len()];
        let v = &t.values;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        Some(std::array::from_fn(|c| {
            let pick = |a: &AxisCandidates<'_>, up: bool| if up { a.hi } else { a.lo };
            let ((i, t), (j, s), (k, r)) = (
                pick(c0, c & 4 != 0),
                pick(c1, c & 2 != 0),
                pick(c2, c & 1 != 0),
            );
            let row = |i: usize, j: usize| {
                let o = (i * n1 + j) * n2 + k;
                lerp(v[o], v[o + 1], r)
            };
            lerp(
                lerp(row(i, j), row(i, j + 1), s),
                lerp(row(i + 1, j), row(i + 1, j + 1), s),
                t,
            )
        }))
    }

    /// The least and largest `W` over the box, exact.
    ///
    /// On each piece between breakpoints `W` is multilinear, so its extremes over the box are
    /// among the points whose coordinates are, per axis, the box's ends or a breakpoint inside
    /// it: the interpolant is evaluated on the tensor product of those candidates, each located
    /// once.
    pub fn extremes(&self) -> Interval {
        let mut out = self.outside;
        let Some([c0, c1, c2]) = &self.inside else {
            return out;
        };
        let t = self.table;
        let [n1, n2] = [t.axes[1].len(), t.axes[2].len()];
        let v = &t.values;
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

    /// Bounds of `W` over the box from the node values alone: the least and largest node of
    /// every cell the box touches (a multilinear interpolant is a convex combination of its
    /// cell's corners). As sound as [`Located::extremes`] (`lo <= extremes.lo`,
    /// `hi >= extremes.hi`, equal on a box that is one cell) and cheaper by the interpolation:
    /// `verify` asks them first and interpolates only where they cannot decide.
    pub fn bounds(&self) -> Interval {
        let mut out = self.outside;
        let Some([c0, c1, c2]) = &self.inside else {
            return out;
        };
        let t = self.table;
        let [n1, n2] = [t.axes[1].len(), t.axes[2].len()];
        let (k0, k1) = (c2.first_cell(), c2.last_cell() + 1);
        for i in c0.first_cell()..=c0.last_cell() + 1 {
            for j in c1.first_cell()..=c1.last_cell() + 1 {
                let row = (i * n1 + j) * n2;
                for &w in &t.values[row + k0..=row + k1] {
                    out.lo = out.lo.min(w);
                    out.hi = out.hi.max(w);
                }
            }
        }
        out
    }
}

/// One axis's breakpoints with an index that locates a coordinate in O(1): the axis's span cut
/// into equal buckets no wider than its narrowest cell (at most 4,096 of them), each holding how
/// many breakpoints lie at or below its start, so a search is confined to its bucket (a step or
/// two) instead of the whole axis (`verify` locates tens of millions of coordinates).
#[derive(Debug, Clone)]
struct BreakpointAxis {
    points: Vec<f64>,
    origin: f64,
    /// Buckets per unit of the axis.
    scale: f64,
    /// `below[b]`: the breakpoints at or below bucket `b`'s start; one more entry than buckets.
    below: Vec<usize>,
}

impl BreakpointAxis {
    const MAX_BUCKETS: usize = 4096;

    fn new(points: Vec<f64>) -> Self {
        let n = points.len();
        let (origin, span) = (points[0], points[n - 1] - points[0]);
        let narrowest = points
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        let buckets = ((span / narrowest).ceil() as usize).clamp(1, Self::MAX_BUCKETS);
        let scale = buckets as f64 / span;
        let below = (0..=buckets)
            .map(|b| {
                let start = origin + b as f64 / scale;
                points.partition_point(|&p| p <= start)
            })
            .collect();
        BreakpointAxis {
            points,
            origin,
            scale,
            below,
        }
    }

    fn len(&self) -> usize {
        self.points.len()
    }

    /// How many breakpoints are at or below `x`: `points.partition_point(|&p| p <= x)`, for `x`
    /// within the axis.
    fn at_or_below(&self, x: f64) -> usize {
        let buckets = self.below.len() - 1;
        let position = (x - self.origin) * self.scale;
        // A coordinate within the axis is finite and its bucket in range; anything else (NaN
        // included) takes the plain search.
        if !(0.0..buckets as f64).contains(&position) {
            return self.points.partition_point(|&p| p <= x);
        }
        // One breakpoint of slack on each side covers a bucket's start rounded past `x`.
        let b = position as usize;
        let (lo, hi) = (
            self.below[b].saturating_sub(1),
            (self.below[b + 1] + 1).min(self.len()),
        );
        lo + self.points[lo..hi].partition_point(|&p| p <= x)
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
    fn new(axis: &'a BreakpointAxis, i: Interval) -> Self {
        let points = &axis.points;
        let n = points.len();
        let (x, y) = (
            i.lo.clamp(points[0], points[n - 1]),
            i.hi.clamp(points[0], points[n - 1]),
        );
        // Breakpoints at or below each end: the cell holding it, and where those strictly
        // inside begin and end.
        let (start, up_to_y) = (axis.at_or_below(x), axis.at_or_below(y));
        let end = if up_to_y > 0 && points[up_to_y - 1] == y {
            up_to_y - 1
        } else {
            up_to_y
        };
        let cell = |count: usize, x: f64| {
            let c = count.clamp(1, n - 1) - 1;
            (
                c,
                ((x - points[c]) / (points[c + 1] - points[c])).clamp(0.0, 1.0),
            )
        };
        AxisCandidates {
            axis: points,
            lo: cell(start, x),
            hi: cell(up_to_y, y),
            inner: start..end.max(start),
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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The bucket index finds what a binary search over the whole axis finds, for every
        /// coordinate: on breakpoints, between them, at the ends and beyond them.
        #[test]
        fn the_bucket_index_agrees_with_a_binary_search(
            steps in proptest::collection::vec(0.001f64..5.0, 1..200),
            start in -10.0f64..10.0,
            probes in proptest::collection::vec(-0.2f64..1.2, 1..50),
        ) {
            let mut points = vec![start];
            for d in &steps {
                let last = points[points.len() - 1];
                points.push(last + d);
            }
            let axis = BreakpointAxis::new(points.clone());
            let span = points[points.len() - 1] - points[0];
            let mut xs: Vec<f64> = probes.iter().map(|f| points[0] + f * span).collect();
            xs.extend(points.iter().copied());
            xs.extend(points.iter().map(|p| p + 1e-12));
            xs.extend(points.iter().map(|p| p - 1e-12));
            for x in xs {
                prop_assert_eq!(axis.at_or_below(x), points.partition_point(|&p| p <= x), "x {}", x);
            }
        }
    }

    #[test]
    fn a_box_of_one_cell_reads_its_corners() {
        let model = RearModel::from_game(
            &table_format::Game::ThreeCarSplit {
                ego: table_format::Bounds::new(-3.5, 2.0),
                leader: table_format::Bounds::new(-6.0, 2.0),
                follower: table_format::FollowerModel::Idm {
                    clip: table_format::Bounds::new(-6.0, 2.0),
                    idm: table_format::IdmParameters::HIGHWAY,
                    time_gap: table_format::Bounds::new(1.0, 2.0),
                },
                max_speed: 35.0,
                emergency: table_format::EmergencyDeclaration::DEFAULT,
            },
            0.0,
        )
        .expect("a split game");
        let axes = [
            vec![0.0, 1.0, 3.0, 7.0],
            vec![0.0, 0.5, 2.0],
            vec![0.0, 1.0, 4.0],
        ];
        let values: Vec<f64> = (0..36).map(|n| ((n * 37) % 11) as f64 - 4.0).collect();
        let t = RearTable::new(model, axes, values, 0.0).expect("a table");
        let cell = t.cell(1, 0, 1);
        let located = t.locate(&cell);
        let corners: Vec<f64> = (0..8)
            .map(|c| t.node(1 + (c >> 2), (c >> 1) & 1, 1 + (c & 1)))
            .collect();
        let lo = corners.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = corners.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(located.bounds(), Interval::new(lo, hi));
        assert_eq!(located.extremes(), Interval::new(lo, hi));
        // A box over two cells: the bounds enclose the exact extremes.
        let wide = StateBox {
            gap: Interval::new(0.5, 2.5),
            ..cell
        };
        let (b, e) = (t.node_bounds(&wide), t.extremes(&wide));
        assert!(b.lo <= e.lo && b.hi >= e.hi, "{b:?} {e:?}");
    }
}
