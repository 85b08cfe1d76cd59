//! PIX2NVS (Bi & Andreopoulos, "PIX2NVS: Parameterized conversion of pixel-domain video frames
//! to neuromorphic vision streams", ICIP 2017), as its released code (`generate_events.cpp`,
//! `print_event.cpp`, `all_defines.h` of github.com/PIX2NVS/PIX2NVS) behaves.
//!
//! Per frame `k` (time `t_k`), for every pixel:
//!
//! 1. Luma `Y` by BT.601 in floating point, then `B = ln(Y + log_offset)`.
//! 2. Local inhibition: the frame is tiled in `block_size`×`block_size` blocks from the top left;
//!    in each block only the pixel with the largest `|B - R|` (`R` the reference) may emit. Ties
//!    go to the first pixel met scanning columns, then rows inside a column, as PIX2NVS scans.
//! 3. With `ΔB = B - R` at that pixel and `θ` its threshold: if `ΔB > θ` it emits
//!    `n = min(⌊ΔB/θ⌋, n_max)` ON events, if `ΔB < -θ` as many OFF events; event `e` (0-based)
//!    is at `t_{k-1} + (e+1)·θ/|ΔB|·(t_k - t_{k-1})` rounded to the microsecond — where a linear
//!    change of `B` would cross `R ± (e+1)θ`.
//! 4. Reference update ([`ReferenceUpdate`], PIX2NVS's `-r`): copy the frame into the reference
//!    everywhere (1), copy it only at pixels that emitted (2), or move the reference of an
//!    emitting pixel by the `n·θ` it emitted, keeping the remainder (3).
//! 5. Adaptive threshold (`-a`): the competing pixel's `θ` is multiplied by `1 + adaptive` when it
//!    emits and by `1 - adaptive` when it does not.
//!
//! Defaults are PIX2NVS's compiled-in ones (`-r 1`, `θ = 0.4`, `n_max = 5`, block 1) except
//! `adaptive`, 0 here as in PIX2NVS's worked example (`-a 0`): its compiled-in 0.05 has no floor,
//! so the threshold of every quiet pixel decays as `0.95^frames` and video-compression noise
//! floods the background within a second or two. Optional bounds (`threshold_min`,
//! `threshold_max`, not in PIX2NVS) keep the adaptive threshold usable. Where this
//! implementation departs from the released code, on purpose:
//!
//! - PIX2NVS computes `log(Y)`, which is `-inf` on black pixels; we add `log_offset` (default 1,
//!   which changes nothing visible above a few grey levels).
//! - In modes 2 and 3 and for the adaptive threshold, the released code updates the block's
//!   top-left pixel (`reference[i][j]`) instead of the pixel that competed
//!   (`[i + i_shift][j + j_shift]`); with its default block size of 1 these are the same pixel.
//!   We update the pixel that competed, which is what the paper describes.
//! - Mode 3 in the released code starts from a zero reference, so the first frames flood every
//!   pixel with ON events; every mode here starts from the first frame.
//! - Blocks at the right and bottom edges are clipped (the released code reads past the frame
//!   when the size is not a multiple of the block size).
//! - `y` has its origin at the top (PIX2NVS writes `height - 1 - y`), events are sorted by time
//!   (PIX2NVS writes them in pixel order within a frame), and times come from the frames' own
//!   timestamps rather than `frame index / frame rate`.
//!
//! With [`Pix2NvsParams::compat`] the simulator instead reproduces the released program's events
//! exactly, quirks included (see `compat_luma_row` and `compete_band_compat`): its luma read
//! from the frame's BMP bytes two bytes late, `log(Y)` without an offset (black is `-inf`, and
//! what the program then does on x86-64 is done here too), updates of the block's top-left
//! pixel in modes 2 and 3 and for the adaptive threshold, mode 3 starting from a zero reference
//! and skipping the first frame, and event times computed as `print_event.cpp` computes them.
//!
//! Pooling to a smaller sensor ([`Pooling`]) is not part of PIX2NVS: Kirkland et al. simulated
//! their 1920×1080 footage and down-sampled the result to 240×180. With [`Pooling::Strongest`]
//! each output pixel takes, per frame interval, the events of the source pixel with the largest
//! change in its area — PIX2NVS's own local-inhibition rule with the area as the block — so the
//! output keeps at most `n_max` events per pixel per frame, like a native sensor of that size.
//! [`Pooling::All`] keeps every event and only maps its coordinates.

use rayon::prelude::*;

