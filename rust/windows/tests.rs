//! Windowing against a direct transcription of its definition.

use proptest::prelude::*;

use super::*;
use crate::events::Event;

fn ev(t: u64, x: u16, y: u16) -> Event {
    Event { t, x, y, p: true }
}

/// The definition, window by window, with no cleverness: O(windows × events).
fn reference(events: &[Event], sensor: SensorSize, config: &WindowConfig) -> Windows {
    let mut w = Windows::empty(sensor, config.length_us);
    let Some(start) = config.start_us.or(events.first().map(|e| e.t)) else {
        return w;
    };
    let end = config
        .end_us
        .unwrap_or_else(|| events.last().map_or(start, |e| (e.t + 1).max(start)));
    let mut t0 = start;
    while t0 < end {
        let mut seen = std::collections::HashSet::new();
        let mut spikes = Vec::new();
        for e in events {
            if e.t >= t0 && e.t < t0 + config.length_us && e.t < end && seen.insert((e.x, e.y)) {
                spikes.push(Spike {
                    t: e.t,
                    x: e.x,
                    y: e.y,
                });
            }
        }
        if config.median {
            let xs: Vec<u16> = spikes.iter().map(|s| s.x).collect();
            let ys: Vec<u16> = spikes.iter().map(|s| s.y).collect();
            let keep = median_keep(sensor, &xs, &ys).unwrap();
            let mut it = keep.iter();
            spikes.retain(|_| *it.next().unwrap());
        }
        let lo = t0.saturating_sub(config.length_us);
        let preceding: std::collections::HashSet<_> = events
            .iter()
            .filter(|e| e.t >= lo && e.t < t0)
            .map(|e| (e.x, e.y))
            .collect();
        w.t0.push(t0);
        w.n_preceding.push(preceding.len() as u64);
        for s in &spikes {
            w.t.push(s.t);
            w.x.push(s.x);
            w.y.push(s.y);
        }
        w.offsets.push(w.t.len());
        t0 += config.step_us;
    }
    w
}

#[test]
fn step_rounds_down_but_respects_decimal_overlaps() {
    assert_eq!(window_step(10_000, 0.9).unwrap(), 1_000);
    assert_eq!(window_step(10_000, 0.5).unwrap(), 5_000);
    assert_eq!(window_step(10_000, 0.1).unwrap(), 9_000);
    assert_eq!(window_step(7, 0.5).unwrap(), 3);
    assert_eq!(window_step(1, 0.99).unwrap(), 1);
    assert!(window_step(0, 0.0).is_err());
    assert!(window_step(10, 1.0).is_err());
    assert!(window_step(10, -0.1).is_err());
    assert!(window_step(10, f64::NAN).is_err());
}

#[test]
fn first_event_per_pixel_and_preceding_counts() {
    let sensor = SensorSize::new(4, 4).unwrap();
    let events = [
        ev(100, 0, 0),
        ev(101, 0, 0),
        ev(105, 1, 0),
        ev(112, 0, 0),
        ev(125, 2, 2),
    ];
    let config = WindowConfig::new(10, 0.5).unwrap();
    let w = make_windows(&events, sensor, &config).unwrap();
    assert_eq!(w.t0, vec![100, 105, 110, 115, 120, 125]);
    // [100,110): (0,0)@100 (its repeat at 101 is dropped), (1,0)@105; [105,115): (1,0)@105,
    // (0,0)@112; [110,120): (0,0)@112; [115,125): nothing; then (2,2)@125 twice.
    assert_eq!(w.offsets, vec![0, 2, 4, 5, 5, 6, 7]);
    assert_eq!(w.t, vec![100, 105, 105, 112, 112, 125, 125]);
    assert_eq!(w.x, vec![0, 1, 1, 0, 0, 2, 2]);
    assert_eq!(w.n_preceding, vec![0, 1, 2, 2, 1, 0]);
    assert_eq!(w, reference(&events, sensor, &config));
}

