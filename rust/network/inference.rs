//! Inference on many windows in parallel: rayon workers, one [`WindowState`] each.

use std::sync::Mutex;

use rayon::prelude::*;

use super::batch::{BatchWindow, WindowBatch};
use super::config::PentEstimate;
use super::detection::Detection;
use super::layer::Layer;
use super::states::feed;
use super::window::{LayerSpike, Network, WindowState};
use crate::error::{Error, Result};

/// What one window gave.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowResult {
    /// Spikes per layer (conv1, pool1, conv2, pool2, conv3).
    pub counts: [u64; 5],
    /// conv1's thresholds.
    pub thresholds: Vec<f32>,
    /// conv3 spikes as detections, by time, then map, row and col.
    pub detections: Vec<Detection>,
    /// Every layer's spikes, when asked for.
    pub spikes: Option<[Vec<LayerSpike>; 5]>,
}

impl WindowResult {
    /// Whether the window contains a UAV: at least `min_detections` conv3 spikes.
    pub fn detected(&self, min_detections: usize) -> bool {
        self.detections.len() >= min_detections
    }

    /// Time of the first conv3 spike.
    pub fn first_detection_t(&self) -> Option<u64> {
        self.detections.first().map(|d| d.t)
    }
}

/// Windows per rayon task: enough to amortise taking a state from the pool.
const CHUNK: usize = 8;

pub use crate::threads::MAX_THREADS;

/// Run every window of `batch` through `net` in inference mode, in parallel on `threads`
/// workers (`None`: the pool the call runs in, rayon's global one unless it runs in another,
/// see [`crate::threads`]; at most [`MAX_THREADS`], a pool kept by [`crate::threads::pool`]).
/// PENT's `N_in` is the window's spike count or its `n_preceding`, as the config's
/// `pent.estimate` says. Results are in window order, and the same on any number of workers.
///
/// Each worker holds a network state: where the states of that many workers would take more
/// than [`MAX_ALLOC_BYTES`](crate::MAX_ALLOC_BYTES) together (a network of a few thousand
/// pixels a side), fewer workers run ([`workers_that_fit`]).
///
/// Each window is re-checked as it is read ([`WindowBatch::window`]), so a batch written as a
/// struct literal gives a typed error, not a panic.
pub fn infer(
    net: &Network,
    batch: &WindowBatch<'_>,
    threads: Option<usize>,
    record: bool,
) -> Result<Vec<WindowResult>> {
    infer_range(net, batch, 0..batch.len(), threads, record)
}

/// [`infer`] on the windows `windows` of `batch` only (the same results as those of the whole
/// batch): a caller that must stay responsive (to Ctrl-C, say) runs a long batch part by part.
///
/// # Errors
///
/// As [`infer`]; [`Error::InvalidParameter`] (`windows`) for a range beyond the batch.
pub fn infer_range(
    net: &Network,
    batch: &WindowBatch<'_>,
    windows: std::ops::Range<usize>,
    threads: Option<usize>,
    record: bool,
) -> Result<Vec<WindowResult>> {
    check_sensor(net, batch.sensor)?;
    if windows.start > windows.end || windows.end > batch.len() {
        return Err(Error::param(
            "windows",
            format!(
                "{windows:?} is not a range of the batch's {} windows",
                batch.len()
            ),
        ));
    }
    let fit = workers_that_fit(net);
    let threads = match threads {
        Some(n) if n <= MAX_THREADS => Some(n.min(fit)),
        None if fit < rayon::current_num_threads() => Some(fit),
        other => other, // 0 or above MAX_THREADS: refused below
    };
    let run = || {
        windows
            .clone()
            .into_par_iter()
            .with_min_len(CHUNK)
            .map_init(
                || StateGuard::take(net.state_pool(), net),
                |guard, i| run_one(net, guard.state()?, batch, i, record),
            )
            .collect::<Result<Vec<_>>>()
    };
    match threads {
        None => run(),
        Some(0) => Err(Error::param("threads", "must be at least 1, got 0")),
        Some(n) if n > MAX_THREADS => Err(Error::param(
            "threads",
            format!("must be at most {MAX_THREADS}, got {n}"),
        )),
        // One worker: the calling thread, with no pool to start.
        Some(1) => {
            let mut guard = StateGuard::take(net.state_pool(), net);
            let state = guard.state()?;
            windows
                .clone()
                .map(|i| run_one(net, state, batch, i, record))
                .collect()
        }
        Some(n) => crate::threads::pool(n)?.install(run),
    }
}

/// The most workers whose network states, one each, take at most
/// [`MAX_ALLOC_BYTES`](crate::MAX_ALLOC_BYTES) together; at least one (a single state is capped
/// at that size when the network is made).
pub fn workers_that_fit(net: &Network) -> usize {
    let one = net.geometry().state_bytes().max(1);
    usize::try_from(crate::MAX_ALLOC_BYTES as u128 / one)
        .unwrap_or(usize::MAX)
        .max(1)
}

