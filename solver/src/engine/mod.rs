//! The engine: numerics that know nothing of cars.
//!
//! - [`dynamics`]: what the engine needs of a game ([`dynamics::Dynamics`]);
//! - [`grid`]: uniform Cartesian grids (up to five axes, C order);
//! - [`scheme`]: the spatial derivatives of the level-set method (first order, ENO2, WENO5);
//! - [`hji`]: the HJI time stepping (Lax-Friedrichs flux, TVD Runge-Kutta, the obstacle, the
//!   grid's boundary) for any [`dynamics::Dynamics`];
//! - [`semi_lagrangian`]: the sampled-data value iteration on breakpoint axes for any
//!   [`semi_lagrangian::SampledGame`], which solves the rear game.

pub mod dynamics;
pub mod grid;
pub mod hji;
pub mod scheme;
pub mod semi_lagrangian;
