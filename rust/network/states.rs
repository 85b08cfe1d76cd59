//! The one-window entry points of docs/model.md §7 on [`Network`]: engine states taken from
//! and given back to its pool, a window run in inference mode or one STDP step. Above both
//! `model` (the pool's holder, which knows nothing of `WindowState`) and `window`.

use super::batch::Spikes;
use super::layer::ConvLayer;
use super::stdp::{self, Rates};
use super::window::{Network, WindowState};
use super::winners::Winner;
use crate::error::{Error, Result};

impl Network {
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
        let reused = self.state_pool().lock().ok().and_then(|mut v| v.pop());
        reused.unwrap_or_else(|| self.new_state())
    }

    /// Return a state to the pool for later calls (states of other networks are dropped).
    pub fn put_state(&self, state: WindowState) {
        if state.made_for(self) {
            if let Ok(mut v) = self.state_pool().lock() {
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
        // The config's signs, finite (a NaN or infinite rate wrote NaN weights).
        let signed = rates.a_plus.is_finite()
            && rates.a_plus > 0.0
            && rates.a_minus.is_finite()
            && rates.a_minus <= 0.0;
        if !signed {
            return Err(Error::param(
                "rates",
                format!(
                    "a_plus must be finite and > 0 and a_minus finite and <= 0, got {} and {}",
                    rates.a_plus, rates.a_minus
                ),
            ));
        }
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
        let (geom, weights) = self.weights_mut(layer);
        let g = geom.conv[layer.index()];
        stdp::apply(weights, &g, state.winners(), rates, |c, row, col| {
            state.input_fired_at(layer, c, row, col)
        });
        self.weights_changed(layer);
    }
}

/// Push a window's spikes group by group (equal times together; see
/// `WindowState::push_spikes`).
pub(crate) fn feed(net: &Network, state: &mut WindowState, spikes: Spikes<'_>) -> Result<()> {
    state.push_spikes(net, spikes)
}
