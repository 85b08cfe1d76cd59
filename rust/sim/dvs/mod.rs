//! A DVS emulator in the spirit of v2e (Hu, Liu & Delbruck, CVPRW 2021) and ESIM (Rebecq,
//! Gehrig & Scaramuzza, `CoRL` 2018): events from frames rendered (or filmed) at a high rate.
//!
//! Each pixel holds a filtered response `L` (v2e's `lin_log` of BT.601 luma: linear below
//! `linlog_threshold`, natural log above) and a memorised value `R`. Between two frames `L`
//! moves linearly, as ESIM assumes, and the difference `d = L - R` is tracked exactly:
//!
//! - Threshold crossings: an ON event when `d` reaches the pixel's `θ_on`, an OFF event when it
//!   reaches `-θ_off`, each at the exact interpolated time, as many as the change holds (up to
//!   [`MAX_EVENTS`] in a frame interval); the pixel then resets (`d = 0`, i.e. `R = L`).
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

use super::frame::{check_size, Converter, Frame, Response};
use super::order::gather_from;
use super::seed;
use crate::error::{check_alloc, Error, Result, MAX_ALLOC_BYTES};
use crate::events::Event;

mod noise;
mod params;
mod pixel;
mod samples;
#[cfg(test)]
mod tests;

use noise::exponential;
pub use params::{DvsParams, MAX_RATE_HZ, MIN_THRESHOLD};
use pixel::{lowpass_eps, pixel_step, Pixel, Step};
pub use samples::SubSamples;

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
    /// The first frame's time: the pixels' `f64` times count from it.
    origin: u64,
    /// Events per µs that leak, hot pixels and shot noise (at its brightest) make on average,
    /// whatever the scene: what an interval costs before any change is seen.
    noise_per_us: f64,
    /// The most events one frame interval may make: [`MAX_EVENTS`] (smaller in tests).
    max_events: usize,
    /// The frame whose events overran the cap, after which the pixels' state is lost.
    failed: Option<usize>,
}

/// The most events one frame interval may make (their bytes are
/// [`MAX_ALLOC_BYTES`]). An interval whose noise alone averages half of it is refused
/// before any pixel moves; one whose events reach it all the same (a change of thousands of
/// thresholds on every pixel) is refused after, and the emulator with it.
pub const MAX_EVENTS: usize = MAX_ALLOC_BYTES / std::mem::size_of::<Event>();

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

impl DvsEmulator {
    /// An emulated `width`×`height` sensor. Thresholds, leak rates and hot pixels are drawn
    /// here from `seed`.
    pub fn new(params: DvsParams, width: usize, height: usize, seed: u64) -> Result<Self> {
        params.validate()?;
        check_size("frame size", width, height)?;
        let n = width * height;
        // Per pixel: its state, and its row's response and luma.
        check_alloc(
            "frame size",
            || format!("a DVS emulator of {width}x{height} pixels"),
            n,
            std::mem::size_of::<Pixel>() + 8,
        )?;
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
        let shot_per_us = params.shot_noise_rate_hz * params.shot_noise_bright_factor.max(1.0);
        let noise_per_us = pixels
            .iter()
            .map(|q| q.leak_per_us / f64::from(q.th_on) + q.hot_per_us + shot_per_us * 1e-6)
            .sum();
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
            origin: 0,
            noise_per_us,
            max_events: MAX_EVENTS,
            failed: None,
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

    /// Cap the events of a frame interval below [`MAX_EVENTS`] (tests reach it so).
    #[cfg(test)]
    fn set_max_events(&mut self, max_events: usize) {
        self.max_events = max_events;
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
        if let Some(k) = self.failed {
            return Err(Error::Simulation(format!(
                "frame {k} made more events than the emulator holds, and the pixels' state was \
                 lost with them: make a new emulator"
            )));
        }
        frame.check(self.width, self.height, self.frames)?;
        let t_prev = super::frame::after_previous(self.last_t, t_us, self.frames)?;
        let row_cap = self.max_events / self.height;
        if let Some(t_prev) = t_prev {
            // Checked before any pixel moves: frames far apart by mistake (times in ns, a
            // clock that jumped) would ask for more events than memory holds.
            let expected = self.noise_per_us * (t_us - t_prev) as f64;
            if expected > (self.max_events / 2) as f64 {
                return Err(Error::Simulation(format!(
                    "frame {} is {} µs after the previous one: leak, hot pixels and shot noise \
                     alone make about {expected:.3e} events in that interval, more than half \
                     the {} a frame interval may make (MAX_EVENTS); are the times in \
                     microseconds?",
                    self.frames,
                    t_us - t_prev,
                    self.max_events
                )));
            }
        }
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
            self.origin = t_us;
            let t0 = 0.0;
            each_row(
                &mut self.pixels,
                &mut self.rows,
                w,
                conv,
                model,
                frame,
                |_, px, row| {
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
                },
            );
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
        let origin = self.origin;
        let step = |t0: u64, t1: u64| {
            let dt_s = (t1 - t0) as f64 * 1e-6;
            Step {
                t0: (t0 - origin) as f64,
                t1: (t1 - origin) as f64,
                origin,
                t0_us: t0,
                t1_us: t1,
                row_cap,
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
        each_row(
            &mut self.pixels,
            &mut self.rows,
            w,
            conv,
            model,
            frame,
            |y, px, row| {
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
            },
        );
        if self.rows.iter().any(|r| r.events.len() >= row_cap) {
            self.failed = Some(self.frames - 1);
            for r in &mut self.rows {
                r.events = Vec::new();
            }
            return Err(Error::Simulation(format!(
                "frame {} makes more events than a frame interval may ({row_cap} on a row of \
                 pixels, MAX_EVENTS over the rows); the pixels' state is lost with them",
                self.frames - 1
            )));
        }
        gather_from(
            &mut self.rows,
            |r| &mut r.events,
            t_prev,
            t_us,
            out,
            &mut self.scratch,
        );
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

/// Run `f(y, pixels, row)` on every pixel row `y` of a `w`-wide sensor, rows in parallel, each
/// once its response to `frame` is computed ([`convert_row`]).
fn each_row<F>(
    pixels: &mut [Pixel],
    rows: &mut [Row],
    w: usize,
    conv: &Converter,
    model: Response,
    frame: &Frame<'_>,
    f: F,
) where
    F: Fn(usize, &mut [Pixel], &mut Row) + Sync,
{
    pixels
        .par_chunks_mut(w)
        .zip(rows.par_iter_mut())
        .enumerate()
        .for_each(|(y, (px, row))| {
            convert_row(conv, model, frame, y, &mut row.response, &mut row.luma);
            f(y, px, row);
        });
}
