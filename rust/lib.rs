//! # uavsnn
//!
//! Drone (UAV) detection on event-camera streams with a convolutional spiking neural network
//! trained without labels by STDP, after Kirkland et al., ICANN 2019.
//!
//! The crate is a pure-Rust engine: events and windows ([`events`], [`windows`], [`filters`]),
//! the network ([`network`]), and the simulation kernels ([`sim`]). The PyO3 binding lives in one
//! module compiled only with the `python` feature, so `cargo test` and `cargo bench` need no
//! Python. The model the engine implements is specified in `docs/model.md`.
//!
//! # Map of the engine
//!
//! Lower modules never import higher ones (tests aside), except where noted.
//!
//! | layer | modules | may use |
//! |---|---|---|
//! | binding | `python` (feature `python`) | the public API of everything below |
//! | streams | [`stream`] | [`network`], [`events`], [`windows`] |
//! | network API | `network::{inference, train, model_io}` | `network::{model, window}` |
//! | model | `network::model` (weights, config, the states' pool) | `network::window` and below (\*) |
//! | per-window engine | `network::window`, which drives `network::{conv, pool, cause, winners}` | `network::{conv, pool, geometry, layer, weights}`, `simd` |
//! | a conv layer | `network::conv` (`mod.rs` state and API; `add`, `wake`, `resolve`, `reset`, `fired`) | `network::{geometry, weights}`, `simd` |
//! | shapes and names | `network::{geometry, config, layer, weights}` | each other one way: `geometry` → `config` |
//! | the CPU | `simd` (crate-private): the `Avx2` token, the vector kernels and their scalar references | nothing of the engine |
//!
//! (\*) `network::model` and `network::window` still import each other: a `Network` keeps a
//! pool of `WindowState`s, and a `WindowState` reads the `Network`'s weights.
//!
//! Only `simd` names `std::arch` or `#[target_feature]`; the engine reaches AVX2 code through
//! its dispatchers with the `Option<Avx2>` its states hold, or through `Avx2::vectorize`.
//! `window` and `cause` use `conv`'s crate-visible items (`ConvState`, `Crossing`, `Fire`,
//! `Fired`, `each_fired_input`), not its files' internals.

pub mod error;
pub mod events;
pub mod filters;
pub mod network;
pub mod signature;
pub mod sim;
mod simd;
pub mod stream;
pub mod windows;

#[cfg(feature = "python")]
mod python;

pub use error::{Error, Result};
pub use events::{Event, SensorSize};
