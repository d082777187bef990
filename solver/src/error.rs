//! Typed errors of the solver library (the binary wraps them with `anyhow`).

use std::fmt;

/// A configuration the solver refuses, naming the field and the reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// The field, as a dotted path in the TOML file (e.g. `game.time_gap.min`).
    pub field: String,
    /// Why it is refused.
    pub reason: String,
}

impl ConfigError {
    /// A refusal of `field` for `reason`.
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        ConfigError {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid config field `{}`: {}", self.field, self.reason)
    }
}

impl std::error::Error for ConfigError {}

/// Everything that can go wrong in the solver library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SolverError {
    /// The configuration is refused.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The table could not be encoded.
    #[error("table encoding failed: {0}")]
    Table(#[from] table_format::Error),
    /// Writing an output file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Drawing a plot failed.
    #[error("plotting {path}: {message}")]
    Plot {
        /// The file.
        path: String,
        /// The plotting library's message.
        message: String,
    },
    /// `verify` cannot check this table.
    #[error("verify: {0}")]
    Verify(String),
    /// The value function became NaN or infinite: the scheme is unstable for these settings.
    #[error("the value function became non-finite at t = {time:.3} s (unstable settings?)")]
    NonFinite {
        /// Backward time reached.
        time: f64,
    },
}
