//! Rotor spectrum: the per-pixel event-rate spectrum of a box, summed over its pixels.
//!
//! The edge estimator of the parent module needs each pixel to see both polarities in runs, three
//! same-direction edges per window. Under a rotor of a few pixels a pixel often sees a single
//! polarity per blade pass, or a handful of events per cycle, and never votes. The modulation is
//! still in the events: each pixel's event *rate* beats at the blade pass
//! (`benches/python/drone_bird_spectra.py`). This estimator measures that directly.
//!
//! # The estimator
//!
//! Each pixel has two channels, ON and OFF. Each channel's events are counted in bins of
//! `bin_us` (default 250 µs, a 2 kHz Nyquist frequency) over at most `span_us` from the first
//! event fed (default 100 ms: a 50 ms window and the 50 ms before it). Feeding an event is an
//! index computation and a saturating byte increment.
//!
//! [`RotorSpectrum::estimate`] then, for each channel with at least `min_events` events, takes
//! the mean out of its counts, applies a Hann window over the span covered so far, and evaluates
//! its power at `freqs` logarithmically spaced frequencies over `f_min_hz..=f_max_hz` (a direct
//! DFT over the channel's non-empty bins, from a cosine/sine table built at construction). The
//! channels' power spectra are summed.
//!
//! # The output ([`Spectrum`])
//!
//! - **prominence** of a line: a local maximum of the summed spectrum in the band (the grid
//!   runs two points past each end, so that a spectrum still rising past the band's edge, such
//!   as the low frequencies of a body's edges passing, is a slope and not a line), over the median power between half and twice its frequency, leaving
//!   out its main lobe (±2.5/T for a span T). Uniform noise gives a few (measured in
//!   `docs/identification.md`).
//! - **frequency**: the most prominent line's, refined by a parabola through it and its
//!   neighbours (in log frequency). A pixel whose events come in short bursts once per cycle
//!   has every harmonic about as strong as the fundamental, so the lowest line at least half
//!   as prominent as the most prominent one is taken.
//! - **pixels**: pixels with a channel whose own spectrum peaks within `agree` (relative) of the
//!   frequency.
//! - **detected**: `prominence >= threshold` and `pixels >= min_pixels`.
//!
//! The state is fixed at construction: `2 × area × span_us / bin_us` bytes of counts, 2 bytes of
//! total per channel (two channels per pixel), `8 × (freqs + 4) × span_us / bin_us` bytes of
//! table. `estimate` allocates its own scratch (a few numbers per frequency, per bin and per
//! channel) once per call, never per event.

use super::{feed, validate_band, Region};
use crate::error::{Error, Result};
use crate::events::{Event, EventSource};

/// The largest state one spectrum estimator may hold: counts plus table, in bytes (256 MiB).
pub const MAX_STATE_BYTES: usize = 1 << 28;

/// The default detection threshold on [`Spectrum::prominence`] (chosen on noise seeds no test
/// uses: `benches/python/rotor_noise.py`, `docs/identification.md`).
pub const DEFAULT_PROMINENCE: f64 = 8.0;

/// Grid points evaluated beyond each end of the band.
const EDGE: usize = 2;

/// Parameters of the spectrum estimator. [`SpectrumConfig::default`] gives the documented ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectrumConfig {
    /// Width of a count bin, µs (default 250).
    pub bin_us: u32,
    /// Longest stretch of time followed from the first event, µs (default 100 000); later
    /// events are counted as beyond and ignored.
    pub span_us: u64,
    /// Lowest frequency searched, Hz (default 50).
    pub f_min_hz: f64,
    /// Highest frequency searched, Hz (default 1000; at most the Nyquist frequency of `bin_us`).
    pub f_max_hz: f64,
    /// Number of logarithmically spaced frequencies (default 256: 1.2 % apart over 50–1000 Hz).
    pub freqs: usize,
    /// Fewest events for a channel to count (default 3).
    pub min_events: u32,
    /// Largest relative distance of a channel's own peak to the frequency for its pixel to agree
    /// (default 0.03).
    pub agree: f64,
    /// Detection threshold on the prominence (default [`DEFAULT_PROMINENCE`]).
    pub threshold: f64,
    /// Fewest agreeing pixels for a detection (default 2).
    pub min_pixels: u32,
}

impl Default for SpectrumConfig {
    fn default() -> Self {
        Self {
            bin_us: 250,
            span_us: 100_000,
            f_min_hz: 50.0,
            f_max_hz: 1000.0,
            freqs: 256,
            min_events: 3,
            agree: 0.03,
            threshold: DEFAULT_PROMINENCE,
            min_pixels: 2,
        }
    }
}

