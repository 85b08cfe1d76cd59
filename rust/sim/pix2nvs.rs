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
//! exactly, quirks included (see [`compat_luma_row`] and [`compete_band_compat`]): its luma read
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

use super::frame::{Converter, Frame, Response};
use super::order::gather_sorted;
use crate::error::{Error, Result};
use crate::events::Event;

/// How the reference (memorised log luma) follows the video: PIX2NVS's `-r 1|2|3`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReferenceUpdate {
    /// `-r 1`: after each frame the reference is the frame.
    #[default]
    Frame,
    /// `-r 2`: the reference takes the frame's value only at pixels that emitted.
    EventCopy,
    /// `-r 3`: an emitting pixel's reference moves by the `n·θ` it emitted; the remainder stays.
    EventIncrement,
}

/// How events at the source resolution are pooled onto a smaller output sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pooling {
    /// Per output pixel and frame interval, only the events of the strongest source pixel.
    #[default]
    Strongest,
    /// Every event, with its coordinates scaled.
    All,
}

/// Parameters of PIX2NVS. Defaults are PIX2NVS's own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pix2NvsParams {
    /// Initial threshold `θ` on the change of natural-log luma (PIX2NVS: 0.4, range 0.2–0.7).
    pub threshold: f32,
    /// At most this many events per pixel per frame (PIX2NVS: 5, range 1–5).
    pub n_max: u32,
    /// Reference update mode (PIX2NVS: 1).
    pub reference: ReferenceUpdate,
    /// Side of the local-inhibition blocks; 1 disables inhibition (PIX2NVS: 1; allows 1, 2, 4).
    pub block_size: usize,
    /// Adaptive threshold step: ×(1+a) after emitting, ×(1−a) otherwise; 0 disables
    /// (PIX2NVS: 0.05, range 0–0.1; our default 0, as in PIX2NVS's worked example `-a 0`).
    pub adaptive: f32,
    /// Lowest value the adaptive threshold may reach (PIX2NVS: none, i.e. 0).
    pub threshold_min: f32,
    /// Highest value the adaptive threshold may reach (PIX2NVS: none, i.e. infinity).
    pub threshold_max: f32,
    /// Added to luma before the logarithm (not in PIX2NVS; keeps black pixels finite). Not
    /// used with `compat`.
    pub log_offset: f32,
    /// Reproduce the released program's events exactly, quirks included (module docs).
    pub compat: bool,
}

impl Default for Pix2NvsParams {
    fn default() -> Self {
        Self {
            threshold: 0.4,
            n_max: 5,
            reference: ReferenceUpdate::Frame,
            block_size: 1,
            adaptive: 0.0,
            threshold_min: 0.0,
            threshold_max: f32::INFINITY,
            log_offset: 1.0,
            compat: false,
        }
    }
}

/// Largest `n_max` accepted (events are counted in an `i8` per pixel and frame).
pub const MAX_N_MAX: u32 = 127;

impl Pix2NvsParams {
    /// Reject values that cannot make sense, naming the parameter and the value.
    pub fn validate(&self) -> Result<()> {
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err(Error::param(
                "threshold",
                format!("must be finite and > 0, got {}", self.threshold),
            ));
        }
        if !(1..=MAX_N_MAX).contains(&self.n_max) {
            return Err(Error::param(
                "n_max",
                format!("must be in 1..={MAX_N_MAX}, got {}", self.n_max),
            ));
        }
        if self.block_size == 0 || self.block_size > 256 {
            return Err(Error::param(
                "block_size",
                format!("must be in 1..=256, got {}", self.block_size),
            ));
        }
        if !(self.adaptive.is_finite() && (0.0..1.0).contains(&self.adaptive)) {
            return Err(Error::param(
                "adaptive",
                format!("must be in [0, 1), got {}", self.adaptive),
            ));
        }
        if !(self.threshold_min >= 0.0
            && self.threshold_min <= self.threshold
            && self.threshold <= self.threshold_max)
        {
            return Err(Error::param(
                "threshold_min, threshold_max",
                format!(
                    "need 0 <= threshold_min <= threshold <= threshold_max, got {} <= {} <= {}",
                    self.threshold_min, self.threshold, self.threshold_max
                ),
            ));
        }
        if self.compat && (self.threshold_min != 0.0 || self.threshold_max != f32::INFINITY) {
            return Err(Error::param(
                "threshold_min, threshold_max",
                "PIX2NVS has no bounds on its adaptive threshold: leave them unset with compat"
                    .to_string(),
            ));
        }
        if !(self.log_offset.is_finite() && self.log_offset > 0.0) {
            return Err(Error::param(
                "log_offset",
                format!("must be finite and > 0, got {}", self.log_offset),
            ));
        }
        Ok(())
    }
}

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