/// Check that a sensor `(width, height)` is the network's input.
pub fn check_sensor(net: &Network, sensor: (usize, usize)) -> Result<()> {
    let c = net.config();
    if sensor != (c.width, c.height) {
        return Err(Error::Shape {
            name: "sensor_size",
            expected: format!("{}x{} (the network's input)", c.width, c.height),
            got: format!("{}x{}", sensor.0, sensor.1),
        });
    }
    Ok(())
}

/// PENT's `N_in` for a window.
pub(crate) fn n_in(net: &Network, window: &BatchWindow<'_>) -> u64 {
    match net.config().pent.estimate {
        PentEstimate::Window => window.spikes.len() as u64,
        PentEstimate::Preceding => window.n_preceding,
    }
}

fn run_one(
    net: &Network,
    state: &mut WindowState,
    batch: &WindowBatch<'_>,
    i: usize,
    record: bool,
) -> Result<WindowResult> {
    let window = batch.checked_window(i)?;
    let thresholds = net.conv1_thresholds(n_in(net, &window));
    state.set_record(record);
    state.begin(net, window.t0, &thresholds)?;
    feed(net, state, window.spikes)?;
    state.finish(net)?;
    Ok(WindowResult {
        counts: state.counts(),
        thresholds,
        detections: state.detections().to_vec(),
        spikes: record.then(|| Layer::ALL.map(|l| state.spikes(l).to_vec())),
    })
}

/// A state borrowed from the network's pool for the life of one rayon task, and given back
/// after: states (megabytes each on large sensors) are made once per worker, and reused from
/// call to call.
struct StateGuard<'a> {
    pool: &'a Mutex<Vec<WindowState>>,
    state: Option<WindowState>,
}

impl<'a> StateGuard<'a> {
    fn take(pool: &'a Mutex<Vec<WindowState>>, net: &Network) -> Self {
        let reused = pool.lock().ok().and_then(|mut v| v.pop());
        Self {
            pool,
            state: Some(reused.unwrap_or_else(|| net.new_state())),
        }
    }

    /// The borrowed state (there until the guard is dropped).
    fn state(&mut self) -> Result<&mut WindowState> {
        self.state
            .as_mut()
            .ok_or_else(|| Error::Internal("worker state missing".into()))
    }
}

impl Drop for StateGuard<'_> {
    fn drop(&mut self) {
        if let (Some(state), Ok(mut v)) = (self.state.take(), self.pool.lock()) {
            v.push(state);
        }
    }
}

#[cfg(test)]
mod pool_tests {
    use super::*;

    #[test]
    fn as_many_workers_run_as_their_states_fit_in_the_memory_cap() {
        use crate::network::NetworkConfig;
        let small = Network::new(NetworkConfig::default(), 0).unwrap();
        assert!(workers_that_fit(&small) > MAX_THREADS);
        let sized = |side: usize| {
            let config = NetworkConfig {
                width: side,
                height: side,
                ..NetworkConfig::default()
            };
            Network::new(config, 0).unwrap()
        };
        // About 2.6 GB a state at 8000 x 8000 (made, never run): one worker fits, not two.
        let big = sized(8000);
        let one = big.geometry().state_bytes();
        assert!(one <= crate::MAX_ALLOC_BYTES as u128 && 2 * one > crate::MAX_ALLOC_BYTES as u128);
        assert_eq!(workers_that_fit(&big), 1);
        let mid = sized(3000);
        let n = workers_that_fit(&mid) as u128;
        let one = mid.geometry().state_bytes();
        assert!(n * one <= crate::MAX_ALLOC_BYTES as u128);
        assert!((n + 1) * one > crate::MAX_ALLOC_BYTES as u128);
    }

    #[test]
    fn a_batch_literal_with_bad_columns_is_an_error() {
        use crate::network::{NetworkConfig, Spikes};
        let config = NetworkConfig {
            width: 16,
            height: 12,
            pent: crate::network::PentConfig {
                estimate: PentEstimate::Preceding,
                ..NetworkConfig::default().pent
            },
            ..NetworkConfig::default()
        };
        let net = Network::new(config, 0).unwrap();
        let (t, x, y) = ([3u64, 4], [1u16, 3], [2u16, 0]);
        let spikes = Spikes::new(&t, &x, &y).unwrap();
        let ok = WindowBatch::new((16, 12), 10, &[0], &[0, 2], spikes, &[1]).unwrap();
        for threads in [None, Some(1), Some(2)] {
            assert_eq!(infer(&net, &ok, threads, false).unwrap().len(), 1);
            // Offsets past the spikes, and no n_preceding with the "preceding" estimate, used
            // to index out of bounds.
            for bad in [
                WindowBatch {
                    offsets: &[0, 3],
                    ..ok
                },
                WindowBatch {
                    offsets: &[0],
                    ..ok
                },
                WindowBatch {
                    n_preceding: &[],
                    ..ok
                },
                WindowBatch {
                    n_preceding: &[-1],
                    ..ok
                },
                WindowBatch { t0: &[0, 5], ..ok },
                // Spikes before t0 (the network refuses them), or at t0 + L and after.
                WindowBatch { t0: &[4], ..ok },
                WindowBatch { length_us: 4, ..ok },
            ] {
                assert!(infer(&net, &bad, threads, false).is_err(), "{bad:?}");
            }
        }
    }
}
