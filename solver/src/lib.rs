//! hjacc's solver: Hamilton-Jacobi-Isaacs solutions of the car-following games of Bahati,
//! Gibson & Bayen (arXiv:2112.14344), compiled into firmware safety tables and proven.
//!
//! # Architecture
//! Data flows one way: a config -> a game -> a solve -> a table -> a proof. Each step has its
//! own room:
//!
//! - [`engine`]: the numerics, knowing nothing of cars: the [`grid`], the level-set
//!   [`scheme`]s, the HJI time stepping ([`hji`]) and the sampled-data value iteration on
//!   breakpoint axes ([`semi_lagrangian`]).
//! - [`games`]: one file per game (dynamics, constraint, Hamiltonian, optimal inputs), and
//!   [`games::AnyGame`], the one place that lists them.
//! - [`pipeline`]: a run from a config to files: the [`config`]s, the level-set [`run`], the
//!   rear game's run ([`rear`]), the [`sweep`] over many rear configs, `solver verify` on a
//!   table file ([`verify_table`]), the table [`compile`]r, and the files and plots
//!   ([`output`]).
//! - [`proof`]: what is checked rather than computed: [`verify`] (an interval proof of the
//!   rear table, cell by cell), the measurement error's cost ([`robust`]), the [`trusted`]
//!   box of a level-set solve, and the [`exact`] values the schemes are tested against.
//!
//! - [`cli`]: what the command-line programs share.
//!
//! The modules are re-exported at the crate's root (`solver::verify`, `solver::rear`, ...),
//! the paths its users (host-tests, the Python module, the examples) name.
#![warn(missing_docs)]
// Index loops read best in the numerical kernels, where several arrays share one index.
#![allow(clippy::needless_range_loop)]

pub mod cli;
pub mod engine;
pub mod error;
pub mod games;
pub mod pipeline;
pub mod proof;

pub use engine::{grid, hji, scheme, semi_lagrangian};
pub use error::{ConfigError, SolverError};
pub use pipeline::{compile, config, output, palette, paper, rear, run, sweep, verify_table};
pub use proof::{exact, robust, trusted, verify};
