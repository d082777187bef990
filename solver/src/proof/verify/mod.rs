//! `verify`: an interval proof, cell by cell, of what the rear table the firmware runs
//! guarantees over one period, decided by computation over every state and every admissible
//! input, not by sampling.
//!
//! One responsibility: take a [`table_format::Game::ThreeCarSplit`] table's bytes and the
//! firmware's rear level, and prove or refute, for every cell the firmware may certify, that the
//! certificate survives one period.
//!
//! # What is checked
//! The firmware calls the rear half of a state `x = (gap_follower, follower_speed, ego_speed)`
//! certified when `W(x) > level`, where `W` is the table's multilinear interpolation of its
//! dequantized node values (the last gap face's smallest value beyond the grid, as the firmware
//! takes it) and `level = error_bound + rear_margin`. For every cell of the grid (a box between
//! consecutive breakpoints) that holds a point with `W > level`, `verify` checks the claim
//!
//! > for every `x` in the cell with `W(x) > level`, every ego acceleration signal in the band
//! > `[-beta, a_max]` and every time-gap signal in `[T_min, T_max]` held by the IDM follower,
//! > the gap stays above `min_gap` throughout `[0, P]` and `W(x(P)) > level`,
//!
//! for the period `P`. The ego's acceleration is any measurable signal in the band: a first-order
//! lag or a dead time between the command and the acceleration keeps the realised acceleration
//! in the band when every command is in it (the firmware's, in every mode), so the rear claim
//! holds for every delay; delays enter only the front half, whose value is in closed form.
//!
//! # How
//! A box `B` of states is advanced over `[0, P]` by interval bounds, each of them sound:
//! - the ego's speed and distance lie between those of constant braking at `beta` from the
//!   box's lowest speed and constant acceleration at `a_max` from its highest, speeds held in
//!   `[0, v_max]` (the saturated dynamics are monotone in the initial speed and the input);
//! - the follower's acceleration is bounded over a *tube* (every state the period can reach):
//!   starting from its clip `[a_min, a_max]`, the IDM is bounded over the tube that bound
//!   allows, and the tube is recomputed from the narrower bound (valid at every round: the
//!   trajectory lies in the tube of any bound it obeys). The IDM bound is exact in each of its
//!   monotone arguments (the gap, the ego's speed, the time gap) and takes the convex quadratic
//!   `v_f (T + (v_f - v_e) / (2 sqrt(a b)))` at its exact extremes over the follower's speeds;
//! - the follower's speed and distance then lie between those of its constant extreme
//!   accelerations; the gap at `P` between `gap_lo + ego_lo - follower_hi` and
//!   `gap_hi + ego_hi - follower_lo`, and the gap over the period above the exact minimum over
//!   `t` of `gap_lo + ego_lo(t) - follower_hi(t)` (a piecewise quadratic: its ends, kinks and
//!   critical points).
//!
//! The end box's smallest value of `W` is exact: on each piece between breakpoints `W` is
//! multilinear, so its extremes are at the piece's corners; the candidates are the box's ends
//! and every breakpoint inside it, per axis ([`table::Located::extremes`]). Before that, the
//! least and largest node of the cells the box touches bound `W` from both sides, and decide
//! most boxes without interpolating ([`Located::bounds`]). A box whose largest `W` is at
//! or below the level holds no certified state.
//!
//! A box that cannot be decided is refined, down to `max_depth` halvings:
//! - first *contracted*: a slab at one of its faces that holds no certified state carries no
//!   claim and is cut off (found by bisection on its depth; `contract`);
//! - then, if no period proves it and the standstill lemma (below) does not either, *halved*
//!   along the axis across which `W` changes most between its corners (`split_axis`), which
//!   separates the states above the level from those below it in fewer halvings than taking
//!   the axes in turn.
//!
//! What is left at `max_depth` is reported with its reason. A cell's search stops at its first
//! unproven sub-box unless [`Settings::exhaustive`] asks for its largest deficit; the verdict
//! is the same either way. The cells go in C order, a chunk at a time, and a [`Budget`] (wall
//! time, unproven cells) can stop the check between chunks: the cells not reached are
//! [`Verdict::Unchecked`], counted as certified and unproven, so the table's record is
//! incomplete and the firmware refuses it.
//!
//! Measured on the deployed table (the iterate the rear pipeline stops at, two cores): 5.5 M
//! boxes in about 14 s. Halving the axes in turn, without contraction or node bounds, took
//! 11.5 M boxes and 44 s on the table solved to a residual of `1e-5`, which these refinements
//! prove in 5.5 s.
//!
//! Arithmetic is `f64` on the table's `f32` values, every bound widened outward by `1e-9`
//! (relative, plus `1e-9` absolute), far above `f64` rounding over these few operations; the
//! firmware evaluates `W` in `f32` within about `1e-6` m, which the level check absorbs with a
//! `TOLERANCE` of `1e-5` m on both sides.
//!
//! # Why one period per state is enough
//! A box is proven when *one* of the listed periods takes every certified state of it to a
//! certified state, the gap above `min_gap` throughout. The period may differ from box to box:
//! it is a function of the state only, never of the inputs to come. So from a certified state
//! the times `t_{k+1} = t_k + P(x(t_k))` grow by at least the shortest period, every `x(t_k)` is
//! certified, and the gap stays above `min_gap` in between: the rear is safe for ever. (The
//! firmware re-checks every 20 ms; between the `t_k` the value may dip below the level, which
//! changes what it reports, not what is proven.) A table solved with a follower stronger than
//! its model (`follower_robustness`) lets the model's trajectories gain on the value at the
//! level set, and a longer period gains more than the interval bounds lose, up to about 0.3 s.
//!
//! # The standstill lemma
//! At a rest point behind the ego the follower is at rest with its IDM braking, the ego may stay
//! at rest, and nothing moves: the level set passes through a continuum of equilibria, where no
//! box proof closes. There a closed-form argument takes over. With the gap at most `G`, where
//! `a (1 - (s0 / G)^2) <= a_min` (`G = s0 / sqrt(1 - a_min / a)`, 0.756 m for the deployment),
//! the IDM asks for `a_min` or harder whatever the speeds and the time gap (`s* >= s0`), so the
//! follower brakes at its clip `a_min` until it stops, and covers at most `v_f^2 / (2 |a_min|)`;
//! the ego never moves backwards, and covers at least what braking at `beta` leaves it. So from
//! a state whose least gap under those two motions exceeds `min_gap` the gap stays above
//! `min_gap` for as long as it is at most `G`; it can only leave through
//! `gap = G`, growing, with the follower no faster than it was and no faster than the ego. A
//! box that no period proves, with `gap <= G / 2` and that bound (sharpened by the ego's least
//! travel, braking at `beta` from its lowest speed), is proven by the lemma when every state
//! `(G, v_f, v_e >= v_f)` it can leave through is certified (checked once over slices of `v_f`
//! up to the largest speed that passes, which bounds the lemma boxes' follower speed), and so
//! lies in a box the periods prove (a lemma box has `gap <= G / 2`, so each stay in the
//! lemma's region ends, if it ends, in a period's proof).
//!
//! # What is *not* provable this way, and why
//! A box that straddles the level set `{W = level}` contains states with `W` below the level
//! whose images the interval bounds must include. For a value function that is the infimum of
//! the future gap, `W` is constant along the worst case, so the images of the states just below
//! the level stay below it: no one-step box proof can close there, however fine the boxes
//! ([`Reason::Tangency`]). What `verify` still proves there is the *dip*: the largest amount by
//! which `W` can fall below the level in one period from a certified state.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;
use table_format::Table;

