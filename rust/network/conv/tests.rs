//! The conv layer's paths against direct computation and against each other.

#![allow(clippy::float_cmp)] // exact equality is the property under test

use super::fired::each_fired_lane;
use super::resolve::sort_runs;
use super::*;
use crate::network::config::{NetworkConfig, Padding};
use crate::network::geometry::Geometry;
use crate::network::weights::ConvWeights;

fn small(padding: Padding) -> (ConvGeom, ConvWeights) {
    let mut c = NetworkConfig {
        width: 12,
        height: 10,
        padding,
        ..NetworkConfig::default()
    };
    c.conv2.kernel = 3;
    c.pool1.kernel = 1;
    c.pool1.stride = 1;
    c.pool2.kernel = 1;
    c.pool2.stride = 1;
    c.conv3.kernel = 1;
    let g = Geometry::new(&c).unwrap().conv[0];
    let w = ConvWeights::random(&g, 0.5, 0.3, 3, 0).unwrap();
    (g, w)
}

/// Running potentials track a direct cross-correlation of the spikes; exact potentials
/// equal it; `reset` zeroes everything.
#[test]
fn potentials_equal_direct_correlation() {
    for padding in [Padding::Same, Padding::Valid] {
        let (g, w) = small(padding);
        let mut s = ConvState::new(g);
        s.set_thresholds(|_| 1e9);
        let spikes = [(0, 0), (3, 4), (9, 11), (5, 5), (9, 0)];
        let mut stamps = vec![0u32; g.in_h * g.in_w];
        for &(y, x) in &spikes {
            stamps[y * g.in_w + x] = 1;
        }
        let fired = Fired {
            stamps: &stamps,
            width: g.in_w,
            channels: 1,
            generation: 1,
        };
        for &(y, x) in &spikes {
            s.add(w.engine(), 0, y, x);
        }
        for oy in 0..g.out_h {
            for ox in 0..g.out_w {
                for m in 0..g.maps {
                    let mut expected = 0.0f64;
                    for &(y, x) in &spikes {
                        let (dy, dx) = (
                            y as isize - oy as isize + g.p_lo as isize,
                            x as isize - ox as isize + g.p_lo as isize,
                        );
                        if (0..g.k as isize).contains(&dy) && (0..g.k as isize).contains(&dx) {
                            expected += f64::from(w.kernel(m)[dy as usize * g.k + dx as usize]);
                        }
                    }
                    let pos = oy * g.out_w + ox;
                    assert_eq!(s.exact(w.canonical(), fired, pos, m), expected);
                    let running = f64::from(s.pot[pos * g.maps + m]);
                    assert!((running - expected).abs() <= 1e-5 * expected.max(1.0));
                }
            }
        }
        s.reset();
        assert!(s.pot.iter().all(|&v| v == 0.0));
    }
}

/// `exact` (through `exact_whole` where the field is whole) equals the general walk, bit
/// for bit, at every neuron of both paddings, with stamps of several generations.
#[test]
fn exact_whole_equals_general() {
    let mut rng = crate::network::xorshift(11u64);
    for padding in [Padding::Same, Padding::Valid] {
        let (g, w) = small(padding);
        let s = ConvState::new(g);
        for density in [2u64, 3, 8] {
            let stamps: Vec<u32> = (0..g.in_h * g.in_w)
                .map(|_| {
                    if rng().is_multiple_of(density) {
                        7
                    } else {
                        (rng() % 7) as u32
                    }
                })
                .collect();
            let fired = Fired {
                stamps: &stamps,
                width: g.in_w,
                channels: 1,
                generation: 7,
            };
            for pos in 0..g.out_h * g.out_w {
                for m in 0..g.maps {
                    let (fast, general) = (
                        s.exact(w.canonical(), fired, pos, m),
                        s.exact_general(w.canonical(), fired, pos, m),
                    );
                    assert_eq!(fast.to_bits(), general.to_bits(), "{padding:?} {pos} {m}");
                }
            }
        }
    }
}

/// `sort_runs` sorts like `sort_unstable`, whatever the runs: none, a few (merged), many
/// (sorted).
#[test]
fn sort_runs_sorts() {
    let mut rng = crate::network::xorshift(5u64);
    let mut next = |m: u64| {
        let s = rng();
        s % m
    };
    let mut buffer = Vec::new();
    for runs in 1..12u64 {
        for len in [0u64, 1, 2, 7, 40, 300] {
            let mut v: Vec<u64> = Vec::new();
            for _ in 0..runs {
                let mut run: Vec<u64> = (0..len).map(|_| next(1000)).collect();
                run.sort_unstable();
                v.extend(run);
            }
            let mut want = v.clone();
            want.sort_unstable();
            sort_runs(&mut v, &mut buffer);
            assert_eq!(v, want, "{runs} runs of {len}");
        }
    }
}

