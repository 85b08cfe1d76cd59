//! A DVS emulator in the spirit of v2e (Hu, Liu & Delbruck, CVPRW 2021) and ESIM (Rebecq,
//! Gehrig & Scaramuzza, `CoRL` 2018): events from frames rendered (or filmed) at a high rate.
//!
//! Each pixel holds a filtered response `L` (v2e's `lin_log` of BT.601 luma: linear below
//! `linlog_threshold`, natural log above) and a memorised value `R`. Between two frames `L`
//! moves linearly, as ESIM assumes, and the difference `d = L - R` is tracked exactly:
//!
//! - Threshold crossings: an ON event when `d` reaches the pixel's `θ_on`, an OFF event when it
//!   reaches `-θ_off`, each at the exact interpolated time, as many as the change holds (no cap);
//!   the pixel then resets (`d = 0`, i.e. `R = L`).
//! - Mismatch: `θ_on`, `θ_off` are drawn once per pixel from `N(θ, σ)`, clipped at 0.01 (v2e).
//! - Refractory period: after any event the pixel is held in reset (`R` follows `L`) for
//!   `refractory_us`, so nothing it sees during that time makes an event.
//! - Leak: `R` drifts down by `leak_rate · θ_on` per second (v2e's junction-leak model), which
//!   makes ON events at `leak_rate` in a static scene. Per-pixel rates are log-normal with
//!   `leak_spread_decades` decades of spread, normalised so their mean is the rate asked for;
//!   the drift starts at a random phase so pixels do not fire in step.
//! - Shot noise: a Poisson process per pixel of rate
//!   `shot_noise_rate_hz · (1 + (shot_noise_bright_factor - 1) · min(Y/255, 1))` — the full rate
//!   in the dark, `bright_factor` times it at white (v2e's intensity dependence), half ON and half
//!   OFF. A noise event resets the pixel like any event but does not move `R` by a threshold
//!   (v2e does, which makes the delivered rate depend on the thresholds).
//! - Hot pixels: `round(hot_pixel_fraction · pixels)` pixels chosen once fire ON events as a
//!   Poisson process at `hot_pixel_rate_hz`, on top of everything else.
//! - Low light: the photoreceptor is a first-order low-pass whose cutoff scales with intensity,
//!   `f_3dB = cutoff_hz · (Y + c) / (255 + c)` with `c = cutoff_dark_luma` (v2e's scaling has
//!   `c = 20`), applied per frame with the exact update `1 - exp(-2π f_3dB Δt)` rather than
//!   v2e's Euler step, so it stays stable at any frame rate. Together with the shot-noise
//!   scaling, darker scenes give slower, noisier pixels.
//! - Sub-frame samples ([`DvsEmulator::push_with_samples`]): between two frames, disjoint
//!   patches of the sensor (a rotor, a wing) may be known at more times; their pixels' response
//!   then moves linearly from sample to sample, each sub-interval treated as a frame interval
//!   (crossings, low-pass, noise alike), so what changes faster than the frame rate reaches them.
//!
//! Randomness comes from one PCG stream per pixel row seeded from the emulator's seed, and rows
//! run in parallel; the events do not depend on the number of threads.

use rand::{seq::index::sample, Rng};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

use super::frame::{Converter, Frame, Response};
use super::order::gather_sorted;
use super::seed;
use crate::error::{Error, Result};
use crate::events::Event;

mod samples;

pub use samples::SubSamples;

/// Lowest threshold a mismatched pixel may get (v2e's clamp).
pub const MIN_THRESHOLD: f32 = 0.01;

/// Highest noise rate accepted, per pixel: one event per microsecond.
pub const MAX_RATE_HZ: f64 = 1e6;

