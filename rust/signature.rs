//! Rotor signature: a periodicity estimate, event by event, over the pixels of a box.
//!
//! A multirotor's propellers modulate the light of the pixels they cover at the blade-pass
//! frequency (about 200–520 Hz for two blades, harmonics above), far above a bird's wing beat
//! (2–15 Hz); an event camera resolves it (SPEC §3, "Detection, then identification"). This module
//! measures it from the raw events of a box, with a fixed amount of state sized at construction,
//! no allocation per event and a few comparisons per event.
//!
//! # The estimator
//!
//! In the spirit of `FrequencyCam` (Pfrommer, 2022), each pixel's brightness is followed through
//! the sign of its events, and its period is the time between two brightness crossings of the
//! same direction. Where `FrequencyCam` reconstructs the brightness with an IIR filter and looks
//! for zero crossings, this estimator takes the crossings directly from the polarity runs: a
//! pixel under a flickering light (or a passing blade) gives a run of ON events then a run of
//! OFF events every cycle, so a *rising edge* is the first ON event after an OFF one and a
//! *falling edge* the first OFF event after an ON one. Per pixel it keeps the time of its last
//! rising and last falling edge and the last interval between edges of each kind (32 bytes).
//!
//! An interval between two edges of the same kind is a period candidate. It **votes** when it
//! lies in the band (`1/f_max_hz ..= 1/f_min_hz`, widened by `consistency` on both sides so that
//! a jittered period at the band's edge still votes, in the edge bin) and agrees with the pixel's
//! previous interval of the same kind within `consistency` (relative): a periodic pixel repeats
//! its period, a noisy one rarely does. A vote adds its frequency `1/interval` to a histogram of
//! `bins` logarithmic bins over the band (`sum` and `count` per bin).
//!
//! # The output ([`Signature`])
//!
//! - **frequency**: the mean frequency of the votes in the best window of three adjacent bins
//!   (the window with the most votes); the mean, not the bin centre, so the answer is not
//!   quantised to the bins.
//! - **strength**: the votes in that window divided by every interval measured in the box (in
//!   the band or not, consistent or not), in `[0, 1]`. A pixel flickering at one frequency gives
//!   about 1; uniform noise spreads its few consistent intervals over the band and gives a small
//!   value (measured in `docs/identification.md`).
//! - **pixels**: how many pixels agree: their latest voting interval is within `agree`
//!   (relative) of the frequency.
//! - **detected**: `strength >= threshold` and `pixels >= min_pixels`. The default threshold
//!   ([`DEFAULT_THRESHOLD`]) was chosen on noise seeds that no test uses (the command is in
//!   `docs/identification.md`).
//!
//! State accumulates from construction or the last [`RotorSignature::clear`]: feed it the events
//! of one detection's box over one window (or a longer stretch), read [`RotorSignature::estimate`],
//! then clear it.
//!
//! Events outside the box are counted and ignored; an event earlier than the latest one seen is
//! counted as late and ignored (the estimator never panics, whatever the sequence).
//!
//! Beside the estimate, the estimator can count its box's events over time
//! ([`RotorSignature::count_rate`]; the module [`rate`]).

use crate::error::{Error, Result};
use crate::events::{Event, EventSource};

pub mod rate;
pub mod region;
pub mod spectrum;

use rate::RateBins;
pub use rate::{rate_swing, MAX_RATE_BINS};
pub use region::{Region, MAX_PIXELS};

/// The default detection threshold on [`Signature::strength`] (see the module's documentation
/// and `docs/identification.md` for how it was chosen).
pub const DEFAULT_THRESHOLD: f64 = 0.1;

/// Parameters of the estimator. [`RotorConfig::default`] gives the documented defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotorConfig {
    /// Lowest frequency searched, in Hz (default 50).
    pub f_min_hz: f64,
    /// Highest frequency searched, in Hz (default 1000).
    pub f_max_hz: f64,
    /// Number of logarithmic bins over the band (default 64: 4.8 % per bin over 50–1000 Hz).
    pub bins: usize,
    /// Largest relative difference between a pixel's two successive intervals of the same kind
    /// for the second to vote (default 0.1).
    pub consistency: f64,
    /// Largest relative difference between a pixel's latest voting frequency and the box's for
    /// the pixel to agree (default 0.05).
    pub agree: f64,
    /// Detection threshold on the strength (default [`DEFAULT_THRESHOLD`]).
    pub threshold: f64,
    /// Fewest agreeing pixels for a detection (default 3).
    pub min_pixels: u32,
}

