//! The trusted box: the part of the grid where the boundary condition does not change the value.
//!
//! The value at a node depends on the states the game's trajectories can reach from it. Near a
//! face that trajectories leave through, that includes ghost nodes whose values are a guess. The
//! solver therefore solves twice: with a pessimistic boundary (leaving the grid is unsafe: a
//! lower bound `V_lo` of the true value) and an optimistic one (leaving is safe: an upper bound
//! `V_hi`, since the true value never exceeds the constraint). A node is *undecided by the grid*
//! where `V_lo <= 0 < V_hi` and the two differ by more than a tolerance: there the boundary guess
//! decides whether it is safe. The trusted box is a box, shrunk face by face from the grid, with
//! no such node. Tables hold the pessimistic value everywhere, so a state they certify is safe
//! inside the box or not; outside it they may call safe states unsafe, and the firmware treats
//! such states as unknown.

use crate::engine::grid::{Grid, MAX_DIMS};

/// An index box `lo[k] ..= hi[k]` per axis.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IndexBox {
    /// First node per axis.
    pub lo: Vec<usize>,
    /// Last node per axis.
    pub hi: Vec<usize>,
}

impl IndexBox {
    /// The whole grid.
    pub fn full(grid: &Grid) -> Self {
        IndexBox {
            lo: vec![0; grid.dims()],
            hi: grid.axes().iter().map(|a| a.points - 1).collect(),
        }
    }

    /// Whether a multi-index is inside.
    pub fn contains(&self, idx: &[usize]) -> bool {
        idx.iter()
            .zip(self.lo.iter().zip(&self.hi))
            .all(|(i, (lo, hi))| lo <= i && i <= hi)
    }

    /// The grid nodes inside the box, in parallel: flat index and coordinates.
    pub fn par_nodes<'g>(
        &'g self,
        grid: &'g Grid,
    ) -> impl rayon::iter::ParallelIterator<Item = (usize, [f64; MAX_DIMS])> + 'g {
        use rayon::prelude::*;
        let d = grid.dims();
        (0..grid.len()).into_par_iter().filter_map(move |node| {
            let mut idx = [0usize; MAX_DIMS];
            grid.multi_index(node, &mut idx[..d]);
            if !self.contains(&idx[..d]) {
                return None;
            }
            let mut z = [0f64; MAX_DIMS];
            grid.node_coordinates(node, &mut z[..d]);
            Some((node, z))
        })
    }

    /// The box in state coordinates, per axis `(min, max)`.
    pub fn bounds(&self, grid: &Grid) -> Vec<(f64, f64)> {
        grid.axes()
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .map(|(a, (&lo, &hi))| (a.coordinate(lo), a.coordinate(hi)))
            .collect()
    }
}

/// A box, shrunk greedily from the whole grid, that holds no node the boundary could flip: the
/// lower bound `lo` calls it unsafe, the upper bound `hi` safe, and they differ by more than
/// `tolerance`; `None` if none is left. (Where `lo > 0` the node is safe whatever the ghost
/// values; where `hi <= 0` it is unsafe whatever they are.)
///
/// Each round peels one face: the one whose outermost layer holds the most such nodes per safe
/// node (`lo > 0`) it would give up, so the box keeps as much of the certified safe set as it
/// can. When no face layer holds any (they are all inside), the face nearest to most of them is
/// peeled.
pub fn agreement_box(grid: &Grid, lo: &[f32], hi: &[f32], tolerance: f64) -> Option<IndexBox> {
    let d = grid.dims();
    let undecided = |node: usize| {
        lo[node] <= 0.0 && hi[node] > 0.0 && f64::from(hi[node] - lo[node]) > tolerance
    };
    let bad: Vec<usize> = (0..lo.len()).filter(|&n| undecided(n)).collect();
    let mut bx = IndexBox::full(grid);
    let mut idx = [0usize; MAX_DIMS];
    loop {
        let mut inside = 0usize;
        // Per face (axis, side): bad nodes on its outermost layer, safe nodes on it, and bad
        // nodes for which it is the nearest face.
        let mut layer_bad = vec![[0usize; 2]; d];
        let mut layer_safe = vec![[0usize; 2]; d];
        let mut nearest = vec![[0usize; 2]; d];
        for &node in &bad {
            grid.multi_index(node, &mut idx[..d]);
            if !bx.contains(&idx[..d]) {
                continue;
            }
            inside += 1;
            let mut best = (usize::MAX, 0, 0);
            for k in 0..d {
                let (to_lo, to_hi) = (idx[k] - bx.lo[k], bx.hi[k] - idx[k]);
                if to_lo == 0 {
                    layer_bad[k][0] += 1;
                }
                if to_hi == 0 {
                    layer_bad[k][1] += 1;
                }
                if to_lo < best.0 {
                    best = (to_lo, k, 0);
                }
                if to_hi < best.0 {
                    best = (to_hi, k, 1);
                }
            }
            nearest[best.1][best.2] += 1;
        }
        if inside == 0 {
            return Some(bx);
        }
        if layer_bad.iter().flatten().any(|&c| c > 0) {
            for (node, &v) in lo.iter().enumerate() {
                if v <= 0.0 {
                    continue;
                }
                grid.multi_index(node, &mut idx[..d]);
                if !bx.contains(&idx[..d]) {
                    continue;
                }
                for k in 0..d {
                    if idx[k] == bx.lo[k] {
                        layer_safe[k][0] += 1;
                    }
                    if idx[k] == bx.hi[k] {
                        layer_safe[k][1] += 1;
                    }
                }
            }
        }
        let mut pick = (f64::NEG_INFINITY, 0, 0);
        for k in 0..d {
            for side in 0..2 {
                let score = if layer_bad.iter().flatten().any(|&c| c > 0) {
                    layer_bad[k][side] as f64 / (layer_safe[k][side] as f64 + 1.0)
                } else {
                    nearest[k][side] as f64
                };
                if score > pick.0 {
                    pick = (score, k, side);
                }
            }
        }
        let (_, k, side) = pick;
        if side == 0 {
            bx.lo[k] += 1;
        } else {
            bx.hi[k] = bx.hi[k].checked_sub(1)?;
        }
        if bx.lo[k] > bx.hi[k] {
            return None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::grid::GridAxis;

    fn grid() -> Grid {
        let axis = |name: &str| GridAxis::new(name, 0.0, 10.0, 11);
        Grid::new(vec![axis("a"), axis("b")]).unwrap()
    }

    #[test]
    fn a_polluted_band_costs_only_its_face() {
        let g = grid();
        let a = vec![0f32; g.len()];
        let mut b = a.clone();
        // Disagreement on the two highest rows of axis 0.
        for i in 9..11 {
            for j in 0..11 {
                b[i * 11 + j] = 1.0;
            }
        }
        let bx = agreement_box(&g, &a, &b, 0.5).unwrap();
        assert_eq!(bx.lo, vec![0, 0]);
        assert_eq!(bx.hi, vec![8, 10]);
    }

    #[test]
    fn full_disagreement_leaves_nothing() {
        let g = grid();
        let a = vec![0f32; g.len()];
        let b = vec![1f32; g.len()];
        assert_eq!(agreement_box(&g, &a, &b, 0.5), None);
        assert_eq!(agreement_box(&g, &a, &a, 0.5), Some(IndexBox::full(&g)));
    }
}