use super::frame::{check_size, Converter, Frame, Response};
use super::order::{gather_from, gather_sorted};
use crate::error::{check_alloc, Error, Result};
use crate::events::Event;

mod compat;
mod compete;
mod params;
mod pool;
#[cfg(test)]
mod tests;

use compat::{compat_luma_row, compete_band_compat};
use compete::compete_band;
pub use params::{Pix2NvsParams, Pooling, ReferenceUpdate, MAX_N_MAX};
use pool::{pool_strongest, Pool};

/// Memory of one source pixel.
#[derive(Debug, Clone, Copy, Default)]
struct PixelState {
    reference: f32,
    threshold: f32,
}

/// A source pixel that emitted in the current frame interval.
#[derive(Debug, Clone, Copy)]
struct Emitter {
    x: u16,
    y: u16,
    /// Signed number of events (positive ON, negative OFF).
    count: i8,
    /// `θ/|ΔB|`: the fraction of the interval between successive events.
    step: f32,
    /// `|ΔB|`, to choose the strongest pixel when pooling.
    magnitude: f32,
    /// The threshold `θ` it crossed (for `print_event.cpp`'s times with `compat`).
    theta: f32,
}

/// Work space of one row of inhibition blocks (`block_size` source rows).
#[derive(Debug, Clone, Default)]
struct Band {
    input: Vec<f32>,
    emitters: Vec<Emitter>,
    events: Vec<Event>,
}

/// A PIX2NVS simulator fed one frame at a time.
#[derive(Debug)]
pub struct Pix2Nvs {
    params: Pix2NvsParams,
    width: usize,
    height: usize,
    pool: Option<Pool>,
    converter: Converter,
    state: Vec<PixelState>,
    bands: Vec<Band>,
    pooled: Vec<Event>,
    scratch: Vec<u32>,
    last_t: Option<u64>,
    frames: usize,
}
impl Pix2Nvs {
    /// A simulator for `width`×`height` frames. With `output = Some((w, h, pooling))` the events
    /// are pooled onto a `w`×`h` sensor (no larger than the frames); otherwise they are at frame
    /// size.
    pub fn new(
        params: Pix2NvsParams,
        width: usize,
        height: usize,
        output: Option<(usize, usize, Pooling)>,
    ) -> Result<Self> {
        params.validate()?;
        check_size("frame size", width, height)?;
        // Per pixel: its state, the band's input and, pooled, at most one output cell.
        check_alloc(
            "frame size",
            || format!("a PIX2NVS simulator of {width}x{height} frames"),
            width * height,
            std::mem::size_of::<PixelState>() + 4 + 16,
        )?;
        let pool = match output {
            None => None,
            Some((w, h, mode)) => {
                check_size("output size", w, h)?;
                if w > width || h > height {
                    return Err(Error::param(
                        "output size",
                        format!("output {w}x{h} is larger than the {width}x{height} frames"),
                    ));
                }
                Some(Pool::new(mode, width, height, w, h))
            }
        };
        let b = params.block_size;
        if params.compat && (!width.is_multiple_of(b) || !height.is_multiple_of(b)) {
            return Err(Error::param(
                "block_size",
                format!(
                    "with compat the frame ({width}x{height}) must be a whole number of \
                     {b}x{b} blocks: PIX2NVS reads past the frame otherwise"
                ),
            ));
        }
        let bands = (0..height.div_ceil(b))
            .map(|k| Band {
                input: vec![0.0; b.min(height - k * b) * width],
                ..Band::default()
            })
            .collect();
        Ok(Self {
            params,
            width,
            height,
            pool,
            converter: Converter::new(Response::Log {
                offset: params.log_offset,
            }),
            state: vec![PixelState::default(); width * height],
            bands,
            pooled: Vec::new(),
            scratch: Vec::new(),
            last_t: None,
            frames: 0,
        })
    }

    /// `(width, height)` of the events this simulator writes.
    pub fn output_size(&self) -> (usize, usize) {
        match &self.pool {
            Some(p) => (p.width, p.height),
            None => (self.width, self.height),
        }
    }

    /// Number of frames consumed so far.
    pub fn frames_seen(&self) -> usize {
        self.frames
    }

    /// Time of the last frame consumed, if any.
    pub fn last_time(&self) -> Option<u64> {
        self.last_t
    }

