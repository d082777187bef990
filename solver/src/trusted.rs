//! The trusted box: the part of the grid where the boundary condition does not change the value.
//!
//! The value at a node depends on the states the game's trajectories can reach from it. Near a
//! face that trajectories leave through, that includes ghost nodes whose values are a guess. The
//! solver therefore solves twice, with a pessimistic and an optimistic (extrapolating) guess,
//! and trusts only the largest box, shrunk face by face from the grid, in which the two agree
//! within a tolerance. Inside it the boundary guess is immaterial to that tolerance; outside it
//! the table still holds the pessimistic value, but the firmware treats the state as unknown.

use crate::grid::{Grid, MAX_DIMS};

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

    /// The box in state coordinates, per axis `(min, max)`.
    pub fn bounds(&self, grid: &Grid) -> Vec<(f64, f64)> {
        grid.axes()
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .map(|(a, (&lo, &hi))| (a.coordinate(lo), a.coordinate(hi)))
            .collect()
    }
}

/// The largest box, shrunk greedily from the whole grid, that holds no node where `a` and `b`
/// differ by more than `tolerance`; `None` if none is left.
///
/// Each round shrinks the face that is nearest to the most disagreeing nodes in the box, so a
/// band polluted from one face costs only that face.
pub fn agreement_box(grid: &Grid, a: &[f32], b: &[f32], tolerance: f64) -> Option<IndexBox> {
    let d = grid.dims();
    let bad: Vec<usize> = a
        .iter()
        .zip(b)
        .enumerate()
        .filter(|(_, (x, y))| f64::from((**x - **y).abs()) > tolerance)
        .map(|(i, _)| i)
        .collect();
    let mut bx = IndexBox::full(grid);
    let mut idx = [0usize; MAX_DIMS];
    loop {
        // For each face (axis k, side s) the number of bad nodes in the box closest to it.
        let mut votes = vec![[0usize; 2]; d];
        let mut any = false;
        for &node in &bad {
            grid.multi_index(node, &mut idx[..d]);
            if !bx.contains(&idx[..d]) {
                continue;
            }
            any = true;
            let mut best = (usize::MAX, 0, 0);
            for k in 0..d {
                let to_lo = idx[k] - bx.lo[k];
                let to_hi = bx.hi[k] - idx[k];
                if to_lo < best.0 {
                    best = (to_lo, k, 0);
                }
                if to_hi < best.0 {
                    best = (to_hi, k, 1);
                }
            }
            votes[best.1][best.2] += 1;
        }
        if !any {
            return Some(bx);
        }
        let (mut k_best, mut s_best, mut most) = (0, 0, 0);
        for (k, v) in votes.iter().enumerate() {
            for (s, &count) in v.iter().enumerate() {
                if count > most {
                    (k_best, s_best, most) = (k, s, count);
                }
            }
        }
        if s_best == 0 {
            bx.lo[k_best] += 1;
        } else {
            bx.hi[k_best] = bx.hi[k_best].checked_sub(1)?;
        }
        if bx.lo[k_best] > bx.hi[k_best] {
            return None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridAxis;

    fn grid() -> Grid {
        let axis = |name: &str| GridAxis {
            name: name.into(),
            unit: "m".into(),
            min: 0.0,
            max: 10.0,
            points: 11,
        };
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
