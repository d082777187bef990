//! Run configurations: the TOML schema, the defaults that reproduce the paper, and validation
//! that names the offending field.
//!
//! IDM defaults are Treiber & Kesting's highway values (*Traffic Flow Dynamics*, Springer 2013,
//! Table 11.2): desired speed 120 km/h (33.3 m/s), time gap 1.0 s, jam distance 2 m, maximum
//! acceleration 1.0 m/s^2, comfortable deceleration 1.5 m/s^2, exponent 4. The paper sets the
//! jam distance to 0 "to allow crashes"; so do the paper configs here.

use serde::{Deserialize, Serialize};

use crate::engine::hji::{Boundary, Dissipation, Numerics, Obstacle, RkOrder, Stop};
use crate::engine::scheme::Spatial;
use crate::error::ConfigError;

/// Bounds `[min, max]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// Lower end.
    pub min: f64,
    /// Upper end.
    pub max: f64,
}

/// One grid axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisConfig {
    /// First node.
    pub min: f64,
    /// Last node.
    pub max: f64,
    /// Number of nodes.
    pub points: usize,
}

/// Which game.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GameKindConfig {
    /// 2-D leader-ego game.
    TwoCar,
    /// 4-D, follower any bounded acceleration.
    ThreeCarBaseline,
    /// 4-D, IDM follower with adversarial time gap.
    ThreeCarIdm,
    /// 5-D in absolute speeds, IDM follower with adversarial time gap.
    ThreeCarIdmSpeeds,
}

/// IDM parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdmConfig {
    /// `a`, m/s^2.
    pub max_acceleration: f64,
    /// `b`, m/s^2.
    pub comfortable_deceleration: f64,
    /// `v0`, m/s.
    pub desired_speed: f64,
    /// `delta`.
    pub exponent: u8,
    /// `s0`, m.
    pub jam_distance: f64,
}

impl Default for IdmConfig {
    fn default() -> Self {
        IdmConfig {
            max_acceleration: 1.0,
            comfortable_deceleration: 1.5,
            desired_speed: 33.3,
            exponent: 4,
            jam_distance: 2.0,
        }
    }
}

/// How the IDM follower's absolute speed is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FollowerSpeedConfig {
    /// The paper's reading: fixed nominal ego speed.
    NominalEgoSpeed {
        /// m/s.
        ego_speed: f64,
    },
    /// The sound reading: adversarial over the feasible range.
    Adversarial {
        /// Lowest ego speed assumed, m/s (0: no assumption).
        #[serde(default)]
        min_ego_speed: f64,
        /// Largest vehicle speed, m/s.
        max_speed: f64,
    },
}

/// The game section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GameConfig {
    /// Which game.
    pub kind: GameKindConfig,
    /// Ego acceleration bounds.
    pub ego: Range,
    /// Leader acceleration bounds.
    pub leader: Range,
    /// Follower acceleration bounds (baseline) or IDM clip (IDM game).
    #[serde(default)]
    pub follower: Option<Range>,
    /// `l = min(gaps) - min_gap`, m.
    #[serde(default)]
    pub min_gap: f64,
    /// IDM parameters (IDM game).
    #[serde(default)]
    pub idm: Option<IdmConfig>,
    /// IDM desired time gap range, s (IDM game).
    #[serde(default)]
    pub time_gap: Option<Range>,
    /// Follower speed model (4-D IDM game).
    #[serde(default)]
    pub follower_speed: Option<FollowerSpeedConfig>,
    /// Largest speed of any vehicle, m/s (5-D IDM game: the speed axes span `[0, max_speed]`).
    #[serde(default)]
    pub max_speed: Option<f64>,
}