/// Parameters of the emulated sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DvsParams {
    /// Mean ON threshold on the change of the response (log units).
    pub threshold_on: f32,
    /// Mean OFF threshold (log units, positive).
    pub threshold_off: f32,
    /// Standard deviation of the per-pixel thresholds.
    pub threshold_sigma: f32,
    /// Refractory period after each event, in microseconds.
    pub refractory_us: f64,
    /// Leak (background activity) ON events per pixel per second in a static scene.
    pub leak_rate_hz: f64,
    /// Log-normal spread of the per-pixel leak rates, in decades.
    pub leak_spread_decades: f64,
    /// Shot-noise events per pixel per second in the dark.
    pub shot_noise_rate_hz: f64,
    /// Shot-noise rate at white relative to the dark rate.
    pub shot_noise_bright_factor: f64,
    /// Fraction of pixels that are hot.
    pub hot_pixel_fraction: f64,
    /// ON events per second of a hot pixel.
    pub hot_pixel_rate_hz: f64,
    /// Photoreceptor cutoff at white, in Hz; 0 disables the low-pass.
    pub cutoff_hz: f64,
    /// Luma added before the cutoff scales with intensity: the cutoff at luma `Y` is
    /// `cutoff_hz · (Y + cutoff_dark_luma) / (255 + cutoff_dark_luma)`. v2e's 20 keeps a dark
    /// pixel at 7 % of the bright bandwidth; a small value makes the cutoff proportional to
    /// the light, as a photoreceptor's is.
    pub cutoff_dark_luma: f32,
    /// Luma below which the response is linear rather than logarithmic.
    pub linlog_threshold: f32,
}

impl Default for DvsParams {
    fn default() -> Self {
        Self {
            threshold_on: 0.2,
            threshold_off: 0.2,
            threshold_sigma: 0.03,
            refractory_us: 100.0,
            leak_rate_hz: 0.1,
            leak_spread_decades: 0.1,
            shot_noise_rate_hz: 1.0,
            shot_noise_bright_factor: 0.25,
            hot_pixel_fraction: 1e-4,
            hot_pixel_rate_hz: 20.0,
            cutoff_hz: 300.0,
            cutoff_dark_luma: 20.0,
            linlog_threshold: 20.0,
        }
    }
}

impl DvsParams {
    /// An ideal sensor: uniform thresholds, no refractory period, no noise, unlimited bandwidth.
    pub fn ideal() -> Self {
        Self {
            threshold_sigma: 0.0,
            refractory_us: 0.0,
            leak_rate_hz: 0.0,
            shot_noise_rate_hz: 0.0,
            hot_pixel_fraction: 0.0,
            cutoff_hz: 0.0,
            ..Self::default()
        }
    }

    /// Reject values that cannot make sense, naming the parameter and the value.
    pub fn validate(&self) -> Result<()> {
        let positive = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::param(
                    name,
                    format!("must be finite and > 0, got {v}"),
                ))
            }
        };
        let non_negative = |name: &'static str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::param(
                    name,
                    format!("must be finite and >= 0, got {v}"),
                ))
            }
        };
        let rate = |name: &'static str, v: f64| {
            non_negative(name, v)?;
            if v > MAX_RATE_HZ {
                return Err(Error::param(
                    name,
                    format!("must be <= {MAX_RATE_HZ} Hz (one event per microsecond), got {v}"),
                ));
            }
            Ok(())
        };
        positive("threshold_on", f64::from(self.threshold_on))?;
        positive("threshold_off", f64::from(self.threshold_off))?;
        non_negative("threshold_sigma", f64::from(self.threshold_sigma))?;
        non_negative("refractory_us", self.refractory_us)?;
        rate("leak_rate_hz", self.leak_rate_hz)?;
        non_negative("leak_spread_decades", self.leak_spread_decades)?;
        if self.leak_spread_decades > 3.0 {
            return Err(Error::param(
                "leak_spread_decades",
                format!("must be <= 3, got {}", self.leak_spread_decades),
            ));
        }
        rate("shot_noise_rate_hz", self.shot_noise_rate_hz)?;
        non_negative("shot_noise_bright_factor", self.shot_noise_bright_factor)?;
        rate(
            "shot_noise_rate_hz * shot_noise_bright_factor",
            self.shot_noise_rate_hz * self.shot_noise_bright_factor,
        )?;
        if !(0.0..=1.0).contains(&self.hot_pixel_fraction) {
            return Err(Error::param(
                "hot_pixel_fraction",
                format!("must be in [0, 1], got {}", self.hot_pixel_fraction),
            ));
        }
        rate("hot_pixel_rate_hz", self.hot_pixel_rate_hz)?;
        non_negative("cutoff_hz", self.cutoff_hz)?;
        positive("cutoff_dark_luma", f64::from(self.cutoff_dark_luma))?;
        positive("linlog_threshold", f64::from(self.linlog_threshold))?;
        Ok(())
    }
}

