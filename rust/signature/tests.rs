//! Tests of the rotor signature estimator: synthetic periodic events, noise, and bounds.

use super::*;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Pixels of a `side`×`side` block flickering at `f` Hz: per cycle a run of `run` ON events
/// then `run` OFF events, every edge jittered by `jitter` (relative to the period), each pixel
/// with its own phase. Sorted by time.
fn flicker(f: f64, side: u16, duration_us: u64, run: usize, jitter: f64, seed: u64) -> Vec<Event> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let period = 1e6 / f;
    let mut out = Vec::new();
    for y in 0..side {
        for x in 0..side {
            let phase = rng.random::<f64>() * period;
            let mut k = 0.0;
            loop {
                let start = phase + k * period;
                if start >= duration_us as f64 {
                    break;
                }
                for (half, p) in [(0.0, true), (0.5, false)] {
                    let edge =
                        start + half * period + (rng.random::<f64>() - 0.5) * 2.0 * jitter * period;
                    for r in 0..run {
                        let t = edge + r as f64 * period * 0.02;
                        if t >= 0.0 && t < duration_us as f64 {
                            out.push(Event {
                                t: t as u64,
                                x,
                                y,
                                p,
                            });
                        }
                    }
                }
                k += 1.0;
            }
        }
    }
    out.sort_by_key(|e| e.t);
    out
}

/// Uniform random events in a `side`×`side` box (also the spectrum's tests' noise).
pub(super) fn noise(rate_hz: f64, side: u16, duration_us: u64, seed: u64) -> Vec<Event> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let n = (rate_hz * duration_us as f64 * 1e-6) as usize;
    let mut out: Vec<Event> = (0..n)
        .map(|_| Event {
            t: rng.random_range(0..duration_us),
            x: rng.random_range(0..side),
            y: rng.random_range(0..side),
            p: rng.random(),
        })
        .collect();
    out.sort_by_key(|e| e.t);
    out
}

/// Events from `(t, x, y, p)` tuples, sorted by time when `sorted` (also the spectrum's
/// tests').
pub(super) fn events_of(raw: Vec<(u64, u16, u16, bool)>, sorted: bool) -> Vec<Event> {
    let mut events: Vec<Event> = raw
        .into_iter()
        .map(|(t, x, y, p)| Event { t, x, y, p })
        .collect();
    if sorted {
        events.sort_by_key(|e| e.t);
    }
    events
}