#[test]
fn empty_streams_and_ranges() {
    let sensor = SensorSize::new(4, 4).unwrap();
    let config = WindowConfig::new(10, 0.0).unwrap();
    assert!(make_windows(&[], sensor, &config).unwrap().is_empty());
    let ranged = config.with_range(Some(0), Some(30));
    let w = make_windows(&[], sensor, &ranged).unwrap();
    assert_eq!(w.t0, vec![0, 10, 20]);
    assert_eq!(w.offsets, vec![0, 0, 0, 0]);
    let bad = config.with_range(Some(30), Some(20));
    assert!(matches!(
        make_windows(&[], sensor, &bad),
        Err(Error::InvalidParameter { name: "end_us", .. })
    ));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let sensor = SensorSize::new(4, 4).unwrap();
    let config = WindowConfig::new(10, 0.0).unwrap();
    let unsorted = [ev(5, 0, 0), ev(4, 0, 0)];
    assert!(matches!(
        make_windows(&unsorted, sensor, &config),
        Err(Error::InvalidEvent { index: 1, .. })
    ));
    let outside = [ev(5, 4, 0)];
    assert!(make_windows(&outside, sensor, &config).is_err());
    let late = [ev(MAX_TIME_US + 1, 0, 0)];
    assert!(make_windows(&late, sensor, &config).is_err());
    let tiny_step = WindowConfig::new(1, 0.0).unwrap();
    let far = [ev(0, 0, 0), ev(1 << 40, 0, 0)];
    assert!(make_windows(&far, sensor, &tiny_step).is_err());
}

#[test]
fn median_keeps_dense_blocks_and_drops_isolated_pixels() {
    let sensor = SensorSize::new(5, 5).unwrap();
    // A full 3x3 block at the corner plus one isolated pixel.
    let mut xs = vec![];
    let mut ys = vec![];
    for y in 0..3 {
        for x in 0..3 {
            xs.push(x);
            ys.push(y);
        }
    }
    xs.push(4);
    ys.push(4);
    let keep = median_keep(sensor, &xs, &ys).unwrap();
    // Corner (0,0) sees 4 active pixels inside the sensor (zero padding): dropped.
    assert!(!keep[0]);
    // Centre (1,1) sees 9; edges (1,0) see 6: kept.
    assert!(keep[4] && keep[1]);
    // (2,2) sees 4: dropped; the isolated pixel sees 1: dropped.
    assert!(!keep[8] && !keep[9]);
    assert!(median_keep(sensor, &[5], &[0]).is_err());
}

#[test]
fn frames_embed_times_and_mark_silence() {
    let sensor = SensorSize::new(3, 2).unwrap();
    let events = [ev(10, 0, 0), ev(13, 2, 1), ev(14, 0, 0)];
    let w = make_windows(&events, sensor, &WindowConfig::new(10, 0.0).unwrap()).unwrap();
    let f = frames(&w.view().unwrap(), &[0]).unwrap();
    assert_eq!(f.len(), 6);
    assert_eq!(f[0].to_bits(), 0.0f32.to_bits());
    assert_eq!(f[5].to_bits(), 3.0f32.to_bits());
    assert!(f[1].is_infinite() && f[4].is_infinite());
    assert!(frames(&w.view().unwrap(), &[1]).is_err());
}

#[test]
fn view_rejects_inconsistent_columns() {
    let sensor = SensorSize::new(3, 2).unwrap();
    let ok = WindowsView::new(sensor, 10, &[0], &[0, 1], &[5], &[1], &[1]);
    assert!(ok.is_ok());
    assert!(WindowsView::new(sensor, 10, &[0], &[0, 2], &[5], &[1], &[1]).is_err());
    assert!(WindowsView::new(sensor, 10, &[0], &[0, 1], &[10], &[1], &[1]).is_err());
    assert!(WindowsView::new(sensor, 10, &[0], &[0, 1], &[5], &[3], &[1]).is_err());
    assert!(WindowsView::new(sensor, 10, &[0, 5], &[0, 1, 0], &[5], &[1], &[1]).is_err());
    assert!(WindowsView::new(sensor, 10, &[0], &[0, 2], &[5, 4], &[1, 2], &[1, 1]).is_err());
}

