//! What the engine needs of a game: the [`Dynamics`] trait, on states and co-states of
//! [`Vector`]s.

use crate::engine::grid::MAX_DIMS;

/// A state or co-state with room for every supported dimension.
pub type Vector = [f32; MAX_DIMS];

/// A differential game the level-set engine can solve: its state's dimension, its constraint,
/// its Hamiltonian and the dissipation the Lax-Friedrichs flux needs. The games
/// (`crate::games`) implement it; the engine knows nothing else of them.
pub trait Dynamics: Sync {
    /// The number of state axes.
    fn dims(&self) -> usize;
    /// The constraint `l(z)`; `l >= 0` is the allowed set.
    fn constraint(&self, z: &Vector) -> f32;
    /// `H(z, p) = max_u min_d p . f(z, u, d)`.
    fn hamiltonian(&self, z: &Vector, p: &Vector) -> f32;
    /// Per axis a bound `alpha_i(z) >= max_{u,d} |f_i(z, u, d)|` for the Lax-Friedrichs
    /// dissipation.
    fn dissipation(&self, z: &Vector, alpha: &mut Vector);
    /// Whether `V` is non-decreasing along `axis`, so that the pessimistic and optimistic ghost
    /// values of [`crate::engine::hji::Boundary`] bound the true ones there. Axes where it is not
    /// (or where nothing leaves the grid) take extrapolated ghosts. Default: every axis.
    fn monotone_axis(&self, _axis: usize) -> bool {
        true
    }

    /// The Lax-Friedrichs numerical Hamiltonian `H(z, pbar) + sum_k alpha_k(z) half_jump_k` along a
    /// row of the last axis: `z` holds the row's fixed coordinates, `last[c]` the last one, and
    /// `pbar[k][c]`, `half_jump[k][c]` the central gradient and `(p+ - p-)/2`. `alpha` is the
    /// global dissipation, used unless `local`. The games override it with straight-line code that
    /// the compiler vectorises; this default is the scalar reference.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn lax_friedrichs_row(
        &self,
        z: &Vector,
        last: &[f32],
        pbar: &[&[f32]],
        half_jump: &[&[f32]],
        local: bool,
        alpha: &Vector,
        rate: &mut [f32],
    ) {
        let d = self.dims();
        for (c, r) in rate.iter_mut().enumerate() {
            let mut zz = *z;
            zz[d - 1] = last[c];
            let mut a = *alpha;
            if local {
                self.dissipation(&zz, &mut a);
            }
            let mut p = [0f32; MAX_DIMS];
            let mut diss = 0.0;
            for k in 0..d {
                p[k] = pbar[k][c];
                diss += a[k] * half_jump[k][c];
            }
            *r = self.hamiltonian(&zz, &p) + diss;
        }
    }
}
