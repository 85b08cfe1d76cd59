//! Bindings for `network`: the `NetworkCore` class that `uavsnn.network.Network` wraps.
//!
//! Inputs arrive as contiguous NumPy arrays of the exact dtypes (the Python layer converts and
//! type-checks them); results go back as columns that the Python layer assembles into
//! structured arrays.

use numpy::prelude::*;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray4};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use super::errors::{detach, map, InUse, SIGNAL_CHECK_SECONDS};
use crate::error::Error;
use crate::network::{
    check_sensor, infer_range, training_order, ConvLayer, Detection, Layer, LayerSpike, Network,
    NetworkConfig, Rates, Spikes, TrainOptions, Trainer, WindowBatch, WindowResult, Winner,
    MAX_THREADS,
};

/// Columns `(t, map, row, col, v)` of spikes.
type SpikeColumns<'py> = (
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u16>>,
    Bound<'py, PyArray1<u16>>,
    Bound<'py, PyArray1<u16>>,
    Bound<'py, PyArray1<f32>>,
);

/// What `run_window` returns: every layer's spikes as packed `SPIKE_DTYPE` records (conv1
/// first), the number of spikes of each layer, conv1's thresholds, and the detections as packed
/// `DETECTION_DTYPE` records. Packed records cost one array each, where columns cost one per
/// field and a structured array to assemble them in Python.
type PackedTrace<'py> = (
    Bound<'py, PyArray1<u8>>,
    [u64; 5],
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u8>>,
);

/// Bytes of one `SPIKE_DTYPE` record: `t u8, map row col u2, v f4`, little endian.
const SPIKE_RECORD: usize = 8 + 3 * 2 + 4;
/// Bytes of one `DETECTION_DTYPE` record: `t u8, map row col u2, x y f4, box 4×u2`.
const DETECTION_RECORD: usize = 8 + 3 * 2 + 2 * 4 + 4 * 2;

fn pack_spike(out: &mut Vec<u8>, s: &LayerSpike) {
    out.extend_from_slice(&s.t.to_le_bytes());
    for v in [s.map, s.row, s.col] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&s.v.to_le_bytes());
}

/// Append one detection's packed record (`t u8, map row col u2, x y f4, box 4×u2`).
pub(super) fn pack_detection(out: &mut Vec<u8>, d: &Detection) {
    out.extend_from_slice(&d.t.to_le_bytes());
    for v in [d.map, d.row, d.col] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&d.x.to_le_bytes());
    out.extend_from_slice(&d.y.to_le_bytes());
    for v in [d.x0, d.y0, d.x1, d.y1] {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

fn spike_columns<'py>(py: Python<'py>, spikes: &[LayerSpike]) -> SpikeColumns<'py> {
    (
        PyArray1::from_iter(py, spikes.iter().map(|s| s.t)),
        PyArray1::from_iter(py, spikes.iter().map(|s| s.map)),
        PyArray1::from_iter(py, spikes.iter().map(|s| s.row)),
        PyArray1::from_iter(py, spikes.iter().map(|s| s.col)),
        PyArray1::from_iter(py, spikes.iter().map(|s| s.v)),
    )
}

fn winner_columns<'py>(py: Python<'py>, winners: &[Winner]) -> SpikeColumns<'py> {
    (
        PyArray1::from_iter(py, winners.iter().map(|w| w.t)),
        PyArray1::from_iter(py, winners.iter().map(|w| w.map)),
        PyArray1::from_iter(py, winners.iter().map(|w| w.row)),
        PyArray1::from_iter(py, winners.iter().map(|w| w.col)),
        PyArray1::from_iter(py, winners.iter().map(|w| w.v as f32)),
    )
}

/// Columns `(window, t, map, row, col, x, y, x0, y0, x1, y1)` of detections.
fn detection_columns<'py>(
    py: Python<'py>,
    detections: &[(i64, Detection)],
) -> PyResult<Bound<'py, PyTuple>> {
    let d = detections;
    PyTuple::new(
        py,
        [
            PyArray1::from_iter(py, d.iter().map(|x| x.0)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.t)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.map)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.row)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.col)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.x)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.y)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.x0)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.y0)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.x1)).into_any(),
            PyArray1::from_iter(py, d.iter().map(|x| x.1.y1)).into_any(),
        ],
    )
}

