//! The engine's one error type. Every message carries the offending values, so that a user
//! reading it in Python knows which event, parameter or file was wrong and why.

use thiserror::Error;

/// Result alias used across the engine.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in the engine. The Python binding maps each variant to a class
/// of the `uavsnn.UavsnnError` hierarchy (see [`Error::python_class`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// An event is malformed: out of the sensor, or its time goes backwards.
    #[error("event {index}: {reason}")]
    InvalidEvent { index: usize, reason: String },

    /// A parameter is outside its valid range (NaN, zero, negative, too large...).
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter { name: &'static str, reason: String },

    /// Array shapes do not agree with each other or with the configuration.
    #[error("shape mismatch for `{name}`: expected {expected}, got {got}")]
    Shape {
        name: &'static str,
        expected: String,
        got: String,
    },

    /// A model file is corrupt, of another version, or inconsistent with its config.
    #[error("model file: {0}")]
    Model(String),

    /// A stream was fed out of order or in a state that does not allow the call.
    #[error("stream: {0}")]
    Stream(String),

    /// Simulation input (video frames, scene parameters) is unusable.
    #[error("simulation: {0}")]
    Simulation(String),

    /// A bug: an invariant of the engine does not hold. Reported, never a panic.
    #[error("internal error (please report): {0}")]
    Internal(String),
}

impl Error {
    /// Name of the Python exception class (in `uavsnn.errors`) this error maps to.
    pub fn python_class(&self) -> &'static str {
        match self {
            Error::InvalidEvent { .. } => "EventError",
            Error::InvalidParameter { .. } => "ParameterError",
            Error::Shape { .. } => "ShapeError",
            Error::Model(_) => "ModelFileError",
            Error::Stream(_) => "StreamError",
            Error::Simulation(_) => "SimulationError",
            Error::Internal(_) => "InternalError",
        }
    }

    /// Shorthand for [`Error::InvalidParameter`].
    pub fn param(name: &'static str, reason: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name,
            reason: reason.into(),
        }
    }
}
