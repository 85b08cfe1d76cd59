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
use crate::error::{Error, Result};
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
/// with a PCG64 stream seeded by `seed` when `shuffle`. Empty when `n` is 0. Callers check
/// `n · epochs` first ([`check_training`]): an order longer than memory panics.
pub fn training_order(n: usize, epochs: usize, seed: u64, shuffle: bool) -> Vec<usize> {
    if n == 0 {
        return Vec::new();
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut order = Vec::with_capacity(n.saturating_mul(epochs));
    for _ in 0..epochs {
        let start = order.len();
        order.extend(0..n);
        if shuffle {
            order[start..].shuffle(&mut rng);
        }
    }
    order
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

    /// Train on window `i` of `batch` (validated, and of `net`'s sensor).
    pub fn step(&mut self, net: &mut Network, batch: &WindowBatch<'_>, i: usize) -> Result<()> {
        let thresholds = net.conv1_thresholds(n_in(net, batch, i));
        self.state
            .begin_training(net, self.layer, batch.t0[i], &thresholds)?;
        feed(net, &mut self.state, batch.window(i))?;
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
    let order = training_order(batch.len(), options.epochs, options.seed, options.shuffle);
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
        assert!(training_order(0, usize::MAX, 0, true).is_empty());
        assert_eq!(training_order(3, 2, 0, false), [0, 1, 2, 0, 1, 2]);
    }
}
