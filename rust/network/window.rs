//! The per-event engine: one window at a time through the whole network ([`WindowState`]).

use super::cause::{self, Causes};
use super::config::NetworkConfig;
use super::conv::{ConvState, Crossing, Fired};
use super::detection::{detection, Detection};
use super::geometry::Geometry;
use super::layer::{ConvLayer, Layer};
use super::model::NetworkOf;
use super::pool::{PoolSpike, PoolState};
use super::winners::{Winner, Wta};
use crate::error::{Error, Result};
use crate::simd::Avx2;

mod input;

/// The network: config, geometry and weights, with a pool of the engine states that run its
/// windows (see [`NetworkOf`]; its one-window entry points are in `states`).
pub type Network = NetworkOf<WindowState>;

/// A spike of a layer, as reported in traces (an input spike of a window is a
/// [`crate::windows::Spike`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerSpike {
    /// Time (µs, absolute).
    pub t: u64,
    pub map: u16,
    pub row: u16,
    pub col: u16,
    /// Potential at the firing time, rounded to float32 (0 for pools).
    pub v: f32,
}

/// The engine state of one worker: one window at a time through the whole network
/// (docs/model.md §3).
///
/// A [`WindowState`] holds everything one worker needs (potentials, stamps, scratch lists), sized
/// by the network's neurons once; it is reused from window to window and allocates nothing per
/// event once its scratch lists have grown. Nothing is swept per window: every per-neuron array
/// carries generation stamps, so starting a window costs O(maps).
///
/// # Incremental use (streams)
///
/// ```
/// use uavsnn::network::{Network, NetworkConfig};
///
/// let config = NetworkConfig { width: 64, height: 48, ..NetworkConfig::default() };
/// let net = Network::new(config, 0).unwrap();
/// let mut state = net.new_state();
/// let thresholds = net.conv1_thresholds(0); // PENT from an estimate known before the window
/// state.begin(&net, 1_000, &thresholds).unwrap();
/// for (t, x, y) in [(1_005, 3, 4), (1_005, 4, 4), (1_009, 5, 4)] {
///     // Detections of completed timestamp groups come back at once.
///     for d in state.push(&net, t, x, y).unwrap() {
///         println!("UAV at ({}, {}) t={}", d.x, d.y, d.t);
///     }
/// }
/// state.finish(&net).unwrap(); // completes the last group
/// println!("{} conv3 spikes", state.detections().len());
/// ```
///
/// Spikes of equal time form a *group* that is processed at once: its crossings are decided only
/// when the group is complete, that is when a later spike arrives ([`WindowState::push`]), when
/// the caller says so ([`WindowState::flush`], [`WindowState::push_group`]) or at
/// [`WindowState::finish`]. A pixel's first spike in the window is its input spike; later ones
/// are ignored (docs/model.md §1), so raw events can be pushed as they come.
#[derive(Debug, Clone)]
pub struct WindowState {
    net_id: u64,
    geom: Geometry,
    width: usize,
    height: usize,
    generation: u32,
    open: bool,
    t0: u64,
    last_t: Option<u64>,
    pushed: usize,
    pixel_fired: Vec<u32>,
    pixel_time: Vec<u64>,
    /// Input spikes (distinct pixels) taken in the window.
    inputs: usize,
    causes: Causes,
    pending: Vec<(u16, u16)>,
    pending_t: Option<u64>,
    conv: [ConvState; 3],
    pool: [PoolState; 2],
    thresholds: Vec<f32>,
    crossings: Vec<Crossing>,
    pool_out: Vec<PoolSpike>,
    counts: [u64; 5],
    record: bool,
    trace: [Vec<LayerSpike>; 5],
    detections: Vec<Detection>,
    training: Option<usize>,
    wta: Wta,
    /// Layers run in inference: `Layer::index() < depth`.
    depth: usize,
    /// Whether the CPU has AVX2 (asked once, at construction).
    avx2: Option<Avx2>,
}

