//! Sweeps: many rear configs made from one, each solved, proven and measured, and a summary
//! across them.
//!
//! One responsibility: turn a sweep file into the rear runs it describes and the figures a
//! designer compares (the certified volume, the proof, the cost of measurement error), with
//! the runs themselves done by [`crate::pipeline::rear`].
//!
//! # The sweep file
//! ```toml
//! name = "sensitivity"                  # output folder under --out
//! base = "../rear/deployment.toml"      # a rear config, relative to this file
//! [[vary]]                              # every combination of the values is a point
//! key = "game.ego.min"                  # a rear config's key ...
//! values = [-2.0, -3.5, -5.0]
//! [[vary]]
//! key = "front.leader_braking"          # ... or the evaluation's (`front.*`, `sensors.*`)
//! values = [3.5, 6.0, 8.0]
//! ```
//! `[[points]]` lists points, each a table of `key = value` (an empty one is the base); with
//! `[[vary]]` too, each listed point is combined with every combination of the values. Keys
//! under `front.` ([`FrontSettings`]) and `sensors.` (`table_format::MeasurementError`)
//! change how a table is measured, not the table: points that differ only there share one
//! solve. `solver/configs/reference/sweep.toml` documents every field.
//!
//! # Tasks, and where they run
//! The points are grouped into [`SweepTask`]s, one per distinct rear config: a task solves and
//! proves its table, then measures it for each of its points. Tasks are independent, and
//! serialisable (JSON) with everything they need: [`run_sweep`] runs them in parallel on this
//! machine (each also parallel inside, on the same thread pool), and the Python module hands
//! them to a Dask cluster (`hjacc.sweep`), one task per worker, and writes the same summary
//! from their results ([`write_summary`]).
//!
//! # The certified volume
//! States `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)` are sampled
//! uniformly (fixed seed) over gaps in `[0, 75]` m, relative speeds within 15 m/s of the ego's
//! and every speed in `[0, 35]` m/s, and counted certified when the front value in closed form
//! exceeds [`FrontSettings::front_level`] and the rear table's value, less its error bound,
//! exceeds [`FrontSettings::rear_level`]: the firmware's test with exact sensors. The cost of
//! the declared measurement error is the rear half's, over the table's nodes taken as
//! measurements (`proof::robust`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use plotters::prelude::*;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use table_format::front::{front_value, FrontModel};
use table_format::{Game, Table};

use crate::error::{ConfigError, SolverError};
use crate::pipeline::config::{check, check_name, locate, parse_toml};
use crate::pipeline::output;
use crate::pipeline::rear::{run_rear_with_report, RearConfig, RearEvent, RearStopped};
use crate::proof::robust::robustness;
use crate::proof::verify::RearTable;
use table_format::MeasurementError;

/// A sweep file ([module docs](self)).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepConfig {
    /// Output folder name.
    pub name: String,
    /// What the sweep is for.
    #[serde(default)]
    pub description: String,
    /// The rear config every point starts from, relative to the sweep file.
    pub base: String,
    /// The values to vary: every combination is a point (of each listed point).
    #[serde(default)]
    pub vary: Vec<Vary>,
    /// Points, listed: each a table of `key = value` (an empty one is the base).
    #[serde(default)]
    pub points: Vec<toml::Table>,
    /// How a table's front half is measured, before any point's overrides.
    #[serde(default)]
    pub front: FrontSettings,
    /// The declared measurement error the tables are measured under, before any point's
    /// overrides (default: the firmware's).
    #[serde(default)]
    pub sensors: MeasurementError,
    /// The sampled certified volume.
    #[serde(default)]
    pub volume: VolumeSettings,
}

/// One varied key and its values.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vary {
    /// A dotted key: a rear config's (`game.ego.min`), or `front.*`, `sensors.*`.
    pub key: String,
    /// Its values.
    pub values: Vec<toml::Value>,
}