use crate::error::SolverError;

mod interval;
mod model;
mod table;

use interval::widen_down;
pub use interval::{Interval, StateBox};
use model::least_difference;
pub use model::{travel, Reach, RearModel};
pub use table::{Located, RearTable};

/// The version of what `verify` proves, recorded in the tables it checks
/// ([`table_format::Verification::verifier`]). Version 2 also bounds the value at every
/// multiple of the shortest period inside each proving period
/// ([`table_format::REAR_SAMPLE_TOLERANCE`]).
pub const VERSION: u16 = table_format::REAR_SAMPLE_VERIFIER;

/// Slack on both sides of the level, m: the firmware's `f32` interpolation is within about
/// `1e-6` m of the exact one.
pub const TOLERANCE: f64 = 1e-5;

/// Why a cell could not be proven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// The gap can reach `min_gap` within the period from a certified state of the box.
    Collision,
    /// The box straddles the level set: states below the level map near it (module docs).
    Tangency,
    /// Every state of the box is certified, yet the period can take one below the level: the
    /// table's own resolution (or a real loss of the certificate).
    Resolution,
}

/// One cell's verdict.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Verdict {
    /// No state of the cell is certified.
    NotCertified,
    /// Every certified state of the cell stays certified through a period.
    Proven,
    /// As [`Verdict::Proven`], with the standstill lemma for some of its sub-boxes.
    ProvenAtStandstill,
    /// Some sub-box could not be decided at the finest depth.
    Unproven {
        /// The reason of the sub-box with the largest deficit found (the first unproven one
        /// unless [`Settings::exhaustive`]).
        reason: Reason,
        /// How far below the level the images of that sub-box's states may fall, m (a bound;
        /// over every unproven sub-box with [`Settings::exhaustive`]).
        deficit: f64,
    },
    /// Not checked: the budget ran out first ([`Budget`]). Counted as certified and unproven,
    /// so that a table with unchecked cells never carries a complete record.
    Unchecked,
}