/// The grid section: one entry per state axis, by name.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridConfig {
    /// Gap to the leader, m.
    pub gap_leader: AxisConfig,
    /// `v_leader - v_ego`, m/s (two-car and 4-D games).
    #[serde(default)]
    pub rel_speed_leader: Option<AxisConfig>,
    /// Gap to the follower, m (three-car games).
    #[serde(default)]
    pub gap_follower: Option<AxisConfig>,
    /// `v_ego - v_follower`, m/s (4-D three-car games).
    #[serde(default)]
    pub rel_speed_follower: Option<AxisConfig>,
    /// The leader's speed, m/s (5-D game).
    #[serde(default)]
    pub leader_speed: Option<AxisConfig>,
    /// The follower's speed, m/s (5-D game).
    #[serde(default)]
    pub follower_speed: Option<AxisConfig>,
    /// The ego's speed, m/s (5-D game).
    #[serde(default)]
    pub ego_speed: Option<AxisConfig>,
}

/// The numerics section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NumericsConfig {
    /// `upwind1`, `eno2` or `weno5`.
    #[serde(default = "default_spatial")]
    pub spatial: Spatial,
    /// 1, 2 or 3.
    #[serde(default = "default_rk")]
    pub rk_order: u8,
    /// CFL number.
    #[serde(default = "default_cfl")]
    pub cfl: f64,
    /// `local` or `global`.
    #[serde(default = "default_dissipation")]
    pub dissipation: Dissipation,
    /// `pessimistic` (default, sound) or `extrapolate` (hj_reachability's behaviour).
    #[serde(default = "default_boundary")]
    pub boundary: Boundary,
    /// `freeze` (default: `min(0, H)`, monotone in the horizon) or `constraint`
    /// (`min(l, ...)`, for values solved to convergence); see [`Obstacle`].
    #[serde(default)]
    pub obstacle: Obstacle,
}

fn default_spatial() -> Spatial {
    Spatial::Weno5
}
fn default_rk() -> u8 {
    3
}
fn default_cfl() -> f64 {
    0.75
}
fn default_dissipation() -> Dissipation {
    Dissipation::Local
}
fn default_boundary() -> Boundary {
    Boundary::Pessimistic
}

impl Default for NumericsConfig {
    fn default() -> Self {
        NumericsConfig {
            spatial: default_spatial(),
            rk_order: default_rk(),
            cfl: default_cfl(),
            dissipation: default_dissipation(),
            boundary: default_boundary(),
            obstacle: Obstacle::default(),
        }
    }
}

/// The horizon section: a fixed horizon, or convergence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HorizonConfig {
    /// Fixed horizon, s (or the time limit when converging).
    pub time: f64,
    /// If set, stop when `max |dV/dt|` falls below it (value units per second).
    #[serde(default)]
    pub converge_tolerance: Option<f64>,
}

/// The table section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableConfig {
    /// 8 or 16.
    #[serde(default = "default_bits")]
    pub bits: u8,
    /// Nodes per axis in state order; each `points - 1` must divide the solver axis's
    /// `points - 1` (the table's nodes are a subset of the solver's). Default: the solver grid.
    #[serde(default)]
    pub points: Option<Vec<usize>>,
}

fn default_bits() -> u8 {
    16
}

impl Default for TableConfig {
    fn default() -> Self {
        TableConfig {
            bits: default_bits(),
            points: None,
        }
    }
}

/// The trusted-box section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrustedConfig {
    /// Measure the trusted box with a second solve under the other boundary condition; if
    /// false the trusted box is the whole grid (only sound when nothing leaves the grid).
    #[serde(default = "yes")]
    pub measure: bool,
    /// Largest value difference between the two boundary conditions still called "no
    /// influence", m.
    #[serde(default = "default_trusted_tolerance")]
    pub tolerance: f64,
}

fn yes() -> bool {
    true
}
fn default_trusted_tolerance() -> f64 {
    0.25
}

impl Default for TrustedConfig {
    fn default() -> Self {
        TrustedConfig {
            measure: true,
            tolerance: default_trusted_tolerance(),
        }
    }
}

