use super::*;
use ndarray::Array2;

pub(super) fn run(
    params: DvsParams,
    frames: &[Array2<f32>],
    times: &[u64],
    seed: u64,
) -> Vec<Event> {
    let (h, w) = frames[0].dim();
    let mut emu = DvsEmulator::new(params, w, h, seed).unwrap();
    let mut out = Vec::new();
    for (f, &t) in frames.iter().zip(times) {
        emu.push(&Frame::GrayF32(f.view()), t, &mut out).unwrap();
    }
    out
}

#[test]
fn ramp_crossings_are_exact_and_unbounded() {
    // ln 200 - ln 50 = 1.386 = 6.93 thresholds of 0.2: six ON events, at the crossing times.
    let p = DvsParams::ideal();
    let f = |v: f32| Array2::from_elem((1, 1), v);
    let ev = run(p, &[f(50.0), f(200.0)], &[0, 1_000_000], 0);
    assert_eq!(ev.len(), 6);
    let slope = (200.0f64.ln() - 50.0f64.ln()) / 1e6;
    for (k, e) in ev.iter().enumerate() {
        let want = (0.2 * (k + 1) as f64 / slope).round() as u64;
        assert!(e.t.abs_diff(want) <= 1, "{} vs {want}", e.t);
        assert!(e.p);
    }
}

#[test]
fn sub_threshold_changes_accumulate() {
    // Three steps of ln 1.1 = 0.095 each: none crosses 0.2 alone, together they do once.
    let f = |v: f32| Array2::from_elem((1, 1), v);
    let frames = [f(100.0), f(110.0), f(121.0), f(133.1)];
    let ev = run(DvsParams::ideal(), &frames, &[0, 10, 20, 30], 0);
    assert_eq!(ev.len(), 1);
    assert!(ev[0].t > 20 && ev[0].t <= 30, "{}", ev[0].t);
}

#[test]
fn refractory_period_spaces_events() {
    let mut p = DvsParams::ideal();
    p.refractory_us = 100_000.0;
    let f = |v: f32| Array2::from_elem((1, 1), v);
    let ev = run(p, &[f(50.0), f(200.0)], &[0, 1_000_000], 0);
    assert!(ev.len() < 6 && !ev.is_empty(), "{}", ev.len());
    for w in ev.windows(2) {
        assert!(w[1].t - w[0].t >= 100_000);
    }
}

#[test]
fn leak_rate_matches() {
    let mut p = DvsParams::ideal();
    p.leak_rate_hz = 2.0;
    let frames = vec![Array2::from_elem((20, 50), 100.0f32); 11];
    let times: Vec<u64> = (0..11).map(|k| k * 1_000_000).collect();
    let ev = run(p, &frames, &times, 3);
    let expected = 2.0 * 10.0 * 1000.0;
    let n = ev.len() as f64;
    assert!(
        (n - expected).abs() < 4.0 * expected.sqrt(),
        "{n} vs {expected}"
    );
    assert!(ev.iter().all(|e| e.p));
}

#[test]
fn deterministic_for_a_seed_whatever_the_threads() {
    let p = DvsParams {
        shot_noise_rate_hz: 50.0,
        hot_pixel_fraction: 0.01,
        ..DvsParams::default()
    };
    let frames: Vec<Array2<f32>> = (0..5)
        .map(|k| Array2::from_shape_fn((16, 24), |(y, x)| ((x * 7 + y * 3 + k * 5) % 200) as f32))
        .collect();
    let times: Vec<u64> = (0..5).map(|k| k * 10_000).collect();
    let a = run(p, &frames, &times, 7);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = pool.install(|| run(p, &frames, &times, 7));
    assert_eq!(a, b);
    assert_ne!(a, run(p, &frames, &times, 8));
    assert!(a.windows(2).all(|w| w[0].t <= w[1].t));
}

#[test]
fn rejects_impossible_parameters() {
    let bad = [
        DvsParams {
            threshold_on: 0.0,
            ..DvsParams::default()
        },
        DvsParams {
            shot_noise_rate_hz: f64::NAN,
            ..DvsParams::default()
        },
        DvsParams {
            hot_pixel_fraction: 1.5,
            ..DvsParams::default()
        },
        DvsParams {
            refractory_us: -1.0,
            ..DvsParams::default()
        },
    ];
    for p in bad {
        assert!(DvsEmulator::new(p, 4, 4, 0).is_err(), "{p:?}");
    }
    assert!(DvsEmulator::new(DvsParams::default(), 0, 4, 0).is_err());
}

