//! The rear game's pipeline: a `[rear]` TOML config -> the sampled-data value on breakpoint
//! axes -> a `ThreeCarSplit` table -> `verify` -> the table with the proof's record, its
//! summary and the verify report.
//!
//! One responsibility: turn a rear config into files. The game is [`crate::games::RearGame`],
//! the scheme [`crate::engine::semi_lagrangian`]; why the split and why that scheme is written
//! there.
//!
//! # The table is the solver's value, not an approximation of it
//! The sampled-data iteration defines its value between nodes by multilinear interpolation, and
//! the table stores the same nodes and interpolates the same way. So the table's interpolant
//! *is* the solver's value function, and its only error against it is quantization, which is
//! rounded down (`V_table <= W`). The error bound's interpolation term is zero by construction.

use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};
use table_format::authority::Braking;
use table_format::{
    Axis, Bounds, EmergencyDeclaration, FollowerModel, Game, Horizon, HorizonStatus, Spacing,
    TableContents, ValueBits, MAX_REACTION_TIME,
};

use crate::engine::semi_lagrangian::{Breakpoints, Iteration};
use crate::error::{ConfigError, SolverError};
use crate::games::{Accel, RearGame};
use crate::pipeline::config::{
    check, check_memory, check_name, idm_parameters, locate, parse_toml, IdmConfig, Range,
    SAMPLED_BYTES_PER_NODE,
};
use crate::pipeline::output;
use crate::proof::verify::{
    verify_bytes_with_progress, Budget, RearTable, Report, Settings as VerifySettings,
};

/// A breakpoint axis: from `start`, uniform pieces `[end, spacing]` in turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PiecewiseAxis {
    /// The first breakpoint.
    pub start: f64,
    /// `[end, spacing]` per piece, ends increasing.
    pub pieces: Vec<[f64; 2]>,
}

/// The rear game's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RearGameConfig {
    /// The ego's acceleration band `[-beta, a_max]`, m/s^2.
    pub ego: Range,
    /// The leader's acceleration bounds, m/s^2: `min` is its hardest braking, which the front
    /// value in closed form assumes (the table records it; the rear iteration does not use it).
    pub leader: Range,
    /// The follower's IDM output is clipped to these bounds, m/s^2.
    pub follower: Range,
    /// The IDM's parameters.
    #[serde(default)]
    pub idm: IdmConfig,
    /// The adversarial time gap's range, s.
    pub time_gap: Range,
    /// Every speed lies in `[0, max_speed]`, m/s.
    pub max_speed: f64,
    /// `l = gap_follower - min_gap`, m.
    #[serde(default)]
    pub min_gap: f64,
    /// The solve's follower accelerates this much more than the model (IDM and clip) allows,
    /// m/s^2 (default 0). The table's header keeps the model; this only makes the solve's
    /// adversary stronger, so that the model's trajectories gain on the table's value and
    /// `verify` can close its proof at the level set (`solver::verify`).
    #[serde(default)]
    pub follower_robustness: f64,
    /// The vehicle's emergency authority, the follower's reaction and the lights' command the
    /// table declares (`[game.emergency]`; default
    /// [`EmergencyDeclaration::DEFAULT`](table_format::EmergencyDeclaration::DEFAULT)). The
    /// rear iteration does not use them; the firmware refuses a table that declares others
    /// than its configuration.
    #[serde(default)]
    pub emergency: EmergencyConfig,
}

/// The `[game.emergency]` section: [`table_format::EmergencyDeclaration`] in the config's
/// units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmergencyConfig {
    /// The vehicle's full braking, m/s^2 (positive).
    pub level: f64,
    /// Its build-up, m/s^3 (positive; `inf`: at once).
    pub jerk: f64,
    /// The follower's reaction to the brake lights, s.
    pub follower_reaction_time: f64,
    /// The deceleration beyond which the brake lights are on for sure, m/s^2 (at least 0).
    pub lights_deceleration: f64,
    /// The command at or below which the brake lights are on once delivered, m/s^2 (below
    /// `-lights_deceleration`).
    pub lights_command: f64,
}

