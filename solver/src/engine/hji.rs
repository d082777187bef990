//! The level-set engine: the HJI variational inequality of the avoid problem, integrated in
//! backward time with a Lax-Friedrichs numerical Hamiltonian, WENO/ENO/upwind gradients and
//! TVD Runge-Kutta steps.
//!
//! # The equation
//! With `tau` the time to go, the value `V(z, tau) = max_u min_d min_{s<=tau} l(xi(s))` solves
//! (Mitchell, Bayen & Tomlin 2005; Fisac et al. 2015)
//!
//! `dV/dtau = min(0, H(z, grad V))`, `V(z, 0) = l(z)`, `H(z, p) = max_u min_d p . f`.
//!
//! The `min(0, .)` is the variational inequality `V = min(l, ...)` written as a freezing of the
//! Hamiltonian: `V` never increases in `tau`, so `V <= l` at all times, and a state once unsafe
//! stays so. The engine keeps this monotonicity to the last bit: each RK stage is a convex
//! combination of values that did not increase, and the last stage takes the minimum with the
//! step's start value to absorb f32 rounding.
//!
//! # The scheme
//! `dV/dtau = min(0, H(z, (p- + p+)/2) + sum_i alpha_i(z) (p+_i - p-_i) / 2)`: the Lax-Friedrichs
//! numerical Hamiltonian of `V_tau + (-H) = 0`, with `p-`, `p+` the one-sided derivatives from
//! [`crate::engine::scheme`] and `alpha_i >= max |dH/dp_i| = max_{u,d} |f_i|` (local: at each node;
//! global: over the grid). The sign of the dissipation is that of a viscosity `+ alpha dx/2
//! V_xx` on the right-hand side, which is what keeps the scheme monotone (Crandall & Lions 1984).
//! Time steps are `dt = CFL / max_z sum_i alpha_i(z) / dx_i`, constant here because `alpha`
//! depends on the state only; TVD RK1/2/3 are those of Shu & Osher (1988).
//!
//! # The boundary
//! Derivatives at the grid's faces need up to three ghost nodes beyond them. Linear
//! extrapolation of the last two nodes ([`Boundary::Extrapolate`]) is hj_reachability's and
//! ToolboxLS's choice; it is optimistic where worst-case trajectories leave the grid (the value
//! is concave across the low-speed faces, so a line overestimates it). [`Boundary::Pessimistic`]
//! and [`Boundary::Optimistic`] put lower and upper bounds of the true ghost values there
//! instead (see the `ghost` function); the two solves bracket the true value,
//! [`crate::proof::trusted`] keeps the box where the bracket is tight, and tables are compiled from
//! the pessimistic solve.
//!
//! # The obstacle
//! [`Obstacle::Freeze`] (the default) is the `min(0, .)` above. For values solved to
//! convergence, [`Obstacle::Constraint`] steps `V_tau = H_LF` and caps each step at `l`
//! instead: the same equation, but its discrete steady state exists (see [`Obstacle`]).
//!
//! # The floor
//! Values are held at the grid's lowest constraint value `floor = min l`: that solves the game
//! for `max(l, floor)`, whose value is `max(V, floor)` (max distributes over the min in time),
//! so the sign of `V` and the safe set are unchanged, while hopeless states stop drifting
//! towards minus infinity and the residual measures what matters.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::engine::dynamics::{Dynamics, Vector};
use crate::engine::grid::{Grid, MAX_DIMS};
use crate::engine::scheme::{derivatives_row, derivatives_strided, Spatial};
use crate::error::SolverError;

/// TVD Runge-Kutta order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RkOrder {
    /// Forward Euler.
    #[serde(rename = "1")]
    One,
    /// Heun (TVD RK2).
    #[serde(rename = "2")]
    Two,
    /// Shu-Osher TVD RK3.
    #[serde(rename = "3")]
    Three,
}

/// Local or global Lax-Friedrichs dissipation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dissipation {
    /// `alpha_i` at each node from the dynamics' bounds there (less smearing).
    Local,
    /// `alpha_i` the maximum over the grid (hj_reachability's default).
    Global,
}