impl WindowState {
    /// A state sized for `net` (see also [`Network::new_state`]).
    pub fn new(net: &Network) -> Self {
        let g = *net.geometry();
        let c = net.config();
        Self {
            net_id: net.id(),
            geom: g,
            width: c.width,
            height: c.height,
            generation: 0,
            open: false,
            t0: 0,
            last_t: None,
            pushed: 0,
            pixel_fired: vec![0; c.width * c.height],
            pixel_time: vec![0; c.width * c.height],
            inputs: 0,
            causes: Causes::new(&g),
            pending: Vec::new(),
            pending_t: None,
            conv: g.conv.map(ConvState::new),
            pool: g.pool.map(PoolState::new),
            thresholds: Vec::new(),
            crossings: Vec::new(),
            pool_out: Vec::new(),
            counts: [0; 5],
            record: false,
            trace: Default::default(),
            detections: Vec::new(),
            training: None,
            wta: Wta::default(),
            depth: Layer::ALL.len(),
            avx2: Avx2::detect(),
        }
    }

    /// Run the coming inference windows only up to `last` (inclusive); layers above it stay
    /// silent. Default: the whole network (`Layer::Conv3`).
    pub fn set_depth(&mut self, last: Layer) {
        self.depth = last.index() + 1;
    }

    /// Whether this state was made for `net` (or a clone of it).
    pub fn made_for(&self, net: &Network) -> bool {
        self.net_id == net.id()
    }

    /// Keep every layer's spikes of the coming windows (see [`Self::spikes`]); off by default.
    pub fn set_record(&mut self, record: bool) {
        self.record = record;
    }

    /// Start a window at `t0` in inference mode, with conv1's per-map `thresholds`
    /// (from [`Network::conv1_thresholds`]). Any unfinished window is dropped.
    pub fn begin(&mut self, net: &Network, t0: u64, thresholds: &[f32]) -> Result<()> {
        self.start(net, t0, thresholds, None)
    }

    /// Start a training window for `layer`: earlier layers run in inference mode, `layer` runs
    /// without lateral inhibition and its crossings compete in the winner-take-all; layers above
    /// it are not run. Read the winners with [`Self::winners`] after [`Self::finish`].
    pub fn begin_training(
        &mut self,
        net: &Network,
        layer: ConvLayer,
        t0: u64,
        thresholds: &[f32],
    ) -> Result<()> {
        self.start(net, t0, thresholds, Some(layer.index()))
    }

    fn start(
        &mut self,
        net: &Network,
        t0: u64,
        thresholds: &[f32],
        training: Option<usize>,
    ) -> Result<()> {
        self.check_net(net)?;
        let maps = self.geom.conv[0].maps;
        if thresholds.len() != maps {
            return Err(Error::Shape {
                name: "thresholds",
                expected: format!("{maps} values (one per conv1 map)"),
                got: format!("{}", thresholds.len()),
            });
        }
        if let Some(v) = thresholds.iter().find(|v| v.is_nan() || **v <= 0.0) {
            return Err(Error::param(
                "thresholds",
                format!("conv1 thresholds must be > 0 and not NaN, got {v}"),
            ));
        }
        for c in &mut self.conv {
            c.reset();
        }
        self.next_generation();
        self.open = true;
        self.t0 = t0;
        self.last_t = None;
        self.pushed = 0;
        self.inputs = 0;
        self.pending.clear();
        self.pending_t = None;
        self.thresholds.clear();
        self.thresholds.extend_from_slice(thresholds);
        let c: &NetworkConfig = net.config();
        self.conv[0].set_thresholds(|m| thresholds[m]);
        self.conv[1].set_thresholds(|_| c.conv2.threshold);
        self.conv[2].set_thresholds(|_| c.conv3.threshold);
        for (conv, layer) in self.conv.iter_mut().zip(ConvLayer::ALL) {
            conv.set_wake(net.conv_weights(layer));
        }
        self.counts = [0; 5];
        for t in &mut self.trace {
            t.clear();
        }
        self.detections.clear();
        self.training = training;
        if let Some(l) = training {
            let lc = c.conv(l);
            self.wta.reset(lc.maps, lc.wta_k, lc.wta_radius);
        }
        Ok(())
    }