/// The checker's settings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Settings {
    /// The periods a box may be advanced by, s: a box is proven when one of them takes every
    /// certified state of it to a certified state (module docs: why one per state suffices).
    pub periods: Vec<f64>,
    /// The firmware's `rear_margin`, m: the level is the table's error bound plus this.
    pub rear_margin: f64,
    /// How many times a box may be halved.
    pub max_depth: u32,
    /// When to stop early, leaving the cells not yet checked [`Verdict::Unchecked`].
    pub budget: Budget,
    /// Search every sub-box of an unproven cell for its largest deficit, instead of stopping
    /// at the first sub-box found unproven (whose deficit then bounds the cell's from below).
    /// The verdicts are the same either way; the search can take long on a table with many
    /// unproven cells.
    pub exhaustive: bool,
    /// The measurement error the table is checked under ([`crate::proof::robust`]), recorded in
    /// its header ([`table_format::Verification::measurement_error`]). The proof itself is
    /// about true states; a complete one also places every measured state the firmware's test
    /// passes in proven cells, under any error: a box whose least value exceeds the level lies
    /// in the certified set, so every cell it touches has a corner above the level (the
    /// multilinear interpolant's largest value on a cell is at a corner), is certified, and was
    /// proven. The record says which error the table's figures and checks were made for, so
    /// that the firmware can refuse a table checked for less than it declares.
    pub measurement_error: table_format::MeasurementError,
}

/// When `verify` stops before every cell is checked. The cells go in C order (the gap to the
/// follower slowest, so the smallest gaps, where the level set lies, come first), a few
/// thousand at a time; the budget is looked at between those chunks.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Budget {
    /// Stop once this much wall time has passed, s (`None`: no limit).
    pub seconds: Option<f64>,
    /// Stop once this many certified cells are found unproven (`None`: no limit): a table
    /// that cannot be proven fails fast, naming those cells.
    pub unproven_cells: Option<usize>,
}

/// Why `verify` stopped before checking every cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stopped {
    /// [`Budget::seconds`] ran out.
    Time,
    /// [`Budget::unproven_cells`] cells were found unproven.
    UnprovenCells,
}

impl Default for Settings {
    /// The firmware's period, and 0.1, 0.2 and 0.3 s (the longer ones let a table solved with
    /// a follower stronger than its model gain the slack its level set needs); 21 halvings; no
    /// budget; an unproven cell's search stops at its first unproven sub-box.
    fn default() -> Self {
        Settings {
            periods: vec![0.02, 0.1, 0.2, 0.3],
            rear_margin: 0.0,
            max_depth: 21,
            budget: Budget::default(),
            exhaustive: false,
            measurement_error: table_format::MeasurementError::default(),
        }
    }
}

