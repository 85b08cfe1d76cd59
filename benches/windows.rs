//! Windowing throughput in events per second, on synthetic streams at the paper's 240×180 and at
//! a 1280×720 (Prophesee Gen4) sensor.
//!
//! The stream: 80 % of the events on a small object crossing the sensor (a drone-like blob a few
//! pixels wide), 20 % uniform background activity, at a constant rate.
//!
//! Run: `cargo bench --bench windows`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use uavsnn::events::{Event, SensorSize};
use uavsnn::windows::{frames, make_windows, WindowConfig};

/// `n` events over `duration_us` on `sensor`, sorted by time.
fn synthetic(sensor: SensorSize, n: usize, duration_us: u64, seed: u64) -> Vec<Event> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (w, h) = (f64::from(sensor.width), f64::from(sensor.height));
    let radius = (w / 40.0).max(3.0);
    (0..n)
        .map(|i| {
            let t = i as u64 * duration_us / n as u64;
            let phase = t as f64 / duration_us as f64;
            let (x, y) = if rng.random_bool(0.8) {
                let cx = phase * (w - 1.0);
                let cy = h / 2.0 + (phase * 12.0).sin() * h / 4.0;
                (
                    cx + rng.random_range(-radius..radius),
                    cy + rng.random_range(-radius..radius),
                )
            } else {
                (rng.random_range(0.0..w), rng.random_range(0.0..h))
            };
            Event {
                t,
                x: x.clamp(0.0, w - 1.0) as u16,
                y: y.clamp(0.0, h - 1.0) as u16,
                p: rng.random_bool(0.5),
            }
        })
        .collect()
}

fn bench_windows(c: &mut Criterion) {
    let cases = [
        (
            "240x180",
            SensorSize::new(240, 180).unwrap(),
            2_000_000usize,
        ),
        (
            "1280x720",
            SensorSize::new(1280, 720).unwrap(),
            4_000_000usize,
        ),
    ];
    for (name, sensor, n) in cases {
        let events = synthetic(sensor, n, 2_000_000, 7);
        let mut group = c.benchmark_group(format!("windows/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(n as u64));
        for (length, overlap, median) in [
            (10_000u64, 0.0, false),
            (10_000, 0.5, false),
            (10_000, 0.9, false),
            (50_000, 0.5, false),
            (10_000, 0.5, true),
        ] {
            let config = WindowConfig::new(length, overlap)
                .unwrap()
                .with_median(median);
            let id = format!(
                "L{}ms_o{}{}",
                length / 1000,
                (overlap * 100.0) as u32,
                if median { "_median" } else { "" }
            );
            group.bench_function(BenchmarkId::from_parameter(id), |b| {
                b.iter(|| make_windows(&events, sensor, &config).unwrap());
            });
        }
        let config = WindowConfig::new(10_000, 0.5).unwrap();
        let windows = make_windows(&events, sensor, &config).unwrap();
        let all: Vec<usize> = (0..windows.len()).collect();
        let view = windows.view().unwrap();
        group.bench_function("frames_L10ms_o50", |b| {
            b.iter(|| frames(&view, &all).unwrap());
        });
        group.finish();
    }
}

criterion_group!(benches, bench_windows);
criterion_main!(benches);