/// Assert that building from `config` failed with an invalid parameter named `name` (also
/// the spectrum's tests').
pub(super) fn assert_rejects<C: std::fmt::Debug, T: std::fmt::Debug>(
    config: C,
    built: Result<T>,
    name: &str,
) {
    match built {
        Err(Error::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
        other => panic!("{config:?}: {other:?}"),
    }
}

fn run(events: &[Event], side: u16) -> Signature {
    let mut s = RotorSignature::new(
        RotorConfig::default(),
        Region::new(0, 0, side, side).unwrap(),
    )
    .unwrap();
    s.extend(events);
    s.estimate()
}

#[test]
fn finds_the_flicker_frequency_within_two_percent() {
    for (i, f) in [50.0, 73.0, 120.0, 200.0, 333.0, 520.0, 777.0, 1000.0]
        .into_iter()
        .enumerate()
    {
        let events = flicker(f, 8, 200_000, 3, 0.01, 1000 + i as u64);
        let s = run(&events, 8);
        assert!((s.frequency_hz - f).abs() <= 0.02 * f, "{f} Hz: {s:?}");
        assert!(s.detected, "{f} Hz: {s:?}");
        assert!(s.pixels >= 32, "{f} Hz: {s:?}");
    }
}

#[test]
fn uniform_noise_raises_no_peak() {
    // Seeds 1000.. (the threshold was chosen on seeds 0..199 by benches/python/rotor_noise.py).
    for seed in 1000..1010 {
        for rate in [1e3, 1e4, 1e5, 1e6] {
            let s = run(&noise(rate, 16, 200_000, seed), 16);
            assert!(!s.detected, "rate {rate}, seed {seed}: {s:?}");
        }
    }
}

#[test]
fn events_outside_the_box_and_late_ones_are_counted_and_ignored() {
    let mut s =
        RotorSignature::new(RotorConfig::default(), Region::new(10, 20, 4, 4).unwrap()).unwrap();
    s.push(Event {
        t: 5,
        x: 9,
        y: 20,
        p: true,
    });
    s.push(Event {
        t: 5,
        x: 14,
        y: 20,
        p: true,
    });
    s.push(Event {
        t: 5,
        x: 10,
        y: 24,
        p: true,
    });
    s.push(Event {
        t: 6,
        x: 13,
        y: 23,
        p: true,
    });
    s.push(Event {
        t: 4,
        x: 13,
        y: 23,
        p: false,
    });
    assert_eq!(
        s.stats(),
        RotorStats {
            events: 1,
            outside: 3,
            late: 1,
            on: 1
        }
    );
    s.clear();
    assert_eq!(s.stats(), RotorStats::default());
    assert_eq!(s.estimate(), Signature::default());
}

#[test]
fn bad_parameters_are_typed_errors() {
    let ok = RotorConfig::default();
    let region = Region::new(0, 0, 4, 4).unwrap();
    for (config, name) in [
        (
            RotorConfig {
                f_min_hz: 0.0,
                ..ok
            },
            "f_min_hz",
        ),
        (
            RotorConfig {
                f_min_hz: f64::NAN,
                ..ok
            },
            "f_min_hz",
        ),
        (
            RotorConfig {
                f_max_hz: f64::INFINITY,
                ..ok
            },
            "f_max_hz",
        ),
        (
            RotorConfig {
                f_min_hz: 1000.0,
                ..ok
            },
            "f_min_hz",
        ),
        (
            RotorConfig {
                f_max_hz: 1e6,
                ..ok
            },
            "f_max_hz",
        ),
        (RotorConfig { bins: 2, ..ok }, "bins"),
        (
            RotorConfig {
                consistency: -0.1,
                ..ok
            },
            "consistency",
        ),
        (RotorConfig { agree: 1.5, ..ok }, "agree"),
        (
            RotorConfig {
                threshold: f64::NAN,
                ..ok
            },
            "threshold",
        ),
    ] {
        assert_rejects(config, RotorSignature::new(config, region), name);
    }
}

#[test]
fn a_region_literal_is_checked_like_region_new() {
    // A struct literal skipped Region::new's cap: 65535x65535 pixels, 137 GB of state, was
    // allocated (an abort), and an empty box was accepted.
    let spectrum = crate::signature::spectrum::SpectrumConfig::default();
    for region in [
        Region {
            x0: 0,
            y0: 0,
            width: 65_535,
            height: 65_535,
        },
        Region {
            x0: 0,
            y0: 0,
            width: 0,
            height: 4,
        },
        Region {
            x0: 65_535,
            y0: 0,
            width: 2,
            height: 2,
        },
    ] {
        for err in [
            RotorSignature::new(RotorConfig::default(), region).map(|_| ()),
            crate::signature::spectrum::RotorSpectrum::new(spectrum, region).map(|_| ()),
        ] {
            let err = err.unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name: "box", .. }),
                "{region:?}: {err}"
            );
        }
    }
    let literal = Region {
        x0: 3,
        y0: 4,
        width: 5,
        height: 6,
    };
    assert_eq!(literal.validate().unwrap(), literal);
    RotorSignature::new(RotorConfig::default(), literal).unwrap();
}

#[test]
fn state_is_fixed_at_construction() {
    let mut s =
        RotorSignature::new(RotorConfig::default(), Region::new(0, 0, 16, 16).unwrap()).unwrap();
    let before = s.state_bytes();
    assert_eq!(before, 16 * 16 * 32 + 64 * 12);
    s.extend(noise(1e6, 20, 100_000, 3).as_slice());
    assert_eq!(s.state_bytes(), before);
}