/// The engine's own copy of a contiguous 1-D array (a typed error naming it otherwise). The
/// engine checks its input once and then trusts it while the GIL is released (or while a
/// training callback runs), so it must read memory no Python thread can change meanwhile: a
/// borrowed slice of the caller's array, rewritten by another thread, sent coordinates checked
/// as in range out of it. The copy costs a few bytes a spike against the network's work.
fn owned<T: numpy::Element + Copy>(
    a: &PyReadonlyArray1<'_, T>,
    name: &'static str,
) -> PyResult<Vec<T>> {
    match a.as_slice() {
        Ok(s) => Ok(s.to_vec()),
        Err(_) => Err(super::errors::to_pyerr(
            a.py(),
            &Error::Shape {
                name,
                expected: "a contiguous 1-D array".into(),
                got: "a strided view".into(),
            },
        )),
    }
}

fn parse_layer(py: Python<'_>, layer: &str) -> PyResult<ConvLayer> {
    map(py, layer.parse())
}

/// The config of `uavsnn.network.default_config()`, as JSON.
#[pyfunction]
fn network_default_config() -> String {
    NetworkConfig::default().to_json()
}

/// The engine's network (weights and config); see `uavsnn.network.Network`.
#[pyclass(module = "uavsnn._core")]
pub struct NetworkCore {
    net: Network,
}

/// The columns of a `uavsnn.windows.Windows`, copied (see [`owned`]).
struct BatchArgs {
    sensor: (usize, usize),
    length_us: u64,
    t0: Vec<u64>,
    offsets: Vec<i64>,
    t: Vec<u64>,
    x: Vec<u16>,
    y: Vec<u16>,
    n_preceding: Vec<i64>,
}

impl BatchArgs {
    /// The columns, copied: each must be contiguous (a typed error naming it otherwise).
    fn new(
        sensor: (usize, usize),
        length_us: u64,
        t0: &PyReadonlyArray1<'_, u64>,
        offsets: &PyReadonlyArray1<'_, i64>,
        t: &PyReadonlyArray1<'_, u64>,
        x: &PyReadonlyArray1<'_, u16>,
        y: &PyReadonlyArray1<'_, u16>,
        n_preceding: &PyReadonlyArray1<'_, i64>,
    ) -> PyResult<Self> {
        Ok(Self {
            sensor,
            length_us,
            t0: owned(t0, "t0")?,
            offsets: owned(offsets, "offsets")?,
            t: owned(t, "t")?,
            x: owned(x, "x")?,
            y: owned(y, "y")?,
            n_preceding: owned(n_preceding, "n_preceding")?,
        })
    }

    /// The validated batch, for `net` (its sensor checked first).
    fn batch(&self, net: &Network) -> crate::Result<WindowBatch<'_>> {
        check_sensor(net, self.sensor)?;
        WindowBatch::new(
            self.sensor,
            self.length_us,
            &self.t0,
            &self.offsets,
            Spikes::new(&self.t, &self.x, &self.y)?,
            &self.n_preceding,
        )
    }
}

/// The fewest windows of one part, per worker, and the first part's size: one, so that Ctrl-C
/// waits for about a window per worker where windows are slow (a static network under heavy
/// noise at 1280×720 takes tens of seconds a window: a floor of 64 made Ctrl-C wait minutes).
/// Parts of cheap windows grow from there toward [`SIGNAL_CHECK_SECONDS`], 16 times at a step.
const PART_WINDOWS_PER_WORKER: usize = 1;

