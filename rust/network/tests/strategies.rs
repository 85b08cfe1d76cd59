//! Random inputs for the tests: small network configs whose thresholds sit on a grid potentials
//! can meet exactly, weights on coarse or fine grids, windows with many equal times, and Table
//! 1's layers with static thresholds low enough for random weights to fire every layer.

use super::*;

/// A random small network config.
pub(super) fn config_strategy() -> impl Strategy<Value = NetworkConfig> {
    (
        (6usize..20, 6usize..20, any::<bool>()),
        (1usize..6, 1usize..5, 0.5f32..4.0, any::<bool>()),
        (1usize..4, 1usize..4),
        (1usize..5, 1usize..5, 0.3f32..3.0, any::<bool>()),
        (1usize..3, 1usize..3),
        (1usize..4, 1usize..4, 0.3f32..2.0, any::<bool>()),
        (any::<bool>(), 0.0f64..20.0, 0.5f64..3.0),
        (1usize..5, 0usize..4),
    )
        .prop_map(|(sensor, c1, p1, c2, p2, c3, pent, wta)| {
            let mut c = NetworkConfig {
                width: sensor.0,
                height: sensor.1,
                padding: if sensor.2 {
                    Padding::Same
                } else {
                    Padding::Valid
                },
                ..NetworkConfig::default()
            };
            // Thresholds on a grid of 1/4, to meet potentials exactly.
            let conv = |(kernel, maps, threshold, li): (usize, usize, f32, bool)| ConvConfig {
                kernel,
                maps,
                threshold: (threshold * 4.0).round().max(1.0) / 4.0,
                lateral_inhibition: li,
                wta_k: wta.0,
                wta_radius: wta.1,
            };
            c.conv1 = conv(c1);
            c.conv2 = conv(c2);
            c.conv3 = conv(c3);
            c.pool1 = PoolConfig {
                kernel: p1.0,
                stride: p1.1,
            };
            c.pool2 = PoolConfig {
                kernel: p2.0,
                stride: p2.1,
            };
            c.pent.mode = if pent.0 {
                ThresholdMode::Pent
            } else {
                ThresholdMode::Static
            };
            c.pent.beta = pent.1;
            c.pent.theta_min = (pent.2 * 4.0).round().max(1.0) / 4.0;
            c
        })
        .prop_filter("layers must fit", |c| c.validate().is_ok())
}

/// Weights on a grid of 1/8 (equal potentials and potentials exactly at a threshold are
/// common), of 2⁻¹², or of 2⁻²⁴ (float32 running sums round), by seed.
pub(super) fn random_weights(net: &mut Network, seed: u64) {
    let steps = [8, 1 << 12, 1 << 24][(seed % 3) as usize];
    let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    for layer in ConvLayer::ALL {
        let n = net.conv_weights(layer).canonical().len();
        let w = (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                ((s >> 40) % (steps + 1)) as f32 / steps as f32
            })
            .collect();
        net.set_weights(layer, w).unwrap();
    }
}

/// Random windows: pixels with times in a small range (many equal times).
pub(super) fn window(
    c: &NetworkConfig,
    seed: u64,
    n: usize,
    t0: u64,
) -> (Vec<u64>, Vec<u16>, Vec<u16>) {
    let mut rng = crate::network::xorshift(seed | 1);
    let mut next = |m: u64| {
        let s = rng();
        s % m
    };
    let mut v: Vec<(u64, u16, u16)> = (0..n)
        .map(|_| {
            (
                t0 + next(12),
                next(c.width as u64) as u16,
                next(c.height as u64) as u16,
            )
        })
        .collect();
    v.sort_by_key(|e| e.0);
    (
        v.iter().map(|e| e.0).collect(),
        v.iter().map(|e| e.1).collect(),
        v.iter().map(|e| e.2).collect(),
    )
}

/// Table 1's layers on a `side` × `side` sensor with static thresholds low enough for random
/// weights to fire every layer, and those weights.
pub(super) fn table1_static(side: usize) -> (NetworkConfig, Network) {
    let mut c = NetworkConfig {
        width: side,
        height: side,
        padding: Padding::Same,
        ..NetworkConfig::default()
    };
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 1.5;
    c.conv2.threshold = 2.0;
    c.conv3.threshold = 1.0;
    let mut net = Network::new(c.clone(), 3).unwrap();
    random_weights(&mut net, 11);
    (c, net)
}