impl Default for EmergencyConfig {
    fn default() -> Self {
        let d = EmergencyDeclaration::DEFAULT;
        EmergencyConfig {
            level: f64::from(d.braking.level),
            jerk: f64::from(d.braking.jerk),
            follower_reaction_time: f64::from(d.follower_reaction_time),
            lights_deceleration: f64::from(d.lights_deceleration),
            lights_command: f64::from(d.lights_command),
        }
    }
}

impl EmergencyConfig {
    /// The declaration the table's header carries.
    pub fn declaration(&self) -> EmergencyDeclaration {
        EmergencyDeclaration {
            braking: Braking {
                level: self.level as f32,
                jerk: self.jerk as f32,
            },
            follower_reaction_time: self.follower_reaction_time as f32,
            lights_deceleration: self.lights_deceleration as f32,
            lights_command: self.lights_command as f32,
        }
    }

    fn validate(&self) -> Result<(), ConfigError> {
        check(
            self.level.is_finite() && self.level > 0.0,
            "game.emergency.level",
            "must be a finite braking > 0 m/s^2",
        )?;
        check(
            self.jerk > 0.0,
            "game.emergency.jerk",
            "must be > 0 m/s^3 (inf: at once)",
        )?;
        check(
            self.follower_reaction_time.is_finite()
                && (0.0..=f64::from(MAX_REACTION_TIME)).contains(&self.follower_reaction_time),
            "game.emergency.follower_reaction_time",
            &format!("must be in [0, {MAX_REACTION_TIME}] s"),
        )?;
        check(
            self.lights_deceleration.is_finite() && self.lights_deceleration >= 0.0,
            "game.emergency.lights_deceleration",
            "must be a finite deceleration >= 0 m/s^2",
        )?;
        check(
            self.lights_command.is_finite() && self.lights_command < -self.lights_deceleration,
            "game.emergency.lights_command",
            "must be a finite command below -lights_deceleration",
        )
    }
}

/// The grid: three breakpoint axes in state order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RearGridConfig {
    /// Gap to the follower, m.
    pub gap_follower: PiecewiseAxis,
    /// The follower's speed, m/s: from 0 to `max_speed`.
    pub follower_speed: PiecewiseAxis,
    /// The ego's speed, m/s: from 0 to `max_speed`.
    pub ego_speed: PiecewiseAxis,
}

/// The iteration's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RearSolveConfig {
    /// The period the inputs are held, s.
    pub period: f64,
    /// When the iteration stops (default [`RearStop::Proven`]).
    #[serde(default)]
    pub stop: RearStop,
    /// With [`RearStop::Residual`]: stop when no node changes by more than this in one
    /// iteration, m. With [`RearStop::Proven`]: give up when that happens and the table is
    /// still not proven.
    pub tolerance: f64,
    /// Give up after this many iterations.
    pub max_iterations: usize,
    /// With [`RearStop::Proven`]: iterations between two attempts at the proof (default 25);
    /// the gap grows to a tenth of the iterations done, so that an unprovable config costs a
    /// few dozen failed attempts, each stopped at its first unproven cell.
    #[serde(default = "default_check_every")]
    pub check_every: usize,
}

fn default_check_every() -> usize {
    25
}

/// When the rear iteration stops.
///
/// The iteration lowers the value monotonically from the constraint, `W_0 = l >= W_1 >= ...`,
/// towards the sampled-data game's fixed point. On the deployed grid that fixed point is not
/// reached in any useful time: the plateau `W ~ s0` hangs on the rest points, where
/// interpolation erodes it by a fraction of a millimetre per iteration for thousands of
/// iterations (`semi_lagrangian::Iteration`). What the firmware needs is not the fixed point
/// but a table `verify` proves invariant, and every iterate is a candidate: the first one the
/// proof closes on is also the highest one, so the one with the largest certified set.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RearStop {
    /// Stop at the first iterate `verify` proves (every certified cell), attempted every
    /// `check_every` iterations.
    #[default]
    Proven,
    /// Stop when the largest change of one iteration is below `tolerance` (a stop that does
    /// not bound the remaining change: the value may go on drifting by the same amount for
    /// thousands of iterations).
    Residual,
}