/// A slice to plot: the speed axes held fixed (the two gaps are the plot's axes). 4-D games
/// use the relative speeds, the 5-D game the three absolute speeds; missing ones are 0 (4-D)
/// or, in 5-D, 20 m/s for the ego and the ego's speed for the other two.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SliceConfig {
    /// `rel_speed_leader`, m/s (4-D).
    #[serde(default)]
    pub rel_speed_leader: f64,
    /// `rel_speed_follower`, m/s (4-D).
    #[serde(default)]
    pub rel_speed_follower: f64,
    /// `ego_speed`, m/s (5-D).
    #[serde(default)]
    pub ego_speed: Option<f64>,
    /// `leader_speed`, m/s (5-D).
    #[serde(default)]
    pub leader_speed: Option<f64>,
    /// `follower_speed`, m/s (5-D).
    #[serde(default)]
    pub follower_speed: Option<f64>,
}

impl SliceConfig {
    /// The slice's fixed speeds as a point of the state space, with the gaps at `(x1, x2)`.
    pub fn point(&self, five_d: bool, x1: f64, x2: f64) -> Vec<f64> {
        if five_d {
            let ve = self.ego_speed.unwrap_or(20.0);
            vec![
                x1,
                self.leader_speed.unwrap_or(ve),
                x2,
                self.follower_speed.unwrap_or(ve),
                ve,
            ]
        } else {
            vec![x1, self.rel_speed_leader, x2, self.rel_speed_follower]
        }
    }

    /// A file-name tag for the slice.
    pub fn tag(&self, five_d: bool) -> String {
        let p = self.point(five_d, 0.0, 0.0);
        if five_d {
            format!("v1_{:.1}_v3_{:.1}_ve_{:.1}", p[1], p[3], p[4])
        } else {
            format!("vg1_{:+.1}_vg2_{:+.1}", p[1], p[3])
        }
    }
}

/// A whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Output folder name, `[a-z0-9_-]+`.
    pub name: String,
    /// A sentence on what the run shows.
    #[serde(default)]
    pub description: String,
    /// The game.
    pub game: GameConfig,
    /// The grid.
    pub grid: GridConfig,
    /// The numerics.
    #[serde(default)]
    pub numerics: NumericsConfig,
    /// The horizon.
    pub horizon: HorizonConfig,
    /// The table.
    #[serde(default)]
    pub table: TableConfig,
    /// The trusted box.
    #[serde(default)]
    pub trusted_box: TrustedConfig,
    /// Slices to plot (three-car games); default: both relative speeds 0.
    #[serde(default)]
    pub slices: Vec<SliceConfig>,
}

/// `Ok` if `ok`, else the refusal of `field` for `reason`.
/// Parses a TOML document into `T`, turning the parser's refusal into a [`ConfigError`] that
/// names the key path (`game.time_gap.min`), the line and the column: the parser reports a
/// byte span, which says nothing to a person editing the file.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, ConfigError> {
    toml::from_str(text).map_err(|e| {
        // Rust's type names say nothing to a person editing the file.
        let message = e
            .message()
            .trim()
            .replace("expected usize", "expected a whole number of at least 0")
            .replace("expected u32", "expected a whole number of at least 0")
            .replace("expected u64", "expected a whole number of at least 0")
            .replace("expected f64", "expected a number")
            .replace("expected f32", "expected a number");
        let Some(span) = e.span() else {
            return ConfigError::new("document", message);
        };
        let (line, column) = line_column(text, span.start);
        let before = &text[..span.start.min(text.len())];
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        // The enclosing table: the last `[header]` above the error.
        let table = before
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| l.starts_with('[') && !l.starts_with("[["))
            .map(|l| l.trim_matches(|c| c == '[' || c == ']').trim().to_string());
        // The key: the one named in the message (unknown or missing field), else the one the
        // erroneous line assigns.
        let named = message
            .split('`')
            .nth(1)
            .filter(|_| {
                message.starts_with("unknown field") || message.starts_with("missing field")
            })
            .map(str::to_string);
        let assigned = text[line_start..]
            .lines()
            .next()
            .and_then(|l| l.split_once('='))
            .map(|(k, _)| k.trim().to_string())
            .filter(|k| !k.is_empty() && !k.starts_with('['));
        let key = if message.starts_with("missing field") {
            // The span of a missing field is the table that lacks it.
            named
        } else {
            assigned.or(named)
        };
        let field = match (table, key) {
            (Some(t), Some(k)) if !t.is_empty() => format!("{t}.{k}"),
            (_, Some(k)) => k,
            (Some(t), None) => t,
            (None, None) => "document".into(),
        };
        ConfigError::new(field, format!("{message} (line {line}, column {column})"))
    })
}

