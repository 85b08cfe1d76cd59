//! The event rate of a box over time, and how strongly it swings.
//!
//! The rotor estimator ([`super::RotorSignature::count_rate`]) can count its box's in-order
//! events in bins of a fixed width from a start time, in its own pass over the events: one
//! comparison per event inside the box (a bin's count is the number of the box's events since
//! the bin was entered, written when the next bin is entered or the counts are read) and
//! nothing per event outside it, where a second pass would cost a box check per event of the
//! window. Identification reads how strongly that rate swings within a window
//! ([`rate_swing`]; `uavsnn.features.rate_swing`, the `log_rate_swing` feature).

use crate::error::{Error, Result};

/// The most rate bins one estimator may count ([`super::RotorSignature::count_rate`]).
pub const MAX_RATE_BINS: usize = 4096;

/// Add `n` to `bins[at]` (saturating), if there is such a bin.
fn add_saturating(bins: &mut [u32], at: usize, n: u64) {
    if let Some(c) = bins.get_mut(at) {
        *c = c.saturating_add(u32::try_from(n).unwrap_or(u32::MAX));
    }
}

/// How strongly a box's event rate swings beyond shot noise, from its events per time bin
/// (identification's `log_rate_swing` feature; `uavsnn.features.rate_swing`).
///
/// The counts are divided by a straight line fitted to them (least squares, kept above 5 % of
/// their mean), so a steady rise or fall is no swing, and less 1; `v` is the variance of what
/// is left. Poisson counts of mean `m` give `v ≈ 1 / m` by chance alone, so the swing is
/// `sqrt(max(v − 1 / m̄, 0))` with `m̄` the line's mean. 0 with fewer than three bins or no
/// event.
pub fn rate_swing(counts: &[u32]) -> f64 {
    let n = counts.len();
    let total: f64 = counts.iter().map(|&c| f64::from(c)).sum();
    if n < 3 || total <= 0.0 {
        return 0.0;
    }
    let nf = n as f64;
    let mean = total / nf;
    let centre = (nf - 1.0) / 2.0;
    let (mut cross, mut square) = (0.0, 0.0);
    for (k, &c) in counts.iter().enumerate() {
        let u = k as f64 - centre;
        cross += u * f64::from(c);
        square += u * u;
    }
    let slope = cross / square;
    let line = |k: usize| (mean + (k as f64 - centre) * slope).max(0.05 * mean);
    let (mut line_sum, mut rel_sum, mut rel_square) = (0.0, 0.0, 0.0);
    for (k, &c) in counts.iter().enumerate() {
        let w = line(k);
        let r = f64::from(c) / w - 1.0;
        line_sum += w;
        rel_sum += r;
        rel_square += r * r;
    }
    let rel_mean = rel_sum / nf;
    let variance = (rel_square / nf - rel_mean * rel_mean).max(0.0);
    (variance - nf / line_sum).max(0.0).sqrt()
}

/// A box's in-order events per time bin of `bin_us` from `start_us`, kept by the estimator
/// that counts them: it passes its count of in-order box events (`counted`) as it goes.
#[derive(Debug, Clone)]
pub(crate) struct RateBins {
    bins: Vec<u32>,
    /// The first bin's start (`u64::MAX` when nothing is counted).
    start_us: u64,
    bin_us: u64,
    /// The bin the latest event fell in (`usize::MAX` before the first bin, or none counted).
    at: usize,
    /// Where the next bin starts (`u64::MAX` when nothing is counted: no event reaches it).
    edge: u64,
    /// `counted` when bin `at` was entered.
    mark: u64,
}

impl RateBins {
    /// Nothing counted.
    pub(crate) fn off() -> Self {
        Self {
            bins: Vec::new(),
            start_us: u64::MAX,
            bin_us: 1,
            at: usize::MAX,
            edge: u64::MAX,
            mark: 0,
        }
    }

    /// `bins` bins of `bin_us` µs from `start_us`, from an estimator that has counted
    /// `counted` events so far.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] when `bin_us` is 0 or `bins` is outside
    /// `1..=`[`MAX_RATE_BINS`].
    pub(crate) fn new(start_us: u64, bin_us: u64, bins: usize, counted: u64) -> Result<Self> {
        if bin_us == 0 {
            return Err(Error::param("bin_us", "must be >= 1, got 0"));
        }
        if !(1..=MAX_RATE_BINS).contains(&bins) {
            return Err(Error::param(
                "bins",
                format!("must be in 1..={MAX_RATE_BINS}, got {bins}"),
            ));
        }
        Ok(Self {
            bins: vec![0; bins],
            start_us,
            bin_us,
            at: usize::MAX,
            edge: start_us,
            mark: counted,
        })
    }

    /// Whether an in-order event at `t` enters a later bin ([`enter`](Self::enter) it then).
    #[inline]
    pub(crate) fn enters(&self, t: u64) -> bool {
        t >= self.edge
    }

    /// The first in-order event at `t` of a later bin, `counted` events before it: the bin
    /// left gets its count, and `t`'s bin becomes the current one. Kept out of line, so that
    /// the estimator's per-event code stays small (inlined, it cost 4 instructions per event).
    #[cold]
    #[inline(never)]
    pub(crate) fn enter(&mut self, t: u64, counted: u64) {
        add_saturating(&mut self.bins, self.at, counted - self.mark);
        let bin = (t - self.start_us) / self.bin_us;
        self.at = usize::try_from(bin).unwrap_or(usize::MAX);
        self.edge = bin
            .saturating_add(1)
            .saturating_mul(self.bin_us)
            .saturating_add(self.start_us);
        self.mark = counted;
    }

    /// The counts per bin, `counted` events counted so far.
    pub(crate) fn counts(&self, counted: u64) -> Vec<u32> {
        let mut bins = self.bins.clone();
        add_saturating(&mut bins, self.at, counted - self.mark);
        bins
    }

    /// Zero the counts (for an estimator whose count starts again from 0); the bins stay.
    pub(crate) fn clear(&mut self) {
        self.bins.fill(0);
        self.at = usize::MAX;
        self.edge = self.start_us;
        self.mark = 0;
    }

    /// Bins held.
    pub(crate) fn capacity(&self) -> usize {
        self.bins.capacity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_swing_is_the_swing_beyond_shot_noise() {
        for none in [&[][..], &[5, 9], &[0; 10], &[40; 10]] {
            assert_eq!(rate_swing(none).to_bits(), 0f64.to_bits(), "{none:?}");
        }
        let ramp: Vec<u32> = (0..10).map(|k| 20 + 6 * k).collect();
        assert!(rate_swing(&ramp) < 1e-6);
        for a in [0.3, 0.6] {
            let wave: Vec<u32> = (0..10)
                .map(|k| (1e6 * (1.0 + a * (std::f64::consts::FRAC_PI_2 * k as f64).sin())) as u32)
                .collect();
            let s = rate_swing(&wave);
            assert!((s / (a / 2f64.sqrt()) - 1.0).abs() < 0.1, "{a}: {s}");
        }
    }
}
