//! The engine against the dense reference: on random small networks and windows, with one
//! state reused across windows (sparse resets), every layer's spikes and counts, detections
//! and their boxes, recorded or not, waking positions by count or not, and STDP steps' winners
//! and weights are those of `reference`; and so on Table 1's layers, through every layer and
//! stopped early at each.

use super::reference::{dense_box, dense_stdp, dense_window};
use super::strategies::{config_strategy, random_weights, table1_static, window};
use super::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn engine_equals_dense_reference(c in config_strategy(), seed in any::<u64>()) {
        let mut net = Network::new(c.clone(), seed).unwrap();
        random_weights(&mut net, seed);
        let mut state = net.new_state();
        for w in 0..3u64 {
            let n = (seed.wrapping_add(w) % (c.width as u64 * c.height as u64)) as usize;
            let (t, x, y) = window(&c, seed.wrapping_add(w * 7919), n, 100 * w);
            net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, true)
                .unwrap();
            let (dense, _) = dense_window(&net, &t, &x, &y, None);
            for layer in Layer::ALL {
                prop_assert_eq!(state.spikes(layer), &dense[layer.index()][..], "{}", layer);
                prop_assert_eq!(state.counts()[layer.index()], dense[layer.index()].len() as u64);
            }
            // Without recording, potentials are gathered exactly only where decisions need
            // them: the same spikes must come out.
            let mut quiet = net.new_state();
            net.run_window(&mut quiet, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, false)
                .unwrap();
            prop_assert_eq!(quiet.counts(), state.counts());
            prop_assert_eq!(quiet.detections(), state.detections());
            let det: Vec<_> = state.detections().iter().map(|d| (d.t, d.map, d.row, d.col)).collect();
            let mut want: Vec<_> = dense[4].iter().map(|s| (s.t, s.map, s.row, s.col)).collect();
            let mut got = det.clone();
            got.sort_unstable();
            want.sort_unstable();
            prop_assert_eq!(got, want);
            for d in state.detections() {
                let want = dense_box(&net, &t, &x, &y, &dense, d);
                prop_assert_eq!((d.x0, d.y0, d.x1, d.y1), want, "{:?}", d);
            }
        }
    }

    #[test]
    fn stdp_step_equals_dense_reference(
        c in config_strategy(),
        seed in any::<u64>(),
        layer in 0usize..3,
    ) {
        let mut net = Network::new(c.clone(), seed).unwrap();
        random_weights(&mut net, seed);
        let mut state = net.new_state();
        let conv = ConvLayer::ALL[layer];
        for w in 0..3u64 {
            let n = (seed.wrapping_add(w) % (c.width as u64 * c.height as u64)) as usize;
            let (t, x, y) = window(&c, seed.wrapping_add(w * 31), n, 50 * w);
            let (_, want) = dense_window(&net, &t, &x, &y, Some(layer));
            let mut expected = net.clone();
            let rates = Rates { a_plus: 0.25, a_minus: -0.125 };
            // The dense update: inputs' first spikes from the dense run of the layers below.
            dense_stdp(&mut expected, &t, &x, &y, layer, &want, rates);
            let got = net
                .stdp_step(&mut state, conv, Spikes::new(&t, &x, &y).unwrap(), 50 * w, None, rates)
                .unwrap();
            prop_assert_eq!(&got, &want);
            prop_assert_eq!(net.conv_weights(conv), expected.conv_weights(conv));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Waking positions by count (the default only for layers with many maps) changes no
    /// spike, potential, detection or STDP update, on any layer.
    #[test]
    fn waking_by_count_equals_dense_reference(
        c in config_strategy(),
        seed in any::<u64>(),
        layer in 0usize..3,
    ) {
        let mut net = Network::new(c.clone(), seed).unwrap();
        random_weights(&mut net, seed);
        let mut state = net.new_state();
        for w in 0..3u64 {
            // Denser windows than above, so that many positions wake.
            let n = (seed.wrapping_add(w) % (2 * c.width as u64 * c.height as u64)) as usize;
            let (t, x, y) = window(&c, seed.wrapping_add(w * 104_729), n, 100 * w);
            let (dense, _) = dense_window(&net, &t, &x, &y, None);
            for (gated, record) in [(true, true), (true, false), (false, false)] {
                state.set_gated(gated);
                net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, record)
                    .unwrap();
                for l in Layer::ALL {
                    prop_assert_eq!(state.counts()[l.index()], dense[l.index()].len() as u64);
                    if record {
                        prop_assert_eq!(state.spikes(l), &dense[l.index()][..], "{}", l);
                    }
                }
            }
            state.set_gated(true);
            let (_, want) = dense_window(&net, &t, &x, &y, Some(layer));
            let mut expected = net.clone();
            let rates = Rates { a_plus: 0.25, a_minus: -0.125 };
            dense_stdp(&mut expected, &t, &x, &y, layer, &want, rates);
            let conv = ConvLayer::ALL[layer];
            let got = net
                .stdp_step(&mut state, conv, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, rates)
                .unwrap();
            prop_assert_eq!(&got, &want);
            prop_assert_eq!(net.conv_weights(conv), expected.conv_weights(conv));
        }
    }
}

/// Table 1's layers (conv2 10 × 10 over 4 maps into 20, conv3 into 10: the shapes the engine
/// has fixed fast paths for, outside `config_strategy`'s sizes) against the dense reference,
/// recorded and not, through every layer and stopped early.
#[test]
fn table1_layers_equal_dense_reference() {
    let (c, net) = table1_static(125);
    let (t, x, y) = window(&c, 7, 6000, 0);
    let (dense, _) = dense_window(&net, &t, &x, &y, None);
    assert!(dense.iter().all(|l| !l.is_empty()), "every layer fires");
    for record in [true, false] {
        for last in Layer::ALL {
            let mut s = net.new_state();
            s.set_gated(true);
            s.set_depth(last);
            net.run_window(&mut s, Spikes::new(&t, &x, &y).unwrap(), 0, None, record)
                .unwrap();
            for layer in Layer::ALL {
                let want = if layer.index() <= last.index() {
                    dense[layer.index()].len() as u64
                } else {
                    0
                };
                assert_eq!(
                    s.counts()[layer.index()],
                    want,
                    "{layer} (to {last}, {record})"
                );
                if record && layer.index() <= last.index() {
                    assert_eq!(s.spikes(layer), &dense[layer.index()][..], "{layer}");
                }
            }
        }
    }
}
