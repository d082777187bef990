//! hjacc's solver: Hamilton-Jacobi-Isaacs level-set solutions of the car-following games of
//! Bahati, Gibson & Bayen (arXiv:2112.14344), compiled into firmware safety tables.
//!
//! Data flows one way: [`config`] (a TOML file) -> [`games`] (dynamics and optimal inputs) ->
//! [`hji`] (the grid solve, with [`scheme`] for gradients on a [`grid`]) -> [`trusted`] (where
//! the grid boundary does not matter) -> [`compile`] (the quantized table and its error bound)
//! -> [`output`] (files and plots).
#![warn(missing_docs)]
// Index loops read best in the numerical kernels, where several arrays share one index.
#![allow(clippy::needless_range_loop)]

pub mod compile;
pub mod config;
pub mod error;
pub mod exact;
pub mod games;
pub mod grid;
pub mod hji;
pub mod output;
pub mod rear;
pub mod robust;
pub mod run;
pub mod scheme;
pub mod semi_lagrangian;
pub mod trusted;
pub mod verify;

pub use error::{ConfigError, SolverError};
