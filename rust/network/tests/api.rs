//! The `WindowState` API around a window: pushing spikes one at a time gives `run_window`'s
//! detections and counts and hands each group's detections back early, duplicate pixels keep
//! their first spike, stopping at a depth leaves the layers below unchanged, a wrapping
//! generation counter changes no result, and bad input — spikes out of the sensor, out of order
//! or before the window, a state of another network, STDP rates of the wrong sign or not
//! finite — is refused with the error and index that pushing it gives, and nothing changed.

use super::strategies::{random_weights, window};
use super::*;

#[test]
fn generation_wrap_keeps_results() {
    let c = NetworkConfig {
        width: 30,
        height: 20,
        ..NetworkConfig::default()
    };
    let mut net = Network::new(c.clone(), 1).unwrap();
    random_weights(&mut net, 3);
    let (t, x, y) = window(&c, 11, 200, 0);
    let mut a = net.new_state();
    net.run_window(&mut a, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    let mut b = net.new_state();
    b.set_generation(u32::MAX - 1);
    for _ in 0..3 {
        net.run_window(&mut b, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
            .unwrap();
        for layer in Layer::ALL {
            assert_eq!(a.spikes(layer), b.spikes(layer));
        }
    }
}

/// `run_window` checks a window's spikes together before taking them without per-spike checks:
/// a bad spike anywhere gives the error, with its index, that pushing the groups one by one
/// gives, after the same earlier spikes.
#[test]
fn run_window_refuses_bad_spikes_like_push_group() {
    let c = NetworkConfig {
        width: 24,
        height: 18,
        ..NetworkConfig::default()
    };
    let net = Network::new(c.clone(), 3).unwrap();
    let (t, x, y) = window(&c, 11, 300, 1_000);
    let k = 150;
    let mut cases = Vec::new();
    for bad in 0..4 {
        let (mut t, mut x, mut y) = (t.clone(), x.clone(), y.clone());
        match bad {
            0 => x[k] = c.width as u16,
            1 => y[k] = c.height as u16,
            2 => t[k] = t[k - 1] - 1,
            _ => t[0] = 999, // before t0
        }
        cases.push((t, x, y));
    }
    for (t, x, y) in &cases {
        let mut a = net.new_state();
        let spikes = Spikes::new(t, x, y).unwrap();
        let err_a = net
            .run_window(&mut a, spikes, 1_000, None, false)
            .unwrap_err();
        let mut b = net.new_state();
        b.begin(&net, 1_000, &net.conv1_thresholds(t.len() as u64))
            .unwrap();
        let mut start = 0;
        let err_b = loop {
            let end = start + t[start..].iter().take_while(|&&ti| ti == t[start]).count();
            if let Err(e) = b.push_group(&net, t[start], &x[start..end], &y[start..end]) {
                break e;
            }
            start = end;
        };
        assert_eq!(err_a.to_string(), err_b.to_string());
        assert_eq!(a.counts(), b.counts());
        assert_eq!(a.input_count(), b.input_count());
    }
}

#[test]
fn push_api_matches_run_window_and_reports_detections_early() {
    let c = NetworkConfig {
        width: 40,
        height: 30,
        ..NetworkConfig::default()
    };
    let mut c = c;
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 1.5;
    c.conv2.threshold = 2.0;
    c.conv3.threshold = 1.0;
    let mut net = Network::new(c.clone(), 2).unwrap();
    random_weights(&mut net, 9);
    let (t, x, y) = window(&c, 5, 400, 0);
    let mut a = net.new_state();
    net.run_window(&mut a, Spikes::new(&t, &x, &y).unwrap(), 0, None, false)
        .unwrap();
    assert!(!a.detections().is_empty(), "the test needs detections");
    let mut b = net.new_state();
    b.begin(&net, 0, &net.conv1_thresholds(t.len() as u64))
        .unwrap();
    let mut seen = Vec::new();
    for i in 0..t.len() {
        for d in b.push(&net, t[i], x[i], y[i]).unwrap() {
            // A group's detections come back as soon as a later spike arrives.
            assert!(d.t < t[i]);
            seen.push(*d);
        }
    }
    b.finish(&net).unwrap();
    seen.extend_from_slice(&b.detections()[seen.len()..]);
    assert_eq!(seen, a.detections());
    assert_eq!(b.counts(), a.counts());
    // Bad input is refused with the event's index, and the window goes on.
    b.begin(&net, 100, &net.conv1_thresholds(0)).unwrap();
    assert!(matches!(
        b.push(&net, 99, 0, 0),
        Err(Error::InvalidEvent { index: 0, .. })
    ));
    assert!(matches!(
        b.push(&net, 100, 40, 0),
        Err(Error::InvalidEvent { index: 0, .. })
    ));
    b.push(&net, 105, 1, 1).unwrap();
    assert!(matches!(
        b.push(&net, 104, 1, 2),
        Err(Error::InvalidEvent { index: 1, .. })
    ));
    // A state made for another network is refused.
    let other = Network::new(c, 2).unwrap();
    assert!(b.push(&other, 106, 0, 0).is_err());
}

#[test]
fn duplicate_pixels_keep_their_first_spike() {
    let c = NetworkConfig {
        width: 20,
        height: 20,
        ..NetworkConfig::default()
    };
    let net = Network::new(c, 0).unwrap();
    let mut state = net.new_state();
    state.begin(&net, 0, &net.conv1_thresholds(0)).unwrap();
    for t in 0..5 {
        state.push(&net, t, 3, 3).unwrap();
    }
    state.finish(&net).unwrap();
    assert_eq!(state.input_count(), 1);
}

#[test]
fn depth_stops_the_network_early_without_changing_the_layers_below() {
    let c = NetworkConfig {
        width: 40,
        height: 30,
        ..NetworkConfig::default()
    };
    let mut c = c;
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 1.5;
    c.conv2.threshold = 2.0;
    c.conv3.threshold = 1.0;
    let mut net = Network::new(c.clone(), 2).unwrap();
    random_weights(&mut net, 9);
    let (t, x, y) = window(&c, 5, 400, 0);
    let mut full = net.new_state();
    net.run_window(&mut full, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    assert!(full.counts().iter().all(|&n| n > 0));
    for last in Layer::ALL {
        let mut s = net.new_state();
        s.set_depth(last);
        net.run_window(&mut s, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
            .unwrap();
        for layer in Layer::ALL {
            if layer.index() <= last.index() {
                assert_eq!(s.spikes(layer), full.spikes(layer));
            } else {
                assert_eq!(s.counts()[layer.index()], 0);
            }
        }
    }
}

#[test]
fn stdp_step_refuses_rates_of_the_wrong_sign_or_not_finite() {
    // A NaN rate wrote NaN weights, which the model file then refused to read back.
    let c = NetworkConfig {
        width: 16,
        height: 12,
        ..NetworkConfig::default()
    };
    let mut net = Network::new(c, 1).unwrap();
    let before = net.clone();
    let mut state = net.new_state();
    let (t, x, y) = (vec![0u64, 1, 2], vec![3u16, 4, 5], vec![3u16, 4, 5]);
    for (a_plus, a_minus) in [
        (f32::NAN, -0.003),
        (0.004, f32::NEG_INFINITY),
        (f32::INFINITY, -0.003),
        (-0.5, -0.003),
        (0.004, 0.5),
    ] {
        let rates = Rates { a_plus, a_minus };
        let spikes = Spikes::new(&t, &x, &y).unwrap();
        let err = net
            .stdp_step(&mut state, ConvLayer::Conv1, spikes, 0, None, rates)
            .unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "rates", .. }),
            "{err}"
        );
    }
    assert_eq!(
        net.conv_weights(ConvLayer::Conv1),
        before.conv_weights(ConvLayer::Conv1)
    );
}