/// How the front half of the split certificate is measured for the certified volume: the
/// front value in closed form ([`table_format::front`]) of a leader braking at
/// `leader_braking` (default: the table's model) and an ego braking at the table's `beta`
/// after `response_time` at `response_acceleration`, through a ramp of `jerk` if given.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrontSettings {
    /// The leader's hardest braking, m/s^2 (positive; `None`: the table's model's).
    pub leader_braking: Option<f32>,
    /// How long the ego keeps `response_acceleration` before it brakes, s.
    pub response_time: f32,
    /// The ego's acceleration during the response, m/s^2.
    pub response_acceleration: f32,
    /// The braking ramp's jerk, m/s^3 (`None`: braking at `beta` at once).
    pub jerk: Option<f32>,
    /// The front value a certified state exceeds, m (the firmware's `front_margin`).
    pub front_level: f32,
    /// The rear value a certified state exceeds, less the table's error bound, m (the
    /// firmware's `rear_margin`).
    pub rear_level: f32,
}

impl Default for FrontSettings {
    /// No response, no ramp, the firmware's default levels (0.5 m front, 0 m rear).
    fn default() -> Self {
        FrontSettings {
            leader_braking: None,
            response_time: 0.0,
            response_acceleration: 0.0,
            jerk: None,
            front_level: table_format::front::DEFAULT_FRONT_MARGIN,
            rear_level: 0.0,
        }
    }
}

/// The sampled certified volume's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VolumeSettings {
    /// States sampled per ego-speed range.
    pub samples: usize,
    /// The sampler's seed.
    pub seed: u64,
}

impl Default for VolumeSettings {
    /// 200,000 samples, seed 7 (as the sensitivity study has always used).
    fn default() -> Self {
        VolumeSettings {
            samples: 200_000,
            seed: 7,
        }
    }
}

/// One point of a sweep: its overrides and how its table is measured.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SweepPoint {
    /// Its place in the sweep, from 0.
    pub index: usize,
    /// The keys it sets, with their values, in the sweep file's order.
    pub overrides: Vec<(String, serde_json::Value)>,
    /// The front half's measurement.
    pub front: FrontSettings,
    /// The declared measurement error.
    pub sensors: MeasurementError,
    /// The sampled volume's settings.
    pub volume: VolumeSettings,
}

/// A rear config and the points measured on its table: the unit of work a sweep hands out.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SweepTask {
    /// The rear config (its name is the sweep's with the task's number).
    pub rear: RearConfig,
    /// The points that share its table.
    pub points: Vec<SweepPoint>,
}

/// A sweep read from its file: its config and its tasks.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The file's contents.
    pub config: SweepConfig,
    /// The tasks, in the order of their first point.
    pub tasks: Vec<SweepTask>,
}

/// What a point's table is, as a sweep reports it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TableFigures {
    /// The rear config's name (its folder beside the summary).
    pub name: String,
    /// Iterations of the solve.
    pub iterations: usize,
    /// Why the solve stopped.
    pub stopped: RearStopped,
    /// Wall time of the iterations and the failed attempts at the proof, s.
    pub solve_s: f64,
    /// Wall time of the proof, s.
    pub verify_s: f64,
    /// Cells `verify` found certified.
    pub certified_cells: u32,
    /// Of those, proven.
    pub proven_cells: u32,
    /// Whether every certified cell is proven (the firmware refuses the table otherwise).
    pub proven: bool,
    /// The rear value at rest with the follower 10 m back, m.
    pub plateau_m: f32,
    /// The table's error bound, m.
    pub error_bound_m: f32,
    /// Its size, bytes.
    pub table_bytes: usize,
}

/// The sampled certified volume: shares of the sampled states ([module docs](self)).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct Volume {
    /// States sampled per ego-speed range.
    pub samples: usize,
    /// Certified (front and rear), ego speeds 15-35 m/s.
    pub certified_ego_15_35: f64,
    /// Certified (front and rear), ego speeds 0-35 m/s.
    pub certified_ego_0_35: f64,
    /// The front half alone, ego speeds 0-35 m/s.
    pub front_ego_0_35: f64,
    /// The rear half alone, ego speeds 0-35 m/s.
    pub rear_ego_0_35: f64,
}

