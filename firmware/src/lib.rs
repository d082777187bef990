//! The ACC safety controller that runs the solver's table on a microcontroller.
//!
//! Not written yet: this crate only reserves its place in the workspace and proves that it
//! cross-builds for `thumbv7em-none-eabihf` together with `table-format`. The control loop is
//! tracked in its own issue.
#![no_std]
#![warn(missing_docs)]

pub use table_format;
