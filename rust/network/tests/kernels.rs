//! The scalar references of `simd` against the AVX2 kernels: a state set to scalar gives, window
//! after window, the spikes, counts and detections of the default kernels and of the dense
//! reference, adding densely and waking by count.

use super::reference::dense_window;
use super::strategies::{table1_static, window};
use super::*;

/// A CPU without AVX2 runs the scalar references of `simd` end to end: the same spikes, counts
/// and detections as the AVX2 kernels (where the CPU has them) and the dense reference, window
/// after window in one state (so that each way's reset between windows runs too), adding
/// densely and waking by count.
#[test]
fn scalar_kernels_give_the_spikes_of_the_avx2_ones() {
    let (c, net) = table1_static(48);
    for gated in [false, true] {
        let (mut fast, mut scalar) = (net.new_state(), net.new_state());
        scalar.set_scalar();
        for w in 0..3u64 {
            let (t, x, y) = window(&c, 7 + w, 1500, 1_000 * w);
            let (dense, _) = dense_window(&net, &t, &x, &y, None);
            assert!(dense.iter().all(|l| !l.is_empty()), "every layer fires");
            for s in [&mut fast, &mut scalar] {
                s.set_gated(gated);
                net.run_window(s, Spikes::new(&t, &x, &y).unwrap(), 1_000 * w, None, true)
                    .unwrap();
            }
            assert_eq!(scalar.counts(), fast.counts(), "window {w}, gated {gated}");
            assert_eq!(
                scalar.detections(),
                fast.detections(),
                "window {w}, gated {gated}"
            );
            for layer in Layer::ALL {
                assert_eq!(
                    scalar.spikes(layer),
                    fast.spikes(layer),
                    "{layer}, window {w}"
                );
                assert_eq!(scalar.spikes(layer), &dense[layer.index()][..], "{layer}");
            }
        }
    }
}
