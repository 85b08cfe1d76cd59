//! The engine's one error type. Every message carries the offending values, so that a user
//! reading it in Python knows which event, parameter or file was wrong and why.

use thiserror::Error;

/// Result alias used across the engine.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in the engine. The Python binding maps each variant to a class
/// of the `uavsnn.UavsnnError` hierarchy (see [`Error::python_class`]). More variants may come:
/// a `match` needs a wildcard arm.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
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

/// Most bytes one allocation sized by the input may take: a sensor's per-pixel state, a
/// network's weights or per-window state, dense frames, noise. 4 GiB is hundreds of times what
/// a 1280 × 720 event camera (or a 2048 × 2048 network of Table 1's layers) needs; a larger
/// request (a 65535 × 65535 sensor, a kernel of 65535) is refused with a typed error instead of
/// exhausting memory or aborting the process.
///
/// 4 GiB on 64-bit targets; on a target whose `isize::MAX` is smaller (32-bit: 2 GiB − 1), that
/// (no allocation may be larger there), so that the constant exists on every target.
pub const MAX_ALLOC_BYTES: usize = {
    const FOUR_GIB: u64 = 1 << 32;
    if (isize::MAX as u64) < FOUR_GIB {
        isize::MAX as usize
    } else {
        FOUR_GIB as usize
    }
};

/// The bytes of `count` items of `item_bytes` each, or [`Error::InvalidParameter`] naming
/// `name` when the product overflows or is above [`MAX_ALLOC_BYTES`]. `what` describes the
/// request in the message (`"a 65535x65535 sensor's state"`).
pub fn check_alloc(
    name: &'static str,
    what: impl FnOnce() -> String,
    count: usize,
    item_bytes: usize,
) -> Result<usize> {
    match count.checked_mul(item_bytes) {
        Some(bytes) if bytes <= MAX_ALLOC_BYTES => Ok(bytes),
        _ => Err(Error::param(
            name,
            format!(
                "{} needs {} bytes ({count} x {item_bytes}), above the cap of {MAX_ALLOC_BYTES} \
                 bytes (MAX_ALLOC_BYTES)",
                what(),
                count as u128 * item_bytes as u128
            ),
        )),
    }
}

/// Test support: `err` is [`check_alloc`]'s refusal of parameter `name`.
#[cfg(test)]
#[track_caller]
pub(crate) fn assert_over_cap(err: &Error, name: &str) {
    assert!(
        matches!(err, Error::InvalidParameter { name: n, .. } if *n == name),
        "{err}"
    );
    assert!(err.to_string().contains("MAX_ALLOC_BYTES"), "{err}");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cap_is_four_gib_where_an_allocation_may_be_that_large() {
        #[cfg(target_pointer_width = "64")]
        assert_eq!(MAX_ALLOC_BYTES as u64, 4 << 30);
        assert_eq!(
            MAX_ALLOC_BYTES as u64,
            (4u64 << 30).min(isize::MAX as u64),
            "the smaller of 4 GiB and isize::MAX"
        );
    }

    #[test]
    fn check_alloc_refuses_overflow_and_the_cap() {
        assert_eq!(check_alloc("n", String::new, 10, 8).unwrap(), 80);
        assert_eq!(
            check_alloc("n", String::new, MAX_ALLOC_BYTES, 1).unwrap(),
            MAX_ALLOC_BYTES
        );
        for (count, size) in [(MAX_ALLOC_BYTES + 1, 1), (usize::MAX, 2)] {
            let err = check_alloc("n", || "x".into(), count, size).unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name: "n", .. }),
                "{err}"
            );
            assert!(err.to_string().contains("MAX_ALLOC_BYTES"), "{err}");
        }
    }
}