/// Ghost-node values beyond the grid's faces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Boundary {
    /// Linear extrapolation of the last two nodes.
    Extrapolate,
    /// Lower bounds: beyond an upper face the face value (more gap or relative speed is never
    /// worse), beyond a lower face the lowest constraint value on the grid ("leaving towards a
    /// collision is unsafe"). The value is then a lower bound of the true one (sound).
    Pessimistic,
    /// Upper bounds: beyond an upper face at least the largest constraint value the ghost nodes
    /// can have (`V <= l`), beyond a lower face the face value. Used to measure the trusted box,
    /// never for a table.
    Optimistic,
}

/// How the obstacle `V <= l` of the avoid problem enters the time steps.
///
/// Both are consistent discretisations of `min(l - V, V_tau - H) = 0` with `V(., 0) = l`; they
/// differ in what the *discrete* value does on long horizons.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Obstacle {
    /// `dV/dtau = min(0, H_LF)`, each step also `min` with its start value: non-increasing in
    /// the horizon to the last bit. But the Lax-Friedrichs viscosity then acts one way only:
    /// where `V` is concave it lowers `V`, where convex the `min(0, .)` stops it from rising, so
    /// on a coarse grid the value keeps eroding after the true value has become stationary.
    /// Right for fixed horizons on fine grids.
    #[default]
    Freeze,
    /// `V <- min(l, V + dt H_LF)` per step (Fisac et al. 2015's variational inequality): the
    /// viscosity acts both ways, so the discrete value has a steady state (`H_LF = 0` where
    /// `V < l`) and a solve to convergence stops eroding. The value is then not monotone in the
    /// horizon node by node (the viscosity may lift it, never above `l`). Right for converged
    /// (stationary) values.
    Constraint,
}

/// The numerical method.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Numerics {
    /// Gradient scheme.
    pub spatial: Spatial,
    /// Time integrator.
    pub rk: RkOrder,
    /// CFL number, in (0, 1].
    pub cfl: f64,
    /// Lax-Friedrichs dissipation.
    pub dissipation: Dissipation,
    /// Ghost nodes.
    pub boundary: Boundary,
    /// How `V <= l` is imposed.
    pub obstacle: Obstacle,
}

impl Default for Numerics {
    fn default() -> Self {
        Numerics {
            spatial: Spatial::Weno5,
            rk: RkOrder::Three,
            cfl: 0.75,
            dissipation: Dissipation::Local,
            boundary: Boundary::Pessimistic,
            obstacle: Obstacle::Freeze,
        }
    }
}

/// When to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// After this many seconds of backward time.
    Horizon(f64),
    /// When `max |dV/dtau| < tolerance`, or after `max_time` seconds.
    Converge {
        /// Tolerance on `max |dV/dtau|`, value units per second.
        tolerance: f64,
        /// Time limit, s.
        max_time: f64,
    },
}

/// How the solve ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// Reached the fixed horizon.
    Horizon,
    /// Converged.
    Converged,
    /// Hit `max_time` before converging.
    NotConverged,
}

/// A computed value function.
#[derive(Debug, Clone)]
pub struct Solution {
    /// `V` at every node, C order.
    pub values: Vec<f32>,
    /// Backward time reached, s.
    pub time: f64,
    /// Time steps taken.
    pub steps: usize,
    /// The time step, s.
    pub dt: f64,
    /// `max |dV/dtau|` at the last step.
    pub residual: f64,
    /// How it ended.
    pub outcome: Outcome,
}

/// The constraint `l` at every node.
pub fn constraint_values<G: Dynamics>(game: &G, grid: &Grid) -> Vec<f32> {
    let d = grid.dims();
    (0..grid.len())
        .into_par_iter()
        .map(|node| {
            let mut z = [0f64; MAX_DIMS];
            grid.node_coordinates(node, &mut z[..d]);
            game.constraint(&z.map(|x| x as f32))
        })
        .collect()
}