/// The rear half under measurement error, over the table's nodes taken as measurements.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct MeasuredRear {
    /// The share the firmware's test passes with exact sensors.
    pub exact_share: f64,
    /// The share it passes under the point's declared error.
    pub declared_share: f64,
    /// Passing measurements whose error box touches an unproven cell (0 for a sound table).
    pub declared_unproven: usize,
}

/// One point's results.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PointResult {
    /// The point.
    pub point: SweepPoint,
    /// Its table.
    pub table: TableFigures,
    /// The certified volume.
    pub volume: Volume,
    /// The rear half under measurement error.
    pub measured_rear: MeasuredRear,
}

/// What a sweep wrote: `sweep.json`.
#[derive(Debug, Clone, Serialize)]
pub struct SweepSummary {
    /// The sweep's name.
    pub name: String,
    /// What it is for.
    pub description: String,
    /// The keys varied, in order.
    pub keys: Vec<String>,
    /// Distinct tables solved.
    pub tables: usize,
    /// Every point, in order.
    pub points: Vec<PointResult>,
    /// Wall time, s (the tasks' own times are in their points).
    pub seconds: f64,
}

/// What a sweep reports while it runs.
#[derive(Debug, Clone)]
pub enum SweepEvent {
    /// A task's solve reported `event` (tasks run in parallel: events interleave).
    Rear(usize, RearEvent),
    /// A task finished: its number, tasks finished so far, tasks.
    TaskFinished(usize, usize, usize),
}

impl Sweep {
    /// Reads a sweep file and its base config (relative to the file), and makes its tasks.
    pub fn open(path: &Path) -> Result<Sweep, SolverError> {
        let read = |p: &Path| {
            std::fs::read_to_string(p).map_err(|e| SolverError::Io {
                path: p.display().to_string(),
                source: e,
            })
        };
        let text = read(path)?;
        let config: SweepConfig = parse_toml(&text)?;
        let dir = path.parent().map_or_else(PathBuf::new, Path::to_path_buf);
        let base = read(&dir.join(&config.base))?;
        Sweep::from_parts(config, &base).map_err(|e| match e {
            SolverError::Config(c) => SolverError::Config(locate(c, &text)),
            e => e,
        })
    }

    /// A sweep from its config and its base rear config's text.
    pub fn from_parts(config: SweepConfig, base: &str) -> Result<Sweep, SolverError> {
        check_name(&config.name)?;
        // The base must be a rear config on its own.
        RearConfig::from_toml(base).map_err(|e| ConfigError::new("base", e.to_string()))?;
        let base: toml::Table =
            toml::from_str(base).map_err(|e| ConfigError::new("base", e.message().to_string()))?;
        for (k, v) in config.vary.iter().enumerate() {
            check(
                !v.values.is_empty(),
                &format!("vary[{k}].values"),
                "needs at least one value",
            )?;
        }
        check(
            config.volume.samples > 0,
            "volume.samples",
            "must be at least 1",
        )?;
        let mut tasks: Vec<SweepTask> = Vec::new();
        let mut rear_texts: Vec<String> = Vec::new();
        for (index, overrides) in point_overrides(&config).into_iter().enumerate() {
            let what = |e: String| {
                let listed: Vec<String> = overrides
                    .iter()
                    .map(|(k, v)| format!("{k} = {v}"))
                    .collect();
                ConfigError::new(format!("point {index} ({})", listed.join(", ")), e)
            };
            let mut rear = base.clone();
            let mut front = toml::Table::try_from(config.front).map_err(|e| what(e.to_string()))?;
            let mut sensors =
                toml::Table::try_from(config.sensors).map_err(|e| what(e.to_string()))?;
            for (key, value) in &overrides {
                let (table, path) = match key.split_once('.') {
                    Some(("front", rest)) => (&mut front, rest),
                    Some(("sensors", rest)) => (&mut sensors, rest),
                    _ => (&mut rear, key.as_str()),
                };
                set_key(table, path, value.clone()).map_err(|e| what(format!("{key}: {e}")))?;
            }
            let front: FrontSettings = front
                .try_into()
                .map_err(|e: toml::de::Error| what(format!("front: {}", e.message())))?;
            let sensors: MeasurementError = sensors
                .try_into()
                .map_err(|e: toml::de::Error| what(format!("sensors: {}", e.message())))?;
            check_front(&front).map_err(|e| what(e.to_string()))?;
            // Points with the same rear config share a task.
            rear.remove("name");
            let rear_text = toml::to_string(&rear).map_err(|e| what(e.to_string()))?;
            let task = match rear_texts.iter().position(|t| *t == rear_text) {
                Some(k) => k,
                None => {
                    let named =
                        format!("name = \"{}-{:02}\"\n{rear_text}", config.name, tasks.len());
                    let rear_config =
                        RearConfig::from_toml(&named).map_err(|e| what(e.to_string()))?;
                    rear_texts.push(rear_text);
                    tasks.push(SweepTask {
                        rear: rear_config,
                        points: Vec::new(),
                    });
                    tasks.len() - 1
                }
            };
            tasks[task].points.push(SweepPoint {
                index,
                overrides: overrides
                    .iter()
                    .map(|(k, v)| (k.clone(), serde_json::to_value(v).unwrap_or_default()))
                    .collect(),
                front,
                sensors,
                volume: config.volume,
            });
        }
        Ok(Sweep { config, tasks })
    }

