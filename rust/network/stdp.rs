//! STDP (docs/model.md §6): the sparse weight update of the winners' kernels, the learning-rate
//! schedule and the convergence measure.

use super::config::StdpConfig;
use super::geometry::ConvGeom;
use super::weights::ConvWeights;
use super::winners::Winner;

/// The learning rates applied to one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rates {
    /// a⁺, applied where the input fired at or before the winner.
    pub a_plus: f32,
    /// a⁻, applied where the input fired later or never (padding never fires).
    pub a_minus: f32,
}

impl Rates {
    /// The config's initial rates.
    pub fn initial(c: &StdpConfig) -> Self {
        Self {
            a_plus: c.a_plus as f32,
            a_minus: c.a_minus as f32,
        }
    }
}

/// `clip(w + a·w·(1 − w), 0, 1)` in float32, evaluated as `w + ((a * w) * (1 − w))`.
#[inline]
pub fn updated(w: f32, a: f32) -> f32 {
    (w + ((a * w) * (1.0 - w))).clamp(0.0, 1.0)
}

/// Apply STDP to the kernels of `winners` (distinct maps). `fired_at(c, row, col)` gives the
/// firing time of the layer's input neuron in this window, if it fired.
pub(crate) fn apply(
    weights: &mut ConvWeights,
    g: &ConvGeom,
    winners: &[Winner],
    rates: Rates,
    fired_at: impl Fn(usize, usize, usize) -> Option<u64>,
) {
    let k = g.k;
    for w in winners {
        let (oy, ox) = (w.row as usize, w.col as usize);
        let kernel = weights.kernel_mut(w.map as usize);
        for c in 0..g.in_ch {
            for dy in 0..k {
                let iy = (oy + dy).checked_sub(g.p_lo).filter(|&y| y < g.in_h);
                for dx in 0..k {
                    let ix = (ox + dx).checked_sub(g.p_lo).filter(|&x| x < g.in_w);
                    let before = match (iy, ix) {
                        (Some(iy), Some(ix)) => fired_at(c, iy, ix).is_some_and(|t| t <= w.t),
                        _ => false,
                    };
                    let a = if before { rates.a_plus } else { rates.a_minus };
                    let weight = &mut kernel[(c * k + dy) * k + dx];
                    *weight = updated(*weight, a);
                }
            }
        }
        weights.sync_map(w.map as usize);
    }
}

/// The learning-rate schedule (after Kheradpisheh et al., 2018): a⁺ doubles every `lr_every`
/// windows up to `a_plus_max`, and a⁻ follows it at the initial ratio.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    config: StdpConfig,
    a_plus: f64,
    seen: u64,
}

impl Schedule {
    pub fn new(config: &StdpConfig) -> Self {
        Self {
            config: *config,
            a_plus: config.a_plus,
            seen: 0,
        }
    }

    /// The rates for the next window. a⁻ is computed as `a⁻₀ · (a⁺ / a⁺₀)`, equal to the
    /// model's `a⁺ · (a⁻₀ / a⁺₀)` and exact while a⁺ is a power-of-two multiple of a⁺₀.
    pub fn rates(&self) -> Rates {
        let c = &self.config;
        Rates {
            a_plus: self.a_plus as f32,
            a_minus: (c.a_minus * (self.a_plus / c.a_plus)) as f32,
        }
    }

    /// Current a⁺ (float64).
    pub fn a_plus(&self) -> f64 {
        self.a_plus
    }

    /// Count one trained window; double a⁺ when a period ends.
    pub fn window_done(&mut self) {
        self.seen += 1;
        if self.seen.is_multiple_of(self.config.lr_every) {
            self.a_plus = (self.a_plus * 2.0).min(self.config.a_plus_max);
        }
    }

    /// Windows counted so far.
    pub fn seen(&self) -> u64 {
        self.seen
    }
}

/// The convergence measure `C = mean(w · (1 − w))`, kept per map so that a window's update
/// costs only its winners' kernels.
#[derive(Debug, Clone, PartialEq)]
pub struct Convergence {
    per_map: Vec<f64>,
    count: usize,
}

impl Convergence {
    pub fn new(weights: &ConvWeights) -> Self {
        let maps = weights.shape()[0];
        let mut c = Self {
            per_map: vec![0.0; maps],
            count: weights.canonical().len(),
        };
        for m in 0..maps {
            c.update_map(weights, m);
        }
        c
    }

    /// Recompute map `m`'s share after its kernel changed.
    pub fn update_map(&mut self, weights: &ConvWeights, m: usize) {
        self.per_map[m] = weights
            .kernel(m)
            .iter()
            .map(|&w| f64::from(w) * (1.0 - f64::from(w)))
            .sum();
    }

    /// `C` over the whole layer.
    pub fn value(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.per_map.iter().sum::<f64>() / self.count as f64
        }
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact equality is the property under test
mod tests {
    use super::*;
    use crate::network::config::NetworkConfig;

    #[test]
    fn update_stays_in_unit_interval() {
        for &w in &[0.0f32, 1e-30, 0.3, 0.5, 0.999_999, 1.0] {
            for &a in &[-1.0f32, -0.1125, -0.003, 0.004, 0.15, 1.0] {
                let u = updated(w, a);
                assert!((0.0..=1.0).contains(&u), "{w} {a} {u}");
                if a > 0.0 {
                    assert!(u >= w);
                } else {
                    assert!(u <= w);
                }
            }
        }
        assert_eq!(updated(0.0, 0.5), 0.0);
        assert_eq!(updated(1.0, -0.5), 1.0);
    }

    #[test]
    fn schedule_doubles_and_caps() {
        let c = NetworkConfig::default().stdp;
        let mut s = Schedule::new(&c);
        assert_eq!(s.rates(), Rates::initial(&c));
        for _ in 0..c.lr_every {
            s.window_done();
        }
        assert_eq!(s.a_plus(), 0.008);
        assert_eq!(s.rates().a_minus, -0.006f32);
        for _ in 0..20 * c.lr_every {
            s.window_done();
        }
        assert_eq!(s.a_plus(), c.a_plus_max);
        let r = s.rates();
        assert!((f64::from(r.a_minus) + 0.75 * 0.15).abs() < 1e-7);
    }
}