/// `infer` on the batch `args`, run a part at a time with the GIL let go, Python's signals
/// checked between parts: Ctrl-C stops a long batch within about [`SIGNAL_CHECK_SECONDS`] rather than
/// when it ends (the network is not changed by inference, so nothing is left half done). The
/// parts grow or shrink toward that time; the results are those of one call.
fn infer_in_parts(
    py: Python<'_>,
    net: &Network,
    args: &BatchArgs,
    threads: Option<usize>,
    record: bool,
) -> PyResult<Vec<WindowResult>> {
    let batch = detach(py, || args.batch(net))?;
    let workers = threads.unwrap_or_else(crate::threads::cores);
    let least = PART_WINDOWS_PER_WORKER * workers.clamp(1, MAX_THREADS);
    let (n, mut part, mut start) = (batch.len(), least, 0);
    let mut results = Vec::with_capacity(n);
    while start < n {
        let end = n.min(start + part);
        let began = std::time::Instant::now();
        results.extend(detach(py, || {
            infer_range(net, &batch, start..end, threads, record)
        })?);
        py.check_signals()?;
        let scale =
            (SIGNAL_CHECK_SECONDS / began.elapsed().as_secs_f64().max(1e-6)).clamp(0.5, 16.0);
        part = ((part as f64 * scale) as usize).max(least);
        start = end;
    }
    Ok(results)
}

/// A layer's output: `(maps, rows, cols)`.
type LayerShape = (usize, usize, usize);

/// Every call borrows the network by hand, so that one made while another thread's call holds
/// it (`infer` and `run_window` read it without the GIL, `train_layer` and `stdp_step` write
/// it) is a `StreamError` (`in_use`), not pyo3's untyped `RuntimeError("Already borrowed")`.
impl NetworkCore {
    const IN_USE: InUse = ("the network", "use a copy() per thread");

    fn read<'py>(slf: &Bound<'py, Self>) -> PyResult<PyRef<'py, Self>> {
        super::errors::read(slf, Self::IN_USE)
    }

    fn write<'py>(slf: &Bound<'py, Self>) -> PyResult<PyRefMut<'py, Self>> {
        super::errors::write(slf, Self::IN_USE)
    }
}

#[pymethods]
impl NetworkCore {
    /// A network from a JSON config (missing fields take their defaults) and a seed.
    #[new]
    fn new(py: Python<'_>, config_json: &str, seed: u64) -> PyResult<Self> {
        let config = map(py, NetworkConfig::from_json(config_json))?;
        let net = map(py, Network::new(config, seed))?;
        Ok(Self { net })
    }

    /// The full config as JSON.
    fn config_json(slf: &Bound<'_, Self>) -> PyResult<String> {
        Ok(Self::read(slf)?.net.config().to_json())
    }

    /// Per layer: `(maps, rows, cols)` of its output.
    fn shapes(slf: &Bound<'_, Self>) -> PyResult<Vec<(String, LayerShape)>> {
        let this = Self::read(slf)?;
        let g = this.net.geometry();
        Ok(Layer::ALL
            .iter()
            .map(|l| {
                let i = l.index() / 2;
                let s = if l.index() % 2 == 0 {
                    (g.conv[i].maps, g.conv[i].out_h, g.conv[i].out_w)
                } else {
                    (g.pool[i].maps, g.pool[i].out_h, g.pool[i].out_w)
                };
                (l.name().to_string(), s)
            })
            .collect())
    }