/// The standstill lemma on one box (module docs): its gap at most `G / 2`, its follower no
/// faster than the exit check's speed, and the gap's least value above `min_gap` while the ego
/// brakes at `beta` from its lowest speed and the follower at its clip from its highest, until
/// both stop.
fn standstill_proves(m: &RearModel, b: &StateBox, z: Standstill) -> bool {
    let (ve, vf) = (b.ego_speed.lo, b.follower_speed.hi);
    // After both have stopped (or the follower, if the ego cannot brake) the gap no longer
    // shrinks.
    let ego_stops = if m.ego_min < 0.0 {
        ve / -m.ego_min
    } else {
        0.0
    };
    let until = ego_stops.max(vf / m.clip_min().abs()) + 1.0;
    let least = b.gap.lo + least_difference(ve, m.ego_min, vf, m.clip_min(), until, m.max_speed);
    b.gap.hi <= 0.5 * z.gap && vf <= z.exit_speed && widen_down(least) > m.min_gap
}

/// Bisection steps per face in [`contract`]: a face moves in by a multiple of 1/64 of the
/// box's width.
const CONTRACTION_STEPS: u32 = 6;

/// The box without the slabs at its faces that hold no certified state (every value in them
/// at or below `level - TOLERANCE`, exactly: [`RearTable::extremes`]).
///
/// Why it is sound: the claim is about the certified states of a box only, and a slab without
/// one carries no claim. Why it pays: a box the level set crosses holds states below the level
/// whose images fall below it; halving alone cuts them off only after many halvings along
/// axes that do not separate them, contraction cuts them off at once. Measured on the deployed
/// table with the value-guided halving below: 5.6 M boxes without, 2.3 M with.
fn contract(table: &RearTable, b: &StateBox, level: f64) -> StateBox {
    let mut out = *b;
    let mut located = table.locate(&out);
    let mut corners = located.corners();
    for k in 0..3 {
        let bit = 4 >> k;
        for upper in [false, true] {
            // A face with a corner above the level is not empty: no slab to cut there (the
            // common case, decided without a search).
            let face_above = corners.is_some_and(|w| {
                (0..8)
                    .filter(|c| (c & bit != 0) == upper)
                    .any(|c| w[c] > level - TOLERANCE)
            });
            if face_above {
                continue;
            }
            let i = out.axis(k);
            let width = i.hi - i.lo;
            // The slab at this face, `f` of the box's width deep.
            let slab = |f: f64| {
                if upper {
                    Interval::new(i.hi - f * width, i.hi)
                } else {
                    Interval::new(i.lo, i.lo + f * width)
                }
            };
            // (A slab past the grid's gaps reads what the box's own outside reads.)
            let empty = |f: f64| {
                if k == 0 {
                    table.extremes(&out.with_axis(k, slab(f))).hi <= level - TOLERANCE
                } else {
                    located.with_axis(k, slab(f)).extremes().hi <= level - TOLERANCE
                }
            };
            if !empty(0.0) {
                continue;
            }
            // The widest empty slab, by bisection on its depth (its largest value grows with
            // it).
            let (mut good, mut bad) = (0.0f64, 1.0f64);
            for _ in 0..CONTRACTION_STEPS {
                let mid = 0.5 * (good + bad);
                if empty(mid) {
                    good = mid;
                } else {
                    bad = mid;
                }
            }
            if good > 0.0 {
                let cut = good * width;
                out = out.with_axis(
                    k,
                    if upper {
                        Interval::new(i.lo, i.hi - cut)
                    } else {
                        Interval::new(i.lo + cut, i.hi)
                    },
                );
                located = table.locate(&out);
                corners = located.corners();
            }
        }
    }
    out
}

/// The axis to halve a box along: the one across which `W` changes most between the box's
/// corners, so that the halves separate states above the level from those below it.
///
/// Halving the axes in turn spent most of the subdivision along the level set instead of
/// across it: measured on the deployed table, 11.5 M boxes in turn and 5.6 M this way.
fn split_axis(table: &RearTable, b: &StateBox) -> usize {
    // A box reaching outside the grid's gaps: split the gap first.
    let Some(w) = table.locate(b).corners() else {
        return 0;
    };
    let mut best = (0usize, -1.0f64);
    for (k, bit) in [(0usize, 4usize), (1, 2), (2, 1)] {
        let change = (0..8)
            .filter(|c| c & bit == 0)
            .map(|c| (w[c | bit] - w[c]).abs())
            .fold(0.0, f64::max);
        if change > best.1 {
            best = (k, change);
        }
    }
    best.0
}