#[test]
fn an_emulator_above_the_memory_cap_is_refused() {
    let err = DvsEmulator::new(DvsParams::ideal(), 65535, 65535, 0).unwrap_err();
    crate::error::assert_over_cap(&err, "frame size");
}

/// A moving edge on a small sensor: frames `k = 0..n` with the edge at column `k`.
fn moving_edge(n: usize) -> Vec<Array2<f32>> {
    (0..n)
        .map(|k| Array2::from_shape_fn((6, 9), |(_, x)| if x <= k { 200.0 } else { 40.0 }))
        .collect()
}

#[test]
fn a_late_clock_gives_the_same_events_later() {
    // Times count from the first frame: a stream whose clock starts at 2e18 µs gives the events
    // of one starting at 0, shifted (its f64 times kept no fraction of a µs there, and a run of
    // crossings 0.04 µs apart never advanced: memory filled until the process aborted).
    let frames = moving_edge(6);
    for params in [DvsParams::default(), DvsParams::ideal()] {
        let times: Vec<u64> = (0..6).map(|k| k * 1_000).collect();
        let want = run(params, &frames, &times, 7);
        assert!(want.len() > 20, "{}", want.len());
        for start in [100_000_000_000_000_000, 2_000_000_000_000_000_000] {
            let late: Vec<u64> = times.iter().map(|t| t + start).collect();
            let got = run(params, &frames, &late, 7);
            let shifted: Vec<Event> = want
                .iter()
                .map(|e| Event {
                    t: e.t + start,
                    ..*e
                })
                .collect();
            assert_eq!(got, shifted, "start {start}");
        }
    }
}

#[test]
fn frames_far_apart_are_refused_before_a_pixel_moves() {
    let frames = moving_edge(2);
    let (h, w) = frames[0].dim();
    let mut emu = DvsEmulator::new(DvsParams::default(), w, h, 3).unwrap();
    let mut out = Vec::new();
    emu.push(&Frame::GrayF32(frames[0].view()), 0, &mut out)
        .unwrap();
    // 11.6 days: the noise alone would be more events than memory holds... at a cap of 10^4.
    emu.set_max_events(10_000);
    let err = emu
        .push(
            &Frame::GrayF32(frames[1].view()),
            1_000_000_000_000,
            &mut out,
        )
        .unwrap_err();
    assert!(
        matches!(&err, Error::Simulation(m) if m.contains("microseconds")),
        "{err}"
    );
    assert!(out.is_empty());
    // Nothing moved: the next frame gives what it gives without the refused one.
    emu.push(&Frame::GrayF32(frames[1].view()), 1_000, &mut out)
        .unwrap();
    assert_eq!(out, run(DvsParams::default(), &frames, &[0, 1_000], 3));
}

#[test]
fn a_frame_over_the_cap_is_refused_and_the_emulator_with_it() {
    // ln 200 - ln 50 = 6.9 thresholds of 0.2 on each of 8 pixels a row: 48 events a row.
    let f = |v: f32| Array2::from_elem((8, 8), v);
    let mut emu = DvsEmulator::new(DvsParams::ideal(), 8, 8, 0).unwrap();
    emu.set_max_events(8 * 40);
    let mut out = Vec::new();
    emu.push(&Frame::GrayF32(f(50.0).view()), 0, &mut out)
        .unwrap();
    let err = emu
        .push(&Frame::GrayF32(f(200.0).view()), 1_000, &mut out)
        .unwrap_err();
    assert!(matches!(&err, Error::Simulation(m) if m.contains("frame 1 makes more events")));
    assert!(out.is_empty());
    let err = emu
        .push(&Frame::GrayF32(f(50.0).view()), 2_000, &mut out)
        .unwrap_err();
    assert!(matches!(&err, Error::Simulation(m) if m.contains("make a new emulator")));
    // Below the cap, the same change is fine.
    let mut emu = DvsEmulator::new(DvsParams::ideal(), 8, 8, 0).unwrap();
    emu.set_max_events(8 * 49);
    emu.push(&Frame::GrayF32(f(50.0).view()), 0, &mut out)
        .unwrap();
    emu.push(&Frame::GrayF32(f(200.0).view()), 1_000, &mut out)
        .unwrap();
    assert_eq!(out.len(), 8 * 8 * 6);
}