    fn check_net(&self, net: &Network) -> Result<()> {
        if net.id() == self.net_id {
            Ok(())
        } else {
            Err(Error::param(
                "network",
                "this WindowState was made for another Network (make one with Network::new_state)",
            ))
        }
    }

    fn next_generation(&mut self) {
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.pixel_fired.fill(0);
            for p in &mut self.pool {
                p.clear_stamps();
            }
            self.causes.clear_stamps();
            self.generation = 1;
        }
    }

    /// Process the pending timestamp group now (call it when no more spikes of its time will
    /// come); returns the detections it produced.
    pub fn flush(&mut self, net: &Network) -> Result<&[Detection]> {
        self.check_open(net)?;
        let first = self.detections.len();
        self.process_pending(net);
        Ok(&self.detections[first..])
    }

    /// Complete the window: process the pending group and close it. Results stay readable
    /// ([`Self::counts`], [`Self::detections`], [`Self::spikes`], [`Self::winners`]) until the
    /// next `begin`.
    pub fn finish(&mut self, net: &Network) -> Result<()> {
        self.check_open(net)?;
        self.process_pending(net);
        self.open = false;
        if self.record {
            for t in &mut self.trace {
                t.sort_unstable_by_key(|s| (s.t, s.map, s.row, s.col));
            }
        }
        Ok(())
    }

    fn check_open(&self, net: &Network) -> Result<()> {
        self.check_net(net)?;
        if self.open {
            Ok(())
        } else {
            Err(Error::Stream(
                "no window is open: call begin() first".into(),
            ))
        }
    }

    /// Run the pending group through the network.
    fn process_pending(&mut self, net: &Network) {
        let Some(t) = self.pending_t.take() else {
            return;
        };
        let w = net.conv_weights(ConvLayer::Conv1).engine();
        for &(x, y) in &self.pending {
            self.conv[0].add(w, 0, usize::from(y), usize::from(x));
        }
        self.pending.clear();
        self.propagate(net, t);
    }

    /// Decide conv1's crossings of the group at `t` and carry the spikes up the layers.
    /// Inlined, so that the common case, a group with nothing to decide, costs its test and
    /// not a call that saves registers.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn propagate(&mut self, net: &Network, t: u64) {
        if self.conv[0].may_fire() {
            self.propagate_fired(net, t);
        }
    }

    /// `propagate` for a group in which conv1 may fire.
    #[inline(never)]
    fn propagate_fired(&mut self, net: &Network, t: u64) {
        // Copies of the steps for the common windows (neither recorded nor trained; most of
        // them through every layer), without the tests of recording, training (and depth)
        // per group; each copy out of line, so that none's registers are another's.
        if !self.record && self.training.is_none() {
            if self.depth == Layer::ALL.len() {
                self.propagate_layers::<true, true>(net, t);
            } else {
                self.propagate_layers::<true, false>(net, t);
            }
        } else {
            self.propagate_layers::<false, false>(net, t);
        }
    }

    /// `propagate_fired`'s steps, `PLAIN` and `WHOLE` as `propagate_layer`'s.
    #[inline(never)]
    fn propagate_layers<const PLAIN: bool, const WHOLE: bool>(&mut self, net: &Network, t: u64) {
        // One copy of the step per layer, each compiled for its layer.
        let _ = self.propagate_layer::<PLAIN, WHOLE>(net, t, 0)
            && self.propagate_layer::<PLAIN, WHOLE>(net, t, 1)
            && self.propagate_layer::<PLAIN, WHOLE>(net, t, 2);
    }

    /// Decide conv layer `layer`'s crossings of the group at `t` and carry its spikes to the
    /// next layer's inputs; returns whether that layer has anything to decide. `PLAIN`: the
    /// window is neither recorded nor trained; `WHOLE`: it runs every layer (with `PLAIN`).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn propagate_layer<const PLAIN: bool, const WHOLE: bool>(
        &mut self,
        net: &Network,
        t: u64,
        layer: usize,
    ) -> bool {
        let config = net.config();
        let generation = self.generation;
        let record = !PLAIN && self.record;
        let training = !PLAIN && self.training == Some(layer);
        let inhibit = config.conv(layer).lateral_inhibition && !training;
        self.crossings.clear();
        // With no candidate, band neuron or waking position `resolve` finds nothing (conv1's
        // was tested by `propagate`): most groups that reach conv2 only count their inputs.
        if layer > 0 && !self.conv[layer].may_fire() {
            return false;
        }
        // Training runs every layer up to the trained one, whatever the depth.
        let depth = if WHOLE || (!PLAIN && self.training.is_some()) {
            5
        } else {
            self.depth
        };
        if PLAIN && layer == 0 && depth > 1 && self.pool[0].tiles() {
            // conv1's spikes straight into pool1 as they fire (it tiles, as Table 1's): no
            // list of crossings, nor a second pass over one.
            self.pool_out.clear();
            let fired = Fired {
                stamps: &self.pixel_fired,
                width: self.width,
                channels: 1,
                generation,
            };
            let mut sink = self.pool[0].sink(generation, t, &mut self.pool_out);
            self.conv[0].resolve(
                net.conv_weights(ConvLayer::Conv1),
                fired,
                inhibit,
                false,
                &mut sink,
            );
            let n = sink.fired;
            if n == 0 {
                return false;
            }
            self.counts[Layer::Conv1.index()] += n as u64;
            self.counts[Layer::Pool1.index()] += self.pool_out.len() as u64;
            if depth <= 2 || self.pool_out.is_empty() {
                return false;
            }
            let w = net.conv_weights(ConvLayer::Conv2).engine();
            self.conv[1].add_spikes(w, &self.pool_out);
            return true;
        }
        let fired = if layer == 0 {
            Fired {
                stamps: &self.pixel_fired,
                width: self.width,
                channels: 1,
                generation,
            }
        } else {
            let pool = &self.pool[layer - 1];
            Fired {
                stamps: pool.stamps(),
                width: pool.geom.out_w,
                channels: pool.geom.maps,
                generation,
            }
        };
        self.conv[layer].resolve(
            net.conv_weights(ConvLayer::ALL[layer]),
            fired,
            inhibit,
            record || training,
            &mut self.crossings,
        );
        if self.crossings.is_empty() {
            return false;
        }
        let split = self.conv[layer].splitter();
        let conv_layer = Layer::ALL[2 * layer];
        self.counts[conv_layer.index()] += self.crossings.len() as u64;
        if record {
            self.trace[conv_layer.index()].extend(self.crossings.iter().map(|c| {
                let (row, col) = split.div_rem(c.pos as usize);
                LayerSpike {
                    t,
                    map: c.map as u16,
                    row: row as u16,
                    col: col as u16,
                    v: c.v as f32,
                }
            }));
        }
        if training {
            for c in &self.crossings {
                let (row, col) = split.div_rem(c.pos as usize);
                self.wta.offer(Winner {
                    t,
                    map: c.map as u16,
                    row: row as u16,
                    col: col as u16,
                    v: c.v,
                });
            }
            self.wta.close_group();
            return false;
        }
        if layer == 2 {
            // Detections of one group in (map, row, col) order, as spikes are reported.
            self.crossings.sort_unstable_by_key(|c| (c.map, c.pos));
            let window = cause::Window {
                geom: &self.geom,
                splits: [
                    self.conv[0].input_split(),
                    self.conv[1].input_split(),
                    self.conv[2].input_split(),
                ],
                width: self.width,
                generation,
                pixel_fired: &self.pixel_fired,
                pixel_time: &self.pixel_time,
                pool: &self.pool,
            };
            for c in &self.crossings {
                let (row, col) = split.div_rem(c.pos as usize);
                let (rows, cols) = self.geom.conv3_receptive_field(row, col);
                let causes = self.causes.conv3_box(&window, c.pos as usize, t);
                self.detections
                    .push(detection(t, c.map, row, col, &rows, &cols, causes));
            }
            return false;
        }
        if 2 * layer + 1 >= depth {
            return false;
        }
        self.pool_out.clear();
        self.pool[layer].on_spikes(generation, t, &self.crossings, &mut self.pool_out);
        let pool_layer = Layer::ALL[2 * layer + 1];
        self.counts[pool_layer.index()] += self.pool_out.len() as u64;
        if record {
            self.trace[pool_layer.index()].extend(self.pool_out.iter().map(|&(m, r, c)| {
                LayerSpike {
                    t,
                    map: m as u16,
                    row: r as u16,
                    col: c as u16,
                    v: 0.0,
                }
            }));
        }
        // Without new inputs the next layer has nothing to decide: its band's exact
        // potentials are sums over inputs that fired, which have not changed.
        if 2 * layer + 2 >= depth || self.pool_out.is_empty() {
            return false;
        }
        let w = net.conv_weights(ConvLayer::ALL[layer + 1]).engine();
        self.conv[layer + 1].add_spikes(w, &self.pool_out);
        true
    }

    /// Spikes per layer (conv1, pool1, conv2, pool2, conv3) in the current or last window.
    pub fn counts(&self) -> [u64; 5] {
        self.counts
    }

    /// conv3 spikes as detections, by time, then map, row and col.
    pub fn detections(&self) -> &[Detection] {
        &self.detections
    }

    /// conv1's thresholds of the current or last window.
    pub fn thresholds(&self) -> &[f32] {
        &self.thresholds
    }

    /// Number of input spikes (distinct pixels) taken so far in the window.
    pub fn input_count(&self) -> usize {
        self.inputs
    }

    /// A layer's spikes, sorted by `(t, map, row, col)` after [`Self::finish`]; empty unless
    /// recording is on ([`Self::set_record`]).
    pub fn spikes(&self, layer: Layer) -> &[LayerSpike] {
        &self.trace[layer.index()]
    }

    /// The training window's winners, in acceptance order.
    pub fn winners(&self) -> &[Winner] {
        self.wta.winners()
    }

    /// When the input neuron `(c, row, col)` of conv layer `layer` fired in this window.
    pub(crate) fn input_fired_at(
        &self,
        layer: ConvLayer,
        c: usize,
        row: usize,
        col: usize,
    ) -> Option<u64> {
        match layer {
            ConvLayer::Conv1 => {
                let p = row * self.width + col;
                (self.pixel_fired[p] == self.generation).then_some(self.pixel_time[p])
            }
            ConvLayer::Conv2 => self.pool[0].fired_at(self.generation, c, row, col),
            ConvLayer::Conv3 => self.pool[1].fired_at(self.generation, c, row, col),
        }
    }

    /// Force every conv layer to wake positions by count, or to add densely (see `conv`).
    #[cfg(test)]
    pub(crate) fn set_gated(&mut self, gated: bool) {
        for c in &mut self.conv {
            c.set_gated(gated);
        }
    }

    /// Run every kernel of this state as on a CPU without AVX2 (the scalar references of
    /// `simd`, and no path compiled for AVX2). Call on a fresh state, before its first window.
    #[cfg(test)]
    pub(crate) fn set_scalar(&mut self) {
        self.avx2 = None;
        self.causes.set_scalar();
        for c in &mut self.conv {
            c.set_scalar();
        }
    }

    #[cfg(test)]
    pub(crate) fn set_generation(&mut self, generation: u32) {
        self.generation = generation;
    }
}