/// A rear-game run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RearConfig {
    /// Output folder name.
    pub name: String,
    /// What the run is for.
    #[serde(default)]
    pub description: String,
    /// The game.
    pub game: RearGameConfig,
    /// The grid.
    pub grid: RearGridConfig,
    /// The iteration.
    pub solve: RearSolveConfig,
    /// Stored value width, 8 or 16 bits.
    pub table_bits: u8,
}

impl PiecewiseAxis {
    fn breakpoints(&self) -> Vec<f32> {
        let pieces: Vec<(f32, f32)> = self
            .pieces
            .iter()
            .map(|p| (p[0] as f32, p[1] as f32))
            .collect();
        Breakpoints::piecewise(self.start as f32, &pieces)
    }

    /// How many breakpoints the axis has, counted without making them (a spacing of 1e-9 m
    /// must be refused, not allocated); `None` beyond `usize`.
    fn count(&self) -> Option<usize> {
        let mut at = self.start;
        let mut n = 1f64;
        for [end, spacing] in &self.pieces {
            n += ((end - at) / spacing).ceil().max(0.0);
            at = *end;
        }
        (n.is_finite() && n < usize::MAX as f64).then_some(n as usize)
    }

    fn validate(&self, field: &str) -> Result<(), ConfigError> {
        check(
            self.start.is_finite() && !self.pieces.is_empty(),
            field,
            "needs a finite start and at least one [end, spacing] piece",
        )?;
        let mut at = self.start;
        for (k, [end, spacing]) in self.pieces.iter().enumerate() {
            check(
                end.is_finite() && *end > at && spacing.is_finite() && *spacing > 0.0,
                &format!("{field}.pieces[{k}]"),
                "each end must exceed the previous one and each spacing be > 0",
            )?;
            at = *end;
        }
        Ok(())
    }

    fn end(&self) -> f64 {
        self.pieces.last().map_or(self.start, |p| p[0])
    }
}

impl RearConfig {
    /// Parses and validates a TOML document.
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let config: RearConfig = parse_toml(text)?;
        config.validate().map_err(|e| locate(e, text))?;
        Ok(config)
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let g = &self.game;
        check_name(&self.name)?;
        check(
            g.ego.min < 0.0 && g.ego.max >= 0.0 && g.ego.min.is_finite() && g.ego.max.is_finite(),
            "game.ego",
            "the band [-beta, a_max] needs min < 0 <= max",
        )?;
        check(
            g.leader.min < 0.0 && g.leader.max >= 0.0 && g.leader.min.is_finite(),
            "game.leader",
            "needs min < 0 <= max (min is the leader's hardest braking)",
        )?;
        check(
            g.follower.min < 0.0 && g.follower.max >= 0.0 && g.follower.min.is_finite(),
            "game.follower",
            "needs min < 0 <= max",
        )?;
        check(
            g.time_gap.min >= 0.0 && g.time_gap.max >= g.time_gap.min,
            "game.time_gap",
            "needs 0 <= min <= max",
        )?;
        check(
            g.max_speed.is_finite() && g.max_speed > 0.0,
            "game.max_speed",
            "must be > 0",
        )?;
        check(
            g.follower_robustness.is_finite() && (0.0..=2.0).contains(&g.follower_robustness),
            "game.follower_robustness",
            "must be in [0, 2] m/s^2",
        )?;
        check(
            g.idm.jam_distance > 0.0,
            "game.idm.jam_distance",
            "must be > 0: with s0 = 0 a follower creeps into a stopped ego and nothing is safe for ever",
        )?;
        g.emergency.validate()?;
        self.grid.gap_follower.validate("grid.gap_follower")?;
        for (field, axis) in [
            ("grid.follower_speed", &self.grid.follower_speed),
            ("grid.ego_speed", &self.grid.ego_speed),
        ] {
            axis.validate(field)?;
            check(
                axis.start == 0.0 && axis.end() == g.max_speed,
                field,
                "must span [0, game.max_speed] (speeds are held in that range)",
            )?;
        }
        let nodes = [
            &self.grid.gap_follower,
            &self.grid.follower_speed,
            &self.grid.ego_speed,
        ]
        .iter()
        .try_fold(1usize, |n, a| n.checked_mul(a.count()?));
        check_memory(
            nodes,
            SAMPLED_BYTES_PER_NODE,
            "grid",
            "the breakpoints (larger spacings or shorter axes)",
        )?;
        let s = &self.solve;
        check(
            s.period > 0.0 && s.period <= 1.0,
            "solve.period",
            "must be in (0, 1] s",
        )?;
        check(s.tolerance > 0.0, "solve.tolerance", "must be > 0")?;
        check(s.max_iterations > 0, "solve.max_iterations", "must be > 0")?;
        check(s.check_every > 0, "solve.check_every", "must be > 0")?;
        check(
            self.table_bits == 8 || self.table_bits == 16,
            "table_bits",
            "must be 8 or 16",
        )?;
        Ok(())
    }

    /// The game as the engine sees it.
    pub fn game(&self) -> RearGame {
        let g = &self.game;
        RearGame {
            ego: Accel {
                min: g.ego.min as f32,
                max: g.ego.max as f32,
            },
            follower: self.follower_model(),
            max_speed: g.max_speed as f32,
            min_gap: g.min_gap as f32,
            follower_robustness: g.follower_robustness as f32,
        }
    }

    /// The follower's model, as the config states it.
    pub fn follower_model(&self) -> FollowerModel {
        let g = &self.game;
        let b = |r: Range| Bounds::new(r.min as f32, r.max as f32);
        FollowerModel::Idm {
            clip: b(g.follower),
            idm: idm_parameters(g.idm),
            time_gap: b(g.time_gap),
        }
    }

    /// The game as the table header describes it.
    pub fn game_description(&self) -> Game {
        let b = |r: Range| Bounds::new(r.min as f32, r.max as f32);
        let g = &self.game;
        Game::ThreeCarSplit {
            ego: b(g.ego),
            leader: b(g.leader),
            follower: self.follower_model(),
            max_speed: g.max_speed as f32,
            emergency: g.emergency.declaration(),
        }
    }

    /// The grid.
    pub fn grid(&self) -> Result<Breakpoints, ConfigError> {
        let gr = &self.grid;
        Breakpoints::new(vec![
            ("gap_follower".into(), gr.gap_follower.breakpoints()),
            ("follower_speed".into(), gr.follower_speed.breakpoints()),
            ("ego_speed".into(), gr.ego_speed.breakpoints()),
        ])
    }
}

