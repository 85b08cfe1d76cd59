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