#[test]
fn noise_adds_the_requested_pixels_and_reports_snr() {
    let sensor = SensorSize::new(20, 10).unwrap();
    let events: Vec<Event> = (0..50).map(|i| ev(i * 2, (i % 20) as u16, 0)).collect();
    let w = make_windows(&events, sensor, &WindowConfig::new(50, 0.0).unwrap()).unwrap();
    let noisy = add_noise(&w.view().unwrap(), &w.n_preceding, 0.05, 7, 0).unwrap();
    assert_eq!(noisy.noise_per_window, 10);
    let again = add_noise(&w.view().unwrap(), &w.n_preceding, 0.05, 7, 0).unwrap();
    assert_eq!(noisy, again);
    let nv = noisy.windows.view().unwrap();
    WindowsView::new(sensor, 50, nv.t0, nv.offsets, nv.t, nv.x, nv.y).unwrap();
    for i in 0..w.len() {
        let signal = w.view().unwrap().range(i).len();
        let got = nv.range(i).len();
        assert!(got >= signal && got <= signal + 10);
        let expected = 10.0 * (signal as f64 / 10.0).log10();
        assert!((noisy.snr_db[i] - expected).abs() < 1e-12);
    }
    // PENT's estimate: the preceding interval's P distinct pixels and the same noise's N,
    // less their expected overlap, round(P + N - P·N/(W·H)).
    assert!(
        w.n_preceding.iter().any(|&p| p >= 20),
        "a window with a busy past"
    );
    let area = sensor.area() as f64;
    for fraction in [0.05, 0.5] {
        let noisy = add_noise(&w.view().unwrap(), &w.n_preceding, fraction, 7, 0).unwrap();
        let n = noisy.noise_per_window as f64;
        let expected: Vec<u64> = w
            .n_preceding
            .iter()
            .map(|&p| (p as f64 + n - p as f64 * n / area).round() as u64)
            .collect();
        assert_eq!(noisy.windows.n_preceding, expected, "fraction {fraction}");
    }
    assert!(add_noise(&w.view().unwrap(), &w.n_preceding, 1.5, 0, 0).is_err());
    assert!(add_noise(&w.view().unwrap(), &w.n_preceding, f64::NAN, 0, 0).is_err());
    let err = add_noise(&w.view().unwrap(), &w.n_preceding, 0.05, 0, u64::MAX).unwrap_err();
    assert!(
        matches!(err, Error::InvalidParameter { name: "first", .. }),
        "{err}"
    );
}

#[test]
fn noise_added_part_by_part_is_the_noise_added_at_once() {
    let sensor = SensorSize::new(20, 10).unwrap();
    let events: Vec<Event> = (0..400)
        .map(|i| ev(i * 2, (i % 20) as u16, (i % 7) as u16))
        .collect();
    let w = make_windows(&events, sensor, &WindowConfig::new(50, 0.5).unwrap()).unwrap();
    let whole = add_noise(&w.view().unwrap(), &w.n_preceding, 0.1, 11, 0).unwrap();
    let n = w.len();
    assert!(n >= 10, "{n} windows");
    for cut in [1, n / 3, n - 1] {
        let (t0, offsets) = (&w.t0, &w.offsets);
        let mut spikes = 0;
        for (a, b) in [(0, cut), (cut, n)] {
            let base = offsets[a];
            let part_offsets: Vec<usize> = offsets[a..=b].iter().map(|&o| o - base).collect();
            let (lo, hi) = (offsets[a], offsets[b]);
            let part = WindowsView::new(
                sensor,
                w.length_us,
                &t0[a..b],
                &part_offsets,
                &w.t[lo..hi],
                &w.x[lo..hi],
                &w.y[lo..hi],
            )
            .unwrap();
            let noisy = add_noise(&part, &w.n_preceding[a..b], 0.1, 11, a as u64).unwrap();
            let (wo, po) = (&whole.windows.offsets, &noisy.windows.offsets);
            assert_eq!(po.len(), b - a + 1);
            for i in 0..b - a {
                let (ws, we) = (wo[a + i], wo[a + i + 1]);
                let (ps, pe) = (po[i], po[i + 1]);
                assert_eq!(
                    whole.windows.t[ws..we],
                    noisy.windows.t[ps..pe],
                    "window {}",
                    a + i
                );
                assert_eq!(whole.windows.x[ws..we], noisy.windows.x[ps..pe]);
                assert_eq!(whole.windows.y[ws..we], noisy.windows.y[ps..pe]);
            }
            assert_eq!(whole.snr_db[a..b], noisy.snr_db[..]);
            assert_eq!(
                whole.windows.n_preceding[a..b],
                noisy.windows.n_preceding[..]
            );
            spikes += noisy.windows.t.len();
        }
        assert_eq!(spikes, whole.windows.t.len(), "cut at {cut}");
    }
    // Another start draws other noise.
    let shifted = add_noise(&w.view().unwrap(), &w.n_preceding, 0.1, 11, 1).unwrap();
    assert_ne!(shifted.windows.t, whole.windows.t);
}