/// Verifies one cell (module docs).
pub fn verify_cell(table: &RearTable, cell: &StateBox, level: f64, s: &Settings) -> Verdict {
    verify_cell_with(table, cell, level, s, None).0
}

/// A bound (m, at least 0) on how far `W` can read below `level` at the multiples of `sample`
/// strictly inside `(0, period)`, from any state of `b`, exact enough to decide whether it is
/// within `limit` (module docs: the samples between the proof's periods).
///
/// The period's tube holds every sample's states: where its node bounds keep the dip within
/// `limit`, that bound is the answer; otherwise each sample is bounded in turn, by its node
/// bounds and, where they do not suffice, exactly.
fn sample_dip(
    table: &RearTable,
    b: &StateBox,
    reach: &Reach,
    (period, sample): (f64, f64),
    level: f64,
    limit: f64,
) -> f64 {
    if period <= sample + 1e-9 {
        return 0.0;
    }
    let whole = (level - table.node_bounds(&reach.tube).lo).max(0.0);
    if whole <= limit {
        return whole;
    }
    let mut dip = 0f64;
    let mut k = 1u32;
    while f64::from(k) * sample < period - 1e-9 {
        // The period's bound on the follower's acceleration holds within it.
        let t = f64::from(k) * sample;
        let end = table.locate(
            &table
                .model
                .reach_within(b, t, reach.follower_acceleration, 0)
                .end,
        );
        let bound = level - end.bounds().lo;
        dip = dip.max(if bound <= limit {
            bound
        } else {
            level - end.extremes().lo
        });
        k += 1;
    }
    dip
}

/// [`verify_cell`], with the standstill lemma where its exit check passed.
fn verify_cell_with(
    table: &RearTable,
    cell: &StateBox,
    level: f64,
    s: &Settings,
    lemma: Option<Standstill>,
) -> (Verdict, f64) {
    debug_assert!(!s.periods.is_empty());
    let shortest = s.periods.iter().copied().fold(f64::INFINITY, f64::min);
    let sample_limit = f64::from(table_format::REAR_SAMPLE_TOLERANCE) - TOLERANCE;
    let mut cell_dip = 0f64;
    let mut by_lemma = false;
    let mut certified = false;
    let mut worst: Option<(Reason, f64)> = None;
    let mut stack = vec![(*cell, 0u32)];
    while let Some((b, depth)) = stack.pop() {
        // Whether the box holds a certified state: the node bounds decide it unless the level
        // lies between them.
        let here = table.locate(&b);
        let bounds = here.bounds();
        if bounds.hi <= level - TOLERANCE {
            continue;
        }
        let w = if bounds.lo > level - TOLERANCE {
            bounds
        } else {
            here.extremes()
        };
        if w.hi <= level - TOLERANCE {
            continue;
        }
        certified = true;
        let b = if w.lo <= level - TOLERANCE {
            contract(table, &b, level)
        } else {
            b
        };
        // The period that does best for this box: proven by it, or else the least deficit.
        let mut best: Option<(bool, f64)> = None;
        let mut proven = false;
        for &period in &s.periods {
            let reach = table.model.reach(&b, period);
            let safe = reach.least_gap > table.model.min_gap;
            let there = table.locate(&reach.end);
            let end = match there.bounds().lo {
                lo if lo > level + TOLERANCE => lo,
                _ => there.extremes().lo,
            };
            if safe && end > level + TOLERANCE {
                let dip = sample_dip(table, &b, &reach, (period, shortest), level, sample_limit);
                if dip <= sample_limit {
                    cell_dip = cell_dip.max(dip);
                    proven = true;
                    break;
                }
            }
            let better = match best {
                None => true,
                Some((was_safe, was_end)) => {
                    (safe && !was_safe) || (safe == was_safe && end > was_end)
                }
            };
            if better {
                best = Some((safe, end));
            }
        }
        if proven {
            continue;
        }
        if let Some(z) = lemma {
            if standstill_proves(&table.model, &b, z) {
                by_lemma = true;
                continue;
            }
        }
        if depth < s.max_depth {
            let axis = split_axis(table, &b);
            let (a, c) = b.axis(axis).halves();
            stack.push((b.with_axis(axis, a), depth + 1));
            stack.push((b.with_axis(axis, c), depth + 1));
            continue;
        }
        let (safe, end) = best.unwrap_or((false, f64::NEG_INFINITY));
        let reason = if !safe {
            Reason::Collision
        } else if table.extremes(&b).lo <= level + TOLERANCE {
            Reason::Tangency
        } else {
            Reason::Resolution
        };
        let deficit = (level + TOLERANCE - end).max(0.0);
        if worst.is_none_or(|(_, d)| deficit > d || reason == Reason::Collision) {
            worst = Some((reason, deficit));
        }
        if !s.exhaustive {
            break;
        }
    }
    let verdict = match worst {
        None if !certified => Verdict::NotCertified,
        None if by_lemma => Verdict::ProvenAtStandstill,
        None => Verdict::Proven,
        Some((reason, deficit)) => Verdict::Unproven { reason, deficit },
    };
    (verdict, cell_dip)
}