/// State of one emulated pixel.
#[derive(Debug, Clone, Copy)]
struct Pixel {
    /// Filtered response at the last frame.
    lp: f32,
    /// Memorised response.
    reference: f32,
    th_on: f32,
    th_off: f32,
    /// Drift of `d = L - R` from leak, per microsecond.
    leak_per_us: f64,
    /// ON rate of a hot pixel per microsecond (0 for normal pixels).
    hot_per_us: f64,
    /// End of the current refractory period (µs).
    hold_until: f64,
    /// Next shot-noise candidate (µs); infinite when there is no shot noise.
    next_shot: f64,
    /// Next hot-pixel event (µs); infinite for normal pixels.
    next_hot: f64,
}

/// Per-frame constants shared by all pixels.
#[derive(Debug, Clone)]
struct Step<'a> {
    t0: f64,
    t1: f64,
    /// The interval's ends in integer microseconds: event times are clamped to them (beyond
    /// 2^53 µs an `f64` time may round past the interval).
    t0_us: u64,
    t1_us: u64,
    /// `1 / (t1 - t0)`, per microsecond.
    inv_dt: f64,
    dt_s: f64,
    /// Low-pass update factor at luma `i / eps_per_luma`, `i = 0..=256 · eps_per_luma`:
    /// exact at integer luma (8-bit gray input, one entry per level), interpolated linearly
    /// between sixteenths of a level for other input (relative error below 1e-4).
    eps_table: &'a [f32],
    /// Entries of `eps_table` per unit of luma; 0: no table (computed per pixel).
    eps_per_luma: f32,
    refractory: f64,
    cutoff_hz: f64,
    dark_luma: f64,
    /// Highest shot-noise rate per microsecond (thinning bound).
    shot_max_per_us: f64,
    bright_factor: f64,
    max_factor: f64,
}

/// A DVS emulator fed one frame at a time.
#[derive(Debug)]
pub struct DvsEmulator {
    params: DvsParams,
    width: usize,
    height: usize,
    seed: u64,
    converter: Converter,
    response: Response,
    pixels: Vec<Pixel>,
    rows: Vec<Row>,
    scratch: Vec<u32>,
    /// The whole-frame low-pass table of the last interval: `(dt_us, entries per luma,
    /// table)`, kept while frames come at a steady rate.
    eps_cache: (u64, usize, Vec<f32>),
    last_t: Option<u64>,
    frames: usize,
}

/// Work space and random stream of one pixel row.
#[derive(Debug, Clone)]
struct Row {
    rng: Pcg64Mcg,
    /// The response to `luma`.
    response: Vec<f32>,
    /// The last frame's luma on this row (NaN before the first frame): a float pixel whose
    /// luma has not changed keeps its response without a logarithm.
    luma: Vec<f32>,
    events: Vec<Event>,
}

#[inline]
fn exponential(rng: &mut Pcg64Mcg, rate_per_us: f64) -> f64 {
    if rate_per_us <= 0.0 {
        return f64::INFINITY;
    }
    let u: f64 = rng.random();
    -(1.0 - u).ln() / rate_per_us
}