    /// A copy of a conv layer's weights, `(maps, in_ch, k, k)` float32.
    fn weights<'py>(
        slf: &Bound<'py, Self>,
        layer: &str,
    ) -> PyResult<Bound<'py, numpy::PyArray4<f32>>> {
        let py = slf.py();
        let this = Self::read(slf)?;
        let w = this.net.conv_weights(parse_layer(py, layer)?);
        PyArray1::from_slice(py, w.canonical()).reshape(w.shape())
    }

    /// Replace a conv layer's weights (checked: shape, finite, in [0, 1]).
    fn set_weights(
        slf: &Bound<'_, Self>,
        layer: &str,
        w: PyReadonlyArray4<'_, f32>,
    ) -> PyResult<()> {
        let py = slf.py();
        let layer = parse_layer(py, layer)?;
        let mut this = Self::write(slf)?;
        let expected = this.net.conv_weights(layer).shape();
        if w.shape() != expected {
            return Err(super::errors::to_pyerr(
                py,
                &Error::Shape {
                    name: "weights",
                    expected: format!("{expected:?}"),
                    got: format!("{:?}", w.shape()),
                },
            ));
        }
        let values = w.as_array().iter().copied().collect();
        map(py, this.net.set_weights(layer, values))
    }

    /// Bytes of one window's state, as the engine counts them (`Geometry::state_bytes`); a
    /// valid config's fit in `u64` (at most `MAX_WINDOW_STATE_BYTES`), clamped there anyway.
    fn state_bytes(slf: &Bound<'_, Self>) -> PyResult<u64> {
        let bytes = Self::read(slf)?.net.geometry().state_bytes();
        Ok(u64::try_from(bytes).unwrap_or(u64::MAX))
    }

    /// conv1's thresholds for a window whose PENT estimate is `n_in`.
    fn conv1_thresholds(slf: &Bound<'_, Self>, n_in: u64) -> PyResult<Vec<f32>> {
        Ok(Self::read(slf)?.net.conv1_thresholds(n_in))
    }

    /// One window in inference mode: `(spikes, counts, thresholds, detections)`, see
    /// `PackedTrace`.
    #[pyo3(signature = (t, x, y, t0, n_in=None))]
    fn run_window<'py>(
        slf: &Bound<'py, Self>,
        t: PyReadonlyArray1<'py, u64>,
        x: PyReadonlyArray1<'py, u16>,
        y: PyReadonlyArray1<'py, u16>,
        t0: u64,
        n_in: Option<u64>,
    ) -> PyResult<PackedTrace<'py>> {
        let py = slf.py();
        let (ts, xs, ys) = (owned(&t, "t")?, owned(&x, "x")?, owned(&y, "y")?);
        let this = Self::read(slf)?;
        let net = &this.net;
        let (spikes, counts, thresholds, detections) = detach(py, || {
            net.with_state(|state| {
                net.run_window(state, Spikes::new(&ts, &xs, &ys)?, t0, n_in, true)?;
                // Every layer's spikes as records of SPIKE_DTYPE, one buffer for all.
                let total: usize = Layer::ALL.iter().map(|&l| state.spikes(l).len()).sum();
                let mut packed = Vec::with_capacity(total * SPIKE_RECORD);
                let mut counts = [0u64; 5];
                for (n, &l) in counts.iter_mut().zip(Layer::ALL.iter()) {
                    let layer = state.spikes(l);
                    *n = layer.len() as u64;
                    for s in layer {
                        pack_spike(&mut packed, s);
                    }
                }
                let found = state.detections();
                let mut detections = Vec::with_capacity(found.len() * DETECTION_RECORD);
                for d in found {
                    pack_detection(&mut detections, d);
                }
                Ok((packed, counts, state.thresholds().to_vec(), detections))
            })
        })?;
        Ok((
            spikes.into_pyarray(py),
            counts,
            PyArray1::from_vec(py, thresholds),
            detections.into_pyarray(py),
        ))
    }

    /// One STDP step of `layer` on one window; returns the winners' columns
    /// `(t, map, row, col, v)` in acceptance order. Rates default to the config's.
    #[pyo3(signature = (layer, t, x, y, t0, n_in=None, a_plus=None, a_minus=None))]
    fn stdp_step<'py>(
        slf: &Bound<'py, Self>,
        layer: &str,
        t: PyReadonlyArray1<'py, u64>,
        x: PyReadonlyArray1<'py, u16>,
        y: PyReadonlyArray1<'py, u16>,
        t0: u64,
        n_in: Option<u64>,
        a_plus: Option<f64>,
        a_minus: Option<f64>,
    ) -> PyResult<SpikeColumns<'py>> {
        let py = slf.py();
        let layer = parse_layer(py, layer)?;
        let (ts, xs, ys) = (owned(&t, "t")?, owned(&x, "x")?, owned(&y, "y")?);
        let mut this = Self::write(slf)?;
        let initial = Rates::initial(&this.net.config().stdp);
        let rates = Rates {
            a_plus: a_plus.map_or(initial.a_plus, |a| a as f32),
            a_minus: a_minus.map_or(initial.a_minus, |a| a as f32),
        };
        if !(rates.a_plus.is_finite() && rates.a_minus.is_finite()) {
            return Err(super::errors::to_pyerr(
                py,
                &Error::param("rates", format!("must be finite, got {rates:?}")),
            ));
        }
        let net = &mut this.net;
        let winners = detach(py, || {
            let mut state = net.take_state();
            let winners = net.stdp_step(
                &mut state,
                layer,
                Spikes::new(&ts, &xs, &ys)?,
                t0,
                n_in,
                rates,
            );
            net.put_state(state);
            winners
        })?;
        Ok(winner_columns(py, &winners))
    }

    /// Inference on many windows in parallel. Returns `(counts (n, 5) int64, thresholds
    /// (n, maps) float32, detections columns, spikes)` where `spikes` is `None` or per layer
    /// `(window, t, map, row, col, v)` columns.
    #[pyo3(signature = (sensor_size, length_us, t0, offsets, t, x, y, n_preceding, threads=None, record=false))]
    fn infer<'py>(
        slf: &Bound<'py, Self>,
        sensor_size: (usize, usize),
        length_us: u64,
        t0: PyReadonlyArray1<'py, u64>,
        offsets: PyReadonlyArray1<'py, i64>,
        t: PyReadonlyArray1<'py, u64>,
        x: PyReadonlyArray1<'py, u16>,
        y: PyReadonlyArray1<'py, u16>,
        n_preceding: PyReadonlyArray1<'py, i64>,
        threads: Option<usize>,
        record: bool,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let args = BatchArgs::new(
            sensor_size,
            length_us,
            &t0,
            &offsets,
            &t,
            &x,
            &y,
            &n_preceding,
        )?;
        let py = slf.py();
        let this = Self::read(slf)?;
        let net = &this.net;
        let results = infer_in_parts(py, net, &args, threads, record)?;
        let n = results.len();
        let maps = net.geometry().conv[0].maps;
        let counts: Vec<i64> = results
            .iter()
            .flat_map(|r| r.counts.map(|c| c as i64))
            .collect();
        let thresholds: Vec<f32> = results.iter().flat_map(|r| r.thresholds.clone()).collect();
        let detections: Vec<(i64, Detection)> = results
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.detections.iter().map(move |d| (i as i64, *d)))
            .collect();
        let spikes = if record {
            let layers: Vec<Bound<'py, PyTuple>> = Layer::ALL
                .iter()
                .map(|&l| {
                    let all: Vec<(i64, LayerSpike)> = results
                        .iter()
                        .enumerate()
                        .flat_map(|(i, r)| {
                            r.spikes
                                .iter()
                                .flat_map(move |s| s[l.index()].iter().map(move |s| (i as i64, *s)))
                        })
                        .collect();
                    let (tt, m, rr, cc, v) =
                        spike_columns(py, &all.iter().map(|(_, s)| *s).collect::<Vec<_>>());
                    PyTuple::new(
                        py,
                        [
                            PyArray1::from_iter(py, all.iter().map(|(i, _)| *i)).into_any(),
                            tt.into_any(),
                            m.into_any(),
                            rr.into_any(),
                            cc.into_any(),
                            v.into_any(),
                        ],
                    )
                })
                .collect::<PyResult<_>>()?;
            Some(PyTuple::new(py, layers)?)
        } else {
            None
        };
        PyTuple::new(
            py,
            [
                PyArray1::from_vec(py, counts).reshape([n, 5])?.into_any(),
                PyArray1::from_vec(py, thresholds)
                    .reshape([n, maps])?
                    .into_any(),
                detection_columns(py, &detections)?.into_any(),
                spikes.map_or_else(|| py.None().into_bound(py), Bound::into_any),
            ],
        )
    }

    /// Train `layer` on windows with winner-take-all and STDP. `callback(done, total, C)` is
    /// called (with the GIL) every `every` windows and at the end; returning `False` stops, as
    /// Ctrl-C does (checked as often), the windows taken so far kept in the weights.
    /// Returns `(convergence, a_plus, windows_seen, winners)`.
    #[pyo3(signature = (layer, sensor_size, length_us, t0, offsets, t, x, y, n_preceding, epochs=1, seed=0, shuffle=true, callback=None, every=64))]
    fn train_layer(
        slf: &Bound<'_, Self>,
        layer: &str,
        sensor_size: (usize, usize),
        length_us: u64,
        t0: PyReadonlyArray1<'_, u64>,
        offsets: PyReadonlyArray1<'_, i64>,
        t: PyReadonlyArray1<'_, u64>,
        x: PyReadonlyArray1<'_, u16>,
        y: PyReadonlyArray1<'_, u16>,
        n_preceding: PyReadonlyArray1<'_, i64>,
        epochs: usize,
        seed: u64,
        shuffle: bool,
        callback: Option<Bound<'_, PyAny>>,
        every: usize,
    ) -> PyResult<(Vec<f64>, Vec<f64>, u64, u64)> {
        let py = slf.py();
        let layer = parse_layer(py, layer)?;
        let args = BatchArgs::new(
            sensor_size,
            length_us,
            &t0,
            &offsets,
            &t,
            &x,
            &y,
            &n_preceding,
        )?;
        let options = TrainOptions {
            epochs,
            seed,
            shuffle,
        };
        let (batch, order, mut trainer) = {
            let this = Self::read(slf)?;
            let net = &this.net;
            let args = &args;
            detach(py, || {
                let batch = args.batch(net)?;
                crate::network::check_training(net, &batch, options)?;
                Ok((
                    batch,
                    training_order(batch.len(), epochs, seed, shuffle)?,
                    Trainer::new(net, layer),
                ))
            })?
        };
        let total = order.len();
        let mut done = 0;
        for chunk in order.chunks(every.max(1)) {
            {
                let mut this = Self::write(slf)?;
                let net = &mut this.net;
                let trainer = &mut trainer;
                let batch = &batch;
                detach(py, || {
                    for &i in chunk {
                        trainer.step(net, batch, i)?;
                    }
                    Ok(())
                })?;
            }
            done += chunk.len();
            // Ctrl-C stops training between chunks (the layer's weights are then those of
            // the windows taken so far, as when the callback stops it).
            py.check_signals()?;
            if let Some(cb) = &callback {
                let p = trainer.progress(done, total);
                let go_on = cb.call1((p.done, p.total, p.convergence))?;
                // Only an explicit `False` stops (a callback returning None goes on).
                if go_on.extract::<bool>().is_ok_and(|b| !b) {
                    break;
                }
            }
        }
        let r = trainer.into_report();
        Ok((r.convergence, r.a_plus, r.windows_seen, r.winners))
    }

    /// Save to a model file (atomic).
    fn save(slf: &Bound<'_, Self>, path: std::path::PathBuf) -> PyResult<()> {
        let this = Self::read(slf)?;
        let net = &this.net;
        detach(slf.py(), || net.save(&path))
    }

    /// Load a model file (checked).
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        let net = detach(py, || Network::load(&path))?;
        Ok(Self { net })
    }

    /// Whether two networks have the same config and bit-identical weights.
    fn same_as(slf: &Bound<'_, Self>, other: &Bound<'_, Self>) -> PyResult<bool> {
        Ok(Self::read(slf)?.net == Self::read(other)?.net)
    }

    /// A deep copy.
    fn copy(slf: &Bound<'_, Self>) -> PyResult<Self> {
        Ok(Self {
            net: Self::read(slf)?.net.clone(),
        })
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(network_default_config, m)?)?;
    m.add_class::<NetworkCore>()
}
