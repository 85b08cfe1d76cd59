//! The spiking network (SPEC §3), exactly as `docs/model.md` specifies it, as an asynchronous,
//! per-event engine.
//!
//! - [`NetworkConfig`]: every number of the paper's Table 1, validated.
//! - [`Network`]: the weights of conv1 (Gabor), conv2 and conv3; one window in inference
//!   ([`Network::run_window`]) or one STDP step ([`Network::stdp_step`]); model files
//!   ([`Network::save`], [`Network::load`]).
//! - [`WindowState`]: the per-thread engine state and its incremental API (`begin`, `push`,
//!   `push_group`, `flush`, `finish`) for streams: input spikes go in one at a time, in time
//!   order, and conv3 detections come out as soon as their timestamp group is complete.
//! - [`infer`]: many windows in parallel (rayon); [`train_layer`]: winner-take-all + STDP on a
//!   stream of windows, one layer at a time.
//!
//! ```
//! use uavsnn::network::{Network, NetworkConfig, Spikes};
//!
//! let config = NetworkConfig { width: 64, height: 48, ..NetworkConfig::default() };
//! let net = Network::new(config, 0).unwrap();
//! let mut state = net.new_state();
//! // A vertical line of 5 pixels at t = 10 µs.
//! let (t, x, y) = (vec![10u64; 5], vec![20u16; 5], vec![10u16, 11, 12, 13, 14]);
//! net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true).unwrap();
//! assert!(state.counts()[0] > 0); // conv1 fired
//! ```

mod batch;
mod cause;
mod config;
mod conv;
mod detection;
mod gabor;
mod geometry;
mod inference;
mod layer;
mod model;
mod model_io;
mod npz;
mod pent;
mod pool;
mod states;
mod stdp;
#[cfg(test)]
mod tests;
mod train;
mod weights;
mod window;
mod winners;

pub use batch::{Spikes, WindowBatch};
pub use config::{
    ConvConfig, DetectionConfig, GaborConfig, InitConfig, NetworkConfig, Padding, PentConfig,
    PentEstimate, PoolConfig, StdpConfig, ThresholdMode, CONFIG_VERSION, MAX_WEIGHTS,
    MAX_WINDOW_STATE_BYTES,
};
pub use detection::Detection;
pub use gabor::gabor_kernels;
pub use geometry::{ConvGeom, Geometry, PoolGeom};
pub use inference::{
    check_sensor, infer, infer_range, workers_that_fit, WindowResult, MAX_THREADS,
};
pub use layer::{ConvLayer, Layer};
pub use model::NetworkOf;
pub use model_io::{MAX_MODEL_FILE_BYTES, MODEL_FORMAT};
pub use stdp::{Convergence, Rates, Schedule};

/// A xorshift64 generator for tests: each call advances the state and returns it.
#[cfg(test)]
pub(crate) fn xorshift(mut s: u64) -> impl FnMut() -> u64 {
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    }
}
pub use train::{
    check_training, train_layer, training_order, TrainOptions, TrainProgress, TrainReport, Trainer,
};
pub use weights::ConvWeights;
pub use window::{LayerSpike, Network, WindowState};

/// The old name of [`LayerSpike`], which [`crate::windows::Spike`] (an input spike) shared.
#[deprecated(note = "renamed `LayerSpike`: `uavsnn::windows::Spike` is an input spike")]
pub type Spike = LayerSpike;
pub use winners::Winner;
