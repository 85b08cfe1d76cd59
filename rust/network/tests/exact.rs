//! Decisions taken on exact potentials: a neuron whose float32 running sum rounds below (or
//! above) its threshold fires as its exact float64 potential says, lateral inhibition between
//! maps whose exact potentials tie goes to the lower map, recorded or not, and a line of pixels
//! makes the matching Gabor kernel fire at exactly the pixel that brings its sum over the
//! threshold, with that sum as its potential.

use super::*;

#[test]
fn a_line_makes_the_matching_gabor_fire_at_its_last_pixel() {
    // A vertical line of 5 pixels, one pixel per microsecond: the 0° kernel (vertical edges)
    // centred on the line reaches its threshold at exactly the pixel that brings the sum of its
    // centre column over it.
    let mut c = NetworkConfig {
        width: 20,
        height: 20,
        ..NetworkConfig::default()
    };
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 4.0;
    let net = Network::new(c, 0).unwrap();
    let w = net.conv_weights(ConvLayer::Conv1).kernel(0).to_vec();
    let column: Vec<f64> = (0..5).map(|r| f64::from(w[r * 5 + 2])).collect();
    let mut sum = 0.0;
    let crossing = column
        .iter()
        .position(|&v| {
            sum += v;
            sum >= 4.0
        })
        .unwrap() as u64;
    let t: Vec<u64> = (0..5).collect();
    let x = vec![10u16; 5];
    let y: Vec<u16> = (8..13).collect();
    let mut state = net.new_state();
    net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    let centre = state
        .spikes(Layer::Conv1)
        .iter()
        .find(|s| (s.row, s.col) == (10, 10))
        .copied()
        .unwrap();
    assert_eq!((centre.map, centre.t), (0, crossing));
    assert_eq!(
        centre.v,
        column[..=crossing as usize].iter().sum::<f64>() as f32
    );
    // Raising the threshold past the whole column silences the centre neuron.
    let mut c = net.config().clone();
    c.conv1.threshold = (column.iter().sum::<f64>() + 0.01) as f32;
    let net = Network::new(c, 0).unwrap();
    let mut state = net.new_state();
    net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    assert!(state
        .spikes(Layer::Conv1)
        .iter()
        .all(|s| (s.row, s.col) != (10, 10) || s.map != 0));
}

/// A neuron whose float32 running sum rounds below its threshold while its exact potential
/// reaches it must fire: the float32 sum is only a filter.
#[test]
fn exact_potential_decides_where_float32_rounds_below() {
    // Find three weights whose sequential float32 sum rounds below the float32 threshold that
    // their exact sum reaches.
    let mut rng = crate::network::xorshift(0x2545_f491_4f6c_dd1du64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 24) as f32 + (s & 0xFF) as f32 * 1e-10
    };
    let (w, theta) = loop {
        let w = [next(), next(), next()];
        let exact: f64 = w.iter().map(|&v| f64::from(v)).sum();
        let running = w[0] + w[1] + w[2];
        let theta = exact as f32;
        let theta = if f64::from(theta) > exact {
            f32::from_bits(theta.to_bits() - 1)
        } else {
            theta
        };
        if running < theta && w.iter().all(|v| (0.0..=1.0).contains(v)) {
            break (w, theta);
        }
    };
    let mut c = NetworkConfig {
        width: 3,
        height: 1,
        ..NetworkConfig::default()
    };
    c.conv1.kernel = 3;
    c.conv1.maps = 1;
    c.conv1.threshold = theta;
    c.pent.mode = ThresholdMode::Static;
    c.pool1 = PoolConfig {
        kernel: 1,
        stride: 1,
    };
    c.conv2.kernel = 1;
    c.pool2 = c.pool1;
    c.conv3.kernel = 1;
    let mut net = Network::new(c, 0).unwrap();
    // Only the middle row of the kernel: the neuron at column 1 reads the 3 pixels.
    let mut kernel = vec![0.0f32; 9];
    kernel[3..6].copy_from_slice(&w);
    net.set_weights(ConvLayer::Conv1, kernel).unwrap();
    let (t, x, y) = (vec![1u64, 2, 3], vec![0u16, 1, 2], vec![0u16; 3]);
    let mut state = net.new_state();
    net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    let exact: f64 = w.iter().map(|&v| f64::from(v)).sum();
    assert_eq!(
        state.spikes(Layer::Conv1),
        &[LayerSpike {
            t: 3,
            map: 0,
            row: 0,
            col: 1,
            v: exact as f32
        }]
    );
}