/// What a rear run measured, written as `summary.json`. Keys end in their unit (`_m`, `_s`,
/// `_m_per_s`) where they have one.
#[derive(Debug, Clone, Serialize)]
pub struct RearSummary {
    /// The config's name.
    pub name: String,
    /// The config, as run.
    pub config: RearConfig,
    /// Breakpoints per axis.
    pub points: [usize; 3],
    /// Iterations done (each one period of the game).
    pub iterations: usize,
    /// Why the iteration stopped.
    pub stopped: RearStopped,
    /// The horizon the iterations cover, `iterations x period`, s.
    pub horizon_s: f64,
    /// The largest change of a node in the last iteration, m.
    pub residual_m: f32,
    /// How far the value still moved over the last stretch of the solve.
    pub drift: Drift,
    /// The attempts at the proof on the way (with [`RearStop::Proven`]).
    pub proof_attempts: Vec<ProofAttempt>,
    /// Wall time of the iterations, the failed attempts at the proof included, s.
    pub solve_s: f64,
    /// The value at rest with the follower 10 m back, m (the exact value is the jam distance
    /// `s0`).
    pub plateau_m: f32,
    /// Per equal speed of both cars (m/s), the smallest gap with `W` above 0.5 m (m; `None`:
    /// none).
    pub smallest_gap_at_equal_speeds: Vec<(f32, Option<f32>)>,
    /// The smallest value on the grid's last `gap_follower` face, m. A follower farther back
    /// than the grid is safe until it crosses that face, where its value is at least this: the
    /// firmware takes it as the value of a follower beyond the grid (or of none).
    pub beyond_grid_m: f32,
    /// Share of nodes with `W > 0`.
    pub safe_share: f64,
    /// Table size, bytes.
    pub table_bytes: usize,
    /// The table's quantization error bound, m.
    pub quantization_error_m: f32,
    /// What `verify` proved of the table (default settings), recorded in its header.
    pub verification: table_format::Verification,
    /// Wall time of the proof of the table written, s.
    pub verify_s: f64,
}