fn arb_stream() -> impl Strategy<Value = (Vec<Event>, u64, f64, bool)> {
    (
        prop::collection::vec((0u64..40, 0u16..6, 0u16..5), 0..120),
        1u64..30,
        prop::sample::select(vec![0.0, 0.1, 0.5, 0.75, 0.9]),
        any::<bool>(),
    )
        .prop_map(|(raw, length, overlap, median)| {
            let mut t = 1_000;
            let events = raw
                .into_iter()
                .map(|(dt, x, y)| {
                    t += dt / 4;
                    ev(t, x, y)
                })
                .collect();
            (events, length, overlap, median)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn windows_equal_the_definition((events, length, overlap, median) in arb_stream()) {
        let sensor = SensorSize::new(6, 5).unwrap();
        let config = WindowConfig::new(length, overlap).unwrap().with_median(median);
        let got = make_windows(&events, sensor, &config).unwrap();
        prop_assert_eq!(&got, &reference(&events, sensor, &config));
    }

    #[test]
    fn ranges_and_runs_equal_the_definition(
        (events, length, overlap, _) in arb_stream(),
        start in 990u64..1_050,
        span in 0u64..200,
    ) {
        let sensor = SensorSize::new(6, 5).unwrap();
        let config = WindowConfig::new(length, overlap)
            .unwrap()
            .with_range(Some(start), Some(start + span));
        let got = make_windows(&events, sensor, &config).unwrap();
        prop_assert_eq!(&got, &reference(&events, sensor, &config));
        // Many small runs (as on a large machine) give the same result as one.
        let grid = Grid { start, step: config.step_us, length, n: got.len() };
        let runs: Vec<_> = (0..grid.n).map(|k| (k, k + 1)).collect();
        for median in [false, true] {
            let one = build(&events, sensor, grid, start + span, median, &[(0, grid.n)]).unwrap();
            let many = build(&events, sensor, grid, start + span, median, &runs).unwrap();
            prop_assert_eq!(&one, &many);
            if config.step_us == length {
                let disjoint =
                    build_disjoint(&events, sensor, grid, start + span, median, &runs).unwrap();
                prop_assert_eq!(&one, &disjoint);
            }
        }
    }
}

#[test]
fn view_checks_every_offset_before_reading_spikes() {
    // A middle offset past the spikes, followed by a smaller one, used to be read as a range
    // before the later decrease was seen (an index out of bounds).
    let sensor = SensorSize::new(4, 4).unwrap();
    let zeros = [0u64; 5];
    let small = [0u16; 5];
    for offsets in [[0, 100, 5], [0, usize::MAX, 5]] {
        let err =
            WindowsView::new(sensor, 10, &[0, 0], &offsets, &zeros, &small, &small).unwrap_err();
        assert!(
            matches!(
                err,
                Error::Shape {
                    name: "offsets",
                    ..
                }
            ),
            "{offsets:?}: {err}"
        );
    }
}

#[test]
fn view_refuses_window_starts_past_max_time() {
    let sensor = SensorSize::new(4, 4).unwrap();
    WindowsView::new(sensor, MAX_TIME_US, &[MAX_TIME_US], &[0, 0], &[], &[], &[]).unwrap();
    for t0 in [MAX_TIME_US + 1, u64::MAX - 5] {
        let err = WindowsView::new(sensor, 10, &[t0], &[0, 0], &[], &[], &[]).unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "t0", .. }),
            "{err}"
        );
    }
    // So noise times never wrap: the latest start and the longest window still fit.
    let view =
        WindowsView::new(sensor, MAX_TIME_US, &[MAX_TIME_US], &[0, 0], &[], &[], &[]).unwrap();
    let noisy = add_noise(&view, &[0], 1.0, 3, 0).unwrap();
    assert_eq!(noisy.windows.t.len(), 16);
    assert!(noisy.windows.t.iter().all(|&t| t >= MAX_TIME_US));
}