impl DvsEmulator {
    /// An emulated `width`×`height` sensor. Thresholds, leak rates and hot pixels are drawn
    /// here from `seed`.
    pub fn new(params: DvsParams, width: usize, height: usize, seed: u64) -> Result<Self> {
        params.validate()?;
        if width == 0 || height == 0 || width > 65535 || height > 65535 {
            return Err(Error::param(
                "frame size",
                format!("must be between 1x1 and 65535x65535, got {width}x{height}"),
            ));
        }
        let n = width * height;
        let mut rngs: Vec<Pcg64Mcg> = (0..height as u64).map(|y| seed::stream(seed, y)).collect();
        let ln10s = std::f64::consts::LN_10 * params.leak_spread_decades;
        let mut pixels = Vec::with_capacity(n);
        for rng in &mut rngs {
            for _ in 0..width {
                let mut draw = |mean: f32| {
                    if params.threshold_sigma > 0.0 {
                        let z: f32 = StandardNormal.sample(rng);
                        (mean + params.threshold_sigma * z).max(MIN_THRESHOLD)
                    } else {
                        mean
                    }
                };
                let th_on = draw(params.threshold_on);
                let th_off = draw(params.threshold_off);
                let spread = if ln10s > 0.0 {
                    let z: f64 = StandardNormal.sample(rng);
                    (ln10s * z - 0.5 * ln10s * ln10s).exp()
                } else {
                    1.0
                };
                pixels.push(Pixel {
                    lp: 0.0,
                    reference: 0.0,
                    th_on,
                    th_off,
                    leak_per_us: params.leak_rate_hz * spread * f64::from(th_on) * 1e-6,
                    hot_per_us: 0.0,
                    hold_until: f64::NEG_INFINITY,
                    next_shot: f64::INFINITY,
                    next_hot: f64::INFINITY,
                });
            }
        }
        let hot = (params.hot_pixel_fraction * n as f64).round() as usize;
        if hot > 0 && params.hot_pixel_rate_hz > 0.0 {
            let mut rng = seed::setup(seed, 1);
            for i in sample(&mut rng, n, hot.min(n)) {
                pixels[i].hot_per_us = params.hot_pixel_rate_hz * 1e-6;
            }
        }
        Ok(Self {
            params,
            width,
            height,
            seed,
            converter: Converter::new(Response::LinLog {
                threshold: params.linlog_threshold,
            }),
            response: Response::LinLog {
                threshold: params.linlog_threshold,
            },
            pixels,
            rows: rngs
                .into_iter()
                .map(|rng| Row {
                    rng,
                    response: vec![0.0; width],
                    luma: vec![f32::NAN; width],
                    events: Vec::new(),
                })
                .collect(),
            scratch: Vec::new(),
            eps_cache: (0, 0, Vec::new()),
            last_t: None,
            frames: 0,
        })
    }

    /// `(width, height)` of the sensor.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The seed the emulator was built with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Number of frames consumed so far.
    pub fn frames_seen(&self) -> usize {
        self.frames
    }

    /// Time of the last frame consumed, if any.
    pub fn last_time(&self) -> Option<u64> {
        self.last_t
    }

    /// Pixels chosen as hot, as row-major indices.
    pub fn hot_pixels(&self) -> Vec<usize> {
        (0..self.pixels.len())
            .filter(|&i| self.pixels[i].hot_per_us > 0.0)
            .collect()
    }

    /// Feed the frame at time `t_us` (strictly after the previous one) and append, sorted by
    /// time, the events of the interval since the previous frame to `out`. The first frame
    /// only sets the pixels' state.
    pub fn push(&mut self, frame: &Frame<'_>, t_us: u64, out: &mut Vec<Event>) -> Result<()> {
        self.push_with_samples(frame, t_us, &[], out)
    }