/// Why the rear iteration stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RearStopped {
    /// `verify` proved the iterate: every certified cell.
    Proven,
    /// The largest change of one iteration fell below the tolerance (with [`RearStop::Proven`]:
    /// and the table was still not proven).
    Residual,
    /// `max_iterations` passed.
    MaxIterations,
}

/// How much the value still moved at the end of the solve: between the iterate at the start of
/// the last stretch (the last attempt at the proof before the stop, or a tenth of the
/// iterations back) and the one written.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Drift {
    /// Iterations in the stretch.
    pub iterations: usize,
    /// The stretch's length in horizon, s.
    pub horizon_s: f64,
    /// The largest change of any node over the stretch, m.
    pub max_change_m: f32,
    /// The plateau's change over the stretch, m.
    pub plateau_change_m: f32,
    /// The largest change of a node per second of horizon over the stretch, m/s.
    pub max_rate_m_per_s: f64,
    /// Nodes whose sign changed over the stretch (safe to unsafe).
    pub safe_nodes_lost: usize,
}

/// One attempt at the proof during the solve.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ProofAttempt {
    /// Iterations done at the attempt.
    pub iterations: usize,
    /// Whether `verify` proved every certified cell.
    pub proven: bool,
    /// Wall time of the attempt, s (an attempt that fails stops at its first unproven cell).
    pub seconds: f64,
}

/// What a rear run reports while it runs.
#[derive(Debug, Clone, Copy)]
pub enum RearEvent {
    /// An iteration finished: iterations done, the largest change in it (m).
    Iteration(usize, f32),
    /// An attempt at the proof starts after this many iterations.
    ProofStarted(usize),
    /// Progress of the proof: cells checked, cells.
    ProofProgress(usize, usize),
    /// An attempt at the proof finished.
    ProofFinished(ProofAttempt),
}

/// Solves a rear config and writes `out/<name>/`: `table.bin`, `value.npy`, `axes.json`,
/// `summary.json`, `verify.json`.
pub fn run_rear(config: &RearConfig, out: &Path) -> Result<RearSummary, SolverError> {
    run_rear_with(config, out, &mut |_| {})
}

/// [`run_rear`], reporting what it does to `events`.
pub fn run_rear_with(
    config: &RearConfig,
    out: &Path,
    events: &mut dyn FnMut(RearEvent),
) -> Result<RearSummary, SolverError> {
    run_rear_with_report(config, out, events).map(|(summary, _, _)| summary)
}