#[test]
fn sensor_sized_allocations_are_capped() {
    use crate::error::MAX_ALLOC_BYTES;
    let huge = SensorSize::new(u16::MAX, u16::MAX).unwrap();
    let view = WindowsView::new(huge, 10, &[0], &[0, 0], &[], &[], &[]).unwrap();
    let is_cap = |err: Error, name: &str| crate::error::assert_over_cap(&err, name);
    is_cap(
        add_noise(&view, &[0], 0.0, 0, 0).unwrap_err(),
        "sensor_size",
    );
    is_cap(frames(&view, &[0]).unwrap_err(), "indices");
    is_cap(frames_len(&view, &[0]).unwrap_err(), "indices");
    is_cap(
        make_windows(&[ev(0, 1, 1)], huge, &WindowConfig::new(10, 0.0).unwrap()).unwrap_err(),
        "sensor_size",
    );
    // Frames: many windows of a small sensor pass the same cap.
    let small = SensorSize::new(1280, 720).unwrap();
    let t0 = vec![0u64; 2000];
    let offsets = vec![0usize; 2001];
    let view = WindowsView::new(small, 10, &t0, &offsets, &[], &[], &[]).unwrap();
    assert_eq!(frames_len(&view, &[0; 10]).unwrap(), 10 * 1280 * 720);
    let all: Vec<usize> = (0..2000).collect();
    const { assert!(2000 * 1280 * 720 * 4 > MAX_ALLOC_BYTES) };
    is_cap(frames_len(&view, &all).unwrap_err(), "indices");
    // Noise: windows × noise spikes are capped too (here 2000 × 921,600).
    is_cap(
        add_noise(&view, &[0; 2000], 1.0, 0, 0).unwrap_err(),
        "fraction",
    );
}

#[test]
fn median_keep_refuses_a_sensor_above_the_memory_cap() {
    // Its per-pixel marks (8 bytes a pixel, 34 GB here) used to be allocated unchecked.
    let huge = SensorSize::new(u16::MAX, u16::MAX).unwrap();
    let err = median_keep(huge, &[0], &[0]).unwrap_err();
    crate::error::assert_over_cap(&err, "sensor_size");
    let err = MedianFilter::new(huge).unwrap_err();
    crate::error::assert_over_cap(&err, "sensor_size");
    assert_eq!(
        median_keep(SensorSize::new(3, 3).unwrap(), &[1], &[1]).unwrap(),
        [false]
    );
}

#[test]
fn view_of_inconsistent_windows_is_refused() {
    // `Windows` has public fields: edited ones used to give a view that `frames` and
    // `add_noise` trusted (an index out of bounds, a division by a zero length).
    let sensor = SensorSize::new(3, 2).unwrap();
    let events = [ev(10, 0, 0), ev(13, 2, 1), ev(14, 1, 0)];
    let good = make_windows(&events, sensor, &WindowConfig::new(10, 0.0).unwrap()).unwrap();
    good.view().unwrap();
    let mut offsets = good.clone();
    offsets.offsets = vec![0, 5];
    assert!(matches!(
        offsets.view().unwrap_err(),
        Error::Shape {
            name: "offsets",
            ..
        }
    ));
    let mut columns = good.clone();
    columns.x.pop();
    assert!(matches!(columns.view().unwrap_err(), Error::Shape { .. }));
    let mut zero = good.clone();
    zero.length_us = 0;
    assert!(matches!(
        zero.view().unwrap_err(),
        Error::InvalidParameter {
            name: "length_us",
            ..
        }
    ));
    let mut outside = good.clone();
    outside.x[0] = 3;
    assert!(matches!(
        outside.view().unwrap_err(),
        Error::InvalidEvent { index: 0, .. }
    ));
    // A checked view's columns read back through its accessors.
    let view = good.view().unwrap();
    assert_eq!(
        (view.sensor(), view.length_us(), view.t0(), view.offsets()),
        (sensor, 10, &[10u64][..], &[0usize, 3][..])
    );
    assert_eq!(
        (view.t(), view.x(), view.y()),
        (&[10u64, 13, 14][..], &[0u16, 2, 1][..], &[0u16, 1, 0][..])
    );
}

#[test]
fn a_zero_sensor_literal_is_refused_where_windows_are_made_or_read() {
    // SensorSize's fields are public: a 0x0 sensor skipped `SensorSize::new`, and windowing
    // gave the empty windows of a range on it, a view of them and a median filter.
    let zero = SensorSize {
        width: 0,
        height: 0,
    };
    let config = WindowConfig::new(10, 0.0)
        .unwrap()
        .with_range(Some(0), Some(30));
    for median in [false, true] {
        let err = make_windows(&[] as &[Event], zero, &config.with_median(median)).unwrap_err();
        crate::events::assert_zero_sensor(&err);
    }
    let no_spikes = WindowsView::new(zero, 10, &[0, 10], &[0, 0, 0], &[], &[], &[]);
    crate::events::assert_zero_sensor(&no_spikes.unwrap_err());
    let mut windows = Windows::empty(zero, 10);
    windows.t0.push(0);
    windows.offsets.push(0);
    windows.n_preceding.push(0);
    crate::events::assert_zero_sensor(&windows.view().unwrap_err());
    crate::events::assert_zero_sensor(&median_keep(zero, &[], &[]).unwrap_err());
}