impl Default for RotorConfig {
    fn default() -> Self {
        Self {
            f_min_hz: 50.0,
            f_max_hz: 1000.0,
            bins: 64,
            consistency: 0.1,
            agree: 0.05,
            threshold: DEFAULT_THRESHOLD,
            min_pixels: 3,
        }
    }
}

impl RotorConfig {
    /// Check every parameter.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] naming the parameter when a frequency is not finite or not
    /// positive, `f_min_hz >= f_max_hz`, `f_max_hz` is above 500 kHz (a period under 2 µs, below
    /// the timestamps' resolution), `bins` is outside `3..=4096`, or `consistency`, `agree` or
    /// `threshold` is not finite or outside `[0, 1]`.
    pub fn validate(&self) -> Result<()> {
        validate_band(self.f_min_hz, self.f_max_hz)?;
        if self.f_max_hz > 500_000.0 {
            return Err(Error::param(
                "f_max_hz",
                format!("must be <= 500000 (a 2 µs period), got {}", self.f_max_hz),
            ));
        }
        if !(3..=4096).contains(&self.bins) {
            return Err(Error::param(
                "bins",
                format!("must be in 3..=4096, got {}", self.bins),
            ));
        }
        for (name, v) in [
            ("consistency", self.consistency),
            ("agree", self.agree),
            ("threshold", self.threshold),
        ] {
            if !v.is_finite() || !(0.0..=1.0).contains(&v) {
                return Err(Error::param(name, format!("must be in [0, 1], got {v}")));
            }
        }
        Ok(())
    }
}

/// Check a frequency band (both estimators' `f_min_hz`, `f_max_hz`): both finite and positive,
/// the lower below the upper.
///
/// # Errors
///
/// [`Error::InvalidParameter`] naming the frequency at fault.
fn validate_band(f_min_hz: f64, f_max_hz: f64) -> Result<()> {
    for (name, v) in [("f_min_hz", f_min_hz), ("f_max_hz", f_max_hz)] {
        if !v.is_finite() || v <= 0.0 {
            return Err(Error::param(
                name,
                format!("must be finite and > 0, got {v}"),
            ));
        }
    }
    if f_min_hz >= f_max_hz {
        return Err(Error::param(
            "f_min_hz",
            format!("must be below f_max_hz, got {f_min_hz} >= {f_max_hz}"),
        ));
    }
    Ok(())
}

/// Feed every event of `events` (any layout) to `push`, in order: both estimators' `extend`.
fn feed<S: EventSource + ?Sized>(events: &S, mut push: impl FnMut(Event)) {
    for i in 0..events.len() {
        push(events.get(i));
    }
}

/// The estimate for a box.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Signature {
    /// The frequency of the strongest peak, in Hz (0 when nothing voted).
    pub frequency_hz: f64,
    /// Votes in the peak's window over every interval measured, in `[0, 1]`.
    pub strength: f64,
    /// Pixels whose latest voting frequency agrees with `frequency_hz`.
    pub pixels: u32,
    /// Votes in the peak's window.
    pub peak_votes: u64,
    /// Votes in the whole band.
    pub votes: u64,
    /// Intervals measured (every pair of same-kind edges of a pixel).
    pub intervals: u64,
    /// Whether the peak passes the detection rule (`strength >= threshold`, `pixels >=
    /// min_pixels`).
    pub detected: bool,
}

/// Counters of what the estimator was fed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RotorStats {
    /// Events inside the box, in time order (those that updated a pixel).
    pub events: u64,
    /// Events outside the box (ignored).
    pub outside: u64,
    /// Events earlier than the latest seen (ignored).
    pub late: u64,
    /// ON events inside the box, late ones included: of the `events + late` events inside the
    /// box, whatever their order, this many are ON (the counts identification's features read
    /// beside the estimate, so that nobody selects the box's events a second time).
    pub on: u64,
}

