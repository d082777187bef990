//! Semi-Lagrangian value iteration of sampled-data avoid games.
//!
//! # The scheme
//! A sampled-data game holds every player's input for a period `h`. Its value is the fixed
//! point of the dynamic-programming step
//!
//! `W_{k+1}(z) = min(l(z), min_{d} W_k(phi_h(z, d)))`, `W_0 = l`,
//!
//! where `phi_h` is the flow over one period and `d` ranges over the (here: all adversarial)
//! inputs. On a grid `W_k` is stored at the nodes and read between them by multilinear
//! interpolation, which is monotone (a convex combination of node values) and exact at nodes.
//!
//! # Why not the level-set engine for the rear game
//! The rear game's stationary value is the jam distance `s0` at rest points (both cars stopped,
//! the follower creeping up to `s0` behind), and the whole plateau `W = s0` hangs on them. A
//! Lax-Friedrichs scheme adds a viscosity proportional to the *input set's* reach there, which
//! no transport balances at a rest point: it lowered the plateau from 2 m to 0.4 m on a 1 m,
//! 1 m/s grid and kept lowering it (`examples/rear_probe.rs`). Here a node whose flow is zero
//! maps onto itself and keeps its value exactly; interpolation mixes in neighbours only as far
//! as the flow really moves in one period. The iteration is also the sampled-data game itself,
//! at the period `h`, which is what a controller that holds its command really plays.
//!
//! # Convergence
//! `W_{k+1} <= W_k` node by node (by induction: `W_1 <= l = W_0`, and the step is monotone), so
//! the iteration decreases to its fixed point; it stops when the largest change in one step
//! falls below the tolerance.

use rayon::prelude::*;

use crate::games::Vector;
use crate::grid::{Grid, MAX_DIMS};

/// A game whose inputs are held for a period and whose players all minimise.
pub trait SampledGame: Sync {
    /// The number of state axes.
    fn dims(&self) -> usize;
    /// The constraint `l(z)`.
    fn constraint(&self, z: &Vector) -> f32;
    /// The number of input combinations the iteration minimises over.
    fn input_count(&self) -> usize;
    /// The state after one period `h` from `z` under input combination `input`.
    fn advance(&self, z: &Vector, input: usize, h: f32) -> Vector;
}

/// The outcome of a value iteration.
#[derive(Debug, Clone)]
pub struct Iterated {
    /// `W` at every node, C order.
    pub values: Vec<f32>,
    /// Iterations done.
    pub iterations: usize,
    /// The largest change in the last iteration, value units.
    pub residual: f32,
    /// Whether the residual fell below the tolerance.
    pub converged: bool,
}

/// Iterates the dynamic-programming step on `grid` with period `h` until the largest change
/// per iteration falls below `tolerance` or `max_iterations` pass. `progress` sees
/// `(iteration, residual, values)` after each iteration.
pub fn iterate<G: SampledGame>(
    game: &G,
    grid: &Grid,
    h: f32,
    tolerance: f32,
    max_iterations: usize,
    mut progress: impl FnMut(usize, f32, &[f32]),
) -> Iterated {
    assert_eq!(game.dims(), grid.dims());
    let d = grid.dims();
    let n = grid.len();
    // Every node's successors and the constraint never change: compute them once.
    let coords: Vec<Vector> = (0..n)
        .into_par_iter()
        .map(|node| {
            let mut c = [0f64; MAX_DIMS];
            grid.node_coordinates(node, &mut c[..d]);
            c.map(|x| x as f32)
        })
        .collect();
    let constraint: Vec<f32> = coords.par_iter().map(|z| game.constraint(z)).collect();
    let stencils: Vec<Stencil> = coords
        .par_iter()
        .flat_map_iter(|z| {
            (0..game.input_count()).map(move |i| Stencil::new(grid, &game.advance(z, i, h)))
        })
        .collect();
    let m = game.input_count();
    let mut values = constraint.clone();
    let mut next = vec![0f32; n];
    let mut residual = f32::INFINITY;
    let mut iterations = 0;
    while iterations < max_iterations {
        next.par_iter_mut().enumerate().for_each(|(node, out)| {
            let mut w = constraint[node];
            for s in &stencils[node * m..(node + 1) * m] {
                w = w.min(s.apply(&values));
            }
            *out = w;
        });
        residual = next
            .par_iter()
            .zip(&values)
            .map(|(a, b)| (a - b).abs())
            .reduce(|| 0.0, f32::max);
        std::mem::swap(&mut values, &mut next);
        iterations += 1;
        progress(iterations, residual, &values);
        if residual < tolerance {
            break;
        }
    }
    Iterated {
        values,
        iterations,
        converged: residual < tolerance,
        residual,
    }
}