    /// As [`push`](Self::push), with sub-frame samples: inside each patch, the pixels' luma is
    /// also known at the patch's times between the previous frame and this one, and the
    /// response moves linearly from sample to sample instead of from frame to frame (fast
    /// parts — rotors, wings — rendered at a higher rate than the scene). Patches must lie on
    /// the sensor and not overlap; their times must increase strictly inside the interval.
    /// The first frame takes no patches.
    pub fn push_with_samples(
        &mut self,
        frame: &Frame<'_>,
        t_us: u64,
        patches: &[SubSamples<'_>],
        out: &mut Vec<Event>,
    ) -> Result<()> {
        frame.check(self.width, self.height, self.frames)?;
        let t_prev = super::frame::after_previous(self.last_t, t_us, self.frames)?;
        if t_prev.is_none() && !patches.is_empty() {
            return Err(Error::Simulation(
                "the first frame only sets the pixels' state: it takes no sub-frame samples".into(),
            ));
        }
        self.check_patches(patches, t_prev.unwrap_or(0), t_us)?;
        self.frames += 1;
        self.last_t = Some(t_us);
        let p = self.params;
        let shot_max_factor = p.shot_noise_bright_factor.max(1.0);
        let shot_max_per_us = p.shot_noise_rate_hz * shot_max_factor * 1e-6;
        let w = self.width;
        let conv = &self.converter;
        let model = self.response;
        let Some(t_prev) = t_prev else {
            let t0 = t_us as f64;
            self.pixels
                .par_chunks_mut(w)
                .zip(self.rows.par_iter_mut())
                .enumerate()
                .for_each(|(y, (px, row))| {
                    convert_row(conv, model, frame, y, &mut row.response, &mut row.luma);
                    let rng = &mut row.rng;
                    for (q, &r) in px.iter_mut().zip(&row.response) {
                        q.lp = r;
                        // A random phase of the leak drift, so that pixels do not fire in step.
                        let phase: f32 = if q.leak_per_us > 0.0 {
                            rng.random()
                        } else {
                            0.0
                        };
                        q.reference = r - phase * q.th_on;
                        q.next_shot = t0 + exponential(rng, shot_max_per_us);
                        q.next_hot = t0 + exponential(rng, q.hot_per_us);
                    }
                });
            return Ok(());
        };
        // The whole frame's low-pass table, rebuilt only when the frame interval changes.
        let per_luma = match frame {
            _ if p.cutoff_hz <= 0.0 => 0,
            Frame::Gray(_) => 1,
            _ => 16,
        };
        let dt_us = t_us - t_prev;
        if self.eps_cache.0 != dt_us || self.eps_cache.1 != per_luma {
            let dt_s = dt_us as f64 * 1e-6;
            self.eps_cache = (
                dt_us,
                per_luma,
                (0..=256 * per_luma)
                    .map(|i| {
                        let y = i as f64 / per_luma as f64;
                        lowpass_eps(p.cutoff_hz, f64::from(p.cutoff_dark_luma), y, dt_s) as f32
                    })
                    .collect(),
            );
        }
        let step = |t0: u64, t1: u64| {
            let dt_s = (t1 - t0) as f64 * 1e-6;
            Step {
                t0: t0 as f64,
                t1: t1 as f64,
                t0_us: t0,
                t1_us: t1,
                inv_dt: 1.0 / (t1 - t0) as f64,
                dt_s,
                eps_table: &[],
                eps_per_luma: 0.0,
                refractory: p.refractory_us,
                cutoff_hz: p.cutoff_hz,
                dark_luma: f64::from(p.cutoff_dark_luma),
                shot_max_per_us,
                bright_factor: p.shot_noise_bright_factor,
                max_factor: shot_max_factor,
            }
        };
        let whole = Step {
            eps_table: &self.eps_cache.2,
            eps_per_luma: per_luma as f32,
            ..step(t_prev, t_us)
        };
        // Each patch's sub-intervals: previous frame -> its samples -> this frame.
        let sub_steps: Vec<Vec<Step>> = patches
            .iter()
            .map(|patch| {
                let mut edges = Vec::with_capacity(patch.times.len() + 2);
                edges.push(t_prev);
                edges.extend_from_slice(patch.times);
                edges.push(t_us);
                edges.windows(2).map(|e| step(e[0], e[1])).collect()
            })
            .collect();
        let response = self.response;
        self.pixels
            .par_chunks_mut(w)
            .zip(self.rows.par_iter_mut())
            .enumerate()
            .for_each(|(y, (px, row))| {
                convert_row(conv, model, frame, y, &mut row.response, &mut row.luma);
                row.events.clear();
                // The patches crossing this row, by their first column.
                let mut spans: Vec<(usize, usize)> = patches
                    .iter()
                    .enumerate()
                    .filter(|(_, pa)| (pa.y0..pa.y0 + pa.height).contains(&y))
                    .map(|(i, pa)| (pa.x0, i))
                    .collect();
                spans.sort_unstable();
                let mut x = 0;
                let mut next = spans.iter().peekable();
                while x < w {
                    let (x_end, patch) = match next.peek() {
                        Some(&&(x0, i)) if x0 == x => {
                            next.next();
                            (x0 + patches[i].width, Some(i))
                        }
                        Some(&&(x0, _)) => (x0, None),
                        None => (w, None),
                    };
                    match patch {
                        None => {
                            for (xi, q) in px[x..x_end].iter_mut().enumerate() {
                                let xx = x + xi;
                                pixel_step(
                                    q,
                                    row.response[xx],
                                    row.luma[xx],
                                    &whole,
                                    &mut row.rng,
                                    xx as u16,
                                    y as u16,
                                    &mut row.events,
                                );
                            }
                        }
                        Some(i) => {
                            let pa = &patches[i];
                            let plane = pa.width * pa.height;
                            let base = (y - pa.y0) * pa.width;
                            for (xi, q) in px[x..x_end].iter_mut().enumerate() {
                                let xx = x + xi;
                                for (j, s) in sub_steps[i].iter().enumerate() {
                                    let (r, l) = if j < pa.times.len() {
                                        let v = pa.values[j * plane + base + xi];
                                        (response.eval(f64::from(v)), v)
                                    } else {
                                        (row.response[xx], row.luma[xx])
                                    };
                                    pixel_step(
                                        q,
                                        r,
                                        l,
                                        s,
                                        &mut row.rng,
                                        xx as u16,
                                        y as u16,
                                        &mut row.events,
                                    );
                                }
                            }
                        }
                    }
                    x = x_end;
                }
            });
        let mut parts: Vec<Vec<Event>> = self
            .rows
            .iter_mut()
            .map(|r| std::mem::take(&mut r.events))
            .collect();
        gather_sorted(&mut parts, t_prev, t_us, out, &mut self.scratch);
        for (row, events) in self.rows.iter_mut().zip(parts) {
            row.events = events;
        }
        Ok(())
    }
}

/// Fill row `y`'s `response` and `luma` from `frame`. Float pixels whose luma is bit for bit
/// the last frame's keep their response (most of a scene's background does not change from
/// one frame to the next, and the logarithm is most of a static pixel's cost); 8-bit input
/// reads tables.
fn convert_row(
    conv: &Converter,
    model: Response,
    frame: &Frame<'_>,
    y: usize,
    response: &mut [f32],
    luma: &mut [f32],
) {
    if let Frame::GrayF32(v) = frame {
        for ((r, l), &p) in response.iter_mut().zip(luma.iter_mut()).zip(v.row(y)) {
            if p.to_bits() != l.to_bits() {
                *l = p;
                *r = model.eval(f64::from(p));
            }
        }
    } else {
        conv.convert_row(frame, y, response, Some(luma));
    }
}

/// The photoreceptor low-pass update factor over `dt_s` seconds at luma `y`: a first-order
/// filter with cutoff `cutoff_hz · (y + dark_luma) / (255 + dark_luma)` (v2e's intensity
/// scaling has `dark_luma` 20), exact for any step.
#[inline]
fn lowpass_eps(cutoff_hz: f64, dark_luma: f64, y: f64, dt_s: f64) -> f64 {
    let f3db = cutoff_hz * (y + dark_luma) / (255.0 + dark_luma);
    let x = std::f64::consts::TAU * f3db * dt_s;
    // Past 40 time constants the filter has settled to within e^-40 (below an f32's
    // resolution): skip the exponential, which bright pixels at kHz cutoffs always hit.
    if x > 40.0 {
        1.0
    } else {
        -(-x).exp_m1()
    }
}

/// Advance one pixel from `step.t0` to `step.t1`, appending its events in time order.
#[inline]
fn pixel_step(
    q: &mut Pixel,
    response: f32,
    luma: f32,
    s: &Step,
    rng: &mut Pcg64Mcg,
    x: u16,
    y: u16,
    row: &mut Vec<Event>,
) {
    // Most pixels of a scene: settled (`L` at the response, so the low-pass leaves it), out of
    // their refractory period, no noise due, and only the leak moving `d` — short of a
    // threshold. The same arithmetic as `pixel_change`'s quiet interval, without the rest.
    if response.to_bits() == q.lp.to_bits()
        && q.hold_until <= s.t0
        && q.next_shot > s.t1
        && q.next_hot > s.t1
    {
        let a = f64::from(q.lp);
        let d_end = (a - f64::from(q.reference)) + q.leak_per_us * (s.t1 - s.t0);
        if d_end < f64::from(q.th_on) && d_end > -f64::from(q.th_off) {
            q.reference = (a - d_end) as f32;
            return;
        }
    }
    pixel_change(q, response, luma, s, rng, x, y, row);
}

/// [`pixel_step`] in general: the low-pass, the refractory period, threshold crossings and
/// noise.
#[inline(never)]
fn pixel_change(
    q: &mut Pixel,
    response: f32,
    luma: f32,
    s: &Step,
    rng: &mut Pcg64Mcg,
    x: u16,
    y: u16,
    row: &mut Vec<Event>,
) {
    let a = f64::from(q.lp);
    // A settled pixel (`L` already at the response) stays where it is: `a + eps · 0`.
    let b = if s.cutoff_hz > 0.0 && response.to_bits() != q.lp.to_bits() {
        let eps = if s.eps_per_luma > 0.0 && (0.0..256.0).contains(&luma) {
            let u = luma * s.eps_per_luma;
            // `u` is in [0, 4096): through `i32`, which x86 converts to in one instruction
            // (a float's conversion to `usize` takes a dozen).
            let i = u as i32 as usize;
            let (lo, hi) = (s.eps_table[i], s.eps_table[i + 1]);
            f64::from(lo + (u - i as f32) * (hi - lo))
        } else {
            lowpass_eps(s.cutoff_hz, s.dark_luma, f64::from(luma), s.dt_s)
        };
        a + eps * (f64::from(response) - a)
    } else {
        f64::from(response)
    };
    let (t0, t1) = (s.t0, s.t1);
    // d = L - R moves linearly: the signal's slope plus the leak's drift.
    let g = (b - a) * s.inv_dt + q.leak_per_us;
    let (th_on, th_off) = (f64::from(q.th_on), f64::from(q.th_off));
    let mut d = a - f64::from(q.reference);
    let mut cur = t0;
    if q.hold_until > cur {
        cur = q.hold_until.min(t1);
        d = 0.0;
    }
    let quiet = q.next_shot > t1 && q.next_hot > t1;
    let d_end = d + g * (t1 - cur);
    if quiet && d_end < th_on && d_end > -th_off {
        // Nothing happens in this interval.
        d = d_end;
    } else if quiet {
        // Signal only: crossings one `θ/|g|` apart, plus the refractory period after each.
        let (on, threshold, distance) = if g > 0.0 {
            (true, th_on, th_on - d)
        } else {
            (false, th_off, th_off + d)
        };
        let pace = 1.0 / g.abs();
        let gap = s.refractory + threshold * pace;
        let mut t = cur + distance.max(0.0) * pace;
        let mut last = f64::NAN;
        while t <= t1 {
            row.push(Event {
                t: ((t + 0.5) as u64).clamp(s.t0_us, s.t1_us),
                x,
                y,
                p: on,
            });
            last = t;
            t += gap;
        }
        if !last.is_nan() {
            q.hold_until = last + s.refractory;
            cur = q.hold_until.min(t1);
            d = 0.0;
        }
        d += g * (t1 - cur);
    } else {
        d = noisy_step(q, d, g, cur, luma, s, rng, x, y, row);
    }
    q.lp = b as f32;
    q.reference = (b - d) as f32;
}

/// The general case: threshold crossings merged in time with noise candidates. Returns `d`
/// at the end of the interval.
#[inline(never)]
fn noisy_step(
    q: &mut Pixel,
    mut d: f64,
    g: f64,
    mut cur: f64,
    luma: f32,
    s: &Step,
    rng: &mut Pcg64Mcg,
    x: u16,
    y: u16,
    row: &mut Vec<Event>,
) -> f64 {
    let t1 = s.t1;
    let (th_on, th_off) = (f64::from(q.th_on), f64::from(q.th_off));
    loop {
        let t_sig = if g > 0.0 {
            cur + ((th_on - d) / g).max(0.0)
        } else if g < 0.0 {
            cur + ((-th_off - d) / g).max(0.0)
        } else {
            f64::INFINITY
        };
        let t_noise = q.next_shot.min(q.next_hot);
        if t_sig.min(t_noise) > t1 {
            break;
        }
        let (t_event, polarity) = if t_sig <= t_noise {
            (t_sig, g > 0.0)
        } else {
            let hot = q.next_hot <= q.next_shot;
            let keep = if hot {
                q.next_hot += exponential(rng, q.hot_per_us);
                true
            } else {
                q.next_shot += exponential(rng, s.shot_max_per_us);
                // Thinning: the rate at this intensity over the highest rate.
                let level = (f64::from(luma) / 255.0).min(1.0);
                let factor = 1.0 + (s.bright_factor - 1.0) * level;
                rng.random::<f64>() * s.max_factor < factor
            };
            // Candidates that fall in a refractory period are lost.
            if !keep || t_noise < cur {
                continue;
            }
            let polarity = hot || rng.random::<bool>();
            (t_noise, polarity)
        };
        row.push(Event {
            t: ((t_event + 0.5) as u64).clamp(s.t0_us, s.t1_us),
            x,
            y,
            p: polarity,
        });
        // Reset, then hold for the refractory period.
        d = 0.0;
        q.hold_until = t_event + s.refractory;
        cur = q.hold_until.min(t1).max(t_event);
    }
    d + g * (t1 - cur)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    pub(super) fn run(
        params: DvsParams,
        frames: &[Array2<f32>],
        times: &[u64],
        seed: u64,
    ) -> Vec<Event> {
        let (h, w) = frames[0].dim();
        let mut emu = DvsEmulator::new(params, w, h, seed).unwrap();
        let mut out = Vec::new();
        for (f, &t) in frames.iter().zip(times) {
            emu.push(&Frame::GrayF32(f.view()), t, &mut out).unwrap();
        }
        out
    }

    #[test]
    fn ramp_crossings_are_exact_and_unbounded() {
        // ln 200 - ln 50 = 1.386 = 6.93 thresholds of 0.2: six ON events, at the crossing times.
        let p = DvsParams::ideal();
        let f = |v: f32| Array2::from_elem((1, 1), v);
        let ev = run(p, &[f(50.0), f(200.0)], &[0, 1_000_000], 0);
        assert_eq!(ev.len(), 6);
        let slope = (200.0f64.ln() - 50.0f64.ln()) / 1e6;
        for (k, e) in ev.iter().enumerate() {
            let want = (0.2 * (k + 1) as f64 / slope).round() as u64;
            assert!(e.t.abs_diff(want) <= 1, "{} vs {want}", e.t);
            assert!(e.p);
        }
    }

    #[test]
    fn sub_threshold_changes_accumulate() {
        // Three steps of ln 1.1 = 0.095 each: none crosses 0.2 alone, together they do once.
        let f = |v: f32| Array2::from_elem((1, 1), v);
        let frames = [f(100.0), f(110.0), f(121.0), f(133.1)];
        let ev = run(DvsParams::ideal(), &frames, &[0, 10, 20, 30], 0);
        assert_eq!(ev.len(), 1);
        assert!(ev[0].t > 20 && ev[0].t <= 30, "{}", ev[0].t);
    }

    #[test]
    fn refractory_period_spaces_events() {
        let mut p = DvsParams::ideal();
        p.refractory_us = 100_000.0;
        let f = |v: f32| Array2::from_elem((1, 1), v);
        let ev = run(p, &[f(50.0), f(200.0)], &[0, 1_000_000], 0);
        assert!(ev.len() < 6 && !ev.is_empty(), "{}", ev.len());
        for w in ev.windows(2) {
            assert!(w[1].t - w[0].t >= 100_000);
        }
    }

    #[test]
    fn leak_rate_matches() {
        let mut p = DvsParams::ideal();
        p.leak_rate_hz = 2.0;
        let frames = vec![Array2::from_elem((20, 50), 100.0f32); 11];
        let times: Vec<u64> = (0..11).map(|k| k * 1_000_000).collect();
        let ev = run(p, &frames, &times, 3);
        let expected = 2.0 * 10.0 * 1000.0;
        let n = ev.len() as f64;
        assert!(
            (n - expected).abs() < 4.0 * expected.sqrt(),
            "{n} vs {expected}"
        );
        assert!(ev.iter().all(|e| e.p));
    }

    #[test]
    fn deterministic_for_a_seed_whatever_the_threads() {
        let p = DvsParams {
            shot_noise_rate_hz: 50.0,
            hot_pixel_fraction: 0.01,
            ..DvsParams::default()
        };
        let frames: Vec<Array2<f32>> = (0..5)
            .map(|k| {
                Array2::from_shape_fn((16, 24), |(y, x)| ((x * 7 + y * 3 + k * 5) % 200) as f32)
            })
            .collect();
        let times: Vec<u64> = (0..5).map(|k| k * 10_000).collect();
        let a = run(p, &frames, &times, 7);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| run(p, &frames, &times, 7));
        assert_eq!(a, b);
        assert_ne!(a, run(p, &frames, &times, 8));
        assert!(a.windows(2).all(|w| w[0].t <= w[1].t));
    }

    #[test]
    fn rejects_impossible_parameters() {
        let bad = [
            DvsParams {
                threshold_on: 0.0,
                ..DvsParams::default()
            },
            DvsParams {
                shot_noise_rate_hz: f64::NAN,
                ..DvsParams::default()
            },
            DvsParams {
                hot_pixel_fraction: 1.5,
                ..DvsParams::default()
            },
            DvsParams {
                refractory_us: -1.0,
                ..DvsParams::default()
            },
        ];
        for p in bad {
            assert!(DvsEmulator::new(p, 4, 4, 0).is_err(), "{p:?}");
        }
        assert!(DvsEmulator::new(DvsParams::default(), 0, 4, 0).is_err());
    }
}
