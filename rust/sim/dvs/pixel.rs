//! One emulated pixel: its state ([`Pixel`]), the constants of one interval ([`Step`]), the
//! photoreceptor low-pass, and the step over an interval — threshold crossings, the refractory
//! period and the leak (noise in [`super::noise`]).

use rand_pcg::Pcg64Mcg;

use super::noise::noisy_step;
use crate::events::Event;

/// State of one emulated pixel.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pixel {
    /// Filtered response at the last frame.
    pub(super) lp: f32,
    /// Memorised response.
    pub(super) reference: f32,
    pub(super) th_on: f32,
    pub(super) th_off: f32,
    /// Drift of `d = L - R` from leak, per microsecond.
    pub(super) leak_per_us: f64,
    /// ON rate of a hot pixel per microsecond (0 for normal pixels).
    pub(super) hot_per_us: f64,
    /// End of the current refractory period (µs).
    pub(super) hold_until: f64,
    /// Next shot-noise candidate (µs); infinite when there is no shot noise.
    pub(super) next_shot: f64,
    /// Next hot-pixel event (µs); infinite for normal pixels.
    pub(super) next_hot: f64,
}

/// Per-frame constants shared by all pixels.
#[derive(Debug, Clone)]
pub(super) struct Step<'a> {
    /// The interval's ends, in µs from `origin` (the emulator's first frame): times as `f64`
    /// keep a fraction of a microsecond however late the stream's clock starts.
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) origin: u64,
    /// The interval's ends in integer microseconds: event times are clamped to them (beyond
    /// 2^53 µs of stream an `f64` time may round past the interval).
    pub(super) t0_us: u64,
    pub(super) t1_us: u64,
    /// The most events one row may hold ([`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES)
    /// over the rows): a pixel stops at it, and the frame is refused.
    pub(super) row_cap: usize,
    /// `1 / (t1 - t0)`, per microsecond.
    pub(super) inv_dt: f64,
    pub(super) dt_s: f64,
    /// Low-pass update factor at luma `i / eps_per_luma`, `i = 0..=256 · eps_per_luma`:
    /// exact at integer luma (8-bit gray input, one entry per level), interpolated linearly
    /// between sixteenths of a level for other input (relative error below 1e-4).
    pub(super) eps_table: &'a [f32],
    /// Entries of `eps_table` per unit of luma; 0: no table (computed per pixel).
    pub(super) eps_per_luma: f32,
    pub(super) refractory: f64,
    pub(super) cutoff_hz: f64,
    pub(super) dark_luma: f64,
    /// Highest shot-noise rate per microsecond (thinning bound).
    pub(super) shot_max_per_us: f64,
    pub(super) bright_factor: f64,
    pub(super) max_factor: f64,
}

impl Step<'_> {
    /// The event time of `t` (µs from the origin, within the interval).
    #[inline]
    pub(super) fn event_time(&self, t: f64) -> u64 {
        self.origin
            .saturating_add((t + 0.5) as u64)
            .clamp(self.t0_us, self.t1_us)
    }
}

/// The photoreceptor low-pass update factor over `dt_s` seconds at luma `y`: a first-order
/// filter with cutoff `cutoff_hz · (y + dark_luma) / (255 + dark_luma)` (v2e's intensity
/// scaling has `dark_luma` 20), exact for any step.
#[inline]
pub(super) fn lowpass_eps(cutoff_hz: f64, dark_luma: f64, y: f64, dt_s: f64) -> f64 {
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
pub(super) fn pixel_step(
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
        // The cap also ends a run whose times no longer advance (a gap below the `f64`
        // resolution of a stream hundreds of years long).
        while t <= t1 && row.len() < s.row_cap {
            row.push(Event {
                t: s.event_time(t),
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