/// The standstill lemma's gap `G` (module docs): `s0 / sqrt(1 - a_min / a)`, where the IDM
/// asks for the follower's clip `a_min` or harder whatever the speeds; `None` if the model has
/// no such gap.
pub fn standstill_gap(m: &RearModel) -> Option<f64> {
    m.follower.braking_gap(m.clip_min())
}

/// The standstill lemma's exit check (module docs): the largest follower speed `V` (a multiple
/// of 0.05 m/s, at most 5 m/s) such that every state `(G, v_f, v_e >= v_f)` with `v_f <= V` is
/// certified, over slices of 0.05 m/s of `v_f`, each with `v_e` over `[slice's lowest, v_max]`
/// (a superset); `None` if not even the slowest slice is.
pub fn standstill_exit_speed(table: &RearTable, g: f64, level: f64) -> Option<f64> {
    let m = &table.model;
    let slices = (5.0f64.min(m.max_speed) / 0.05) as u32;
    let passed = (0..slices)
        .take_while(|&i| {
            let v = 0.05 * f64::from(i);
            let face = StateBox {
                gap: Interval::new(g, g),
                follower_speed: Interval::new(v, v + 0.05),
                ego_speed: Interval::new(v, m.max_speed),
            };
            table.extremes(&face).lo > level + TOLERANCE
        })
        .count();
    (passed > 0).then_some(0.05 * passed as f64)
}

/// The standstill lemma's region: gap `G` and the exit check's follower speed `V`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Standstill {
    /// `G`, m.
    #[serde(rename = "gap_m")]
    pub gap: f64,
    /// `V`, m/s.
    #[serde(rename = "exit_speed_m_per_s")]
    pub exit_speed: f64,
}

/// One unproven cell of the report.
#[derive(Debug, Clone, Serialize)]
pub struct UnprovenCell {
    /// Breakpoint indices of the cell's lower corner.
    pub index: [usize; 3],
    /// The cell.
    pub cell: StateBox,
    /// Why.
    pub reason: Reason,
    /// How far below the level its certified states' images may fall, m (see
    /// [`Verdict::Unproven`]).
    #[serde(rename = "deficit_m")]
    pub deficit: f64,
}

