//! # uavsnn
//!
//! Drone (UAV) detection on event-camera streams with a convolutional spiking neural network
//! trained without labels by STDP, after Kirkland et al., ICANN 2019.
//!
//! The crate is a pure-Rust engine: events and windows ([`events`], [`windows`], [`filters`]),
//! the network ([`network`]), and the simulation kernels ([`sim`]). The PyO3 binding lives in one
//! module compiled only with the `python` feature, so `cargo test` and `cargo bench` need no
//! Python. The model the engine implements is specified in `docs/model.md`.

pub mod error;
pub mod events;
pub mod filters;
pub mod network;
pub mod sim;
mod simd;
pub mod stream;
pub mod windows;

#[cfg(feature = "python")]
mod python;

pub use error::{Error, Result};
pub use events::{Event, SensorSize};