    /// The points, in order.
    pub fn points(&self) -> usize {
        self.tasks.iter().map(|t| t.points.len()).sum()
    }
}

/// The overrides of every point: each listed point (or the base alone) combined with every
/// combination of the varied values (the last key varying fastest).
fn point_overrides(config: &SweepConfig) -> Vec<Vec<(String, toml::Value)>> {
    let mut out: Vec<Vec<(String, toml::Value)>> = if config.points.is_empty() {
        vec![Vec::new()]
    } else {
        config
            .points
            .iter()
            .map(|table| {
                let mut flat = Vec::new();
                flatten("", table, &mut flat);
                flat
            })
            .collect()
    };
    for v in &config.vary {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                v.values.iter().map(move |value| {
                    let mut p = prefix.clone();
                    p.push((v.key.clone(), value.clone()));
                    p
                })
            })
            .collect();
    }
    out
}

/// A listed point's table as dotted keys (`{game = {ego = {min = -2}}}` -> `game.ego.min`).
fn flatten(prefix: &str, table: &toml::Table, out: &mut Vec<(String, toml::Value)>) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            // An inline table whose keys are all config keys is a nested point key; a table
            // value (a range `{ min, max }`) is set whole only where the key names it whole.
            toml::Value::Table(t) if !is_range(t) => flatten(&key, t, out),
            _ => out.push((key, v.clone())),
        }
    }
}

/// `{ min = .., max = .. }`: a config's range, set as a whole.
fn is_range(t: &toml::Table) -> bool {
    t.len() == 2 && t.contains_key("min") && t.contains_key("max")
}

/// Sets the dotted `path` in `table` to `value`, making intermediate tables where the config
/// has optional ones.
fn set_key(table: &mut toml::Table, path: &str, value: toml::Value) -> Result<(), String> {
    let mut parts = path.split('.').peekable();
    let mut here = table;
    while let Some(part) = parts.next() {
        if parts.peek().is_none() {
            here.insert(part.to_string(), value);
            return Ok(());
        }
        here = match here
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        {
            toml::Value::Table(t) => t,
            _ => return Err(format!("`{part}` is not a table")),
        };
    }
    Err("an empty key".into())
}

fn check_front(f: &FrontSettings) -> Result<(), ConfigError> {
    check(
        f.leader_braking.is_none_or(|b| b.is_finite() && b > 0.0),
        "front.leader_braking",
        "must be a positive deceleration, m/s^2",
    )?;
    check(
        f.response_time.is_finite() && f.response_time >= 0.0,
        "front.response_time",
        "must be at least 0 s",
    )?;
    check(
        f.response_acceleration.is_finite(),
        "front.response_acceleration",
        "must be a finite acceleration, m/s^2",
    )?;
    check(
        f.jerk.is_none_or(|j| j.is_finite() && j > 0.0),
        "front.jerk",
        "must be a positive jerk, m/s^3",
    )?;
    check(
        f.front_level.is_finite() && f.rear_level.is_finite(),
        "front",
        "the levels must be finite",
    )
}