/// Everything a stage needs that does not change between stages.
///
/// Work is split into *blocks*: a run of consecutive rows of one *plane* (the last two axes).
/// A block's neighbours along the outer axes are contiguous blocks of the same shape at fixed
/// strides, so every derivative loop runs over contiguous memory and vectorises.
struct Context<'g, G> {
    game: &'g G,
    grid: &'g Grid,
    numerics: Numerics,
    /// Global alpha per axis (used with [`Dissipation::Global`]).
    global_alpha: Vector,
    /// Lowest constraint value on the grid, and an upper bound of the constraint at every ghost
    /// node (the ghost caps).
    caps: (f32, f32),
    /// Nodes per plane (the last two axes).
    plane: usize,
    /// The units of work, in memory order (fixed for a grid, so made once).
    blocks: Vec<Block>,
    /// Coordinates per axis.
    coords: Vec<Vec<f32>>,
    /// The constraint at every node ([`Obstacle::Constraint`] only).
    constraint: Vec<f32>,
}

/// One unit of work: rows `r0..r1` of plane `p`.
#[derive(Clone, Copy)]
struct Block {
    p: usize,
    r0: usize,
    r1: usize,
}

/// Per-thread scratch rows.
#[derive(Default)]
struct Scratch {
    dm: Vec<Vec<f32>>,
    dp: Vec<Vec<f32>>,
    ghosts: Vec<Vec<f32>>,
    padded: Vec<f32>,
    pad_dm: Vec<f32>,
    pad_dp: Vec<f32>,
    rate: Vec<f32>,
}

impl Scratch {
    /// Turns the one-sided derivatives of the first `len` nodes into the central gradient
    /// `(p- + p+)/2` (in `dm`) and the half jump `(p+ - p-)/2` (in `dp`).
    #[inline(always)]
    fn make_central(&mut self, len: usize) {
        for (m, p) in self.dm.iter_mut().zip(self.dp.iter_mut()) {
            for (a, b) in m[..len].iter_mut().zip(p[..len].iter_mut()) {
                let (lo, hi) = (*a, *b);
                *a = 0.5 * (lo + hi);
                *b = 0.5 * (hi - lo);
            }
        }
    }
}

impl Scratch {
    fn ensure(&mut self, dims: usize, len: usize) {
        for (v, count) in [
            (&mut self.dm, dims),
            (&mut self.dp, dims),
            (&mut self.ghosts, 7),
        ] {
            v.resize_with(count, Vec::new);
            for row in v.iter_mut() {
                row.resize(len, 0.0);
            }
        }
    }
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// Where an RK stage reads its `a * base` term from.
#[derive(Clone, Copy)]
enum Base<'a> {
    /// No base term (`a = 0`).
    Zero,
    /// A separate array.
    Slice(&'a [f32]),
    /// The output array's previous contents.
    Output,
}

/// The ghost value `|side|` nodes beyond a face (`side < 0`: below the lowest node, `side > 0`:
/// above the highest), from the face node `edge` and its inner neighbour `inner`.
///
/// The capped variants rest on monotonicity: more gap or more relative speed (leader faster
/// than the ego, ego faster than the follower) is never worse, so `V` is non-decreasing along
/// every axis (exactly so in the two-car and baseline games, by comparison of trajectories under
/// the same inputs; assumed for the IDM follower). Then beyond an upper face the face value is
/// a lower bound and the largest constraint value an upper bound; beyond a lower face the face
/// value is an upper bound and, for the sign of `V`, the grid's lowest constraint value a lower
/// one.
#[inline(always)]
fn ghost(edge: f32, inner: f32, side: f32, boundary: Boundary, caps: (f32, f32)) -> f32 {
    let extrapolated = edge + side.abs() * (edge - inner);
    match (boundary, side > 0.0) {
        (Boundary::Extrapolate, _) => extrapolated,
        (Boundary::Pessimistic, true) => edge,
        (Boundary::Pessimistic, false) => extrapolated.min(caps.0).min(edge),
        (Boundary::Optimistic, true) => extrapolated.max(caps.1),
        (Boundary::Optimistic, false) => edge,
    }
}

impl<G: Dynamics> Context<'_, G> {
    fn new<'g>(game: &'g G, grid: &'g Grid, numerics: Numerics) -> Context<'g, G> {
        let d = grid.dims();
        let coords: Vec<Vec<f32>> = grid
            .axes()
            .iter()
            .map(|a| (0..a.points).map(|i| a.coordinate(i) as f32).collect())
            .collect();
        // alpha and l are extremal at grid nodes for these games (piecewise linear in z).
        let (global_alpha, floor, top) = (0..grid.len())
            .into_par_iter()
            .map(|node| {
                let mut z = [0f64; MAX_DIMS];
                grid.node_coordinates(node, &mut z[..d]);
                let zf = z.map(|x| x as f32);
                let mut alpha = [0f32; MAX_DIMS];
                game.dissipation(&zf, &mut alpha);
                let l = game.constraint(&zf);
                (alpha, l, l)
            })
            .reduce(
                || ([0f32; MAX_DIMS], f32::INFINITY, f32::NEG_INFINITY),
                |(a, f, t), (b, g, u)| {
                    (core::array::from_fn(|k| a[k].max(b[k])), f.min(g), t.max(u))
                },
            );
        // The constraints here are 1-Lipschitz in the state (min of gaps), so three spacings
        // beyond the grid they are at most `top + 3 max spacing`.
        let reach = grid.axes().iter().map(|a| a.spacing()).fold(0.0, f64::max) as f32;
        let caps = (floor, top + 3.0 * reach);
        let n_rows = grid.axes()[d - 2].points;
        let n_last = grid.axes()[d - 1].points;
        let plane = n_rows * n_last;
        // Blocks of about 2k nodes: the scratch rows of all axes stay in the L2 cache, and there
        // are enough blocks to share out between threads.
        let rows_per_block = (2048 / n_last).clamp(1, n_rows);
        let mut blocks = Vec::new();
        for p in 0..grid.len() / plane {
            let mut r0 = 0;
            while r0 < n_rows {
                let r1 = (r0 + rows_per_block).min(n_rows);
                blocks.push(Block { p, r0, r1 });
                r0 = r1;
            }
        }
        let constraint = match numerics.obstacle {
            Obstacle::Freeze => Vec::new(),
            Obstacle::Constraint => constraint_values(game, grid),
        };
        Context {
            game,
            grid,
            numerics,
            global_alpha,
            caps,
            plane,
            blocks,
            coords,
            constraint,
        }
    }

