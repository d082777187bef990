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
    /// A table could not be read or written. The cause is in the message and is not also the
    /// error's source, so that a chain of causes (`anyhow`'s `{:#}`) says it once.
    #[error("{0}")]
    Table(table_format::Error),
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

impl From<table_format::Error> for SolverError {
    fn from(e: table_format::Error) -> Self {
        SolverError::Table(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table error is said once: in the message, with no source to repeat it.
    #[test]
    fn a_table_error_is_said_once() {
        let e = SolverError::from(table_format::Error::BadMagic);
        let text = e.to_string();
        assert_eq!(text, "not a safety table (bad magic bytes)");
        assert!(std::error::Error::source(&e).is_none());
    }
}
