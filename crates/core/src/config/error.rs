//! Errors a user can make in a scene or an override, each naming the key and what is accepted.

use thiserror::Error;

/// Everything that can be wrong with a scene file or a `--set` override.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// The scene's chain cannot be linearised (its damping ratio, its automatic step).
    #[error("this scene cannot be linearised: {0}")]
    Linear(#[from] crate::model::linear::LinearError),
    /// The scene file could not be read.
    #[error("cannot read scene file `{path}`: {source}")]
    Io {
        /// Path that was given.
        path: String,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The path is not a scene file (not a regular file, or far too large).
    #[error("`{path}` is not a scene file: {reason}")]
    NotAScene {
        /// Path that was given.
        path: String,
        /// Why.
        reason: String,
    },
    /// The scene file is not valid TOML.
    #[error("scene `{path}` is not valid TOML: {message}")]
    Toml {
        /// Path (or `<embedded>`).
        path: String,
        /// Parser message, with line and column.
        message: String,
    },
    /// A `--set` argument is not of the form `section.key=value`.
    #[error("bad override `{arg}`: {reason}")]
    BadOverride {
        /// The argument as given.
        arg: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A key that no part of the program reads (usually a typo).
    #[error("unknown key `{key}`{}", suggestion.as_ref().map(|s| format!(" (did you mean `{s}`?)")).unwrap_or_default())]
    UnknownKey {
        /// Dotted key path.
        key: String,
        /// The closest known key, if one is close.
        suggestion: Option<String>,
    },
    /// A key holds a value of the wrong TOML type.
    #[error("key `{key}` must be {expected}, found {found}")]
    WrongType {
        /// Dotted key path.
        key: String,
        /// What is expected, e.g. "a number (kg)".
        expected: String,
        /// What was found, e.g. "a string \"abc\"".
        found: String,
    },
    /// A number is NaN or infinite.
    #[error("key `{key}` must be a finite number, found {}", crate::text::num(*value))]
    NotFinite {
        /// Dotted key path.
        key: String,
        /// The value as written.
        value: f64,
    },
    /// A number lies outside the accepted range.
    #[error("key `{key}` = {} is out of range: accepted {range}", crate::text::num(*value))]
    OutOfRange {
        /// Dotted key path.
        key: String,
        /// The value given.
        value: f64,
        /// The accepted range, with units, e.g. "(0, 90) deg".
        range: String,
    },
    /// A string key holds a value that is not one of its choices.
    #[error("key `{key}` = \"{value}\" is not one of {choices}")]
    BadChoice {
        /// Dotted key path.
        key: String,
        /// The value given.
        value: String,
        /// The accepted values.
        choices: String,
    },
    /// A combination of keys that cannot work together.
    #[error("key `{key}`: {reason}")]
    Inconsistent {
        /// Dotted key path of the offending key.
        key: String,
        /// Why it is inconsistent.
        reason: String,
    },
}