    /// The output split into the blocks' slices.
    fn split<'o>(&self, mut out: &'o mut [f32], blocks: &[Block]) -> Vec<&'o mut [f32]> {
        let n_last = self.grid.axes()[self.grid.dims() - 1].points;
        let mut parts = Vec::with_capacity(blocks.len());
        for b in blocks {
            let (head, tail) = std::mem::take(&mut out).split_at_mut((b.r1 - b.r0) * n_last);
            parts.push(head);
            out = tail;
        }
        parts
    }

    /// The stable time step: `CFL / max_z sum_i alpha_i(z) / dx_i`.
    fn time_step(&self) -> f64 {
        let d = self.grid.dims();
        let inv_dx: Vec<f64> = self.grid.axes().iter().map(|a| 1.0 / a.spacing()).collect();
        let worst = match self.numerics.dissipation {
            Dissipation::Global => (0..d)
                .map(|k| f64::from(self.global_alpha[k]) * inv_dx[k])
                .sum::<f64>(),
            Dissipation::Local => (0..self.grid.len())
                .into_par_iter()
                .map(|node| {
                    let mut z = [0f64; MAX_DIMS];
                    self.grid.node_coordinates(node, &mut z[..d]);
                    let mut alpha = [0f32; MAX_DIMS];
                    self.game.dissipation(&z.map(|x| x as f32), &mut alpha);
                    (0..d).map(|k| f64::from(alpha[k]) * inv_dx[k]).sum::<f64>()
                })
                .reduce(|| 0.0, f64::max),
        };
        self.numerics.cfl / worst.max(1e-12)
    }

    /// One RK stage over the whole grid: `out = a * base + b * (inp + dt * L(inp))`, where
    /// `L` is the numerical Hamiltonian (with [`Obstacle::Freeze`], `min(0, .)` of it).
    fn stage(&self, inp: &[f32], base: Base<'_>, out: &mut [f32], a: f32, b: f32, dt: f32) {
        let parts = self.split(out, &self.blocks);
        let d = self.grid.dims();
        self.blocks
            .par_iter()
            .zip(parts)
            .for_each(|(block, out_block)| {
                SCRATCH.with(|cell| {
                    let mut scratch = cell.borrow_mut();
                    scratch.ensure(d, out_block.len());
                    stage_block(self, inp, base, out_block, *block, &mut scratch, a, b, dt)
                })
            })
    }

    /// Fills `scratch.dm[k]`, `scratch.dp[k]` with the one-sided derivatives along every axis
    /// at the nodes of `block`.
    #[inline(always)]
    fn derivatives(&self, inp: &[f32], block: Block, scratch: &mut Scratch) {
        let d = self.grid.dims();
        let axes = self.grid.axes();
        let strides = self.grid.strides();
        let n_rows = axes[d - 2].points;
        let n_last = axes[d - 1].points;
        let plane_start = block.p * self.plane;
        let (lo, hi) = (block.r0 * n_last, block.r1 * n_last);
        let len = hi - lo;
        let start = plane_start + lo;
        let boundary = self.numerics.boundary;
        let caps = self.caps;
        let scheme = self.numerics.spatial;
        // The plane's multi-index on the outer axes.
        let mut outer = [0usize; MAX_DIMS];
        let mut rest = block.p;
        for k in (0..d - 2).rev() {
            outer[k] = rest % axes[k].points;
            rest /= axes[k].points;
        }
        let Scratch {
            dm,
            dp,
            ghosts,
            padded,
            pad_dm,
            pad_dp,
            ..
        } = scratch;
        for k in 0..d {
            let boundary = if self.game.monotone_axis(k) {
                boundary
            } else {
                Boundary::Extrapolate
            };
            let inv_dx = (1.0 / axes[k].spacing()) as f32;
            let n = axes[k].points;
            if k < d - 2 {
                // Neighbouring blocks along an outer axis are contiguous at stride `strides[k]`.
                let i = outer[k];
                let block_at = |j: usize| &inp[start - i * strides[k] + j * strides[k]..][..len];
                for o in 0..7usize {
                    let j = i as isize + o as isize - 3;
                    if j < 0 || j >= n as isize {
                        let (edge, inner, dist) = if j < 0 {
                            (block_at(0), block_at(1), j as f32)
                        } else {
                            (
                                block_at(n - 1),
                                block_at(n - 2),
                                (j - n as isize + 1) as f32,
                            )
                        };
                        for ((slot, &e), &q) in ghosts[o][..len].iter_mut().zip(edge).zip(inner) {
                            *slot = ghost(e, q, dist, boundary, caps);
                        }
                    }
                }
                let row_refs: [&[f32]; 7] = core::array::from_fn(|o| {
                    let j = i as isize + o as isize - 3;
                    if j < 0 || j >= n as isize {
                        &ghosts[o][..len]
                    } else {
                        block_at(j as usize)
                    }
                });
                derivatives_row(
                    scheme,
                    &row_refs,
                    inv_dx,
                    &mut dm[k][..len],
                    &mut dp[k][..len],
                );
            } else {
                // Inner axes: one copy of the block with three ghost rows (axis d-2) or three
                // ghost nodes per line (axis d-1) on each side; the seven stencil rows are then
                // offsets into it.
                let plane = &inp[plane_start..plane_start + self.plane];
                if k == d - 2 {
                    let rows_here = block.r1 - block.r0;
                    padded.clear();
                    for j in block.r0 as isize - 3..block.r1 as isize + 3 {
                        if j >= 0 && j < n_rows as isize {
                            padded.extend_from_slice(&plane[j as usize * n_last..][..n_last]);
                        } else {
                            let (e, q, dist) = if j < 0 {
                                (0, 1, j as f32)
                            } else {
                                (n_rows - 1, n_rows - 2, (j - n_rows as isize + 1) as f32)
                            };
                            let edge = &plane[e * n_last..][..n_last];
                            let inner = &plane[q * n_last..][..n_last];
                            padded.extend(
                                edge.iter()
                                    .zip(inner)
                                    .map(|(&ev, &iv)| ghost(ev, iv, dist, boundary, caps)),
                            );
                        }
                    }
                    debug_assert_eq!(padded.len(), (rows_here + 6) * n_last);
                    derivatives_strided(
                        scheme,
                        padded,
                        n_last,
                        inv_dx,
                        &mut dm[k][..len],
                        &mut dp[k][..len],
                    );
                } else {
                    let width = n_last + 6;
                    padded.clear();
                    for line in plane[lo..hi].chunks(n_last) {
                        let (l0, l1) = (line[0], line[1]);
                        let (e0, e1) = (line[n_last - 1], line[n_last - 2]);
                        for dist in [-3.0, -2.0, -1.0] {
                            padded.push(ghost(l0, l1, dist, boundary, caps));
                        }
                        padded.extend_from_slice(line);
                        for dist in [1.0, 2.0, 3.0] {
                            padded.push(ghost(e0, e1, dist, boundary, caps));
                        }
                    }
                    let span = padded.len() - 6;
                    pad_dm.resize(span, 0.0);
                    pad_dp.resize(span, 0.0);
                    derivatives_strided(scheme, padded, 1, inv_dx, pad_dm, pad_dp);
                    for ((cm, cp), (sm, sp)) in dm[k][..len]
                        .chunks_mut(n_last)
                        .zip(dp[k][..len].chunks_mut(n_last))
                        .zip(pad_dm.chunks(width).zip(pad_dp.chunks(width)))
                    {
                        cm.copy_from_slice(&sm[..n_last]);
                        cp.copy_from_slice(&sp[..n_last]);
                    }
                }
            }
        }
    }

    /// Writes `out = a * base + b * (inp + dt * L)` over a block (`L = min(0, H_LF)` or `H_LF`,
    /// by [`Obstacle`]; the last stage caps at the step's start value or at `l`), from the central
    /// gradients and half jumps that [`Self::derivatives`] left in the scratch rows. The games'
    /// row form of the Hamiltonian is straight-line code, so every loop here vectorises.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn combine(
        &self,
        inp: &[f32],
        base: Base<'_>,
        out_block: &mut [f32],
        block: Block,
        scratch: &mut Scratch,
        a: f32,
        b: f32,
        dt: f32,
    ) {
        let d = self.grid.dims();
        let axes = self.grid.axes();
        let n_last = axes[d - 1].points;
        let start = block.p * self.plane + block.r0 * n_last;
        let len = out_block.len();
        let mut z = [0f32; MAX_DIMS];
        let mut rest = block.p;
        for k in (0..d - 2).rev() {
            z[k] = self.coords[k][rest % axes[k].points];
            rest /= axes[k].points;
        }
        let local = self.numerics.dissipation == Dissipation::Local;
        let Scratch { dm, dp, rate, .. } = scratch;
        rate.resize(len, 0.0);
        for (row, r) in (block.r0..block.r1).enumerate() {
            z[d - 2] = self.coords[d - 2][r];
            let span = row * n_last..(row + 1) * n_last;
            let pbar: [&[f32]; MAX_DIMS] =
                core::array::from_fn(|k| dm.get(k).map_or(&[][..], |v| &v[span.clone()]));
            let half_jump: [&[f32]; MAX_DIMS] =
                core::array::from_fn(|k| dp.get(k).map_or(&[][..], |v| &v[span.clone()]));
            self.game.lax_friedrichs_row(
                &z,
                &self.coords[d - 1],
                &pbar[..d],
                &half_jump[..d],
                local,
                &self.global_alpha,
                &mut rate[span],
            );
        }
        let inp = &inp[start..start + len];
        let rate = &mut rate[..len];
        if self.numerics.obstacle == Obstacle::Freeze {
            for r in rate.iter_mut() {
                *r = if *r < 0.0 { *r } else { 0.0 };
            }
        }
        let rate = &*rate;
        match base {
            Base::Zero | Base::Slice(_) => {
                let prev = match base {
                    Base::Slice(s) => &s[start..start + len],
                    _ => inp,
                };
                for c in 0..len {
                    out_block[c] = a * prev[c] + b * (inp[c] + dt * rate[c]);
                }
            }
            Base::Output => {
                // The last stage of a step: its base is the step's start value, which the exact
                // combination never exceeds; the `min` removes f32 rounding so that the value is
                // non-increasing in the horizon to the last bit (the variational inequality's
                // `V = min(V, ...)`).
                // It also holds the value at the grid's lowest constraint value `floor`: that
                // solves the game for `max(l, floor)`, whose value is `max(V, floor)` (max
                // distributes over the min in time), so the sign of V, and the safe set, are
                // unchanged, while states hopelessly unsafe stop drifting to minus infinity.
                // With `Obstacle::Constraint` the cap is the constraint instead.
                let floor = self.caps.0;
                if self.numerics.obstacle == Obstacle::Freeze {
                    for c in 0..len {
                        let v = a * out_block[c] + b * (inp[c] + dt * rate[c]);
                        let v = if v < out_block[c] { v } else { out_block[c] };
                        out_block[c] = if v > floor { v } else { floor };
                    }
                } else {
                    let l = &self.constraint[start..start + len];
                    for c in 0..len {
                        let v = a * out_block[c] + b * (inp[c] + dt * rate[c]);
                        let v = if v < l[c] { v } else { l[c] };
                        out_block[c] = if v > floor { v } else { floor };
                    }
                }
            }
        }
    }
}