/// Runs one task: solves and proves its table into `dir/<rear name>/`, then measures it for
/// each of its points.
pub fn run_task(
    task: &SweepTask,
    dir: &Path,
    events: &mut dyn FnMut(RearEvent),
) -> Result<Vec<PointResult>, SolverError> {
    let (summary, report, bytes) = run_rear_with_report(&task.rear, dir, events)?;
    let table = Table::parse(&bytes)?;
    let rear = RearTable::from_table(&table)?;
    let axes = [rear.axis(0), rear.axis(1), rear.axis(2)];
    let exact = robustness(&table, &report, axes, &MeasurementError::EXACT);
    let figures = TableFigures {
        name: summary.name.clone(),
        iterations: summary.iterations,
        stopped: summary.stopped,
        solve_s: summary.solve_s,
        verify_s: summary.verify_s,
        certified_cells: summary.verification.certified_cells,
        proven_cells: summary.verification.proven_cells,
        proven: summary.verification.is_complete(),
        plateau_m: summary.plateau_m,
        error_bound_m: table.header().error_bound.total(),
        table_bytes: summary.table_bytes,
    };
    task.points
        .iter()
        .map(|point| {
            let declared = robustness(&table, &report, axes, &point.sensors);
            Ok(PointResult {
                point: point.clone(),
                table: figures.clone(),
                volume: certified_volume(&table, &point.front, &point.volume)?,
                measured_rear: MeasuredRear {
                    exact_share: exact.passing_share,
                    declared_share: declared.passing_share,
                    declared_unproven: declared.unproven,
                },
            })
        })
        .collect()
}

/// The sampled certified volume of a split table ([module docs](self)).
pub fn certified_volume(
    table: &Table<'_>,
    front: &FrontSettings,
    volume: &VolumeSettings,
) -> Result<Volume, SolverError> {
    let Game::ThreeCarSplit {
        ego,
        leader,
        max_speed,
        ..
    } = table.header().game
    else {
        return Err(SolverError::Verify(
            "the certified volume needs a ThreeCarSplit (rear) table".into(),
        ));
    };
    let model = FrontModel {
        ramp_from: front.response_acceleration,
        jerk: front.jerk.unwrap_or(f32::INFINITY),
        ..FrontModel::step(
            front.leader_braking.unwrap_or(-leader.min),
            -ego.min,
            front.response_time,
            front.response_acceleration,
            max_speed,
        )
    };
    let bound = table.header().error_bound.total();
    let rear_ok = |s: &[f32; 5]| {
        table
            .value_at(&[s[2], s[3], s[4]])
            .is_ok_and(|w| w - bound > front.rear_level)
    };
    let front_ok = |s: &[f32; 5]| front_value(s[0], s[1], s[4], &model) > front.front_level;
    let share = |states: &[[f32; 5]], f: &dyn Fn(&[f32; 5]) -> bool| {
        states.iter().filter(|s| f(s)).count() as f64 / states.len() as f64
    };
    let fast = sample_states(volume, 15.0);
    let all = sample_states(volume, 0.0);
    Ok(Volume {
        samples: volume.samples,
        certified_ego_15_35: share(&fast, &|s| front_ok(s) && rear_ok(s)),
        certified_ego_0_35: share(&all, &|s| front_ok(s) && rear_ok(s)),
        front_ego_0_35: share(&all, &front_ok),
        rear_ego_0_35: share(&all, &rear_ok),
    })
}