/// The line and the column (both from 1, the column in characters) of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (
        before.matches('\n').count() + 1,
        before[line_start..].chars().count() + 1,
    )
}

/// `error` (a refusal found after parsing, by `validate`) with the line and the column of its
/// field in `text` appended, as the parser's own refusals have them.
///
/// The field is a dotted path with array indices (`grid.gap_leader.points`,
/// `vary[1].values`). The path is walked through the document with the parser's spans; where
/// a segment is absent (a required field left out), the position is that of the deepest
/// table that is present, which is where the field must be written. An error that already
/// carries a position, or whose document does not parse, is returned as it is.
pub(crate) fn locate(error: ConfigError, text: &str) -> ConfigError {
    use toml::de::{DeTable, DeValue};
    if error.reason.contains("(line ") {
        return error;
    }
    let Ok(root) = DeTable::parse(text) else {
        return error;
    };
    let mut span = None;
    let mut table = Some(root.get_ref());
    let mut here: Option<&toml::Spanned<DeValue<'_>>> = None;
    'walk: for segment in error.field.split('.') {
        // `name[3][1]`: a key, then indices into arrays.
        let mut parts = segment.split('[');
        let key = parts.next().unwrap_or("");
        if !key.is_empty() {
            let Some((name, value)) =
                table.and_then(|t| t.iter().find(|(k, _)| k.get_ref().as_ref() == key))
            else {
                break;
            };
            span = Some(name.span());
            here = Some(value);
        }
        for index in parts {
            let Some(i) = index.trim_end_matches(']').parse::<usize>().ok() else {
                break 'walk;
            };
            let Some(DeValue::Array(array)) = here.map(|h| h.get_ref()) else {
                break 'walk;
            };
            let Some(item) = array.get(i) else {
                break 'walk;
            };
            span = Some(item.span());
            here = Some(item);
        }
        table = match here.map(|h| h.get_ref()) {
            Some(DeValue::Table(t)) => Some(t),
            _ => None,
        };
    }
    let Some(span) = span else {
        return error;
    };
    let (line, column) = line_column(text, span.start);
    ConfigError::new(
        error.field,
        format!("{} (line {line}, column {column})", error.reason),
    )
}

/// The most memory a config may ask for, bytes (8 GiB): checked before anything is allocated,
/// so that a grid too large is refused with a message instead of aborting the process.
pub const MAX_GRID_BYTES: u64 = 8 << 30;
/// Peak resident bytes per grid node of a level-set solve (measured: 36.7 MB for the 31^4
/// baseline grid, 40 B per node; rounded up).
pub(crate) const LEVEL_SET_BYTES_PER_NODE: u64 = 48;
/// Peak resident bytes per node of the sampled-data iteration (measured: 158 MiB for the
/// 133 x 73 x 73 deployment grid, 233 B per node; rounded up).
pub(crate) const SAMPLED_BYTES_PER_NODE: u64 = 256;