    /// Feed the frame at time `t_us` (strictly after the previous one) and append, sorted by
    /// time, the events of the interval since the previous frame to `out`. The first frame only
    /// sets the reference.
    pub fn push(&mut self, frame: &Frame<'_>, t_us: u64, out: &mut Vec<Event>) -> Result<()> {
        frame.check(self.width, self.height, self.frames)?;
        if self.params.compat && matches!(frame, Frame::GrayF32(_)) {
            return Err(Error::Simulation(
                "compat reads 8-bit frames, as PIX2NVS reads BMP bytes; got float frames"
                    .to_string(),
            ));
        }
        let t_prev = super::frame::after_previous(self.last_t, t_us, self.frames)?;
        self.frames += 1;
        self.last_t = Some(t_us);
        let (w, b) = (self.width, self.params.block_size);
        let p = self.params;
        let conv = &self.converter;
        let direct = self.pool.is_none();
        let dt = t_prev.map_or(0, |t| t_us - t);
        // Steps 1–5 band by band (bands of inhibition blocks never share a pixel); without
        // pooling the events are made in the same pass.
        self.state
            .par_chunks_mut(b * w)
            .zip(self.bands.par_iter_mut())
            .enumerate()
            .for_each(|(k, (state, band))| {
                for (r, row) in band.input.chunks_exact_mut(w).enumerate() {
                    if p.compat {
                        compat_luma_row(frame, k * b + r, row);
                    } else {
                        conv.convert_row(frame, k * b + r, row, None);
                    }
                }
                let Some(t_prev) = t_prev else {
                    // PIX2NVS's mode 3 never reads the first frame: its reference starts at 0.
                    let zero = p.compat && p.reference == ReferenceUpdate::EventIncrement;
                    for (s, &v) in state.iter_mut().zip(&band.input) {
                        *s = PixelState {
                            reference: if zero { 0.0 } else { v },
                            threshold: p.threshold,
                        };
                    }
                    return;
                };
                band.emitters.clear();
                if p.compat {
                    compete_band_compat(&p, state, &band.input, w, k * b, &mut band.emitters);
                } else {
                    compete_band(&p, state, &band.input, w, k * b, &mut band.emitters);
                }
                if direct {
                    band.events.clear();
                    for e in &band.emitters {
                        push_events(&mut band.events, e, e.x, e.y, t_prev, dt, p.compat);
                    }
                }
            });
        let Some(t_prev) = t_prev else {
            return Ok(());
        };
        match &mut self.pool {
            None => {}
            Some(pool) if pool.mode == Pooling::All => {
                let (x_of, y_of) = (&pool.x_of, &pool.y_of);
                let compat = p.compat;
                self.bands.par_iter_mut().for_each(|band| {
                    band.events.clear();
                    for e in &band.emitters {
                        let (x, y) = (x_of[e.x as usize], y_of[e.y as usize]);
                        push_events(&mut band.events, e, x, y, t_prev, dt, compat);
                    }
                });
            }
            Some(pool) => {
                pool_strongest(pool, &self.bands, &mut self.pooled, t_prev, dt, p.compat);
                let mut parts = [std::mem::take(&mut self.pooled)];
                gather_sorted(&mut parts, t_prev, t_us, out, &mut self.scratch);
                let [pooled] = parts;
                self.pooled = pooled;
                return Ok(());
            }
        }
        gather_from(
            &mut self.bands,
            |b| &mut b.events,
            t_prev,
            t_us,
            out,
            &mut self.scratch,
        );
        Ok(())
    }
}

/// Append the events of one emitter: event `k` (1-based) at `t_prev + k·step·dt`, rounded
/// half up (`frac·dt >= 0`); with `compat`, at `t_prev + round(dt·k·θ/|ΔB|)` in double
/// precision, as `print_event.cpp` computes it.
#[inline]
fn push_events(
    row: &mut Vec<Event>,
    e: &Emitter,
    x: u16,
    y: u16,
    t_prev: u64,
    dt_us: u64,
    compat: bool,
) {
    let p = e.count > 0;
    let dt = dt_us as f64;
    for k in 1..=u32::from(e.count.unsigned_abs()) {
        let raw = if compat {
            (dt * f64::from(k) * f64::from(e.theta) / f64::from(e.magnitude)).round()
        } else {
            (f64::from(k) * f64::from(e.step)).min(1.0) * dt + 0.5
        };
        // `dt` is exact below 2^53 µs; beyond, rounding must not pass the interval's end.
        let offset = (raw as u64).min(dt_us);
        row.push(Event {
            t: t_prev + offset,
            x,
            y,
            p,
        });
    }
}