/// What `verify` found.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The settings.
    pub settings: Settings,
    /// The level the firmware certifies above, m (`error_bound + rear_margin`).
    #[serde(rename = "level_m")]
    pub level: f64,
    /// The table's error bound, m.
    #[serde(rename = "error_bound_m")]
    pub error_bound: f64,
    /// The table's CRC-32 (its trailer), hex.
    pub table_crc32: String,
    /// Cells in the grid.
    pub cells: usize,
    /// Cells holding a certified state (and the cells not checked, which may).
    pub certified: usize,
    /// Certified cells proven.
    pub proven: usize,
    /// Of those, cells with sub-boxes proven by the standstill lemma (module docs).
    pub proven_at_standstill: usize,
    /// The standstill lemma's region, when its exit check passed.
    pub standstill: Option<Standstill>,
    /// `proven / certified`.
    pub proven_share: f64,
    /// Unproven cells per reason.
    pub unproven_by_reason: UnprovenCounts,
    /// Cells not checked because the budget ran out (counted in `certified`, not in
    /// `proven`).
    pub unchecked: usize,
    /// Why the check stopped early, if it did.
    pub stopped: Option<Stopped>,
    /// The largest deficit among the unproven cells: how far below the level the images of
    /// their certified states may fall, under the best of the periods (0 when every cell is
    /// proven), m.
    #[serde(rename = "largest_unproven_deficit_m")]
    pub dip: f64,
    /// The largest amount by which `W` can read below the level at a multiple of the shortest
    /// period inside the period that proves a box, over every box proven by a period (the
    /// standstill lemma's sub-boxes excepted), m; a box is proven only when this is within
    /// [`table_format::REAR_SAMPLE_TOLERANCE`].
    #[serde(rename = "largest_dip_between_samples_m")]
    pub sample_dip: f64,
    /// Wall time, s.
    #[serde(rename = "wall_s")]
    pub seconds: f64,
    /// Every unproven cell.
    pub unproven: Vec<UnprovenCell>,
    /// Every cell's verdict, in C order (not written to the JSON report).
    #[serde(skip)]
    pub verdicts: Vec<Verdict>,
}

impl Report {
    /// The record a table carries of this report.
    pub fn record(&self) -> table_format::Verification {
        let periods = &self.settings.periods;
        table_format::Verification {
            verifier: VERSION,
            rear_margin: self.settings.rear_margin as f32,
            certified_cells: u32::try_from(self.certified).unwrap_or(u32::MAX),
            proven_cells: u32::try_from(self.proven).unwrap_or(u32::MAX),
            shortest_period: periods.iter().copied().fold(f64::INFINITY, f64::min) as f32,
            longest_period: periods.iter().copied().fold(0.0, f64::max) as f32,
            measurement_error: self.settings.measurement_error,
        }
    }
}

/// Verifies a split table's bytes with `settings`; returns the table as `verify` reads it, the
/// report, and the bytes with the report's record in the header.
pub fn verify_bytes(
    bytes: &[u8],
    settings: &Settings,
) -> Result<(RearTable, Report, Vec<u8>), SolverError> {
    verify_bytes_with_progress(bytes, settings, &[], &mut |_, _| {})
}

/// [`verify_bytes`], with the suspects first and progress reported as
/// [`verify_suspects_first`] does.
pub fn verify_bytes_with_progress(
    bytes: &[u8],
    settings: &Settings,
    suspects: &[usize],
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(RearTable, Report, Vec<u8>), SolverError> {
    let table = Table::parse(bytes)?;
    let rear = RearTable::from_table(&table)?;
    let report = verify_suspects_first(
        &rear,
        table_format::CRC32.checksum(bytes),
        settings,
        suspects,
        progress,
    );
    let recorded = table_format::with_verification(bytes, report.record())?;
    Ok((rear, report, recorded))
}

/// Unproven cells per reason.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct UnprovenCounts {
    /// [`Reason::Collision`].
    pub collision: usize,
    /// [`Reason::Tangency`].
    pub tangency: usize,
    /// [`Reason::Resolution`].
    pub resolution: usize,
}

/// Verifies every cell of a rear table.
pub fn verify(table: &RearTable, crc: u32, s: &Settings) -> Report {
    verify_with_progress(table, crc, s, &mut |_, _| {})
}

/// Cells checked between two looks at the budget and two progress reports: small enough that
/// a budget is kept within a fraction of a second, large enough for the cores to share.
const CHUNK: usize = 4096;

/// [`verify`], calling `progress(cells checked, cells)` after each chunk of cells (on the
/// calling thread).
pub fn verify_with_progress(
    table: &RearTable,
    crc: u32,
    s: &Settings,
    progress: &mut dyn FnMut(usize, usize),
) -> Report {
    verify_suspects_first(table, crc, s, &[], progress)
}

