//! Training one layer on a stream of windows (docs/model.md §6): for each window, run the
//! frozen layers below in inference mode, find the trained layer's winners, apply STDP to their
//! kernels, advance the learning-rate schedule and report the convergence `C`.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::batch::WindowBatch;
use super::inference::{check_sensor, n_in};
use super::layer::ConvLayer;
use super::states::feed;
use super::stdp::{Convergence, Schedule};
use super::window::{Network, WindowState};
use crate::error::{check_alloc, Error, Result};
use crate::windows::MAX_WINDOWS;

/// How to walk the training windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrainOptions {
    /// Passes over the windows (≥ 1).
    pub epochs: usize,
    /// Seed of the per-epoch shuffle.
    pub seed: u64,
    /// Shuffle the windows in each epoch (STDP learns less of the order of a recording).
    pub shuffle: bool,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            epochs: 1,
            seed: 0,
            shuffle: true,
        }
    }
}

/// Progress passed to the callback of [`train_layer`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainProgress {
    /// Windows trained so far.
    pub done: usize,
    /// Windows to train in all (windows × epochs).
    pub total: usize,
    /// `C` after the last window.
    pub convergence: f64,
    /// a⁺ for the next window.
    pub a_plus: f64,
}

/// What a training run did.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainReport {
    pub layer: ConvLayer,
    /// `C = mean(w · (1 − w))` after each window.
    pub convergence: Vec<f64>,
    /// a⁺ used for each window.
    pub a_plus: Vec<f64>,
    /// Windows trained.
    pub windows_seen: u64,
    /// Winners found in all (kernel updates made).
    pub winners: u64,
}

/// The order in which to visit `n` windows for `epochs` epochs: `0..n` each epoch, shuffled
/// with a PCG64 stream seeded by `seed` when `shuffle`. Empty when `n` is 0.
///
/// # Errors
///
/// [`Error::InvalidParameter`] (`epochs`) when the order's `n · epochs` entries are above
/// [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES) (training refuses far shorter orders,
/// above [`MAX_WINDOWS`]: see [`check_training`]).
pub fn training_order(n: usize, epochs: usize, seed: u64, shuffle: bool) -> Result<Vec<usize>> {
    if n == 0 {
        return Ok(Vec::new());
    }
    check_alloc(
        "epochs",
        || format!("a training order of {n} windows x {epochs} epochs"),
        n.saturating_mul(epochs),
        std::mem::size_of::<usize>(),
    )?;
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut order = Vec::with_capacity(n * epochs);
    for _ in 0..epochs {
        let start = order.len();
        order.extend(0..n);
        if shuffle {
            order[start..].shuffle(&mut rng);
        }
    }
    Ok(order)
}

/// The training of one layer, one window at a time (for callers that interleave training with
/// other work, like the Python binding between callbacks).
#[derive(Debug, Clone)]
pub struct Trainer {
    layer: ConvLayer,
    schedule: Schedule,
    convergence: Convergence,
    state: WindowState,
    report: TrainReport,
}

impl Trainer {
    /// Start training `layer` of `net` with the config's initial learning rates.
    pub fn new(net: &Network, layer: ConvLayer) -> Self {
        Self {
            layer,
            schedule: Schedule::new(&net.config().stdp),
            convergence: Convergence::new(net.conv_weights(layer)),
            state: net.new_state(),
            report: TrainReport {
                layer,
                convergence: Vec::new(),
                a_plus: Vec::new(),
                windows_seen: 0,
                winners: 0,
            },
        }
    }

    /// Train on window `i` of `batch`.
    ///
    /// # Errors
    ///
    /// [`Error::Shape`] (`sensor_size`) when `batch` is not of `net`'s sensor; as
    /// [`WindowBatch::window`] when there is no window `i` (checked in `O(1)`); an error of the
    /// network for spikes it refuses, or a `net` other than the one the trainer was made for.
    pub fn step(&mut self, net: &mut Network, batch: &WindowBatch<'_>, i: usize) -> Result<()> {
        check_sensor(net, batch.sensor)?;
        let window = batch.checked_window(i)?;
        let thresholds = net.conv1_thresholds(n_in(net, &window));
        self.state
            .begin_training(net, self.layer, window.t0, &thresholds)?;
        feed(net, &mut self.state, window.spikes)?;
        self.state.finish(net)?;
        let rates = self.schedule.rates();
        net.apply_stdp(&self.state, self.layer, rates);
        let weights = net.conv_weights(self.layer);
        for w in self.state.winners() {
            self.convergence.update_map(weights, w.map as usize);
        }
        self.report.a_plus.push(self.schedule.a_plus());
        self.schedule.window_done();
        self.report.convergence.push(self.convergence.value());
        self.report.windows_seen += 1;
        self.report.winners += self.state.winners().len() as u64;
        Ok(())
    }

