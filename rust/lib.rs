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
//! Lower modules never import higher ones (tests aside).
//!
//! | layer | modules | may use |
//! |---|---|---|
//! | binding | `python` (feature `python`) | the public API of everything below |
//! | streams | [`stream`] | [`network`], [`events`], [`windows`] |
//! | network API | `network::{inference, train, model_io}` | `network::{states, window, model}` |
//! | one-window entry points | `network::states` (`Network`'s states taken and given back, `run_window`, `stdp_step`) | `network::{window, model}` |
//! | per-window engine | `network::window` (`WindowState`, and `Network = NetworkOf<WindowState>`), which drives `network::{conv, pool, cause, winners}` | `network::{model, conv, pool, geometry, layer, weights}`, `simd` |
//! | model | `network::model` (`NetworkOf<S>`: weights, config, a pool of states of a type it does not know) | `network::{geometry, config, layer, weights, gabor, pent}` |
//! | a conv layer | `network::conv` (`mod.rs` state and API; `add`, `wake`, `resolve`, `reset`, `fired`) | `network::{geometry, weights}`, `simd` |
//! | shapes and names | `network::{geometry, config, layer, weights}` | each other one way: `geometry` → `config` |
//! | the CPU | `simd` (crate-private): the `Avx2` token, the vector kernels and their scalar references | nothing of the engine |
//!
//! `network::model` holds the pool of states generically (`NetworkOf<S>`), so that the window,
//! which reads the network's weights, imports the model and not the other way round.
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
pub mod threads;
pub mod windows;

#[cfg(feature = "python")]
mod python;

pub use error::{check_alloc, Error, Result, MAX_ALLOC_BYTES};
pub use events::{Event, SensorSize};