/// Two maps whose exact potentials tie while their float32 running sums differ (the same
/// weights added in another order): the tie goes to the lower map, as the exact values say.
#[test]
fn inhibition_ties_are_decided_exactly() {
    let mut rng = crate::network::xorshift(0x9E37_79B9_7F4A_7C15u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let w = loop {
        let w = [next(), next(), next()];
        if (w[2] + w[1]) + w[0] > (w[0] + w[1]) + w[2] {
            break w;
        }
    };
    let mut c = NetworkConfig {
        width: 3,
        height: 1,
        ..NetworkConfig::default()
    };
    c.conv1.kernel = 3;
    c.conv1.maps = 2;
    c.conv1.threshold = 0.01;
    c.pent.mode = ThresholdMode::Static;
    c.pool1 = PoolConfig {
        kernel: 1,
        stride: 1,
    };
    c.conv2.kernel = 1;
    c.conv2.maps = 1;
    c.conv2.threshold = 0.5;
    c.pool2 = c.pool1;
    c.conv3.kernel = 1;
    let mut net = Network::new(c, 0).unwrap();
    // Middle rows: map 0 reads the pixels with (w0, w1, w2), map 1 with (w2, w1, w0).
    let mut kernels = vec![0.0f32; 18];
    kernels[3..6].copy_from_slice(&w);
    kernels[12..15].copy_from_slice(&[w[2], w[1], w[0]]);
    net.set_weights(ConvLayer::Conv1, kernels).unwrap();
    // conv2 (1x1) listens to map 0 only, so its count tells which map won, even unrecorded.
    net.set_weights(ConvLayer::Conv2, vec![1.0, 0.0]).unwrap();
    // All three pixels at once: both maps cross at (0, 1) in the same group with equal exact
    // potentials.
    let (t, x, y) = (vec![5u64; 3], vec![0u16, 1, 2], vec![0u16; 3]);
    let mut recorded = net.new_state();
    net.run_window(
        &mut recorded,
        Spikes::new(&t, &x, &y).unwrap(),
        0,
        None,
        true,
    )
    .unwrap();
    let winner: Vec<u16> = recorded
        .spikes(Layer::Conv1)
        .iter()
        .filter(|s| s.col == 1)
        .map(|s| s.map)
        .collect();
    assert_eq!(winner, vec![0]);
    assert!(recorded.spikes(Layer::Conv2).iter().any(|s| s.col == 1));
    let mut quiet = net.new_state();
    net.run_window(&mut quiet, Spikes::new(&t, &x, &y).unwrap(), 0, None, false)
        .unwrap();
    assert_eq!(quiet.counts(), recorded.counts());
}

/// The mirror case: a float32 running sum that rounds up to the threshold while the exact
/// potential stays below it must not fire.
#[test]
fn exact_potential_decides_where_float32_rounds_above() {
    let mut rng = crate::network::xorshift(0x1234_5678_9abc_def1u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 24) as f32 + (s & 0xFF) as f32 * 1e-10
    };
    let (w, theta) = loop {
        let w = [next(), next(), next()];
        let exact: f64 = w.iter().map(|&v| f64::from(v)).sum();
        let running = w[0] + w[1] + w[2];
        if f64::from(running) > exact && w.iter().all(|v| (0.0..=1.0).contains(v)) {
            // The running sum itself as threshold: reached by float32, not by the exact sum.
            break (w, running);
        }
    };
    let mut c = NetworkConfig {
        width: 3,
        height: 1,
        ..NetworkConfig::default()
    };
    c.conv1.kernel = 3;
    c.conv1.maps = 1;
    c.conv1.threshold = theta;
    c.pent.mode = ThresholdMode::Static;
    c.pool1 = PoolConfig {
        kernel: 1,
        stride: 1,
    };
    c.conv2.kernel = 1;
    c.pool2 = c.pool1;
    c.conv3.kernel = 1;
    let mut net = Network::new(c, 0).unwrap();
    let mut kernel = vec![0.0f32; 9];
    kernel[3..6].copy_from_slice(&w);
    net.set_weights(ConvLayer::Conv1, kernel).unwrap();
    let (t, x, y) = (vec![1u64, 2, 3], vec![0u16, 1, 2], vec![0u16; 3]);
    for record in [false, true] {
        let mut state = net.new_state();
        net.run_window(
            &mut state,
            Spikes::new(&t, &x, &y).unwrap(),
            0,
            None,
            record,
        )
        .unwrap();
        assert_eq!(state.counts()[0], 0);
    }
}
