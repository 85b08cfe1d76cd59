//! # uavsnn
//!
//! Drone (UAV) detection on event-camera streams with a convolutional spiking neural network
//! trained without labels by STDP, after Kirkland et al., ICANN 2019.
//!
//! The crate is a pure-Rust engine:
//!
//! - [`events`]: events `(t, x, y, p)`, their checks and decoders; [`filters`]: denoising, crop
//!   and downsample;
//! - [`windows`]: a recording cut into (overlapping) time windows of input spikes, the batch
//!   path's input;
//! - [`network`]: the spiking network: windows in parallel ([`network::infer`]), STDP training
//!   ([`network::train_layer`]), model files;
//! - [`stream`]: the streaming detector, which takes events in chunks of any size and returns
//!   each detection as soon as it is decided (the same detections as the batch path's with
//!   PENT's "preceding" estimate);
//! - [`signature`]: the rotor signature, a periodicity estimate over the events of a box;
//! - [`sim`]: the simulation kernels, video frames to events;
//! - [`threads`]: the worker pools the parallel calls run on;
//! - [`Error`] and [`Result`]: the one error type, whose messages name the offending values.
//!
//! The PyO3 binding lives in one module compiled only with the `python` feature, so
//! `cargo test` and `cargo bench` need no Python. The model the engine implements is specified
//! in the repository's [`docs/model.md`](https://github.com/uavsnn/uavsnn/blob/main/docs/model.md).
//!
//! # Getting started
//!
//! A network for a small sensor, a few synthetic events, then the batch path (windows, then
//! [`network::infer`] on all of them) and the streaming detector on the same events:
//!
//! ```
//! use uavsnn::network::{infer, Network, NetworkConfig, PentEstimate, WindowBatch};
//! use uavsnn::stream::{NetworkDetector, StreamConfig};
//! use uavsnn::windows::{make_windows, WindowConfig};
//! use uavsnn::{Event, SensorSize};
//!
//! // The paper's network (Table 1) on a 64 × 48 sensor with seeded initial weights (a trained
//! // model comes from `Network::load`), conv2's threshold as in the project's training recipe,
//! // and PENT's "preceding" estimate, the one a live stream has.
//! let mut config = NetworkConfig { width: 64, height: 48, ..NetworkConfig::default() };
//! config.conv2.threshold = 10.0;
//! config.pent.estimate = PentEstimate::Preceding;
//! let net = Network::new(config, 0)?;
//!
//! // A 4 × 4 square moving right: each of its pixels gives an event every 500 µs.
//! let events: Vec<Event> = (0..40u64)
//!     .flat_map(|k| {
//!         let (t, x0) = (1_000 + 500 * k, 10 + (k / 2) as u16);
//!         (0..16u16).map(move |i| Event { t, x: x0 + i % 4, y: 20 + i / 4, p: k % 2 == 0 })
//!     })
//!     .collect();
//!
//! // Batch: 10 ms windows overlapping by half, run in parallel; a result per window.
//! let sensor = SensorSize::new(64, 48)?;
//! let windows = make_windows(&events, sensor, &WindowConfig::new(10_000, 0.5)?)?;
//! let results = WindowBatch::with_windows(&windows, |batch| infer(&net, batch, None, false))?;
//! assert_eq!(results.len(), windows.len());
//! assert!(results[0].counts[0] > 0); // conv1 spiked in the first window
//! let in_batch: usize = results.iter().map(|r| r.detections.len()).sum();
//!
//! // Streaming: the same windows; push events as they come, in chunks of any size, and take
//! // each conv3 detection (with its window's index) as soon as it is decided.
//! let stream = StreamConfig { window_us: 10_000, overlap: 0.5, start_us: None };
//! let mut detector = NetworkDetector::new(net, stream)?;
//! let mut found = Vec::new();
//! for chunk in events.chunks(100) {
//!     detector.push(chunk, &mut found)?;
//! }
//! detector.flush(&mut found)?; // the end of the stream: close the windows still open
//! assert!(in_batch > 0);
//! assert_eq!(found.len(), in_batch);
//! let d = found[0].detection;
//! println!("window {}, t = {} µs: box {:?}", found[0].window, d.t, (d.x0, d.y0, d.x1, d.y1));
//! # Ok::<(), uavsnn::Error>(())
//! ```
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