/// Refuses a grid of `nodes` nodes (`None`: more than `usize` can count) whose solve would need
/// more than [`MAX_GRID_BYTES`].
pub(crate) fn check_memory(
    nodes: Option<usize>,
    bytes_per_node: u64,
    field: &str,
    what: &str,
) -> Result<(), ConfigError> {
    let bytes = nodes.and_then(|n| (n as u64).checked_mul(bytes_per_node));
    match bytes {
        Some(b) if b <= MAX_GRID_BYTES => Ok(()),
        _ => Err(ConfigError::new(
            field,
            format!(
                "{} nodes need about {} of memory ({bytes_per_node} B per node), more than the \
                 {} limit: lower {what}",
                nodes.map_or_else(|| "too many".to_string(), |n| n.to_string()),
                bytes.map_or_else(|| "more than 16 EiB".to_string(), human_bytes),
                human_bytes(MAX_GRID_BYTES)
            ),
        )),
    }
}

fn human_bytes(b: u64) -> String {
    const GIB: f64 = (1u64 << 30) as f64;
    if b >= 1 << 40 {
        format!("{:.1} TiB", b as f64 / GIB / 1024.0)
    } else {
        format!("{:.1} GiB", b as f64 / GIB)
    }
}

pub(crate) fn check(ok: bool, field: &str, reason: &str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::new(field, reason))
    }
}

/// A run's name names its output folder: non-empty, a-z, 0-9, '-' and '_' only.
pub(crate) fn check_name(name: &str) -> Result<(), ConfigError> {
    check(
        !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_'),
        "name",
        "must be non-empty and use only a-z, 0-9, '-' and '_' (it names the output folder)",
    )
}

fn check_range(r: &Range, field: &str) -> Result<(), ConfigError> {
    check(
        r.min.is_finite() && r.max.is_finite() && r.min <= r.max,
        field,
        "needs finite min <= max",
    )
}

fn check_accel(r: &Range, field: &str) -> Result<(), ConfigError> {
    check_range(r, field)?;
    check(
        r.min < 0.0 && r.max > 0.0,
        field,
        "an acceleration range must contain both braking (min < 0) and accelerating (max > 0)",
    )
}