/// `max |a - b|` over the nodes where `b > floor` (the others are pinned at the floor),
/// NaN-propagating (lane-wise maxima, so it vectorises).
/// One block of an RK stage: derivatives, central averages, and the combination.
///
/// Compiled twice, for the baseline x86-64 and for AVX2 + FMA, and chosen at run time by the
/// CPU's features (`multiversion`): the loops below (inlined here, so that they get the
/// features) vectorise 8 floats wide where the CPU allows, and the binary still runs on any
/// x86-64. The arithmetic is the same either way (Rust does not contract `a * b + c` into an
/// FMA), so results agree to the bit.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
#[allow(clippy::too_many_arguments)]
fn stage_block<G: Dynamics>(
    ctx: &Context<'_, G>,
    inp: &[f32],
    base: Base<'_>,
    out_block: &mut [f32],
    block: Block,
    scratch: &mut Scratch,
    a: f32,
    b: f32,
    dt: f32,
) {
    ctx.derivatives(inp, block, scratch);
    scratch.make_central(out_block.len());
    ctx.combine(inp, base, out_block, block, scratch, a, b, dt)
}

fn max_abs_difference(a: &[f32], b: &[f32], floor: f32) -> f32 {
    a.par_chunks(1 << 14)
        .zip(b.par_chunks(1 << 14))
        .map(|(x, y)| {
            let mut lanes = [0f32; 8];
            let mut nan = false;
            for (cx, cy) in x.chunks(8).zip(y.chunks(8)) {
                for ((l, &p), &q) in lanes.iter_mut().zip(cx).zip(cy) {
                    let d = if q > floor { (p - q).abs() } else { 0.0 };
                    nan |= p.is_nan();
                    *l = if d > *l { d } else { *l };
                }
            }
            if nan {
                f32::NAN
            } else {
                lanes.iter().copied().fold(0.0, f32::max)
            }
        })
        .reduce(|| 0.0, nan_max)
}

