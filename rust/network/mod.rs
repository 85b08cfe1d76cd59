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
mod model;
mod model_io;
mod npz;
mod pent;
mod pool;
mod stdp;
#[cfg(test)]
mod tests;
mod train;
mod weights;
mod window;
mod winners;

use std::fmt;
use std::str::FromStr;

pub use batch::{Spikes, WindowBatch};
pub use config::{
    ConvConfig, DetectionConfig, GaborConfig, InitConfig, NetworkConfig, Padding, PentConfig,
    PentEstimate, PoolConfig, StdpConfig, ThresholdMode, CONFIG_VERSION,
};
pub use detection::Detection;
pub use gabor::gabor_kernels;
pub use geometry::{ConvGeom, Geometry, PoolGeom};
pub use inference::{check_sensor, infer, WindowResult};
pub use model::Network;
pub use model_io::MODEL_FORMAT;
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
pub use window::{Spike, WindowState};
pub use winners::Winner;

use crate::error::{Error, Result};

/// The five layers, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layer {
    Conv1,
    Pool1,
    Conv2,
    Pool2,
    Conv3,
}

impl Layer {
    /// All layers in order.
    pub const ALL: [Layer; 5] = [
        Layer::Conv1,
        Layer::Pool1,
        Layer::Conv2,
        Layer::Pool2,
        Layer::Conv3,
    ];

    /// Index in [`Layer::ALL`] (and in spike counts).
    pub fn index(self) -> usize {
        self as usize
    }

    /// `"conv1"`, `"pool1"`, ...
    pub fn name(self) -> &'static str {
        ["conv1", "pool1", "conv2", "pool2", "conv3"][self.index()]
    }
}

impl fmt::Display for Layer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The three trainable (conv) layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConvLayer {
    Conv1,
    Conv2,
    Conv3,
}

impl ConvLayer {
    /// All conv layers in order.
    pub const ALL: [ConvLayer; 3] = [ConvLayer::Conv1, ConvLayer::Conv2, ConvLayer::Conv3];

    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// `"conv1"`, `"conv2"` or `"conv3"`.
    pub fn name(self) -> &'static str {
        ["conv1", "conv2", "conv3"][self.index()]
    }
}

impl fmt::Display for ConvLayer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ConvLayer {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        ConvLayer::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| {
                Error::param(
                    "layer",
                    format!("must be one of conv1, conv2, conv3, got {s:?}"),
                )
            })
    }
}