impl Config {
    /// Parses and validates a TOML document.
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let config: Config = parse_toml(text)?;
        config.validate().map_err(|e| locate(e, text))?;
        Ok(config)
    }

    /// Checks every field the solver relies on.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_name(&self.name)?;
        let g = &self.game;
        check_accel(&g.ego, "game.ego")?;
        check_accel(&g.leader, "game.leader")?;
        check(
            g.min_gap.is_finite() && g.min_gap >= 0.0,
            "game.min_gap",
            "must be finite and >= 0",
        )?;
        let three = g.kind != GameKindConfig::TwoCar;
        let five = g.kind == GameKindConfig::ThreeCarIdmSpeeds;
        let need = |present: bool, field: &str| {
            check(
                present,
                field,
                if five {
                    "required for the 5-D game (gap_leader, leader_speed, gap_follower, \
                     follower_speed, ego_speed)"
                } else {
                    "required for this game"
                },
            )
        };
        let refuse = |absent: bool, field: &str| check(absent, field, "this game has no such axis");
        let gr = &self.grid;
        if five {
            need(gr.leader_speed.is_some(), "grid.leader_speed")?;
            need(gr.follower_speed.is_some(), "grid.follower_speed")?;
            need(gr.ego_speed.is_some(), "grid.ego_speed")?;
            refuse(gr.rel_speed_leader.is_none(), "grid.rel_speed_leader")?;
            refuse(gr.rel_speed_follower.is_none(), "grid.rel_speed_follower")?;
            let vmax = g
                .max_speed
                .ok_or_else(|| ConfigError::new("game.max_speed", "required for the 5-D game"))?;
            check(
                vmax.is_finite() && vmax > 0.0,
                "game.max_speed",
                "must be > 0",
            )?;
            for (field, a) in [
                ("grid.leader_speed", gr.leader_speed),
                ("grid.follower_speed", gr.follower_speed),
                ("grid.ego_speed", gr.ego_speed),
            ] {
                if let Some(a) = a {
                    check(
                        a.min == 0.0 && a.max == vmax,
                        field,
                        "must span [0, game.max_speed] (speeds are held in that range)",
                    )?;
                }
            }
        } else {
            need(gr.rel_speed_leader.is_some(), "grid.rel_speed_leader")?;
            refuse(gr.leader_speed.is_none(), "grid.leader_speed")?;
            refuse(gr.follower_speed.is_none(), "grid.follower_speed")?;
            refuse(gr.ego_speed.is_none(), "grid.ego_speed")?;
        }
        if three {
            let f = g
                .follower
                .ok_or_else(|| ConfigError::new("game.follower", "required for three-car games"))?;
            check_accel(&f, "game.follower")?;
            check(
                self.grid.gap_follower.is_some(),
                "grid.gap_follower",
                "required for three-car games",
            )?;
            if !five {
                need(gr.rel_speed_follower.is_some(), "grid.rel_speed_follower")?;
            }
        } else {
            check(
                self.grid.gap_follower.is_none() && self.grid.rel_speed_follower.is_none(),
                "grid.gap_follower",
                "the two-car game has no follower axes",
            )?;
        }
        if g.kind == GameKindConfig::ThreeCarIdm || five {
            let idm = g.idm.unwrap_or_default();
            check(
                idm.max_acceleration.is_finite() && idm.max_acceleration > 0.0,
                "game.idm.max_acceleration",
                "must be > 0",
            )?;
            check(
                idm.comfortable_deceleration.is_finite() && idm.comfortable_deceleration > 0.0,
                "game.idm.comfortable_deceleration",
                "must be > 0 (a deceleration magnitude)",
            )?;
            check(
                idm.desired_speed.is_finite() && idm.desired_speed > 0.0,
                "game.idm.desired_speed",
                "must be > 0",
            )?;
            check(
                (1..=8).contains(&idm.exponent),
                "game.idm.exponent",
                "must be 1 to 8",
            )?;
            check(
                idm.jam_distance.is_finite() && idm.jam_distance >= 0.0,
                "game.idm.jam_distance",
                "must be >= 0",
            )?;
            let t = g
                .time_gap
                .ok_or_else(|| ConfigError::new("game.time_gap", "required for the IDM game"))?;
            check_range(&t, "game.time_gap")?;
            check(t.min >= 0.0, "game.time_gap.min", "must be >= 0")?;
            match g.follower_speed {
                None if five => {}
                Some(_) if five => {
                    return Err(ConfigError::new(
                        "game.follower_speed",
                        "the 5-D game has the follower's speed as a state; remove this field",
                    ))
                }
                None => return Err(ConfigError::new(
                    "game.follower_speed",
                    "required for the IDM game: kind = \"adversarial\" or \"nominal_ego_speed\"",
                )),
                Some(FollowerSpeedConfig::Adversarial {
                    min_ego_speed,
                    max_speed,
                }) => {
                    check(
                        min_ego_speed.is_finite() && min_ego_speed >= 0.0,
                        "game.follower_speed.min_ego_speed",
                        "must be >= 0",
                    )?;
                    check(
                        max_speed.is_finite() && max_speed > min_ego_speed,
                        "game.follower_speed.max_speed",
                        "must be > min_ego_speed",
                    )?
                }
                Some(FollowerSpeedConfig::NominalEgoSpeed { ego_speed }) => check(
                    ego_speed.is_finite() && ego_speed >= 0.0,
                    "game.follower_speed.ego_speed",
                    "must be >= 0",
                )?,
            }
        }
        for (name, axis) in self.axes() {
            let field = format!("grid.{name}");
            check(
                axis.min.is_finite() && axis.max.is_finite() && axis.min < axis.max,
                &field,
                "needs finite min < max",
            )?;
            check(
                (5..=2001).contains(&axis.points),
                &format!("{field}.points"),
                "must be 5 to 2001 (WENO5 needs 5)",
            )?;
        }
        let nodes = self
            .axes()
            .iter()
            .try_fold(1usize, |n, (_, a)| n.checked_mul(a.points));
        check_memory(nodes, LEVEL_SET_BYTES_PER_NODE, "grid", "the grid's points")?;
        let n = &self.numerics;
        check(
            n.cfl.is_finite() && n.cfl > 0.0 && n.cfl <= 1.0,
            "numerics.cfl",
            "must be in (0, 1]",
        )?;
        check(
            (1..=3).contains(&n.rk_order),
            "numerics.rk_order",
            "must be 1, 2 or 3",
        )?;
        check(
            n.boundary != Boundary::Optimistic,
            "numerics.boundary",
            "\"optimistic\" overestimates the value and only serves to measure the trusted box; \
             use \"pessimistic\" (sound) or \"extrapolate\"",
        )?;
        let h = &self.horizon;
        check(
            h.time.is_finite() && h.time > 0.0,
            "horizon.time",
            "must be > 0",
        )?;
        if let Some(tol) = h.converge_tolerance {
            check(
                tol.is_finite() && tol > 0.0,
                "horizon.converge_tolerance",
                "must be > 0",
            )?;
        }
        check(
            self.table.bits == 8 || self.table.bits == 16,
            "table.bits",
            "must be 8 or 16",
        )?;
        if let Some(points) = &self.table.points {
            let axes = self.axes();
            check(
                points.len() == axes.len(),
                "table.points",
                "needs one entry per grid axis, in state order",
            )?;
            for (p, (name, a)) in points.iter().zip(&axes) {
                check(
                    *p >= 2 && *p <= a.points && (a.points - 1) % (p - 1) == 0,
                    "table.points",
                    &format!(
                        "{name}: {p} table points do not subsample {} solver points \
                         (table points - 1 must divide solver points - 1)",
                        a.points
                    ),
                )?;
            }
        }
        check(
            self.trusted_box.tolerance.is_finite() && self.trusted_box.tolerance > 0.0,
            "trusted_box.tolerance",
            "must be > 0",
        )?;
        Ok(())
    }

    /// The grid axes in state order, with their names.
    pub fn axes(&self) -> Vec<(&'static str, AxisConfig)> {
        let gr = &self.grid;
        let named = [
            ("gap_leader", Some(gr.gap_leader)),
            ("rel_speed_leader", gr.rel_speed_leader),
            ("leader_speed", gr.leader_speed),
            ("gap_follower", gr.gap_follower),
            ("rel_speed_follower", gr.rel_speed_follower),
            ("follower_speed", gr.follower_speed),
            ("ego_speed", gr.ego_speed),
        ];
        named
            .into_iter()
            .filter_map(|(name, a)| a.map(|a| (name, a)))
            .collect()
    }

    /// The engine's numerics.
    pub fn numerics(&self) -> Numerics {
        Numerics {
            spatial: self.numerics.spatial,
            rk: match self.numerics.rk_order {
                1 => RkOrder::One,
                2 => RkOrder::Two,
                _ => RkOrder::Three,
            },
            cfl: self.numerics.cfl,
            dissipation: self.numerics.dissipation,
            boundary: self.numerics.boundary,
            obstacle: self.numerics.obstacle,
        }
    }

    /// The engine's stopping rule.
    pub fn stop(&self) -> Stop {
        match self.horizon.converge_tolerance {
            None => Stop::Horizon(self.horizon.time),
            Some(tolerance) => Stop::Converge {
                tolerance,
                max_time: self.horizon.time,
            },
        }
    }

    /// The game as the table header describes it.
    pub fn game_description(&self) -> table_format::Game {
        let b = |r: Range| table_format::Bounds::new(r.min as f32, r.max as f32);
        let g = &self.game;
        let follower = g.follower.unwrap_or(g.leader);
        match g.kind {
            GameKindConfig::TwoCar => table_format::Game::TwoCar {
                ego: b(g.ego),
                leader: b(g.leader),
            },
            GameKindConfig::ThreeCarBaseline => table_format::Game::ThreeCarBaseline {
                ego: b(g.ego),
                leader: b(g.leader),
                follower: b(follower),
            },
            GameKindConfig::ThreeCarIdmSpeeds => table_format::Game::ThreeCarIdmSpeeds {
                ego: b(g.ego),
                leader: b(g.leader),
                follower_clip: b(follower),
                idm: idm_parameters(g.idm.unwrap_or_default()),
                time_gap: b(g.time_gap.unwrap_or(Range { min: 1.0, max: 2.0 })),
                max_speed: g.max_speed.unwrap_or(35.0) as f32,
            },
            GameKindConfig::ThreeCarIdm => {
                let idm = g.idm.unwrap_or_default();
                table_format::Game::ThreeCarIdm {
                    ego: b(g.ego),
                    leader: b(g.leader),
                    follower_clip: b(follower),
                    idm: idm_parameters(idm),
                    time_gap: b(g.time_gap.unwrap_or(Range { min: 1.0, max: 2.0 })),
                    follower_speed: match g.follower_speed {
                        Some(FollowerSpeedConfig::NominalEgoSpeed { ego_speed }) => {
                            table_format::FollowerSpeed::NominalEgoSpeed {
                                ego_speed: ego_speed as f32,
                            }
                        }
                        Some(FollowerSpeedConfig::Adversarial {
                            min_ego_speed,
                            max_speed,
                        }) => table_format::FollowerSpeed::Adversarial {
                            min_ego_speed: min_ego_speed as f32,
                            max_speed: max_speed as f32,
                        },
                        // Refused by `validate`; the sound reading is the safe fallback.
                        None => table_format::FollowerSpeed::Adversarial {
                            min_ego_speed: 0.0,
                            max_speed: 40.0,
                        },
                    },
                }
            }
        }
    }
}