/// `max |min(a, cap) - b|` over the nodes where `b > floor`, NaN-propagating.
fn max_capped_difference(a: &[f32], b: &[f32], cap: &[f32], floor: f32) -> f32 {
    const CHUNK: usize = 1 << 14;
    a.par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .zip(cap.par_chunks(CHUNK))
        .map(|((x, y), c)| {
            let mut m = 0f32;
            let mut nan = false;
            for ((&p, &q), &l) in x.iter().zip(y).zip(c) {
                nan |= p.is_nan();
                let d = if q > floor { (p.min(l) - q).abs() } else { 0.0 };
                m = if d > m { d } else { m };
            }
            if nan {
                f32::NAN
            } else {
                m
            }
        })
        .reduce(|| 0.0, nan_max)
}

/// The larger of two, NaN if either is.
fn nan_max(p: f32, q: f32) -> f32 {
    if p.is_nan() || q.is_nan() {
        f32::NAN
    } else {
        p.max(q)
    }
}

/// Whether every value is finite.
fn all_finite(v: &[f32]) -> bool {
    v.par_chunks(1 << 14)
        .all(|c| c.iter().all(|x| x.is_finite()))
}

/// Solves the avoid game on `grid` from `V = l`, reporting `(time, residual, values)` after
/// each step to `progress`.
pub fn solve<G: Dynamics>(
    game: &G,
    grid: &Grid,
    numerics: Numerics,
    stop: Stop,
    mut progress: impl FnMut(f64, f64, &[f32]),
) -> Result<Solution, SolverError> {
    assert!(grid.dims() >= 2 && grid.dims() == game.dims());
    let ctx = Context::new(game, grid, numerics);
    let dt_max = ctx.time_step();
    let mut v = constraint_values(game, grid);
    let mut u = vec![0f32; v.len()];
    let mut w = vec![0f32; v.len()];
    let (horizon, tolerance) = match stop {
        Stop::Horizon(t) => (t, None),
        Stop::Converge {
            tolerance,
            max_time,
        } => (max_time, Some(tolerance)),
    };
    let mut time = 0.0f64;
    let mut steps = 0usize;
    let mut residual = f64::INFINITY;
    let mut outcome = Outcome::Horizon;
    while time < horizon - 1e-9 {
        // Equal steps that land exactly on the horizon.
        let remaining = horizon - time;
        let dt = if remaining <= dt_max {
            remaining
        } else {
            remaining / (remaining / dt_max).ceil()
        };
        let dtf = dt as f32;
        // After the first stage w = v + dt L(v): the residual max |L(v)| = max |w - v| / dt.
        ctx.stage(&v, Base::Zero, &mut w, 0.0, 1.0, dtf);
        // The rate the step really applies: under the constraint obstacle, where `V = l` and
        // `H_LF > 0` the cap holds `V` in place, so the rate is measured after the cap.
        let rate = match numerics.obstacle {
            Obstacle::Freeze => max_abs_difference(&w, &v, ctx.caps.0),
            Obstacle::Constraint => max_capped_difference(&w, &v, &ctx.constraint, ctx.caps.0),
        } / dtf;
        match numerics.rk {
            RkOrder::One => {
                let floor = ctx.caps.0;
                w.par_iter_mut()
                    .for_each(|x| *x = if *x > floor { *x } else { floor });
                std::mem::swap(&mut v, &mut w)
            }
            RkOrder::Two => ctx.stage(&w, Base::Output, &mut v, 0.5, 0.5, dtf),
            RkOrder::Three => {
                ctx.stage(&w, Base::Slice(&v), &mut u, 0.75, 0.25, dtf);
                ctx.stage(&u, Base::Output, &mut v, 1.0 / 3.0, 2.0 / 3.0, dtf);
            }
        }
        time += dt;
        steps += 1;
        if !(rate.is_finite() && all_finite(&v)) {
            return Err(SolverError::NonFinite { time });
        }
        residual = f64::from(rate);
        progress(time, residual, &v);
        if let Some(tol) = tolerance {
            if residual < tol {
                outcome = Outcome::Converged;
                break;
            }
            outcome = Outcome::NotConverged;
        }
    }
    Ok(Solution {
        values: v,
        time,
        steps,
        dt: dt_max,
        residual,
        outcome,
    })
}

