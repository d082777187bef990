//! The rear game's pipeline: a `[rear]` TOML config -> the sampled-data value on breakpoint
//! axes -> a `ThreeCarSplit` table -> `verify` -> the table with the proof's record, its
//! summary and the verify report.
//!
//! One responsibility: turn a rear config into files. The game is [`crate::games::RearIdm`],
//! the scheme [`crate::engine::semi_lagrangian`]; why the split and why that scheme is written there.
//!
//! # The table is the solver's value, not an approximation of it
//! The sampled-data iteration defines its value between nodes by multilinear interpolation, and
//! the table stores the same nodes and interpolates the same way. So the table's interpolant
//! *is* the solver's value function, and its only error against it is quantization, which is
//! rounded down (`V_table <= W`). The error bound's interpolation term is zero by construction.

use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};
use table_format::{Axis, Bounds, Game, Horizon, HorizonStatus, Spacing, TableContents, ValueBits};

use crate::engine::semi_lagrangian::{iterate, Breakpoints};
use crate::error::{ConfigError, SolverError};
use crate::games::{Accel, Idm, RearIdm};
use crate::pipeline::config::{
    check, check_memory, check_name, idm_parameters, parse_toml, IdmConfig, Range,
    SAMPLED_BYTES_PER_NODE,
};
use crate::pipeline::output;
use crate::proof::verify::{verify_bytes, Settings as VerifySettings};

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
    /// Stop when no node changes by more than this in one iteration, m.
    pub tolerance: f64,
    /// Give up after this many iterations (the table then says "not converged").
    pub max_iterations: usize,
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
        config.validate()?;
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
        check(
            self.table_bits == 8 || self.table_bits == 16,
            "table_bits",
            "must be 8 or 16",
        )?;
        Ok(())
    }

    /// The game as the engine sees it.
    pub fn game(&self) -> RearIdm {
        let g = &self.game;
        let accel = |r: Range| Accel {
            min: r.min as f32,
            max: r.max as f32,
        };
        RearIdm {
            ego: accel(g.ego),
            follower_clip: accel(g.follower),
            idm: Idm::from(idm_parameters(g.idm)),
            time_gap: accel(g.time_gap),
            max_speed: g.max_speed as f32,
            min_gap: g.min_gap as f32,
            follower_robustness: g.follower_robustness as f32,
        }
    }

    /// The game as the table header describes it.
    pub fn game_description(&self) -> Game {
        let b = |r: Range| Bounds::new(r.min as f32, r.max as f32);
        let g = &self.game;
        Game::ThreeCarSplit {
            ego: b(g.ego),
            leader: b(g.leader),
            follower_clip: b(g.follower),
            idm: idm_parameters(g.idm),
            time_gap: b(g.time_gap),
            max_speed: g.max_speed as f32,
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

/// What a rear run measured.
#[derive(Debug, Clone, Serialize)]
pub struct RearSummary {
    /// The config's name.
    pub name: String,
    /// The config, as run.
    pub config: RearConfig,
    /// Breakpoints per axis.
    pub points: [usize; 3],
    /// Iterations done.
    pub iterations: usize,
    /// Whether the largest change per iteration fell below the tolerance.
    pub converged: bool,
    /// The largest change in the last iteration, m.
    pub residual: f32,
    /// A bound on how much any node changed over the last tenth of the iterations: the sum of
    /// the per-iteration largest changes, m.
    pub change_over_last_tenth: f32,
    /// A bound on how much the safe set changed over the last tenth of the iterations: the
    /// share of nodes within `change_over_last_tenth` of zero (no other node can have changed
    /// sign).
    pub safe_set_change_bound: f64,
    /// Wall time of the iteration, s.
    pub solve_seconds: f64,
    /// The value at rest with the follower 10 m back (the plateau `s0` is its exact value).
    pub plateau: f32,
    /// Per equal speed of both cars, the smallest gap with `W` above 0.5 m (m; `None`: none).
    pub smallest_gap_at_equal_speeds: Vec<(f32, Option<f32>)>,
    /// The smallest value on the grid's top `gap_follower` face, m. A follower farther back
    /// than the grid is safe until it crosses that face, where its value is at least this: the
    /// firmware takes it as the value of a follower beyond the grid (or of none).
    pub top_face_min: f32,
    /// Share of nodes with `W > 0`.
    pub safe_share: f64,
    /// Table size, bytes.
    pub table_bytes: usize,
    /// The table's quantization error bound, m.
    pub quantization_error: f32,
    /// What `verify` proved of the table (default settings), recorded in its header.
    pub verification: table_format::Verification,
    /// Wall time of `verify`, s.
    pub verify_seconds: f64,
}

/// Solves a rear config and writes `out/<name>/`: `table.bin`, `value.npy`, `summary.json`.
pub fn run_rear(config: &RearConfig, out: &Path) -> Result<RearSummary, SolverError> {
    config.validate()?;
    let grid = config.grid()?;
    let game = config.game();
    let s = config.solve;
    let t0 = Instant::now();
    let mut history: Vec<f32> = Vec::new();
    let result = iterate(
        &game,
        &grid,
        s.period as f32,
        s.tolerance as f32,
        s.max_iterations,
        |_, residual, _| history.push(residual),
    );
    let solve_seconds = t0.elapsed().as_secs_f64();
    let tail = history.len() / 10;
    let change_over_last_tenth = history[history.len() - tail.max(1)..].iter().copied().sum();

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
            seconds: (result.iterations as f64 * s.period) as f32,
            status: if result.converged {
                HorizonStatus::Converged {
                    tolerance: s.tolerance as f32,
                    residual: result.residual,
                }
            } else {
                HorizonStatus::NotConverged {
                    tolerance: s.tolerance as f32,
                    residual: result.residual,
                }
            },
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
        values: &result.values,
        accelerate: &[],
    })?;
    let table = table_format::Table::parse(&bytes)?;
    let quantization_error = table.header().error_bound.quantization;
    // The table the firmware may run carries what verify proved of it (the firmware refuses a
    // split table without a complete record).
    let (_, report, bytes) = verify_bytes(&bytes, &VerifySettings::default())?;

    let dir = out.join(&config.name);
    std::fs::create_dir_all(&dir).map_err(|e| SolverError::Io {
        path: dir.display().to_string(),
        source: e,
    })?;
    output::write_bytes(&dir.join("table.bin"), &bytes)?;
    output::write_json(&dir.join("verify.json"), &report)?;
    let points = [lists[0].len(), lists[1].len(), lists[2].len()];
    output::write_npy(&dir.join("value.npy"), &result.values, &points)?;
    let axes: Vec<output::AxisCoordinates> = (0..3)
        .map(|k| output::AxisCoordinates {
            name: grid.name(k).to_string(),
            unit: if k == 0 { "m" } else { "m/s" }.to_string(),
            coordinates: lists[k].iter().map(|&x| f64::from(x)).collect(),
        })
        .collect();
    output::write_axes(&dir.join("axes.json"), &axes)?;

    let at = |x: f32, vf: f32, ve: f32| grid.interpolate(&result.values, &[x, vf, ve]);
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
        iterations: result.iterations,
        converged: result.converged,
        residual: result.residual,
        change_over_last_tenth,
        safe_set_change_bound: result
            .values
            .iter()
            .filter(|w| w.abs() <= change_over_last_tenth)
            .count() as f64
            / result.values.len() as f64,
        solve_seconds,
        plateau: at(10.0, 0.0, 0.0),
        smallest_gap_at_equal_speeds,
        top_face_min: result.values[result.values.len() - points[1] * points[2]..]
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min),
        safe_share: result.values.iter().filter(|&&w| w > 0.0).count() as f64
            / result.values.len() as f64,
        table_bytes: bytes.len(),
        quantization_error,
        verification: report.record(),
        verify_seconds: report.seconds,
    };
    output::write_json(&dir.join("summary.json"), &summary)?;
    Ok(summary)
}