/// Output pooling geometry: the output column and row of each source column and row.
#[derive(Debug, Clone)]
struct Pool {
    mode: Pooling,
    width: usize,
    height: usize,
    x_of: Vec<u16>,
    y_of: Vec<u16>,
    /// Per output pixel, the strongest emitter so far this frame: (magnitude, band, index).
    best: Vec<(f32, u32, u32)>,
    touched: Vec<u32>,
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

/// The output index (column or row) of each of `from` source indices mapped onto `to`.
fn index_map(from: usize, to: usize) -> Vec<u16> {
    (0..from).map(|i| (i * to / from) as u16).collect()
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
        let pool = match output {
            None => None,
            Some((w, h, mode)) => {
                check_size("output size", w, h)?;
                if w > width || h > height {
                    return Err(Error::param(
                        "size",
                        format!("output {w}x{h} is larger than the {width}x{height} frames"),
                    ));
                }
                Some(Pool {
                    mode,
                    width: w,
                    height: h,
                    x_of: index_map(width, w),
                    y_of: index_map(height, h),
                    best: vec![(0.0, u32::MAX, 0); w * h],
                    touched: Vec::new(),
                })
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
        let mut parts: Vec<Vec<Event>> = self
            .bands
            .iter_mut()
            .map(|b| std::mem::take(&mut b.events))
            .collect();
        gather_sorted(&mut parts, t_prev, t_us, out, &mut self.scratch);
        for (band, events) in self.bands.iter_mut().zip(parts) {
            band.events = events;
        }
        Ok(())
    }
}

/// Per output pixel, the events of the strongest emitter in its area (ties: the first found,
/// bands top to bottom, blocks left to right).
fn pool_strongest(
    pool: &mut Pool,
    bands: &[Band],
    out: &mut Vec<Event>,
    t_prev: u64,
    dt: u64,
    compat: bool,
) {
    for &o in &pool.touched {
        pool.best[o as usize] = (0.0, u32::MAX, 0);
    }
    pool.touched.clear();
    for (k, band) in bands.iter().enumerate() {
        for (i, e) in band.emitters.iter().enumerate() {
            let o =
                pool.y_of[e.y as usize] as usize * pool.width + pool.x_of[e.x as usize] as usize;
            let best = &mut pool.best[o];
            if best.1 == u32::MAX {
                pool.touched.push(o as u32);
                *best = (e.magnitude, k as u32, i as u32);
            } else if e.magnitude > best.0 {
                *best = (e.magnitude, k as u32, i as u32);
            }
        }
    }
    out.clear();
    for &o in &pool.touched {
        let (_, k, i) = pool.best[o as usize];
        let e = &bands[k as usize].emitters[i as usize];
        let (x, y) = (o as usize % pool.width, o as usize / pool.width);
        push_events(out, e, x as u16, y as u16, t_prev, dt, compat);
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

/// Decide one competing pixel (steps 3–5); returns its emission, if any.
#[inline]
fn decide(p: &Pix2NvsParams, s: &mut PixelState, input: f32) -> Option<(i8, f32, f32, f32)> {
    let delta = input - s.reference;
    let theta = s.threshold;
    let magnitude = delta.abs();
    if magnitude > theta {
        let n = ((magnitude / theta) as u32).min(p.n_max);
        let signed = if delta > 0.0 { n as i8 } else { -(n as i8) };
        match p.reference {
            ReferenceUpdate::EventCopy => s.reference = input,
            ReferenceUpdate::EventIncrement => s.reference += f32::from(signed) * theta,
            ReferenceUpdate::Frame => {}
        }
        if p.adaptive > 0.0 {
            s.threshold = (theta * (1.0 + p.adaptive)).min(p.threshold_max);
        }
        Some((signed, theta / magnitude, magnitude, theta))
    } else {
        if p.adaptive > 0.0 {
            s.threshold = (theta * (1.0 - p.adaptive)).max(p.threshold_min);
        }
        None
    }
}

/// One band of `rows` source rows starting at row `y0`: every inhibition block in it.
fn compete_band(
    p: &Pix2NvsParams,
    state: &mut [PixelState],
    input: &[f32],
    w: usize,
    y0: usize,
    emitters: &mut Vec<Emitter>,
) {
    let b = p.block_size;
    let rows = input.len() / w;
    let emit = |emitters: &mut Vec<Emitter>, i: usize, (count, step, magnitude, theta)| {
        emitters.push(Emitter {
            x: (i % w) as u16,
            y: (y0 + i / w) as u16,
            count,
            step,
            magnitude,
            theta,
        });
    };
    if b == 1 {
        // No inhibition: every pixel competes on its own.
        for (i, (s, &v)) in state.iter_mut().zip(input).enumerate() {
            if let Some(e) = decide(p, s, v) {
                emit(emitters, i, e);
            }
            if p.reference == ReferenceUpdate::Frame {
                s.reference = v;
            }
        }
        return;
    }
    for x0 in (0..w).step_by(b) {
        let bw = b.min(w - x0);
        // The strongest change; PIX2NVS scans x outer, y inner, and keeps the first strict
        // maximum above 0 (so an unchanged block competes with its top-left pixel).
        let mut win = x0;
        let mut best = 0.0f32;
        for x in x0..x0 + bw {
            for y in 0..rows {
                let i = y * w + x;
                let d = (input[i] - state[i].reference).abs();
                if d > best {
                    best = d;
                    win = i;
                }
            }
        }
        if let Some(e) = decide(p, &mut state[win], input[win]) {
            emit(emitters, win, e);
        }
        if p.reference == ReferenceUpdate::Frame {
            for y in 0..rows {
                for x in x0..x0 + bw {
                    state[y * w + x].reference = input[y * w + x];
                }
            }
        }
    }
}

/// The 24-bit BMP bytes of `frame` as ffmpeg writes them (rows bottom up, each padded to a
/// multiple of 4 bytes, pixels in B, G, R order), counted from the start of the pixel data;
/// 0 for padding and past the end.
#[inline]
fn bmp_byte(frame: &Frame<'_>, w: usize, h: usize, a: usize) -> u8 {
    let stride = (3 * w).div_ceil(4) * 4;
    let (row, col) = (a / stride, a % stride);
    if row >= h || col >= 3 * w {
        return 0;
    }
    let (x, y, c) = (col / 3, h - 1 - row, col % 3);
    match frame {
        Frame::Bgr(v) => v[[y, x, c]],
        Frame::Gray(v) => v[[y, x]],
        Frame::GrayF32(_) => 0, // refused before conversion
    }
}

/// Row `y` of `frame` as PIX2NVS's `readframe.cpp` and `log_frame.cpp` see it: `ln(Y)` in
/// single precision, `Y` computed in double from the BMP bytes two bytes after the pixel's own.
///
/// `readframe.cpp` skips `sizeof(BITMAPFILEHEADER) + sizeof(BITMAPINFOHEADER)` bytes, 56 with
/// the compiler's padding of its unpacked file-header struct, where the pixels start at byte
/// 54. Its blue, green and red of pixel `k` (counted without row padding) are therefore the
/// bytes `2 + 3k`, `3 + 3k`, `4 + 3k` of the pixel data: the red of pixel `k` and the blue and
/// green of the next — of the row above at a row's right end, and past the buffer (read as 0
/// here; undefined in the program) for the top right pixel.
fn compat_luma_row(frame: &Frame<'_>, y: usize, out: &mut [f32]) {
    let (w, h) = frame.size();
    let file_row = h - 1 - y;
    for (x, o) in out.iter_mut().enumerate() {
        let a = 2 + 3 * (w * file_row + x);
        let blue = f64::from(bmp_byte(frame, w, h, a));
        let green = f64::from(bmp_byte(frame, w, h, a + 1));
        let red = f64::from(bmp_byte(frame, w, h, a + 2));
        let luma = (0.299 * red + 0.587 * green + 0.114 * blue) as f32;
        *o = luma.ln();
    }
}

/// C's `(int)` of a float on x86-64 (`cvttss2si`): truncation, and `i32::MIN` for NaN, the
/// infinities and anything out of range.
#[inline]
fn x86_int(v: f32) -> i32 {
    if v.is_finite() && v > -2_147_483_648.0 && v < 2_147_483_648.0 {
        v as i32
    } else {
        i32::MIN
    }
}

/// One band of blocks as `generate_events.cpp` processes it: the winner decides with its own
/// threshold, but modes 2 and 3 and the adaptive threshold update the block's top-left pixel;
/// `print_event.cpp`'s count is `(int)(ΔB/θ)` capped at `n_max` (an infinite change, from a
/// black pixel's `-inf`, gives `INT_MIN`: no event, and mode 3 moves the reference by
/// `INT_MIN·θ`).
fn compete_band_compat(
    p: &Pix2NvsParams,
    state: &mut [PixelState],
    input: &[f32],
    w: usize,
    y0: usize,
    emitters: &mut Vec<Emitter>,
) {
    let b = p.block_size;
    let rows = input.len() / w;
    let (up, down) = (1.0 + p.adaptive, 1.0 - p.adaptive);
    for x0 in (0..w).step_by(b) {
        let mut win = x0;
        let mut best = 0.0f32;
        for x in x0..x0 + b {
            for y in 0..rows {
                let i = y * w + x;
                let d = (input[i] - state[i].reference).abs();
                if d > best {
                    best = d;
                    win = i;
                }
            }
        }
        let delta = input[win] - state[win].reference;
        let theta = state[win].threshold;
        let origin = x0; // the block's top-left pixel: row 0 of the band, column x0
        let on = delta > theta;
        if on || delta < -theta {
            let magnitude = if on { delta } else { -delta };
            let moddiff = x86_int(magnitude / theta);
            let evenum = if moddiff > p.n_max as i32 {
                p.n_max as i32
            } else {
                moddiff
            };
            if evenum > 0 {
                emitters.push(Emitter {
                    x: (win % w) as u16,
                    y: (y0 + win / w) as u16,
                    count: if on { evenum as i8 } else { -(evenum as i8) },
                    step: theta / magnitude,
                    magnitude,
                    theta,
                });
            }
            let o = &mut state[origin];
            match p.reference {
                ReferenceUpdate::EventCopy => o.reference = input[origin],
                ReferenceUpdate::EventIncrement => {
                    let moved = evenum as f32 * o.threshold;
                    o.reference = if on {
                        o.reference + moved
                    } else {
                        o.reference - moved
                    };
                }
                ReferenceUpdate::Frame => {}
            }
            o.threshold *= up;
        } else {
            state[origin].threshold *= down;
        }
        if p.reference == ReferenceUpdate::Frame {
            for y in 0..rows {
                for x in x0..x0 + b {
                    state[y * w + x].reference = input[y * w + x];
                }
            }
        }
    }
}

fn check_size(what: &'static str, width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 || width > usize::from(u16::MAX) || height > usize::from(u16::MAX)
    {
        return Err(Error::param(
            what,
            format!("must be between 1x1 and 65535x65535, got {width}x{height}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    fn run(params: Pix2NvsParams, frames: &[Array2<u8>], dt: u64) -> Vec<Event> {
        let (h, w) = frames[0].dim();
        let mut sim = Pix2Nvs::new(params, w, h, None).unwrap();
        let mut out = Vec::new();
        for (k, f) in frames.iter().enumerate() {
            sim.push(&Frame::Gray(f.view()), k as u64 * dt, &mut out)
                .unwrap();
        }
        out
    }

    fn flat(w: usize, h: usize, v: u8) -> Array2<u8> {
        Array2::from_elem((h, w), v)
    }

    #[test]
    fn static_scene_is_silent() {
        let f = flat(8, 6, 90);
        assert!(run(Pix2NvsParams::default(), &[f.clone(), f.clone(), f], 1000).is_empty());
    }

    #[test]
    fn counts_and_times_follow_print_event() {
        // ln(201/51) = 1.371 -> floor(1.371/0.4) = 3 ON events at k*0.4/1.371 of the interval.
        let p = Pix2NvsParams {
            adaptive: 0.0,
            ..Pix2NvsParams::default()
        };
        let ev = run(p, &[flat(1, 1, 50), flat(1, 1, 200)], 30_000);
        let d = (201.0f64 / 51.0).ln();
        let want: Vec<u64> = (1..=3)
            .map(|k| (30_000.0 * f64::from(k) * 0.4 / d).round() as u64)
            .collect();
        assert_eq!(ev.iter().map(|e| e.t).collect::<Vec<_>>(), want);
        assert!(ev.iter().all(|e| e.p));
        // and OFF going back down, capped by n_max
        let p2 = Pix2NvsParams { n_max: 2, ..p };
        let ev = run(p2, &[flat(1, 1, 200), flat(1, 1, 50)], 30_000);
        assert_eq!(ev.len(), 2);
        assert!(ev.iter().all(|e| !e.p));
    }

    #[test]
    fn increment_mode_keeps_the_remainder() {
        let p = Pix2NvsParams {
            adaptive: 0.0,
            threshold: 0.5,
            reference: ReferenceUpdate::EventIncrement,
            ..Pix2NvsParams::default()
        };
        // ln(2.7 * 51) - ln(51) ~ 0.99 -> 1 event, remainder 0.49 stays; a small further
        // rise of 0.02 then makes a second event in increment mode only.
        let a = flat(1, 1, 50);
        let b = flat(1, 1, 137);
        let c = flat(1, 1, 140);
        assert_eq!(run(p, &[a.clone(), b.clone(), c.clone()], 10).len(), 2);
        let copy = Pix2NvsParams {
            reference: ReferenceUpdate::EventCopy,
            ..p
        };
        assert_eq!(run(copy, &[a, b, c], 10).len(), 1);
    }

    #[test]
    fn inhibition_keeps_one_pixel_per_block_and_pooling_one_per_output() {
        let mut b = flat(4, 4, 50);
        b[[0, 0]] = 120;
        b[[1, 1]] = 250; // strongest in the top-left 2x2 block
        b[[3, 3]] = 200;
        let p = Pix2NvsParams {
            block_size: 2,
            n_max: 1,
            ..Pix2NvsParams::default()
        };
        let ev = run(p, &[flat(4, 4, 50), b.clone()], 100);
        let mut xy: Vec<(u16, u16)> = ev.iter().map(|e| (e.x, e.y)).collect();
        xy.sort_unstable();
        assert_eq!(xy, vec![(1, 1), (3, 3)]);

        let p1 = Pix2NvsParams {
            n_max: 1,
            ..Pix2NvsParams::default()
        };
        let mut sim = Pix2Nvs::new(p1, 4, 4, Some((2, 2, Pooling::Strongest))).unwrap();
        let mut out = Vec::new();
        sim.push(&Frame::Gray(flat(4, 4, 50).view()), 0, &mut out)
            .unwrap();
        sim.push(&Frame::Gray(b.view()), 100, &mut out).unwrap();
        let mut xy: Vec<(u16, u16)> = out.iter().map(|e| (e.x, e.y)).collect();
        xy.sort_unstable();
        assert_eq!(xy, vec![(0, 0), (1, 1)]);
        let mut all = Pix2Nvs::new(p1, 4, 4, Some((2, 2, Pooling::All))).unwrap();
        let mut out = Vec::new();
        all.push(&Frame::Gray(flat(4, 4, 50).view()), 0, &mut out)
            .unwrap();
        all.push(&Frame::Gray(b.view()), 100, &mut out).unwrap();
        assert_eq!(out.len(), 3);
    }

    #[test]
    fn adaptive_threshold_rises_after_events() {
        // Same step twice: with a large adaptive coefficient the second step is below the
        // raised threshold.
        let p = Pix2NvsParams {
            adaptive: 0.5,
            threshold: 0.3,
            n_max: 1,
            reference: ReferenceUpdate::EventCopy,
            ..Pix2NvsParams::default()
        };
        let steps = [flat(1, 1, 50), flat(1, 1, 75), flat(1, 1, 112)];
        assert_eq!(run(p, &steps, 10).len(), 1);
        // A ceiling on the threshold lets the second step through again.
        let capped = Pix2NvsParams {
            threshold_max: 0.35,
            ..p
        };
        assert_eq!(run(capped, &steps, 10).len(), 2);
        let bad = Pix2NvsParams {
            threshold_min: 0.5,
            ..p
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn compat_reads_luma_two_bytes_late_and_converts_like_x86() {
        // One row of 4 pixels (12 bytes, no padding): pixel x's luma takes the red of x and
        // the blue and green of x + 1; the last takes pixel 0 of the row above, here past
        // the end of the data (0).
        let mut img = ndarray::Array3::<u8>::zeros((1, 4, 3));
        for x in 0..4 {
            img[[0, x, 0]] = 10 + x as u8; // B
            img[[0, x, 1]] = 20 + x as u8; // G
            img[[0, x, 2]] = 30 + x as u8; // R
        }
        let mut out = vec![0.0f32; 4];
        compat_luma_row(&Frame::Bgr(img.view()), 0, &mut out);
        for (x, &got) in out.iter().take(3).enumerate() {
            let (r, b, g) = (30.0 + x as f64, 11.0 + x as f64, 21.0 + x as f64);
            let y = (0.299 * g + 0.587 * b + 0.114 * r) as f32;
            assert_eq!(got.to_bits(), y.ln().to_bits(), "pixel {x}");
        }
        assert_eq!(out[3].to_bits(), ((0.114 * 33.0) as f32).ln().to_bits());
        assert_eq!(x86_int(f32::INFINITY), i32::MIN);
        assert_eq!(x86_int(f32::NAN), i32::MIN);
        assert_eq!(x86_int(3.9), 3);
        let odd = Pix2NvsParams {
            compat: true,
            block_size: 2,
            ..Pix2NvsParams::default()
        };
        assert!(Pix2Nvs::new(odd, 3, 2, None).is_err());
        assert!(Pix2Nvs::new(odd, 4, 2, None).is_ok());
    }

    #[test]
    fn rejects_bad_input() {
        let mut sim = Pix2Nvs::new(Pix2NvsParams::default(), 3, 2, None).unwrap();
        let mut out = Vec::new();
        sim.push(&Frame::Gray(flat(3, 2, 1).view()), 10, &mut out)
            .unwrap();
        let e = sim
            .push(&Frame::Gray(flat(3, 2, 1).view()), 10, &mut out)
            .unwrap_err();
        assert!(e.to_string().contains("not after"), "{e}");
        assert!(sim
            .push(&Frame::Gray(flat(2, 2, 1).view()), 20, &mut out)
            .is_err());
        let bad = Pix2NvsParams {
            threshold: f32::NAN,
            ..Pix2NvsParams::default()
        };
        assert!(Pix2Nvs::new(bad, 3, 2, None).is_err());
        assert!(Pix2Nvs::new(Pix2NvsParams::default(), 3, 2, Some((4, 2, Pooling::All))).is_err());
        assert!(Pix2Nvs::new(Pix2NvsParams::default(), 0, 2, None).is_err());
    }
}