/// The IDM as a table header states it.
pub(crate) fn idm_parameters(idm: IdmConfig) -> table_format::IdmParameters {
    table_format::IdmParameters {
        max_acceleration: idm.max_acceleration as f32,
        comfortable_deceleration: idm.comfortable_deceleration as f32,
        desired_speed: idm.desired_speed as f32,
        exponent: idm.exponent,
        jam_distance: idm.jam_distance as f32,
    }
}

/// The built-in level-set configs that `cargo run -p solver` runs with no `--config`: the
/// paper's results and the 4-D table the firmware ran before the split certificate. The same
/// files are under `solver/configs/`.
pub fn builtin() -> Vec<(&'static str, &'static str)> {
    vec![
        ("two-car.toml", include_str!("../../configs/two-car.toml")),
        (
            "three-car-baseline.toml",
            include_str!("../../configs/three-car-baseline.toml"),
        ),
        (
            "three-car-idm.toml",
            include_str!("../../configs/three-car-idm.toml"),
        ),
        (
            "three-car-idm-adversarial-speed.toml",
            include_str!("../../configs/three-car-idm-adversarial-speed.toml"),
        ),
        (
            "three-car-idm-speeds.toml",
            include_str!("../../configs/three-car-idm-speeds.toml"),
        ),
        (
            "three-car-idm-4d-table.toml",
            include_str!("../../configs/three-car-idm-4d-table.toml"),
        ),
    ]
}

/// The built-in rear-game configs (`solver/configs/rear/`), run by the main job after
/// [`builtin`]: the firmware's deployed table.
pub fn builtin_rear() -> Vec<(&'static str, &'static str)> {
    vec![(
        "rear/deployment.toml",
        include_str!("../../configs/rear/deployment.toml"),
    )]
}