impl SpectrumConfig {
    /// Number of count bins (`span_us / bin_us`, at least 1).
    pub fn bins(&self) -> usize {
        (self.span_us / u64::from(self.bin_us.max(1))).max(1) as usize
    }

    /// Check every parameter.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] naming the parameter when `bin_us` is 0, `span_us` holds fewer
    /// than 8 bins or more than 65 536, a frequency is not finite and positive, `f_min_hz >=
    /// f_max_hz`, `f_max_hz` is above the Nyquist frequency `5e5 / bin_us`, `freqs` is outside
    /// `3..=4096`, `min_events` is 0, or `agree` is outside `[0, 1]` or `threshold` negative or not
    /// finite.
    pub fn validate(&self) -> Result<()> {
        if self.bin_us == 0 {
            return Err(Error::param("bin_us", "must be > 0"));
        }
        let bins = self.span_us / u64::from(self.bin_us);
        if !(8..=65_536).contains(&bins) {
            return Err(Error::param(
                "span_us",
                format!(
                    "must hold 8..=65536 bins of {} µs, got {} µs",
                    self.bin_us, self.span_us
                ),
            ));
        }
        validate_band(self.f_min_hz, self.f_max_hz)?;
        let nyquist = 5e5 / f64::from(self.bin_us);
        if self.f_max_hz > nyquist {
            return Err(Error::param(
                "f_max_hz",
                format!(
                    "must be <= {nyquist} (the Nyquist frequency of {} µs bins), got {}",
                    self.bin_us, self.f_max_hz
                ),
            ));
        }
        if !(3..=4096).contains(&self.freqs) {
            return Err(Error::param(
                "freqs",
                format!("must be in 3..=4096, got {}", self.freqs),
            ));
        }
        if self.min_events == 0 {
            return Err(Error::param("min_events", "must be >= 1"));
        }
        if !self.agree.is_finite() || !(0.0..=1.0).contains(&self.agree) {
            return Err(Error::param(
                "agree",
                format!("must be in [0, 1], got {}", self.agree),
            ));
        }
        if !self.threshold.is_finite() || self.threshold < 0.0 {
            return Err(Error::param(
                "threshold",
                format!("must be finite and >= 0, got {}", self.threshold),
            ));
        }
        Ok(())
    }
}

/// The spectrum estimate for a box.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Spectrum {
    /// The peak's frequency, Hz (0 when no channel counted).
    pub frequency_hz: f64,
    /// The peak's power over the band's median power (0 when no channel counted).
    pub prominence: f64,
    /// Pixels with a channel whose own peak agrees with `frequency_hz`.
    pub pixels: u32,
    /// Channels (pixel and polarity) with at least `min_events` events.
    pub channels: u32,
    /// Events in the counted channels.
    pub events: u64,
    /// Whether the peak passes the detection rule.
    pub detected: bool,
}

/// Counters of what the estimator was fed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SpectrumStats {
    /// Events counted.
    pub events: u64,
    /// Events outside the box.
    pub outside: u64,
    /// Events earlier than the latest one seen.
    pub late: u64,
    /// Events later than `span_us` after the first one.
    pub beyond: u64,
}

/// The spectrum estimator over one box: fixed state, sized at construction.
#[derive(Debug, Clone)]
pub struct RotorSpectrum {
    config: SpectrumConfig,
    region: Region,
    bins: usize,
    /// `counts[channel * bins + bin]`, channel = `2 × pixel + polarity`.
    counts: Vec<u8>,
    /// Events per channel (saturating).
    per_channel: Vec<u16>,
    /// `table[bin * freqs + k]` = (cos, sin) of `2π f_k (bin + 0.5) bin_us`.
    cos: Vec<f32>,
    sin: Vec<f32>,
    /// The frequency grid, Hz.
    grid: Vec<f64>,
    origin: Option<u64>,
    last_t: u64,
    stats: SpectrumStats,
}