/// [`run_rear_with`], also returning `verify`'s report of the table written (with every cell's
/// verdict) and the table's bytes.
pub fn run_rear_with_report(
    config: &RearConfig,
    out: &Path,
    events: &mut dyn FnMut(RearEvent),
) -> Result<(RearSummary, Report, Vec<u8>), SolverError> {
    config.validate()?;
    let grid = config.grid()?;
    let game = config.game();
    let s = config.solve;
    let plateau_at = |values: &[f32]| grid.interpolate(values, &[10.0, 0.0, 0.0]);
    let t0 = Instant::now();
    let mut iteration = Iteration::new(&game, &grid, s.period as f32);
    let mut residual;
    let mut attempts = Vec::new();
    // The iterate at the start of the last stretch, for the drift: the one at the last attempt
    // at the proof (or, with the residual stop, a tenth of the iterations back).
    let mut stretch: (usize, Vec<f32>) = (0, iteration.values().to_vec());
    let mut next_check = s.check_every;
    let mut proven: Option<(Proof, Drift)> = None;
    // The cells earlier attempts found unproven, checked first by the next attempt: a table
    // that fails where an earlier one failed fails at once.
    let mut suspects: Vec<usize> = Vec::new();
    let stopped = loop {
        residual = iteration.sweep();
        let k = iteration.sweeps();
        events(RearEvent::Iteration(k, residual));
        let settled = residual < s.tolerance as f32;
        let last = settled || k >= s.max_iterations;
        if k >= next_check || last {
            if s.stop == RearStop::Proven {
                events(RearEvent::ProofStarted(k));
                let drift = drift(&stretch, iteration.values(), k, s.period, &plateau_at);
                let status = HorizonStatus::Proven {
                    residual,
                    drift: drift.max_change_m,
                    stretch: drift.horizon_s as f32,
                };
                // An attempt stops at its first unproven cell; one that passes has checked
                // every cell, as the full proof does, and is the proof.
                let attempt = prove(
                    config,
                    &grid,
                    iteration.values(),
                    (k, status),
                    &suspects,
                    events,
                    true,
                )?;
                let [_, nj, nk] = [0, grid.axis(1).len() - 1, grid.axis(2).len() - 1];
                suspects.extend(
                    attempt
                        .report
                        .unproven
                        .iter()
                        .map(|c| (c.index[0] * nj + c.index[1]) * nk + c.index[2]),
                );
                let done = attempt.report.proven == attempt.report.certified;
                let summary = ProofAttempt {
                    iterations: k,
                    proven: done,
                    seconds: attempt.report.seconds,
                };
                attempts.push(summary);
                events(RearEvent::ProofFinished(summary));
                if done {
                    proven = Some((attempt, drift));
                    break RearStopped::Proven;
                }
            }
            if !last {
                stretch = (k, iteration.values().to_vec());
                next_check = k + s.check_every.max(k / 10);
            }
        }
        if settled {
            break RearStopped::Residual;
        }
        if k >= s.max_iterations {
            break RearStopped::MaxIterations;
        }
    };
    let k = iteration.sweeps();
    let values = iteration.into_values();
    let solve_s =
        t0.elapsed().as_secs_f64() - proven.as_ref().map_or(0.0, |(p, _)| p.report.seconds);
    // A table not proven on the way gets the full proof (within a budget) for its report.
    let (proof, drift) = match proven {
        Some(p) => p,
        None => {
            let status = if stopped == RearStopped::Residual {
                HorizonStatus::Converged {
                    tolerance: s.tolerance as f32,
                    residual,
                }
            } else {
                HorizonStatus::NotConverged {
                    tolerance: s.tolerance as f32,
                    residual,
                }
            };
            let drift = drift(&stretch, &values, k, s.period, &plateau_at);
            (
                prove(
                    config,
                    &grid,
                    &values,
                    (k, status),
                    &suspects,
                    events,
                    false,
                )?,
                drift,
            )
        }
    };

    let dir = out.join(&config.name);
    std::fs::create_dir_all(&dir).map_err(|e| SolverError::Io {
        path: dir.display().to_string(),
        source: e,
    })?;
    output::write_bytes(&dir.join("table.bin"), &proof.bytes)?;
    output::write_json(&dir.join("verify.json"), &proof.report)?;
    super::table_plots::deployed_table_plots(
        &table_format::Table::parse(&proof.bytes)?,
        &proof.rear,
        &proof.report,
        &dir,
    )?;
    let lists: Vec<Vec<f32>> = (0..3).map(|k| grid.axis(k).to_vec()).collect();
    let points = [lists[0].len(), lists[1].len(), lists[2].len()];
    output::write_npy(&dir.join("value.npy"), &values, &points)?;
    let axes: Vec<output::AxisCoordinates> = (0..3)
        .map(|k| output::AxisCoordinates {
            name: grid.name(k).to_string(),
            unit: if k == 0 { "m" } else { "m/s" }.to_string(),
            coordinates: lists[k].iter().map(|&x| f64::from(x)).collect(),
        })
        .collect();
    output::write_axes(&dir.join("axes.json"), &axes)?;

    let at = |x: f32, vf: f32, ve: f32| grid.interpolate(&values, &[x, vf, ve]);
    let vmax = config.game.max_speed as f32;
    let smallest_gap_at_equal_speeds = [0.0f32, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0]
        .into_iter()
        .filter(|&v| v <= vmax)
        .map(|v| {
            let gap = lists[0].iter().copied().find(|&x| at(x, v, v) > 0.5);
            (v, gap)
        })
        .collect();
    let summary = RearSummary {
        name: config.name.clone(),
        config: config.clone(),
        points,
        iterations: k,
        stopped,
        horizon_s: k as f64 * s.period,
        residual_m: residual,
        drift,
        proof_attempts: attempts,
        solve_s,
        plateau_m: plateau_at(&values),
        smallest_gap_at_equal_speeds,
        beyond_grid_m: values[values.len() - points[1] * points[2]..]
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min),
        safe_share: values.iter().filter(|&&w| w > 0.0).count() as f64 / values.len() as f64,
        table_bytes: proof.bytes.len(),
        quantization_error_m: proof.quantization_error,
        verification: proof.report.record(),
        verify_s: proof.report.seconds,
    };
    output::write_json(&dir.join("summary.json"), &summary)?;
    Ok((summary, proof.report, proof.bytes))
}

