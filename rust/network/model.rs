//! [`Network`]: a validated config and the three conv layers' weights, with the one-window
//! entry points of docs/model.md §7.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use super::batch::Spikes;
use super::config::NetworkConfig;
use super::gabor::gabor_kernels;
use super::geometry::Geometry;
use super::layer::ConvLayer;
use super::pent::conv1_thresholds;
use super::stdp::{self, Rates};
use super::weights::ConvWeights;
use super::window::WindowState;
use super::winners::Winner;
use crate::error::Result;

/// Identifies a network's geometry to the [`WindowState`]s made for it.
static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// The network: config, geometry and weights.
#[derive(Debug, Clone)]
pub struct Network {
    id: u64,
    config: NetworkConfig,
    geom: Geometry,
    weights: [ConvWeights; 3],
    /// `K1[m]` of PENT: float64 sums of conv1's kernels.
    kernel_sums: Vec<f64>,
    /// Engine states kept between parallel calls (one per worker that used one).
    states: StatePool,
}

/// Engine states for reuse; a clone starts empty.
#[derive(Debug, Default)]
pub(crate) struct StatePool(Mutex<Vec<WindowState>>);

impl Clone for StatePool {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl PartialEq for Network {
    /// Same config and bit-identical weights.
    fn eq(&self, other: &Self) -> bool {
        self.config == other.config && self.weights == other.weights
    }
}

impl Network {
    /// A network from a config: conv1 holds the Gabor kernels, conv2 and conv3 draw
    /// `N(mean, std)` clipped to `[0, 1]` from `seed`.
    pub fn new(config: NetworkConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        let geom = Geometry::new(&config)?;
        let c1 = &geom.conv[0];
        let gabor = gabor_kernels(c1.k, c1.maps, &config.gabor);
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
            states: StatePool::default(),
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
    pub(crate) fn state_pool(&self) -> &Mutex<Vec<WindowState>> {
        &self.states.0
    }

    /// Run `f` with an engine state from the pool (made if none is free), then give it back:
    /// repeated one-window calls allocate nothing.
    pub fn with_state<T>(&self, f: impl FnOnce(&mut WindowState) -> T) -> T {
        let mut state = self.take_state();
        let out = f(&mut state);
        self.put_state(state);
        out
    }

    /// An engine state from the pool, or a fresh one; give it back with [`Self::put_state`].
    pub fn take_state(&self) -> WindowState {
        let reused = self.states.0.lock().ok().and_then(|mut v| v.pop());
        reused.unwrap_or_else(|| self.new_state())
    }

    /// Return a state to the pool for later calls (states of other networks are dropped).
    pub fn put_state(&self, state: WindowState) {
        if state.made_for(self) {
            if let Ok(mut v) = self.states.0.lock() {
                v.push(state);
            }
        }
    }

    /// A fresh engine state for this network (one per worker thread).
    pub fn new_state(&self) -> WindowState {
        WindowState::new(self)
    }

    /// Run one window's input spikes (sorted by time) through the network in inference mode.
    /// `n_in` overrides PENT's `N_in` (default: the number of spikes given). Results are read
    /// from `state`; with `record`, every layer's spikes are kept.
    pub fn run_window(
        &self,
        state: &mut WindowState,
        spikes: Spikes<'_>,
        t0: u64,
        n_in: Option<u64>,
        record: bool,
    ) -> Result<()> {
        let thresholds = self.conv1_thresholds(n_in.unwrap_or(spikes.len() as u64));
        state.set_record(record);
        state.begin(self, t0, &thresholds)?;
        feed(self, state, spikes)?;
        state.finish(self)
    }

    /// One STDP training step of `layer` on one window (docs/model.md §6): run it, find the
    /// winners, update their kernels with `rates`. Returns the winners in acceptance order.
    pub fn stdp_step(
        &mut self,
        state: &mut WindowState,
        layer: ConvLayer,
        spikes: Spikes<'_>,
        t0: u64,
        n_in: Option<u64>,
        rates: Rates,
    ) -> Result<Vec<Winner>> {
        let thresholds = self.conv1_thresholds(n_in.unwrap_or(spikes.len() as u64));
        state.set_record(false);
        state.begin_training(self, layer, t0, &thresholds)?;
        feed(self, state, spikes)?;
        state.finish(self)?;
        self.apply_stdp(state, layer, rates);
        Ok(state.winners().to_vec())
    }

    /// Apply STDP for the winners of the training window just finished in `state`.
    pub(crate) fn apply_stdp(&mut self, state: &WindowState, layer: ConvLayer, rates: Rates) {
        let g = self.geom.conv[layer.index()];
        stdp::apply(
            &mut self.weights[layer.index()],
            &g,
            state.winners(),
            rates,
            |c, row, col| state.input_fired_at(layer, c, row, col),
        );
        if layer == ConvLayer::Conv1 {
            self.update_kernel_sums();
        }
    }
}

/// Push a window's spikes group by group (equal times together; see
/// `WindowState::push_spikes`).
pub(crate) fn feed(net: &Network, state: &mut WindowState, spikes: Spikes<'_>) -> Result<()> {
    state.push_spikes(net, spikes)
}