/// The gradient `(p- + p+)/2` at every node, per axis: the co-state the numerical Hamiltonian
/// uses, so that policies read from it maximise the same Hamiltonian the solve integrated.
pub fn gradient<G: Dynamics>(
    game: &G,
    grid: &Grid,
    numerics: Numerics,
    values: &[f32],
) -> Vec<Vec<f32>> {
    let ctx = Context::new(game, grid, numerics);
    let d = grid.dims();
    let blocks = &ctx.blocks;
    let mut grads = vec![vec![0f32; values.len()]; d];
    let mut parts: Vec<Vec<&mut [f32]>> = Vec::new();
    for g in grads.iter_mut() {
        parts.push(ctx.split(g, blocks));
    }
    // Regroup per block: the k-th axis slice of every block.
    let mut per_block: Vec<Vec<&mut [f32]>> = (0..blocks.len()).map(|_| Vec::new()).collect();
    for axis_parts in parts {
        for (i, part) in axis_parts.into_iter().enumerate() {
            per_block[i].push(part);
        }
    }
    blocks
        .par_iter()
        .zip(per_block)
        .for_each(|(block, mut outs)| {
            SCRATCH.with(|cell| {
                let mut scratch = cell.borrow_mut();
                let len = outs[0].len();
                scratch.ensure(d, len);
                ctx.derivatives(values, *block, &mut scratch);
                for (k, out) in outs.iter_mut().enumerate() {
                    for (q, slot) in out.iter_mut().enumerate() {
                        *slot = 0.5 * (scratch.dm[k][q] + scratch.dp[k][q]);
                    }
                }
            })
        });
    grads
}
