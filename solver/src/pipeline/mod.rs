//! The pipeline: from a config to the files a user reads and the table the firmware runs.
//!
//! - [`config`]: the level-set configs (TOML), validated with the key and line of each error;
//! - [`run`]: one level-set run (solve, trusted box, policy, table, plots);
//! - [`rear`]: one rear-game run (value iteration, table, proof);
//! - [`sweep`]: many rear configs made from one, solved, proven and compared;
//! - [`verify_table`]: `solver verify` on a table file, its report and plots;
//! - [`compile`]: values to a quantized, interpolated table with its error bound;
//! - `plots`: what a level-set run draws, and where;
//! - [`paper`]: the paper's Fig. 3 from the baseline's and the IDM formulation's runs;
//! - [`table_plots`]: what a split table certifies, and verify's verdicts over it;
//! - [`proof_plots`]: the proof's verdicts and the measured states under error, drawn;
//! - [`output`]: the files (`.npy`, JSON, tables) and the plots' drawing;
//! - [`palette`]: the plots' colours, once.

pub mod compile;
pub mod config;
pub mod output;
pub mod palette;
pub mod paper;
mod plots;
pub mod proof_plots;
pub mod rear;
pub mod run;
pub mod sweep;
pub mod table_plots;
pub mod verify_table;