/// A table and what `verify` found of it.
struct Proof {
    /// The table's bytes, with the proof's record in its header.
    bytes: Vec<u8>,
    /// The table as the proof read it.
    rear: RearTable,
    report: Report,
    quantization_error: f32,
}

/// Compiles the iterate `values` after `iterations` into a table and proves it: failing fast
/// (at the first unproven cell) on the way, or, for the table written without a proof, within
/// the command line's default budget (600 s, 1,000 unproven cells named).
fn prove(
    config: &RearConfig,
    grid: &Breakpoints,
    values: &[f32],
    (iterations, status): (usize, HorizonStatus),
    suspects: &[usize],
    events: &mut dyn FnMut(RearEvent),
    fail_fast: bool,
) -> Result<Proof, SolverError> {
    let s = config.solve;
    let lists: Vec<Vec<f32>> = (0..3).map(|k| grid.axis(k).to_vec()).collect();
    let axes: Vec<Axis<'_>> = (0..3)
        .map(|k| Axis {
            name: grid.name(k),
            unit: if k == 0 { "m" } else { "m/s" },
            min: lists[k][0],
            max: *lists[k].last().unwrap_or(&lists[k][0]),
            points: lists[k].len() as u32,
            spacing: Spacing::Listed,
        })
        .collect();
    let trusted: Vec<Bounds> = axes.iter().map(|a| Bounds::new(a.min, a.max)).collect();
    let breakpoints: Vec<&[f32]> = lists.iter().map(Vec::as_slice).collect();
    let bytes = table_format::encode(&TableContents {
        game: config.game_description(),
        min_gap: config.game.min_gap as f32,
        horizon: Horizon {
            seconds: (iterations as f64 * s.period) as f32,
            status,
        },
        axes: &axes,
        breakpoints: &breakpoints,
        trusted_box: &trusted,
        interpolation_error: 0.0,
        value_bits: if config.table_bits == 8 {
            ValueBits::Eight
        } else {
            ValueBits::Sixteen
        },
        values,
        accelerate: &[],
    })?;
    let quantization_error = table_format::Table::parse(&bytes)?
        .header()
        .error_bound
        .quantization;
    let settings = VerifySettings {
        budget: if fail_fast {
            Budget {
                seconds: None,
                unproven_cells: Some(1),
            }
        } else {
            Budget {
                seconds: Some(600.0),
                unproven_cells: Some(1000),
            }
        },
        ..VerifySettings::default()
    };
    let (rear, report, bytes) =
        verify_bytes_with_progress(&bytes, &settings, suspects, &mut |done, total| {
            events(RearEvent::ProofProgress(done, total))
        })?;
    Ok(Proof {
        bytes,
        rear,
        report,
        quantization_error,
    })
}

/// The drift from the iterate `stretch` (after `stretch.0` iterations) to `values` (after `k`).
fn drift(
    stretch: &(usize, Vec<f32>),
    values: &[f32],
    k: usize,
    period: f64,
    plateau_at: &dyn Fn(&[f32]) -> f32,
) -> Drift {
    let before = &stretch.1;
    let mut max_change = 0f32;
    let mut lost = 0usize;
    for (now, was) in values.iter().zip(before) {
        max_change = max_change.max((was - now).abs());
        lost += usize::from(*was > 0.0 && *now <= 0.0);
    }
    let iterations = k - stretch.0;
    let horizon_s = iterations as f64 * period;
    Drift {
        iterations,
        horizon_s,
        max_change_m: max_change,
        plateau_change_m: plateau_at(before) - plateau_at(values),
        max_rate_m_per_s: f64::from(max_change) / horizon_s.max(f64::MIN_POSITIVE),
        safe_nodes_lost: lost,
    }
}