/// States `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)`, uniform over
/// gaps in `[0, 75]` m, the other cars within 15 m/s of the ego, every speed in `[0, 35]` m/s,
/// and the ego's speed at least `low_ego_speed`.
fn sample_states(v: &VolumeSettings, low_ego_speed: f32) -> Vec<[f32; 5]> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(v.seed);
    let mut out = Vec::with_capacity(v.samples);
    while out.len() < v.samples {
        let ve: f32 = rng.random_range(low_ego_speed..35.0);
        let vl = ve + rng.random_range(-15.0f32..15.0);
        let vf = ve - rng.random_range(-15.0f32..15.0);
        if !(0.0..=35.0).contains(&vl) || !(0.0..=35.0).contains(&vf) {
            continue;
        }
        let gap_leader = rng.random_range(0.0f32..75.0);
        let gap_follower = rng.random_range(0.0f32..75.0);
        out.push([gap_leader, vl, gap_follower, vf, ve]);
    }
    out
}

/// Runs a sweep into `out/<name>/`: its tasks in parallel, then [`write_summary`].
pub fn run_sweep(
    sweep: &Sweep,
    out: &Path,
    events: &(dyn Fn(SweepEvent) + Sync),
) -> Result<SweepSummary, SolverError> {
    let t0 = Instant::now();
    let dir = out.join(&sweep.config.name);
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<Vec<PointResult>> = sweep
        .tasks
        .par_iter()
        .enumerate()
        .with_max_len(1)
        .map(|(k, task)| {
            let r = run_task(task, &dir, &mut |e| events(SweepEvent::Rear(k, e)));
            let n = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            events(SweepEvent::TaskFinished(k, n, sweep.tasks.len()));
            r
        })
        .collect::<Result<_, _>>()?;
    let points = results.into_iter().flatten().collect();
    write_summary(sweep, points, out, t0.elapsed().as_secs_f64())
}

/// Writes `out/<name>/sweep.json`, `sweep.csv` and `sweep.png` from the points' results
/// (however they were run).
pub fn write_summary(
    sweep: &Sweep,
    mut points: Vec<PointResult>,
    out: &Path,
    seconds: f64,
) -> Result<SweepSummary, SolverError> {
    points.sort_by_key(|p| p.point.index);
    check(
        points.len() == sweep.points()
            && points.iter().enumerate().all(|(k, p)| p.point.index == k),
        "points",
        "the results are not one per point of the sweep",
    )?;
    let dir = out.join(&sweep.config.name);
    std::fs::create_dir_all(&dir).map_err(|e| SolverError::Io {
        path: dir.display().to_string(),
        source: e,
    })?;
    // The listed points' keys in the order they first appear, then the varied ones.
    let mut keys: Vec<String> = Vec::new();
    let listed = sweep.config.points.iter().flat_map(|t| {
        let mut flat = Vec::new();
        flatten("", t, &mut flat);
        flat.into_iter().map(|(k, _)| k)
    });
    for k in listed.chain(sweep.config.vary.iter().map(|v| v.key.clone())) {
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let summary = SweepSummary {
        name: sweep.config.name.clone(),
        description: sweep.config.description.clone(),
        keys,
        tables: sweep.tasks.len(),
        points,
        seconds,
    };
    output::write_json(&dir.join("sweep.json"), &summary)?;
    let csv = dir.join("sweep.csv");
    std::fs::write(&csv, summary_csv(&summary)).map_err(|e| SolverError::Io {
        path: csv.display().to_string(),
        source: e,
    })?;
    plot_summary(&summary, &dir.join("sweep.png"))?;
    Ok(summary)
}

/// A value as a person reads it: a range `{min, max}` as `[min, max]`, a number as written.
pub fn show_value(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Object(o) if o.len() == 2 => match (o.get("min"), o.get("max")) {
            (Some(a), Some(b)) => format!("[{a}, {b}]"),
            _ => v.to_string(),
        },
        serde_json::Value::String(s) => s.clone(),
        _ => v.to_string(),
    }
}