impl RotorSpectrum {
    /// An estimator over `region`, every table and count allocated here.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] for an invalid configuration ([`SpectrumConfig::validate`]), an
    /// invalid region ([`Region::validate`], `box`) or a state above [`MAX_STATE_BYTES`] (`box`).
    pub fn new(config: SpectrumConfig, region: Region) -> Result<Self> {
        config.validate()?;
        let region = region.validate()?;
        let bins = config.bins();
        let channels = 2 * region.area();
        let bytes = channels * (bins + 2) + 8 * (config.freqs + 2 * EDGE) * bins;
        if bytes > MAX_STATE_BYTES {
            return Err(Error::param(
                "box",
                format!(
                    "{}x{} over {bins} bins needs {bytes} bytes, above the cap of {MAX_STATE_BYTES}",
                    region.width, region.height
                ),
            ));
        }
        // The band, and EDGE points beyond each end so that a line at the band's edge is still
        // a local maximum.
        let k = config.freqs + 2 * EDGE;
        let ratio = (config.f_max_hz / config.f_min_hz).ln() / (config.freqs - 1) as f64;
        let grid: Vec<f64> = (0..k)
            .map(|i| config.f_min_hz * (ratio * (i as f64 - EDGE as f64)).exp())
            .collect();
        let mut cos = vec![0.0f32; k * bins];
        let mut sin = vec![0.0f32; k * bins];
        // Each frequency's phasor turned bin by bin (in f64: the drift over 65,536 bins stays
        // far below f32's resolution), instead of a sine and a cosine per entry.
        let dt = f64::from(config.bin_us) * 1e-6;
        for (i, f) in grid.iter().enumerate() {
            let (sin_step, cos_step) = (std::f64::consts::TAU * f * dt).sin_cos();
            let (mut c, mut s) = (1.0f64, 0.0f64);
            for j in 0..bins {
                cos[j * k + i] = c as f32;
                sin[j * k + i] = s as f32;
                (c, s) = (c * cos_step - s * sin_step, s * cos_step + c * sin_step);
            }
        }
        Ok(Self {
            config,
            region,
            bins,
            counts: vec![0; channels * bins],
            per_channel: vec![0; channels],
            cos,
            sin,
            grid,
            origin: None,
            last_t: 0,
            stats: SpectrumStats::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SpectrumConfig {
        &self.config
    }

    /// The box followed.
    pub fn region(&self) -> Region {
        self.region
    }

    /// What the estimator was fed since construction or the last [`clear`](Self::clear).
    pub fn stats(&self) -> SpectrumStats {
        self.stats
    }

    /// The frequency grid, Hz: the band's `freqs` points and two more beyond each end.
    pub fn grid(&self) -> &[f64] {
        &self.grid
    }

    /// Bytes of state held (fixed at construction).
    pub fn state_bytes(&self) -> usize {
        self.counts.capacity()
            + 2 * self.per_channel.capacity()
            + 4 * (self.cos.capacity() + self.sin.capacity())
            + 8 * self.grid.capacity()
    }

    /// Forget every event (the state keeps its size).
    pub fn clear(&mut self) {
        self.counts.fill(0);
        self.per_channel.fill(0);
        self.origin = None;
        self.last_t = 0;
        self.stats = SpectrumStats::default();
    }

    /// Feed one event.
    #[inline]
    pub fn push(&mut self, e: Event) {
        let Some(i) = self.region.index(e.x, e.y) else {
            self.stats.outside += 1;
            return;
        };
        if e.t < self.last_t {
            self.stats.late += 1;
            return;
        }
        let origin = *self.origin.get_or_insert(e.t);
        let bin = (e.t - origin) / u64::from(self.config.bin_us);
        if bin >= self.bins as u64 {
            self.stats.beyond += 1;
            return;
        }
        self.last_t = e.t;
        self.stats.events += 1;
        let channel = 2 * i + usize::from(e.p);
        let c = &mut self.counts[channel * self.bins + bin as usize];
        *c = c.saturating_add(1);
        let n = &mut self.per_channel[channel];
        *n = n.saturating_add(1);
    }

    /// Feed a sequence of events (any layout).
    pub fn extend<S: EventSource + ?Sized>(&mut self, events: &S) {
        feed(events, |e| self.push(e));
    }

    /// Bins covered from the first event to the latest (0 before any event).
    fn covered(&self) -> usize {
        self.origin.map_or(0, |origin| {
            (((self.last_t - origin) / u64::from(self.config.bin_us)) as usize + 1).min(self.bins)
        })
    }

    /// The summed power spectrum over the grid and per-channel peaks: `(power, peaks, channels,
    /// events)`, `peaks[c]` the grid index of channel `c`'s peak (`u16::MAX`: not counted).
    fn spectrum(&self) -> (Vec<f64>, Vec<u16>, u32, u64) {
        let k = self.grid.len();
        let mut total = vec![0.0f64; k];
        let mut peaks = vec![u16::MAX; self.per_channel.len()];
        // Too few bins to transform (none before any event).
        let n = self.covered();
        if n < 8 {
            return (total, peaks, 0, 0);
        }
        let window: Vec<f32> = (0..n)
            .map(|j| {
                (0.5 - 0.5 * (std::f64::consts::TAU * (j as f64 + 0.5) / n as f64).cos()) as f32
            })
            .collect();
        // The window's own transform, to take each channel's mean out in the frequency domain.
        let (mut wre, mut wim) = (vec![0.0f32; k], vec![0.0f32; k]);
        for (j, w) in window.iter().enumerate() {
            let (c, s) = (&self.cos[j * k..(j + 1) * k], &self.sin[j * k..(j + 1) * k]);
            for i in 0..k {
                wre[i] += w * c[i];
                wim[i] += w * s[i];
            }
        }
        let (mut re, mut im) = (vec![0.0f32; k], vec![0.0f32; k]);
        let (mut channels, mut events) = (0u32, 0u64);
        for (ch, &count) in self.per_channel.iter().enumerate() {
            if u32::from(count) < self.config.min_events {
                continue;
            }
            re.fill(0.0);
            im.fill(0.0);
            let row = &self.counts[ch * self.bins..ch * self.bins + n];
            let mut sum = 0.0f32;
            for (j, &c) in row.iter().enumerate() {
                if c == 0 {
                    continue;
                }
                sum += f32::from(c);
                let a = f32::from(c) * window[j];
                let (cs, sn) = (&self.cos[j * k..(j + 1) * k], &self.sin[j * k..(j + 1) * k]);
                for i in 0..k {
                    re[i] += a * cs[i];
                    im[i] += a * sn[i];
                }
            }
            let mean = sum / n as f32;
            let mut best = (0usize, -1.0f64);
            for i in 0..k {
                let r = f64::from(re[i] - mean * wre[i]);
                let m = f64::from(im[i] - mean * wim[i]);
                let p = r * r + m * m;
                total[i] += p;
                if p > best.1 {
                    best = (i, p);
                }
            }
            peaks[ch] = best.0 as u16;
            channels += 1;
            events += u64::from(sum as u32);
        }
        (total, peaks, channels, events)
    }

    /// The summed power spectrum at [`grid`](Self::grid) (for plots and checks).
    pub fn power(&self) -> Vec<f64> {
        self.spectrum().0
    }

    /// The estimate from everything fed so far (costs a DFT over each counted channel's
    /// non-empty bins).
    pub fn estimate(&self) -> Spectrum {
        let (total, peaks, channels, events) = self.spectrum();
        if channels == 0 {
            return Spectrum::default();
        }
        let k = total.len();
        let step =
            (self.config.f_max_hz / self.config.f_min_hz).ln() / (self.config.freqs - 1) as f64;
        // The Hann window's main lobe is ±2/T wide; the baseline of a peak leaves it out.
        let span_s = self.covered() as f64 * f64::from(self.config.bin_us) * 1e-6;
        let lobe_hz = 2.5 / span_s;
        let mut scratch = Vec::with_capacity(k);
        let mut prominence_at = |i: usize| -> f64 {
            let f = self.grid[i];
            scratch.clear();
            scratch.extend(
                (0..k)
                    .filter(|&j| {
                        let g = self.grid[j];
                        g >= 0.5 * f && g <= 2.0 * f && (g - f).abs() >= lobe_hz
                    })
                    .map(|j| total[j]),
            );
            if scratch.len() < 8 {
                return 0.0;
            }
            scratch.sort_by(f64::total_cmp);
            let m = scratch.len();
            let median = 0.5 * (scratch[(m - 1) / 2] + scratch[m / 2]);
            if median > 0.0 {
                total[i] / median
            } else {
                0.0
            }
        };
        // Lines only: local maxima inside the band (a maximum at its edge is a slope, as the
        // low frequencies of a body's edges passing), each against its own neighbourhood.
        let maxima: Vec<(usize, f64)> = (EDGE..k - EDGE)
            .filter(|&i| total[i] > total[i - 1] && total[i] >= total[i + 1])
            .map(|i| (i, prominence_at(i)))
            .collect();
        let Some(&(_, best)) = maxima.iter().max_by(|a, b| a.1.total_cmp(&b.1)) else {
            return Spectrum {
                channels,
                events,
                ..Spectrum::default()
            };
        };
        // Harmonics: the lowest line at least half as prominent as the most prominent.
        let (peak, prominence) = maxima
            .iter()
            .copied()
            .find(|&(_, p)| p >= 0.5 * best && p > 0.0)
            .unwrap_or((0, 0.0));
        if prominence <= 0.0 {
            return Spectrum {
                channels,
                events,
                ..Spectrum::default()
            };
        }
        let mut offset = 0.0;
        {
            let (a, b, c) = (
                total[peak - 1].max(1e-30).ln(),
                total[peak].max(1e-30).ln(),
                total[peak + 1].max(1e-30).ln(),
            );
            let d = a - 2.0 * b + c;
            if d < 0.0 {
                offset = (0.5 * (a - c) / d).clamp(-0.5, 0.5);
            }
        }
        let frequency_hz =
            self.config.f_min_hz * ((peak as f64 - EDGE as f64 + offset) * step).exp();
        let lo = frequency_hz * (1.0 - self.config.agree);
        let hi = frequency_hz * (1.0 + self.config.agree);
        let agrees = |p: u16| p != u16::MAX && (lo..=hi).contains(&self.grid[usize::from(p)]);
        let pixels = peaks
            .chunks_exact(2)
            .filter(|pair| agrees(pair[0]) || agrees(pair[1]))
            .count() as u32;
        Spectrum {
            frequency_hz,
            prominence,
            pixels,
            channels,
            events,
            detected: prominence >= self.config.threshold && pixels >= self.config.min_pixels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{assert_rejects, events_of, noise};
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// `pixels` pixels of a row, each giving `per_cycle` events of one polarity at `f` Hz (own
    /// phase, timing jittered by `jitter` of the period), over `duration_us`.
    fn periodic(
        f: f64,
        pixels: u16,
        per_cycle: usize,
        jitter: f64,
        duration_us: u64,
        seed: u64,
    ) -> Vec<Event> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let period = 1e6 / f;
        let mut out = Vec::new();
        for x in 0..pixels {
            let phase = rng.random::<f64>() * period;
            let mut t0 = phase;
            while t0 < duration_us as f64 {
                for r in 0..per_cycle {
                    let t =
                        t0 + r as f64 * 30.0 + (rng.random::<f64>() - 0.5) * 2.0 * jitter * period;
                    if (0.0..duration_us as f64).contains(&t) {
                        out.push(Event {
                            t: t as u64,
                            x,
                            y: 0,
                            p: x % 2 == 0,
                        });
                    }
                }
                t0 += period;
            }
        }
        out.sort_by_key(|e| e.t);
        out
    }

    fn run(events: &[Event], w: u16, h: u16) -> Spectrum {
        let mut s = RotorSpectrum::new(SpectrumConfig::default(), Region::new(0, 0, w, h).unwrap())
            .unwrap();
        s.extend(events);
        s.estimate()
    }

    #[test]
    fn finds_a_periodic_rate_within_two_percent() {
        for (i, f) in [50.0, 73.0, 120.0, 240.0, 333.0, 520.0, 777.0, 1000.0]
            .into_iter()
            .enumerate()
        {
            for per_cycle in [1, 2] {
                let s = run(
                    &periodic(f, 6, per_cycle, 0.02, 100_000, 1000 + i as u64),
                    6,
                    1,
                );
                assert!(
                    (s.frequency_hz - f).abs() <= 0.02 * f,
                    "{f} Hz, {per_cycle}/cycle: {s:?}"
                );
                assert!(s.pixels >= 5, "{f} Hz: {s:?}");
                // Below about 100 Hz a 100 ms window's harmonics cover the band, so the median
                // is on the comb and the prominence is low (docs/identification.md).
                assert!(s.detected || f < 100.0, "{f} Hz: {s:?}");
            }
        }
    }

    #[test]
    fn uniform_noise_raises_no_peak() {
        // Seeds 1000.. (the threshold was chosen on seeds 0..199 by benches/python/rotor_noise.py).
        for seed in 1000..1010 {
            for rate in [1e3, 1e4, 1e5, 1e6] {
                let s = run(&noise(rate, 16, 100_000, seed), 16, 16);
                assert!(!s.detected, "rate {rate}, seed {seed}: {s:?}");
            }
        }
    }

    #[test]
    fn events_outside_late_and_beyond_are_counted_and_ignored() {
        let mut s = RotorSpectrum::new(
            SpectrumConfig::default(),
            Region::new(10, 20, 4, 4).unwrap(),
        )
        .unwrap();
        let e = |t, x, y| Event { t, x, y, p: true };
        s.push(e(5, 9, 20));
        s.push(e(100, 10, 20));
        s.push(e(50, 10, 20));
        s.push(e(100 + 100_000, 10, 20));
        assert_eq!(
            s.stats(),
            SpectrumStats {
                events: 1,
                outside: 1,
                late: 1,
                beyond: 1
            }
        );
        assert_eq!(s.estimate(), Spectrum::default());
        s.clear();
        assert_eq!(s.stats(), SpectrumStats::default());
    }

    #[test]
    fn bad_parameters_are_typed_errors() {
        let ok = SpectrumConfig::default();
        let region = Region::new(0, 0, 4, 4).unwrap();
        for (config, name) in [
            (SpectrumConfig { bin_us: 0, ..ok }, "bin_us"),
            (
                SpectrumConfig {
                    span_us: 1000,
                    ..ok
                },
                "span_us",
            ),
            (
                SpectrumConfig {
                    f_min_hz: f64::NAN,
                    ..ok
                },
                "f_min_hz",
            ),
            (
                SpectrumConfig {
                    f_min_hz: 2000.0,
                    ..ok
                },
                "f_min_hz",
            ),
            (
                SpectrumConfig {
                    f_max_hz: 2001.0,
                    ..ok
                },
                "f_max_hz",
            ),
            (SpectrumConfig { freqs: 2, ..ok }, "freqs"),
            (
                SpectrumConfig {
                    min_events: 0,
                    ..ok
                },
                "min_events",
            ),
            (SpectrumConfig { agree: 2.0, ..ok }, "agree"),
            (
                SpectrumConfig {
                    threshold: -1.0,
                    ..ok
                },
                "threshold",
            ),
        ] {
            assert_rejects(config, RotorSpectrum::new(config, region), name);
        }
        assert!(RotorSpectrum::new(ok, Region::new(0, 0, 2048, 2048).unwrap()).is_err());
    }

    #[test]
    fn state_is_fixed_at_construction() {
        let mut s = RotorSpectrum::new(
            SpectrumConfig::default(),
            Region::new(0, 0, 16, 16).unwrap(),
        )
        .unwrap();
        let before = s.state_bytes();
        s.extend(noise(1e6, 20, 100_000, 3).as_slice());
        let _ = s.estimate();
        assert_eq!(s.state_bytes(), before);
    }

    mod properties {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(48))]

            /// Any sequence never panics, keeps its state size and accounts for every event.
            #[test]
            fn never_panics_and_stays_bounded(
                events in proptest::collection::vec((0u64..300_000, 0u16..12, 0u16..12, any::<bool>()), 0..400),
                sorted in any::<bool>(),
                x0 in 0u16..6, y0 in 0u16..6, w in 1u16..8, h in 1u16..8,
            ) {
                let events = events_of(events, sorted);
                let mut s = RotorSpectrum::new(SpectrumConfig::default(), Region::new(x0, y0, w, h).unwrap()).unwrap();
                let bytes = s.state_bytes();
                s.extend(events.as_slice());
                let est = s.estimate();
                prop_assert_eq!(s.state_bytes(), bytes);
                let st = s.stats();
                prop_assert_eq!(st.events + st.outside + st.late + st.beyond, events.len() as u64);
                prop_assert!(est.prominence >= 0.0 && est.prominence.is_finite());
                prop_assert!(est.pixels as usize <= s.region().area());
                prop_assert!(est.frequency_hz == 0.0 || (49.0..=1010.0).contains(&est.frequency_hz));
            }

            /// One pixel at any frequency in the band, one event per cycle, comes back within 2 %.
            #[test]
            fn an_exact_rate_comes_back(f in 50.0f64..1000.0) {
                let period = 1e6 / f;
                let events: Vec<Event> = (0..2100u32)
                    .map(|k| 300.0 + f64::from(k) * period)
                    .take_while(|t| *t < 100_000.0)
                    .map(|t| Event { t: t as u64, x: 0, y: 0, p: true })
                    .collect();
                let mut s = RotorSpectrum::new(SpectrumConfig { min_pixels: 1, ..SpectrumConfig::default() }, Region::new(0, 0, 1, 1).unwrap()).unwrap();
                s.extend(events.as_slice());
                let est = s.estimate();
                prop_assert!((est.frequency_hz - f).abs() <= 0.02 * f, "{} {:?}", f, est);
            }
        }
    }
}
