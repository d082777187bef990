//! Closed-loop simulation of three cars with the real firmware in the loop.
//!
//! The only way to believe the table and the firmware together is to drive them: [`sim`]
//! integrates a leader, the ego and a follower exactly between the firmware's 20 ms samples and
//! finds collisions inside each interval, not only at the samples; [`humans`] plays leaders and
//! followers that keep to the game's model (bounded leader, IDM follower with its time gap in
//! range, leaders that stop to standstill and go again) and a follower that does not (the
//! paper's baseline); [`world`] steps the loop one period at a time and judges the true state;
//! [`campaign`] samples starts over the whole certified set, standstill included, and reports
//! collisions, certificate losses (the true state leaving the certified set), minimum gaps,
//! time under override and jerk; [`falsify`] *searches* for what sampling misses: starts on the
//! certified boundary and at the domain's edges, humans chosen by cross-entropy, hill climbing
//! and greedy rollouts within the model; [`gap_policy`] tells what the gap policy and two braking
//! authorities cost in distance, and [`floor`] the least gap any certificate of the model can
//! give; [`move_off`] what a committed move-off from a standstill would certify; [`plots`] draws a trace and the gap policy. The ego is `firmware::Controller` itself, on
//! the same table bytes the target runs.
#![warn(missing_docs)]

pub mod campaign;
pub mod falsify;
pub mod floor;
pub mod gap_policy;
pub mod humans;
pub mod iso;
pub mod move_off;
pub mod plots;
pub mod scenarios;
pub mod sim;
pub mod world;

pub use campaign::{run_episode, run_group, Episode, GroupSummary, Outcome};
pub use humans::{Follower, Leader};
pub use sim::SensorModel;