/// One line per point: its overrides, then the figures, with units in the header.
fn summary_csv(s: &SweepSummary) -> String {
    let mut out = String::new();
    let mut header: Vec<String> = vec!["point".into()];
    header.extend(s.keys.iter().cloned());
    header.extend(
        [
            "table",
            "proven",
            "certified_cells",
            "proven_cells",
            "iterations",
            "solve_s",
            "verify_s",
            "plateau_m",
            "error_bound_m",
            "certified_ego_0_35",
            "certified_ego_15_35",
            "front_ego_0_35",
            "rear_ego_0_35",
            "rear_nodes_exact",
            "rear_nodes_declared_error",
        ]
        .map(String::from),
    );
    out.push_str(&header.join(","));
    out.push('\n');
    for p in &s.points {
        let mut row = vec![p.point.index.to_string()];
        let set: BTreeMap<&str, &serde_json::Value> = p
            .point
            .overrides
            .iter()
            .map(|(k, v)| (k.as_str(), v))
            .collect();
        row.extend(s.keys.iter().map(|k| {
            set.get(k.as_str())
                .map_or(String::new(), |v| csv_field(&show_value(v)))
        }));
        let t = &p.table;
        row.extend([
            t.name.clone(),
            t.proven.to_string(),
            t.certified_cells.to_string(),
            t.proven_cells.to_string(),
            t.iterations.to_string(),
            format!("{:.2}", t.solve_s),
            format!("{:.2}", t.verify_s),
            format!("{:.4}", t.plateau_m),
            format!("{:.4}", t.error_bound_m),
            format!("{:.4}", p.volume.certified_ego_0_35),
            format!("{:.4}", p.volume.certified_ego_15_35),
            format!("{:.4}", p.volume.front_ego_0_35),
            format!("{:.4}", p.volume.rear_ego_0_35),
            format!("{:.4}", p.measured_rear.exact_share),
            format!("{:.4}", p.measured_rear.declared_share),
        ]);
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

/// A CSV field, quoted when it holds a comma or a quote.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// One bar per point: its certified share over ego speeds 0-35 m/s, coloured by whether the
/// firmware would run its table (colour-blind-safe: blue proven, vermillion not), each row
/// labelled with its overrides.
fn plot_summary(s: &SweepSummary, path: &Path) -> Result<(), SolverError> {
    output::register_plot_font()?;
    let err = |e: &dyn std::fmt::Display| SolverError::Plot {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let rows = s.points.len().max(1);
    let height = 140 + 34 * rows as u32;
    let root = BitMapBackend::new(path, (1100, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let label = |p: &PointResult| {
        if p.point.overrides.is_empty() {
            "base".to_string()
        } else {
            p.point
                .overrides
                .iter()
                .map(|(k, v)| format!("{k} = {}", show_value(v)))
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "Sweep {}: certified share of sampled states, ego speeds 0-35 m/s",
                s.name
            ),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(420)
        .build_cartesian_2d(0.0..1.0f64, (0..rows).into_segmented())
        .map_err(|e| err(&e))?;
    // The first point at the top.
    let row = |i: usize| rows - 1 - i;
    let labels: Vec<String> = (0..rows)
        .map(|r| s.points.get(rows - 1 - r).map(label).unwrap_or_default())
        .collect();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc("share of sampled states certified (front and rear, exact sensors)")
        .y_labels(rows)
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
            _ => String::new(),
        })
        .draw()
        .map_err(|e| err(&e))?;
    let (proven, refused) = (super::palette::BLUE, super::palette::VERMILLION);
    let bar = |i: usize, p: &PointResult| {
        [
            (0.0, SegmentValue::Exact(row(i))),
            (p.volume.certified_ego_0_35, SegmentValue::Exact(row(i) + 1)),
        ]
    };
    chart
        .draw_series(s.points.iter().enumerate().map(|(i, p)| {
            let colour = if p.table.proven { proven } else { refused };
            Rectangle::new(bar(i, p), colour.filled())
        }))
        .map_err(|e| err(&e))?;
    // A white outline parts the bars.
    chart
        .draw_series(
            s.points
                .iter()
                .enumerate()
                .map(|(i, p)| Rectangle::new(bar(i, p), WHITE.stroke_width(6))),
        )
        .map_err(|e| err(&e))?;
    for (name, colour) in [
        ("table proven (the firmware runs it)", proven),
        ("table not proven (the firmware refuses it)", refused),
    ] {
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, SegmentValue<usize>)>>())
            .map_err(|e| err(&e))?
            .label(name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], colour.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