    /// Progress after `done` of `total` windows.
    pub fn progress(&self, done: usize, total: usize) -> TrainProgress {
        TrainProgress {
            done,
            total,
            convergence: self.convergence.value(),
            a_plus: self.schedule.a_plus(),
        }
    }

    /// The report so far.
    pub fn report(&self) -> &TrainReport {
        &self.report
    }

    /// The final report.
    pub fn into_report(self) -> TrainReport {
        self.report
    }
}

/// Train `layer` of `net` on `batch`. `progress` is called after each window and may return
/// `false` to stop early.
pub fn train_layer(
    net: &mut Network,
    layer: ConvLayer,
    batch: &WindowBatch<'_>,
    options: TrainOptions,
    mut progress: impl FnMut(&TrainProgress) -> bool,
) -> Result<TrainReport> {
    check_training(net, batch, options)?;
    let order = training_order(batch.len(), options.epochs, options.seed, options.shuffle)?;
    let mut trainer = Trainer::new(net, layer);
    for (done, &i) in order.iter().enumerate() {
        trainer.step(net, batch, i)?;
        if !progress(&trainer.progress(done + 1, order.len())) {
            break;
        }
    }
    Ok(trainer.into_report())
}

/// Check a training run's inputs: `epochs` at least 1, and windows × epochs (the length of
/// the training order) at most [`MAX_WINDOWS`], as is `epochs` alone.
pub fn check_training(net: &Network, batch: &WindowBatch<'_>, options: TrainOptions) -> Result<()> {
    check_sensor(net, batch.sensor)?;
    check_epochs(batch.len(), options.epochs)
}

/// `epochs` in `1..=MAX_WINDOWS`, and `n · epochs` at most [`MAX_WINDOWS`].
fn check_epochs(n: usize, epochs: usize) -> Result<()> {
    if epochs == 0 {
        return Err(Error::param("epochs", "must be at least 1, got 0"));
    }
    if epochs > MAX_WINDOWS
        || n.checked_mul(epochs)
            .is_none_or(|total| total > MAX_WINDOWS)
    {
        return Err(Error::param(
            "epochs",
            format!(
                "{n} windows x {epochs} epochs is above the limit of {MAX_WINDOWS} training \
                 windows (MAX_WINDOWS)"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epochs_are_capped_before_the_order_is_allocated() {
        check_epochs(10, 3).unwrap();
        check_epochs(0, 1).unwrap();
        check_epochs(MAX_WINDOWS, 1).unwrap();
        for (n, epochs) in [
            (10, 0),
            (10, 1 << 61),
            (1 << 4, 1 << 60), // wraps to 0
            (0, 1 << 61),
            (2, MAX_WINDOWS),
        ] {
            let err = check_epochs(n, epochs).unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name: "epochs", .. }),
                "{n} x {epochs}: {err}"
            );
        }
        // No windows: an empty order, at once, whatever the epochs.
        assert!(training_order(0, usize::MAX, 0, true).unwrap().is_empty());
        assert_eq!(training_order(3, 2, 0, false).unwrap(), [0, 1, 2, 0, 1, 2]);
    }

    #[test]
    fn an_order_above_the_memory_cap_is_refused() {
        // 2^40 entries of 8 bytes used to abort on allocation.
        let err = training_order(1, 1 << 40, 0, true).unwrap_err();
        crate::error::assert_over_cap(&err, "epochs");
        let err = training_order(1 << 33, 1 << 33, 0, false).unwrap_err();
        crate::error::assert_over_cap(&err, "epochs");
    }

    #[test]
    fn step_checks_the_window_index_and_the_sensor() {
        use crate::network::{Spikes, WindowBatch};
        let config = crate::network::NetworkConfig {
            width: 16,
            height: 12,
            ..Default::default()
        };
        let mut net = Network::new(config, 0).unwrap();
        let empty = Spikes::new(&[], &[], &[]).unwrap();
        let batch = WindowBatch::new((16, 12), 10, &[0], &[0, 0], empty, &[0]).unwrap();
        let mut trainer = Trainer::new(&net, ConvLayer::Conv1);
        // Window 1 of 1 used to index out of bounds.
        let err = trainer.step(&mut net, &batch, 1).unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "i", .. }),
            "{err}"
        );
        // A 4x4 batch on a 16x12 network used to train silently.
        let (t, x, y) = ([3u64, 4], [1u16, 3], [2u16, 0]);
        let small = Spikes::new(&t, &x, &y).unwrap();
        let other = WindowBatch::new((4, 4), 10, &[0], &[0, 2], small, &[0]).unwrap();
        let err = trainer.step(&mut net, &other, 0).unwrap_err();
        assert!(
            matches!(
                err,
                Error::Shape {
                    name: "sensor_size",
                    ..
                }
            ),
            "{err}"
        );
        assert_eq!(trainer.report().windows_seen, 0);
        trainer.step(&mut net, &batch, 0).unwrap();
        assert_eq!(trainer.report().windows_seen, 1);
    }
}