/// `add_spikes` leaves a layer as `add` spike by spike does, waking by count or not:
/// potentials, counts, candidates, positions to wake and footprints (Table 1's conv2 on a
/// small sensor, so that many inputs are clipped, with thresholds that wake positions).
#[test]
fn add_spikes_equals_add() {
    let c = NetworkConfig {
        width: 64,
        height: 48,
        ..NetworkConfig::default()
    };
    let g = Geometry::new(&c).unwrap().conv[1];
    let w = ConvWeights::random(&g, 0.5, 0.3, 9, 1).unwrap();
    let mut rng = crate::network::xorshift(17u64);
    for (round, gated) in (0..40).zip([true, false].into_iter().cycle()) {
        let mut a = ConvState::new(g);
        a.set_thresholds(|m| 2.0 + (m + round) as f32 % 7.0);
        a.set_gated(gated);
        a.set_wake(&w);
        assert_eq!(a.gated, gated);
        let mut b = a.clone();
        let mut stamps = vec![0u32; g.in_h * g.in_w * g.in_ch];
        for _ in 0..4 {
            let spikes: Vec<(u32, u32, u32)> = (0..rng() % 40)
                .map(|_| {
                    let v = rng();
                    (
                        (v % g.in_ch as u64) as u32,
                        (v / 8 % g.in_h as u64) as u32,
                        (v / 256 % g.in_w as u64) as u32,
                    )
                })
                .collect();
            a.add_spikes(w.engine(), &spikes);
            for &(c, iy, ix) in &spikes {
                b.add(w.engine(), c as usize, iy as usize, ix as usize);
            }
            let footprints = |s: &ConvState| {
                s.touched
                    .inputs
                    .iter()
                    .map(|f| (f.first, f.rows, f.cols))
                    .collect::<Vec<_>>()
            };
            assert_eq!(
                a.pot.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                b.pot.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            );
            assert_eq!(a.count.counts, b.count.counts);
            assert_eq!(a.candidates, b.candidates);
            assert_eq!(a.count.waking, b.count.waking);
            assert_eq!(footprints(&a), footprints(&b));
            assert_eq!(a.touched.lanes, b.touched.lanes);
            assert_eq!((a.breaks_len, a.pos_sorted), (b.breaks_len, b.pos_sorted));
            // Wake what reached its count, so that later batches add to awake positions.
            for &(c, iy, ix) in &spikes {
                stamps[(iy as usize * g.in_w + ix as usize) * g.in_ch + c as usize] = 1;
            }
            let fired = Fired {
                stamps: &stamps,
                width: g.in_w,
                channels: g.in_ch,
                generation: 1,
            };
            a.wake(w.engine(), fired);
            b.wake(w.engine(), fired);
        }
        if gated {
            assert!(
                a.count.counts.iter().any(|&n| n & AWAKE != 0),
                "round {round}"
            );
        }
    }
}

/// `each_fired_lane` visits the fired inputs of a receptive field in memory order, rows of one
/// word of stamps and longer ones, clipped fields included: as a scan of every input does.
#[test]
fn each_fired_lane_equals_a_scan() {
    let mut rng = crate::network::xorshift(19u64);
    for (in_ch, k) in [(1, 5), (4, 10), (20, 5), (7, 10)] {
        let c = NetworkConfig {
            width: 40,
            height: 30,
            ..NetworkConfig::default()
        };
        let mut g = Geometry::new(&c).unwrap().conv[0];
        (g.in_ch, g.k, g.p_lo) = (in_ch, k, (k - 1) / 2);
        let stamps: Vec<u32> = (0..g.in_h * g.in_w * in_ch)
            .map(|_| (rng() % 3) as u32)
            .collect();
        let fired = Fired {
            stamps: &stamps,
            width: g.in_w,
            channels: in_ch,
            generation: 1,
        };
        for (oy, ox) in [(0, 0), (3, 7), (g.out_h - 1, g.out_w - 1), (g.out_h / 2, 1)] {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let cols = g.inputs_of(ox, g.in_w);
            for iy in g.inputs_of(oy, g.in_h) {
                let from = (iy * g.in_w + cols.start) * in_ch;
                for l in 0..cols.len() * in_ch {
                    if stamps[from + l] == fired.generation {
                        a.push((iy, l));
                    }
                }
            }
            each_fired_lane(&g, fired, Avx2::detect(), oy, ox, |iy, l| b.push((iy, l)));
            assert!(!b.is_empty());
            assert_eq!(a, b, "{in_ch} channels, k {k}, ({oy}, {ox})");
        }
    }
}

#[test]
fn filter_threshold_is_below_the_threshold() {
    let (g, _) = small(Padding::Same);
    let mut s = ConvState::new(g);
    s.set_thresholds(|m| [1.0, 3.0, 1e-30, f32::INFINITY][m]);
    for (m, &t) in s.thr.exact.iter().enumerate() {
        assert!(f64::from(s.thr.lo[m]) <= t * (1.0 - 25.0 * 2f64.powi(-24)));
        assert!(f64::from(s.thr.hi[m]) >= t * (1.0 + 25.0 * 2f64.powi(-24)));
    }
}