/// [`verify_with_progress`], checking the cells `suspects` (indices in C order, as
/// [`UnprovenCell::index`] flattened) before the others: with a budget of unproven cells, a
/// table that fails where an earlier one failed fails at once (the rear pipeline passes the
/// cells its earlier attempts found unproven). The verdicts do not depend on the order.
pub fn verify_suspects_first(
    table: &RearTable,
    crc: u32,
    s: &Settings,
    suspects: &[usize],
    progress: &mut dyn FnMut(usize, usize),
) -> Report {
    let t0 = Instant::now();
    let level = table.error_bound + s.rear_margin;
    let [ni, nj, nk] = table.cells();
    let total = ni * nj * nk;
    let lemma = standstill_gap(&table.model).and_then(|gap| {
        standstill_exit_speed(table, gap, level).map(|exit_speed| Standstill { gap, exit_speed })
    });
    // The order: the suspects (once each), then every other cell in C order.
    let mut first = vec![false; total];
    let mut order: Vec<usize> = Vec::with_capacity(total);
    for &n in suspects {
        if n < total && !first[n] {
            first[n] = true;
            order.push(n);
        }
    }
    let suspected = order.len();
    order.extend((0..total).filter(|&n| !first[n]));
    let mut results: Vec<(Verdict, f64)> = vec![(Verdict::Unchecked, 0.0); total];
    let mut done = 0usize;
    let mut unproven_so_far = 0usize;
    let mut stopped = None;
    while done < total {
        if s.budget
            .seconds
            .is_some_and(|limit| t0.elapsed().as_secs_f64() >= limit)
        {
            stopped = Some(Stopped::Time);
            break;
        }
        if s.budget
            .unproven_cells
            .is_some_and(|limit| unproven_so_far >= limit)
        {
            stopped = Some(Stopped::UnprovenCells);
            break;
        }
        // The suspects make a chunk of their own.
        let size = if done < suspected {
            suspected - done
        } else {
            CHUNK
        };
        let chunk = &order[done..(done + size).min(total)];
        let part: Vec<(Verdict, f64)> = chunk
            .par_iter()
            .map(|&n| {
                let (i, j, k) = (n / (nj * nk), (n / nk) % nj, n % nk);
                verify_cell_with(table, &table.cell(i, j, k), level, s, lemma)
            })
            .collect();
        for (&n, r) in chunk.iter().zip(part) {
            unproven_so_far += usize::from(matches!(r.0, Verdict::Unproven { .. }));
            results[n] = r;
        }
        done += chunk.len();
        progress(done, total);
    }
    let sample_dip = results.iter().map(|r| r.1).fold(0.0, f64::max);
    let verdicts: Vec<Verdict> = results.into_iter().map(|r| r.0).collect();
    let mut counts = UnprovenCounts::default();
    let mut unproven = Vec::new();
    let (mut certified, mut proven, mut proven_at_standstill, mut unchecked) = (0, 0, 0, 0);
    let mut dip = 0f64;
    for (n, v) in verdicts.iter().enumerate() {
        match *v {
            Verdict::NotCertified => {}
            Verdict::Proven => {
                certified += 1;
                proven += 1;
            }
            Verdict::ProvenAtStandstill => {
                certified += 1;
                proven += 1;
                proven_at_standstill += 1;
            }
            Verdict::Unchecked => {
                certified += 1;
                unchecked += 1;
            }
            Verdict::Unproven { reason, deficit } => {
                certified += 1;
                dip = dip.max(deficit);
                match reason {
                    Reason::Collision => counts.collision += 1,
                    Reason::Tangency => counts.tangency += 1,
                    Reason::Resolution => counts.resolution += 1,
                }
                let index = [n / (nj * nk), (n / nk) % nj, n % nk];
                unproven.push(UnprovenCell {
                    index,
                    cell: table.cell(index[0], index[1], index[2]),
                    reason,
                    deficit,
                });
            }
        }
    }
    Report {
        settings: s.clone(),
        level,
        error_bound: table.error_bound,
        table_crc32: format!("{crc:08x}"),
        cells: verdicts.len(),
        certified,
        proven,
        proven_at_standstill,
        standstill: lemma,
        proven_share: if certified == 0 {
            1.0
        } else {
            proven as f64 / certified as f64
        },
        unproven_by_reason: counts,
        unchecked,
        stopped,
        dip,
        sample_dip,
        seconds: t0.elapsed().as_secs_f64(),
        unproven,
        verdicts,
    }
}
