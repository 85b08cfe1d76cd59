//! [`NetworkOf`]: a validated config and the three conv layers' weights, and a pool of engine
//! states of a type it does not know. The engine's [`Network`](super::Network) is
//! `NetworkOf<WindowState>` (named in `window`); its one-window entry points of docs/model.md
//! §7, which run a `WindowState`, are in `states`. So this module imports nothing of the
//! engine's window, and the window imports it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use super::config::NetworkConfig;
use super::gabor::gabor_kernels;
use super::geometry::Geometry;
use super::layer::ConvLayer;
use super::pent::conv1_thresholds;
use super::weights::ConvWeights;
use crate::error::Result;

/// Identifies a network's geometry to the engine states made for it.
static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// The network: config, geometry and weights, and a pool of engine states `S` kept between
/// parallel calls (one per worker that used one; a clone starts with none). Used as
/// [`Network`](super::Network), its one instance.
///
/// Name it as `Network`: `NetworkOf` is public only because it is `Network`'s definition, so
/// that the methods below are `Network`'s in the docs (hidden, they would be left out of them).
#[derive(Debug)]
pub struct NetworkOf<S> {
    id: u64,
    config: NetworkConfig,
    geom: Geometry,
    weights: [ConvWeights; 3],
    /// `K1[m]` of PENT: float64 sums of conv1's kernels.
    kernel_sums: Vec<f64>,
    /// Engine states kept between parallel calls.
    states: Mutex<Vec<S>>,
}

impl<S> Clone for NetworkOf<S> {
    /// The same network, with no pooled states.
    fn clone(&self) -> Self {
        Self {
            id: self.id,
            config: self.config.clone(),
            geom: self.geom,
            weights: self.weights.clone(),
            kernel_sums: self.kernel_sums.clone(),
            states: Mutex::default(),
        }
    }
}

impl<S> PartialEq for NetworkOf<S> {
    /// Same config and bit-identical weights.
    fn eq(&self, other: &Self) -> bool {
        self.config == other.config && self.weights == other.weights
    }
}

impl<S> NetworkOf<S> {
    /// A network from a config: conv1 holds the Gabor kernels, conv2 and conv3 draw
    /// `N(mean, std)` clipped to `[0, 1]` from `seed`.
    pub fn new(config: NetworkConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        let geom = Geometry::new(&config)?;
        let c1 = &geom.conv[0];
        let gabor = gabor_kernels(c1.k, c1.maps, &config.gabor)?;
        let weights = [
            ConvWeights::new(c1, gabor)?,
            ConvWeights::random(&geom.conv[1], config.init.mean, config.init.std, seed, 1)?,
            ConvWeights::random(&geom.conv[2], config.init.mean, config.init.std, seed, 2)?,
        ];
        Ok(Self::assemble(config, &geom, weights))
    }

    /// A network from a config and the three layers' canonical weights (checked: shapes and
    /// values in `[0, 1]`).
    pub fn from_weights(config: NetworkConfig, weights: [Vec<f32>; 3]) -> Result<Self> {
        config.validate()?;
        let geom = Geometry::new(&config)?;
        let [w1, w2, w3] = weights;
        let weights = [
            ConvWeights::new(&geom.conv[0], w1)?,
            ConvWeights::new(&geom.conv[1], w2)?,
            ConvWeights::new(&geom.conv[2], w3)?,
        ];
        Ok(Self::assemble(config, &geom, weights))
    }

    fn assemble(config: NetworkConfig, geom: &Geometry, weights: [ConvWeights; 3]) -> Self {
        let mut net = Self {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            config,
            geom: *geom,
            weights,
            kernel_sums: Vec::new(),
            states: Mutex::default(),
        };
        net.update_kernel_sums();
        net
    }

    fn update_kernel_sums(&mut self) {
        let w = &self.weights[0];
        self.kernel_sums = (0..w.shape()[0]).map(|m| w.kernel_sum(m)).collect();
    }

    pub(crate) fn id(&self) -> u64 {
        self.id
    }

    /// The (validated) config.
    pub fn config(&self) -> &NetworkConfig {
        &self.config
    }

    /// The layers' sizes.
    pub fn geometry(&self) -> &Geometry {
        &self.geom
    }

    /// A conv layer's weights.
    pub fn conv_weights(&self, layer: ConvLayer) -> &ConvWeights {
        &self.weights[layer.index()]
    }

    /// Replace a conv layer's canonical `(maps, in_ch, k, k)` weights (checked).
    pub fn set_weights(&mut self, layer: ConvLayer, weights: Vec<f32>) -> Result<()> {
        self.weights[layer.index()] = ConvWeights::new(&self.geom.conv[layer.index()], weights)?;
        if layer == ConvLayer::Conv1 {
            self.update_kernel_sums();
        }
        Ok(())
    }

    /// conv1's per-map thresholds for a window whose PENT estimate is `n_in` (ignored in
    /// static mode).
    pub fn conv1_thresholds(&self, n_in: u64) -> Vec<f32> {
        conv1_thresholds(&self.config, &self.kernel_sums, n_in)
    }

    /// The pool of engine states reused by parallel calls.
    pub(crate) fn state_pool(&self) -> &Mutex<Vec<S>> {
        &self.states
    }

    /// A conv layer's geometry and its weights to update in place (what STDP does); what is
    /// derived from them is brought up to date by [`Self::weights_changed`].
    pub(crate) fn weights_mut(&mut self, layer: ConvLayer) -> (&Geometry, &mut ConvWeights) {
        (&self.geom, &mut self.weights[layer.index()])
    }

    /// Bring what is derived from a layer's weights up to date after `weights_mut`.
    pub(crate) fn weights_changed(&mut self, layer: ConvLayer) {
        if layer == ConvLayer::Conv1 {
            self.update_kernel_sums();
        }
    }
}