/// A point's interpolation stencil: the lower corner node and the weights along each axis.
#[derive(Debug, Clone, Copy)]
struct Stencil {
    base: u32,
    frac: [f32; 3],
    strides: [u32; 3],
    dims: u8,
}

impl Stencil {
    fn new(grid: &Grid, z: &Vector) -> Self {
        let d = grid.dims();
        assert!(d <= 3, "semi-Lagrangian stencils are for up to three axes");
        let mut base = 0usize;
        let mut frac = [0f32; 3];
        let mut strides = [0u32; 3];
        for k in 0..d {
            let a = &grid.axes()[k];
            let s = ((f64::from(z[k]) - a.min) / a.spacing()).clamp(0.0, (a.points - 1) as f64);
            let i = (s.floor() as usize).min(a.points - 2);
            frac[k] = (s - i as f64) as f32;
            base += i * grid.strides()[k];
            strides[k] = grid.strides()[k] as u32;
        }
        Stencil {
            base: base as u32,
            frac,
            strides,
            dims: d as u8,
        }
    }

    #[inline(always)]
    fn apply(&self, v: &[f32]) -> f32 {
        let b = self.base as usize;
        let [s0, s1, s2] = self.strides.map(|s| s as usize);
        let [t0, t1, t2] = self.frac;
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        match self.dims {
            2 => lerp(
                lerp(v[b], v[b + s1], t1),
                lerp(v[b + s0], v[b + s0 + s1], t1),
                t0,
            ),
            _ => {
                let plane = |o: usize| {
                    lerp(
                        lerp(v[o], v[o + s2], t2),
                        lerp(v[o + s1], v[o + s1 + s2], t2),
                        t1,
                    )
                };
                lerp(plane(b), plane(b + s0), t0)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridAxis;

    /// A car `x` metres from a wall at speed `v >= 0` towards it, braking at `b`: the smallest
    /// distance it ever has is `x - v^2 / (2 b)`, exactly.
    struct Braking {
        b: f32,
    }

    impl SampledGame for Braking {
        fn dims(&self) -> usize {
            2
        }
        fn constraint(&self, z: &Vector) -> f32 {
            z[0]
        }
        fn input_count(&self) -> usize {
            1
        }
        fn advance(&self, z: &Vector, _input: usize, h: f32) -> Vector {
            let (v, b) = (z[1], self.b);
            let t = h.min(v / b);
            let mut out = *z;
            out[0] = z[0] - (v * t - 0.5 * b * t * t);
            out[1] = v - b * t;
            out
        }
    }

    fn error(points: usize) -> (f32, bool) {
        let grid = Grid::new(vec![
            GridAxis::new("gap", -20.0, 40.0, points),
            GridAxis::new("speed", 0.0, 10.0, points),
        ])
        .unwrap();
        let game = Braking { b: 4.0 };
        let mut previous: Option<Vec<f32>> = None;
        let mut monotone = true;
        let out = iterate(&game, &grid, 0.1, 1e-6, 10_000, |_, _, v| {
            if let Some(p) = &previous {
                monotone &= v.iter().zip(p).all(|(a, b)| a <= b);
            }
            previous = Some(v.to_vec());
        });
        assert!(out.converged);
        let mut worst = 0f32;
        let mut z = [0f64; MAX_DIMS];
        for node in 0..grid.len() {
            grid.node_coordinates(node, &mut z[..2]);
            let exact = (z[0] - z[1] * z[1] / 8.0) as f32;
            // Away from the lower gap face, where the grid clamps.
            if exact > -10.0 {
                worst = worst.max((out.values[node] - exact).abs());
            }
        }
        (worst, monotone)
    }

    #[test]
    fn braking_to_a_wall_converges_to_the_exact_value_under_refinement() {
        let (coarse, m1) = error(31);
        let (fine, m2) = error(61);
        assert!(m1 && m2, "W_k must not increase");
        assert!(fine < 0.5, "error {fine} m at 61^2");
        assert!(fine < 0.75 * coarse, "no convergence: {coarse} -> {fine}");
    }
}
