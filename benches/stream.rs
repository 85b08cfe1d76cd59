//! Criterion benchmarks of the streaming detector (issue 6).
//!
//! - `push/{1,100,10000}`: one `Detector::push` of a chunk of that many events, in the middle
//!   of a stream (processing latency per chunk, push to return);
//! - `throughput/stream` against `throughput/batch` (the same recording through `make_windows`
//!   and then `infer` on one thread, the "preceding" PENT estimate): the ratio of the two is
//!   the streaming path's cost relative to the batch path.
//!
//! Events: a 240×180 synthetic recording, a blob crossing the sensor over uniform noise
//! (100 k events/s), through the default network with its seeded initial weights.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use uavsnn::network::{infer, Network, NetworkConfig, PentEstimate, WindowBatch};
use uavsnn::stream::{NetworkDetector, StreamConfig};
use uavsnn::windows::{make_windows, WindowConfig};
use uavsnn::{Event, SensorSize};

const WINDOW_US: u64 = 50_000;
const OVERLAP: f64 = 0.5;

fn recording(n: usize) -> Vec<Event> {
    let mut s: u64 = 0x5eed;
    let mut next = |m: u64| {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 33) % m
    };
    let mut t = 1_000_000;
    (0..n)
        .map(|i| {
            t += next(20); // 10 µs apart on average: 100 k events/s
            let (x, y) = if next(3) == 0 {
                let cx = 20 + (i as u64 * 200 / n as u64);
                (cx + next(8), 86 + next(8))
            } else {
                (next(240), next(180))
            };
            Event {
                t,
                x: x as u16,
                y: y as u16,
                p: next(2) == 0,
            }
        })
        .collect()
}

fn network() -> Network {
    let mut c = NetworkConfig::default();
    c.pent.estimate = PentEstimate::Preceding;
    Network::new(c, 0).expect("default network")
}

fn detector(net: &Network) -> NetworkDetector {
    let config = StreamConfig {
        window_us: WINDOW_US,
        overlap: OVERLAP,
        start_us: None,
    };
    NetworkDetector::new(net.clone(), config).expect("detector")
}

fn push_latency(c: &mut Criterion) {
    let net = network();
    let events = recording(400_000);
    let mut group = c.benchmark_group("push");
    for size in [1usize, 100, 10_000] {
        group.throughput(Throughput::Elements(size as u64));
        // Warm the detector on the first half; then push consecutive chunks of the second
        // half, starting over (with a fresh warm detector) when it runs out.
        let half = events.len() / 2;
        let mut det = detector(&net);
        let mut out = Vec::new();
        det.push(&events[..half], &mut out).expect("warm-up");
        let mut at = half;
        group.bench_function(size.to_string(), |b| {
            b.iter_custom(|iters| {
                let mut spent = Duration::ZERO;
                for _ in 0..iters {
                    if at + size > events.len() {
                        // Start over, unmeasured, with a freshly warmed detector.
                        det.reset();
                        det.push(&events[..half], &mut out).expect("warm-up");
                        at = half;
                    }
                    out.clear();
                    let start = Instant::now();
                    det.push(black_box(&events[at..at + size]), &mut out)
                        .expect("push");
                    spent += start.elapsed();
                    at += size;
                }
                spent
            });
        });
    }
    group.finish();
}

fn throughput(c: &mut Criterion) {
    let net = network();
    let events = recording(200_000);
    let sensor = SensorSize::new(240, 180).expect("sensor");
    let mut group = c.benchmark_group("throughput");
    group.sample_size(10);
    group.throughput(Throughput::Elements(events.len() as u64));
    group.bench_function("stream", |b| {
        b.iter_batched(
            || detector(&net),
            |mut det| {
                let mut out = Vec::new();
                for chunk in events.chunks(10_000) {
                    det.push(chunk, &mut out).expect("push");
                }
                det.flush(&mut out).expect("flush");
                out.len()
            },
            BatchSize::LargeInput,
        );
    });
    group.bench_function("batch", |b| {
        b.iter(|| {
            let config = WindowConfig::new(WINDOW_US, OVERLAP).expect("config");
            let w = make_windows(&events, sensor, &config).expect("windows");
            let results = WindowBatch::with_windows(&w, |batch| infer(&net, batch, Some(1), false))
                .expect("infer");
            results.iter().map(|r| r.detections.len()).sum::<usize>()
        });
    });
    group.finish();
}

criterion_group!(benches, push_latency, throughput);
criterion_main!(benches);
