//! The rear iteration's orders side by side on the deployed grid: the Jacobi sweeps the solver
//! runs (`solver::semi_lagrangian::Iteration`) against in-place Gauss-Seidel sweeps in C order,
//! with and without each stencil's own weight eliminated exactly (the node's local fixed point
//! given its neighbours: `W = min(l, min_d R_d)`, `R_d` the stencil's other corners with their
//! weights renormalised).
//!
//! `cargo run -p solver --release --example iteration_study -- [SWEEPS]` (default 2,000; about
//! 40 s per 1,000 Gauss-Seidel sweeps on one core). It prints, per method and every few hundred
//! sweeps, the largest change of the last sweep and the plateau `W(10 m, 0, 0)` (exactly
//! `s0 = 2 m` for the continuous game). What it shows (`semi_lagrangian::Iteration`'s docs):
//! the slow part of the value is the plateau eroding at the rest points, which no order of the
//! sweeps removes; Gauss-Seidel only reaches the lower values sooner.
use std::time::Instant;

use rayon::prelude::*;
use solver::rear::RearConfig;
use solver::semi_lagrangian::{Breakpoints, Iteration, SampledGame};

/// A successor's stencil, with the node's own corner (if the successor's cell has it) and
/// `1 / (1 - its weight)`.
#[derive(Clone, Copy)]
struct Stencil {
    base: u32,
    frac: [f32; 3],
    own_corner: u8,
    rescale: f32,
}

struct Problem {
    inputs: usize,
    shape: [usize; 3],
    strides: [usize; 3],
    constraint: Vec<f32>,
    stencils: Vec<Stencil>,
}

fn locate(a: &[f32], x: f32) -> (usize, f32) {
    let n = a.len();
    let x = x.clamp(a[0], a[n - 1]);
    let i = a.partition_point(|&b| b <= x).clamp(1, n - 1) - 1;
    (i, ((x - a[i]) / (a[i + 1] - a[i])).clamp(0.0, 1.0))
}

fn build<G: SampledGame>(game: &G, grid: &Breakpoints, h: f32) -> Problem {
    let shape = [grid.axis(0).len(), grid.axis(1).len(), grid.axis(2).len()];
    let strides = [shape[1] * shape[2], shape[2], 1];
    let m = game.input_count();
    let constraint = (0..grid.len())
        .into_par_iter()
        .map(|n| game.constraint(&grid.node_coordinates(n)))
        .collect();
    let stencils = (0..grid.len())
        .into_par_iter()
        .flat_map_iter(|node| {
            let z = grid.node_coordinates(node);
            let index = [
                node / strides[0],
                (node / strides[1]) % shape[1],
                node % shape[2],
            ];
            (0..m).map(move |input| {
                let next = game.advance(&z, input, h);
                let (mut base, mut frac, mut corner, mut own) = (0, [0f32; 3], 0usize, true);
                let mut away = [0f32; 3];
                for k in 0..3 {
                    let (i, t) = locate(grid.axis(k), next[k]);
                    base += i * strides[k];
                    frac[k] = t;
                    match index[k].checked_sub(i) {
                        Some(0) => away[k] = t,
                        Some(1) => {
                            corner |= 4 >> k;
                            away[k] = 1.0 - t;
                        }
                        _ => own = false,
                    }
                }
                // 1 - prod(1 - away_k), without cancellation.
                let other = away[0] + (1.0 - away[0]) * (away[1] + (1.0 - away[1]) * away[2]);
                Stencil {
                    base: base as u32,
                    frac,
                    own_corner: if own { corner as u8 } else { 8 },
                    rescale: if own && other > 0.0 { 1.0 / other } else { 0.0 },
                }
            })
        })
        .collect();
    Problem {
        inputs: m,
        shape,
        strides,
        constraint,
        stencils,
    }
}

impl Problem {
    /// The node's update from `v`: the plain dynamic-programming step, or with its own weight
    /// eliminated (an input that maps the node onto itself then constrains nothing).
    fn update(&self, node: usize, v: &[f32], eliminate: bool) -> f32 {
        let [s0, s1, s2] = self.strides;
        let mut w = self.constraint[node];
        for s in &self.stencils[node * self.inputs..(node + 1) * self.inputs] {
            let b = s.base as usize;
            let mut c = [
                v[b],
                v[b + s2],
                v[b + s1],
                v[b + s1 + s2],
                v[b + s0],
                v[b + s0 + s2],
                v[b + s0 + s1],
                v[b + s0 + s1 + s2],
            ];
            let own = eliminate && s.own_corner < 8;
            if own {
                if s.rescale == 0.0 {
                    continue;
                }
                c[s.own_corner as usize] = 0.0;
            }
            let [t0, t1, t2] = s.frac;
            let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
            let plane = |o: usize| lerp(lerp(c[o], c[o + 1], t2), lerp(c[o + 2], c[o + 3], t2), t1);
            let r = lerp(plane(0), plane(4), t0);
            w = w.min(if own { r * s.rescale } else { r });
        }
        w.min(v[node])
    }

    /// One in-place sweep in C order; the largest change.
    fn gauss_seidel(&self, v: &mut [f32], eliminate: bool) -> f32 {
        let mut largest = 0f32;
        for node in 0..self.shape.iter().product() {
            let w = self.update(node, v, eliminate);
            largest = largest.max(v[node] - w);
            v[node] = w;
        }
        largest
    }
}

fn main() {
    let sweeps: usize = std::env::args()
        .nth(1)
        .map_or(2000, |s| s.parse().expect("SWEEPS: a count"));
    let config = RearConfig::from_toml(include_str!("../configs/rear/deployment.toml"))
        .expect("the deployment config");
    let grid = config.grid().expect("its grid");
    let game = config.game();
    let h = config.solve.period as f32;
    let plateau = |v: &[f32]| grid.interpolate(v, &[10.0, 0.0, 0.0]);
    let report = |method: &str, k: usize, residual: f32, v: &[f32], seconds: f64| {
        println!(
            "| {method} | {k} | {residual:.2e} | {:.4} | {} | {seconds:.1} |",
            plateau(v),
            v.iter().filter(|&&w| w > 0.0).count()
        );
    };
    println!(
        "| method | sweeps | largest change (m) | plateau (m) | nodes with W > 0 | wall (s) |"
    );
    println!("|---|---|---|---|---|---|");
    let marks = |k: usize| k.is_multiple_of((sweeps / 4).max(1)) || k == sweeps;

    let t = Instant::now();
    let mut jacobi = Iteration::new(&game, &grid, h);
    for k in 1..=sweeps {
        let r = jacobi.sweep();
        if marks(k) {
            report(
                "Jacobi (the solver's)",
                k,
                r,
                jacobi.values(),
                t.elapsed().as_secs_f64(),
            );
        }
    }
    let problem = build(&game, &grid, h);
    for (name, eliminate) in [
        ("Gauss-Seidel, C order", false),
        ("Gauss-Seidel, own weight eliminated", true),
    ] {
        let t = Instant::now();
        let mut v = problem.constraint.clone();
        for k in 1..=sweeps {
            let r = problem.gauss_seidel(&mut v, eliminate);
            if marks(k) {
                report(name, k, r, &v, t.elapsed().as_secs_f64());
            }
        }
    }
}