/// Marks "no edge yet" in a pixel's edge times.
const NO_EDGE: u64 = u64::MAX;

/// One pixel's state: 32 bytes.
#[derive(Debug, Clone, Copy)]
struct Pixel {
    /// Time of the last rising (OFF→ON) and falling (ON→OFF) edge, or [`NO_EDGE`].
    edge_t: [u64; 2],
    /// The last in-band interval between edges of each kind, µs (0: none).
    interval: [f32; 2],
    /// The pixel's latest voting frequency, Hz (0: none).
    frequency: f32,
    /// Polarity of the last event: 0 none, 1 OFF, 2 ON.
    polarity: u8,
}

impl Pixel {
    const EMPTY: Self = Self {
        edge_t: [NO_EDGE; 2],
        interval: [0.0; 2],
        frequency: 0.0,
        polarity: 0,
    };
}

/// A rotor-signature estimator over one box: fixed state, sized at construction.
#[derive(Debug, Clone)]
pub struct RotorSignature {
    config: RotorConfig,
    region: Region,
    pixels: Vec<Pixel>,
    count: Vec<u32>,
    sum: Vec<f64>,
    /// Band limits as periods in µs, widened by `consistency`.
    min_period: f32,
    max_period: f32,
    ln_f_min: f32,
    inv_bin_width: f32,
    intervals: u64,
    votes: u64,
    last_t: u64,
    stats: RotorStats,
    /// The box's in-order events per time bin ([`count_rate`](Self::count_rate); none
    /// counted until then).
    rate: RateBins,
}

impl RotorSignature {
    /// An estimator over `region`, all state allocated here (`32 × area` bytes for the pixels,
    /// `12 × bins` for the histogram).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] when the configuration is invalid ([`RotorConfig::validate`]),
    /// or `box` when the region is ([`Region::validate`]: a struct literal may be empty or
    /// above [`MAX_PIXELS`]).
    pub fn new(config: RotorConfig, region: Region) -> Result<Self> {
        config.validate()?;
        let region = region.validate()?;
        let ln_min = config.f_min_hz.ln();
        let ln_max = config.f_max_hz.ln();
        Ok(Self {
            config,
            region,
            pixels: vec![Pixel::EMPTY; region.area()],
            count: vec![0; config.bins],
            sum: vec![0.0; config.bins],
            min_period: (1e6 / (config.f_max_hz * (1.0 + config.consistency))) as f32,
            max_period: (1e6 * (1.0 + config.consistency) / config.f_min_hz) as f32,
            ln_f_min: ln_min as f32,
            inv_bin_width: (config.bins as f64 / (ln_max - ln_min)) as f32,
            intervals: 0,
            votes: 0,
            last_t: 0,
            stats: RotorStats::default(),
            rate: RateBins::off(),
        })
    }

    /// Count the box's events from now on in `bins` bins of `bin_us` µs from `start_us`: bin
    /// `k` holds the in-order events inside the box with `start_us + k·bin_us <= t < start_us +
    /// (k + 1)·bin_us` (late events, and events before or after the bins, are not counted).
    /// The counts start at zero; [`clear`](Self::clear) zeroes them and keeps the bins.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] when `bin_us` is 0 or `bins` is outside
    /// `1..=`[`MAX_RATE_BINS`].
    pub fn count_rate(&mut self, start_us: u64, bin_us: u64, bins: usize) -> Result<()> {
        self.rate = RateBins::new(start_us, bin_us, bins, self.stats.events)?;
        Ok(())
    }

    /// [`rate_swing`] of the box's rate bins.
    pub fn rate_swing(&self) -> f64 {
        rate_swing(&self.rate())
    }

    /// The box's events per rate bin since [`count_rate`](Self::count_rate) (empty when the
    /// rate is not counted).
    pub fn rate(&self) -> Vec<u32> {
        self.rate.counts(self.stats.events)
    }

    /// The configuration.
    pub fn config(&self) -> &RotorConfig {
        &self.config
    }

    /// The box followed.
    pub fn region(&self) -> Region {
        self.region
    }