#[test]
fn rate_counts_the_box_in_order_events_per_bin() {
    let mut s =
        RotorSignature::new(RotorConfig::default(), Region::new(0, 0, 4, 4).unwrap()).unwrap();
    assert!(s.rate().is_empty());
    let bytes = s.state_bytes();
    s.count_rate(1000, 10, 3).unwrap();
    assert_eq!(s.state_bytes(), bytes + 12);
    // t: before the bins, on each bin's edges, late, outside the box, after the bins.
    for (t, x) in [
        (999, 0),
        (1000, 0),
        (1009, 1),
        (1010, 2),
        (1005, 3),
        (1025, 9),
        (1029, 3),
        (1030, 0),
    ] {
        s.push(Event {
            t,
            x,
            y: 0,
            p: true,
        });
    }
    assert_eq!(s.rate(), [2, 1, 1]);
    s.clear();
    assert_eq!(s.rate(), [0, 0, 0]);
    assert!(s.count_rate(0, 0, 3).is_err());
    assert!(s.count_rate(0, 1, 0).is_err());
    assert!(s.count_rate(0, 1, MAX_RATE_BINS + 1).is_err());
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Any sequence (unsorted, outside the box, repeated times) never panics, leaves the
        /// state's size alone, and gives a sane estimate.
        #[test]
        fn never_panics_and_stays_bounded(
            events in proptest::collection::vec((any::<u64>(), 0u16..40, 0u16..40, any::<bool>()), 0..400),
            sorted in any::<bool>(),
            x0 in 0u16..20, y0 in 0u16..20, w in 1u16..20, h in 1u16..20,
        ) {
            let events = events_of(events, sorted);
            let mut s = RotorSignature::new(RotorConfig::default(), Region::new(x0, y0, w, h).unwrap()).unwrap();
            let bytes = s.state_bytes();
            s.extend(events.as_slice());
            let est = s.estimate();
            prop_assert_eq!(s.state_bytes(), bytes);
            let st = s.stats();
            prop_assert_eq!(st.events + st.outside + st.late, events.len() as u64);
            let inside: Vec<&Event> = events.iter().filter(|e| {
                (x0..x0 + w).contains(&e.x) && (y0..y0 + h).contains(&e.y)
            }).collect();
            prop_assert_eq!(st.events + st.late, inside.len() as u64);
            prop_assert_eq!(st.on, inside.iter().filter(|e| e.p).count() as u64);
            prop_assert!((0.0..=1.0).contains(&est.strength));
            prop_assert!(est.peak_votes <= est.votes && est.votes <= est.intervals);
            prop_assert!(est.pixels as usize <= s.region().area());
            prop_assert!(est.frequency_hz == 0.0 || (50.0 / 1.11..=1100.1).contains(&est.frequency_hz));
        }

        /// The rate bins hold, bin by bin, the box's in-order events (those `events` counts)
        /// whose time falls in the bin; their sum never exceeds `events`.
        #[test]
        fn rate_bins_count_the_in_order_events_of_the_box(
            events in proptest::collection::vec((0u64..2000, 0u16..12, 0u16..12, any::<bool>()), 0..300),
            sorted in any::<bool>(),
            start in 0u64..1500, bin in 1u64..300, bins in 1usize..12,
        ) {
            let events = events_of(events, sorted);
            let mut s = RotorSignature::new(RotorConfig::default(), Region::new(2, 3, 6, 5).unwrap()).unwrap();
            s.count_rate(start, bin, bins).unwrap();
            s.extend(events.as_slice());
            let mut expected = vec![0u32; bins];
            let mut latest = 0u64;
            for e in &events {
                if !((2..8).contains(&e.x) && (3..8).contains(&e.y)) || e.t < latest {
                    continue;
                }
                latest = e.t;
                if e.t >= start && ((e.t - start) / bin) < bins as u64 {
                    expected[((e.t - start) / bin) as usize] += 1;
                }
            }
            prop_assert_eq!(s.rate(), expected);
            prop_assert!(s.rate().iter().map(|&c| u64::from(c)).sum::<u64>() <= s.stats().events);
        }

        /// A single pixel with an exact period anywhere in the band comes back within 2 %.
        #[test]
        fn an_exact_period_comes_back(f in 50.0f64..1000.0, cycles in 4usize..40) {
            let period = 1e6 / f;
            let mut events = Vec::new();
            for k in 0..cycles {
                let t = 1000.0 + k as f64 * period;
                events.push(Event { t: t as u64, x: 0, y: 0, p: true });
                events.push(Event { t: (t + period / 2.0) as u64, x: 0, y: 0, p: false });
            }
            let mut s = RotorSignature::new(RotorConfig::default(), Region::new(0, 0, 1, 1).unwrap()).unwrap();
            s.extend(events.as_slice());
            let est = s.estimate();
            prop_assert!((est.frequency_hz - f).abs() <= 0.02 * f, "{} {:?}", f, est);
        }
    }
}
