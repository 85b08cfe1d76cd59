//! Inference on many windows in parallel: rayon workers, one [`WindowState`] each.

use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use super::batch::WindowBatch;
use super::config::PentEstimate;
use super::detection::Detection;
use super::layer::Layer;
use super::model::{feed, Network};
use super::window::{Spike, WindowState};
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
    pub spikes: Option<[Vec<Spike>; 5]>,
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

/// Run every window of `batch` through `net` in inference mode, in parallel on `threads`
/// workers (`None`: rayon's global pool). PENT's `N_in` is the window's spike count or its
/// `n_preceding`, as the config's `pent.estimate` says. Results are in window order.
pub fn infer(
    net: &Network,
    batch: &WindowBatch<'_>,
    threads: Option<usize>,
    record: bool,
) -> Result<Vec<WindowResult>> {
    check_sensor(net, batch.sensor)?;
    let run = || {
        (0..batch.len())
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
        // One worker: the calling thread, with no pool to start.
        Some(1) => {
            let mut guard = StateGuard::take(net.state_pool(), net);
            let state = guard.state()?;
            (0..batch.len())
                .map(|i| run_one(net, state, batch, i, record))
                .collect()
        }
        Some(n) => pool(n)?.install(run),
    }
}

/// A rayon pool of `n` workers, started on first use and kept for later calls (starting
/// threads costs more than a small batch).
fn pool(n: usize) -> Result<Arc<rayon::ThreadPool>> {
    static POOLS: Mutex<Vec<(usize, Arc<rayon::ThreadPool>)>> = Mutex::new(Vec::new());
    let mut pools = POOLS
        .lock()
        .map_err(|_| Error::Internal("thread pools poisoned".into()))?;
    if let Some((_, p)) = pools.iter().find(|(m, _)| *m == n) {
        return Ok(Arc::clone(p));
    }
    let p = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| Error::Internal(format!("cannot start {n} threads: {e}")))?,
    );
    pools.push((n, Arc::clone(&p)));
    Ok(p)
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

/// PENT's `N_in` for window `i`.
pub(crate) fn n_in(net: &Network, batch: &WindowBatch<'_>, i: usize) -> u64 {
    match net.config().pent.estimate {
        PentEstimate::Window => batch.window(i).len() as u64,
        PentEstimate::Preceding => batch.n_preceding[i] as u64,
    }
}

fn run_one(
    net: &Network,
    state: &mut WindowState,
    batch: &WindowBatch<'_>,
    i: usize,
    record: bool,
) -> Result<WindowResult> {
    let thresholds = net.conv1_thresholds(n_in(net, batch, i));
    state.set_record(record);
    state.begin(net, batch.t0[i], &thresholds)?;
    feed(net, state, batch.window(i))?;
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