    /// What the estimator was fed since construction or the last [`clear`](Self::clear).
    pub fn stats(&self) -> RotorStats {
        self.stats
    }

    /// Bytes of state held (fixed at construction).
    pub fn state_bytes(&self) -> usize {
        self.pixels.capacity() * std::mem::size_of::<Pixel>()
            + (self.count.capacity() + self.rate.capacity()) * std::mem::size_of::<u32>()
            + self.sum.capacity() * std::mem::size_of::<f64>()
    }

    /// Forget every event (the state keeps its size).
    pub fn clear(&mut self) {
        self.pixels.fill(Pixel::EMPTY);
        self.count.fill(0);
        self.sum.fill(0.0);
        self.intervals = 0;
        self.votes = 0;
        self.last_t = 0;
        self.stats = RotorStats::default();
        self.rate.clear();
    }

    /// Feed one event.
    #[inline]
    pub fn push(&mut self, e: Event) {
        let Some(i) = self.region.index(e.x, e.y) else {
            self.stats.outside += 1;
            return;
        };
        self.stats.on += u64::from(e.p);
        if e.t < self.last_t {
            self.stats.late += 1;
            return;
        }
        self.last_t = e.t;
        if self.rate.enters(e.t) {
            self.rate.enter(e.t, self.stats.events);
        }
        self.stats.events += 1;
        let px = &mut self.pixels[i];
        let polarity = 1 + u8::from(e.p);
        let before = px.polarity;
        px.polarity = polarity;
        if before == polarity || before == 0 {
            return;
        }
        // An edge: rising (kind 1) when the run turns ON, falling (kind 0) when it turns OFF.
        let kind = usize::from(e.p);
        let last = px.edge_t[kind];
        px.edge_t[kind] = e.t;
        if last == NO_EDGE {
            return;
        }
        self.intervals += 1;
        let dt = (e.t - last) as f32;
        if dt < self.min_period || dt > self.max_period {
            px.interval[kind] = 0.0;
            return;
        }
        let previous = px.interval[kind];
        px.interval[kind] = dt;
        if previous <= 0.0 || (dt - previous).abs() > self.config.consistency as f32 * previous {
            return;
        }
        let f = 1e6 / dt;
        let bin =
            (((f.ln() - self.ln_f_min) * self.inv_bin_width) as usize).min(self.count.len() - 1);
        self.count[bin] += 1;
        self.sum[bin] += f as f64;
        self.votes += 1;
        px.frequency = f;
    }

    /// Feed a sequence of events (any layout: a slice, packed NumPy records).
    pub fn extend<S: EventSource + ?Sized>(&mut self, events: &S) {
        feed(events, |e| self.push(e));
    }

    /// The estimate from everything fed so far (costs one pass over the box's pixels).
    pub fn estimate(&self) -> Signature {
        let n = self.count.len();
        let window = |i: usize| -> (u64, f64) {
            let lo = i.saturating_sub(1);
            let hi = (i + 1).min(n - 1);
            (lo..=hi).fold((0, 0.0), |(c, s), j| {
                (c + u64::from(self.count[j]), s + self.sum[j])
            })
        };
        let mut best = (0u64, 0.0f64);
        for i in 0..n {
            let w = window(i);
            if w.0 > best.0 {
                best = w;
            }
        }
        let (peak_votes, sum) = best;
        if peak_votes == 0 {
            return Signature {
                intervals: self.intervals,
                votes: self.votes,
                ..Signature::default()
            };
        }
        let frequency_hz = sum / peak_votes as f64;
        let strength = peak_votes as f64 / self.intervals.max(1) as f64;
        let tolerance = self.config.agree * frequency_hz;
        let pixels = self
            .pixels
            .iter()
            .filter(|p| {
                p.frequency > 0.0 && (f64::from(p.frequency) - frequency_hz).abs() <= tolerance
            })
            .count() as u32;
        Signature {
            frequency_hz,
            strength,
            pixels,
            peak_votes,
            votes: self.votes,
            intervals: self.intervals,
            detected: strength >= self.config.threshold && pixels >= self.config.min_pixels,
        }
    }
}

#[cfg(test)]
mod tests;
