//! The proof side: what is checked rather than computed.
//!
//! - [`verify`]: the interval proof, cell by cell, that the rear table's certificate survives
//!   a control period under every admissible input;
//! - [`robust`]: the same table under the declared measurement error, as the firmware tests it;
//! - [`trusted`]: the box of a level-set solve where the grid's boundary does not matter;
//! - [`exact`]: the two-car game's exact value, against which the schemes are checked.

pub mod exact;
pub mod robust;
pub mod trusted;
pub mod verify;
