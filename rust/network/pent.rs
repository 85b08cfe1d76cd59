//! conv1's thresholds: PENT, pre-emptive neuron thresholding, or static (docs/model.md §4).
//!
//! `θ1[m] = max(θ_min, β · (N_in / (W · H)) · K1[m])`: `β · (N_in / (W · H)) · K1[m]` is the
//! potential that input of the window's average density would give a neuron of map `m`; β asks
//! for local structure β times denser, so noise that floods the sensor raises the bar before it
//! reaches layer 1. With `ρ_max` (`pent.max_density`) the density asked for is at most `ρ_max`:
//! `θ1[m] = max(θ_min, min(β · N_in / (W · H), ρ_max) · K1[m])`. Computed in float64 and
//! rounded to float32.

use super::config::{NetworkConfig, ThresholdMode};

/// conv1's per-map thresholds for a window with `n_in` input spikes; `kernel_sums[m]` is
/// `K1[m]`, the float64 sum of map `m`'s weights.
pub fn conv1_thresholds(config: &NetworkConfig, kernel_sums: &[f64], n_in: u64) -> Vec<f32> {
    match config.pent.mode {
        ThresholdMode::Static => vec![config.conv1.threshold; kernel_sums.len()],
        ThresholdMode::Pent => {
            let p = &config.pent;
            let area = (config.width * config.height) as f64;
            let asked = p.beta * (n_in as f64 / area);
            let asked = p.max_density.map_or(asked, |r| asked.min(r));
            kernel_sums
                .iter()
                .map(|&k1| p.theta_min.max(asked * k1) as f32)
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::config::PentConfig;

    #[test]
    fn floor_then_proportional() {
        let config = NetworkConfig::default();
        let sums = [10.0, 20.0];
        // 1 % density: 8 × 0.01 × 10 = 0.8 < θ_min.
        assert_eq!(conv1_thresholds(&config, &sums, 432), vec![3.0, 3.0]);
        // 10 % density: 8 × 0.1 × K1.
        let t = conv1_thresholds(&config, &sums, 4320);
        assert_eq!(
            t,
            vec![(8.0 * 0.1 * 10.0f64) as f32, (8.0 * 0.1 * 20.0f64) as f32]
        );
        let c = NetworkConfig {
            pent: PentConfig {
                mode: ThresholdMode::Static,
                ..config.pent
            },
            ..config
        };
        assert_eq!(conv1_thresholds(&c, &sums, 4320), vec![4.0, 4.0]);
    }

    #[test]
    fn max_density_caps_the_density_asked_for() {
        let mut config = NetworkConfig::default();
        config.pent.max_density = Some(0.5);
        let sums = [10.0, 20.0];
        // 5 % density: 8 × 0.05 = 0.4 < 0.5, as without a cap.
        let t = conv1_thresholds(&config, &sums, 2160);
        assert_eq!(
            t,
            vec![(8.0 * 0.05 * 10.0f64) as f32, (8.0 * 0.05 * 20.0f64) as f32]
        );
        // 20 % density: 8 × 0.2 = 1.6 asks for more than a whole kernel; capped at 0.5 × K1.
        assert_eq!(conv1_thresholds(&config, &sums, 8640), vec![5.0, 10.0]);
        // The floor still holds.
        config.pent.theta_min = 7.0;
        assert_eq!(conv1_thresholds(&config, &sums, 8640), vec![7.0, 10.0]);
    }
}
