//! Cost per event of the rotor signature (`uavsnn::signature`), beside the whole network's on
//! the same event streams, measured in the same run.
//!
//! - `network/240x180/1%` — Table 1's network on the engine bench's scenes (`benches/common`:
//!   moving edges and noise, 1 % of the pixels active per 50 ms window, eight windows), as in
//!   `benches/engine.rs`: the reference.
//! - `signature/sensor/240x180/1%` — the estimator over the whole sensor, fed the same events
//!   (polarities drawn from a seeded generator; the scenes carry none): the cost when nearly
//!   every event is a pixel's first. The state carries over from pass to pass (events shifted in
//!   time), as over a stream.
//! - `signature/box/flicker` — a 32×32 box where a 12×12 patch flickers at 400 Hz (runs of three
//!   events per edge) over uniform noise at 10^4 events/s, 100 ms: the worst case, where every
//!   third event is an edge and most edges vote; each pass clears the box, feeds it and reads
//!   the estimate, as for one detection.
//! - `signature/box/flicker+rate` — the same, with the box's events also counted in 5 ms bins
//!   (`count_rate`, as identification's `log_rate_swing` asks for) and their swing read: the
//!   bins' cost beside the line above.
//! - `spectrum/box/flicker` — the same box through the rate spectrum
//!   (`uavsnn::signature::spectrum`): cleared, fed and read per pass (the estimate's DFT over
//!   each counted channel is most of the cost, so the figure per event includes it).
//!
//! Criterion reports throughput in events per second (the cost per event is its inverse). Time it
//! on a quiet machine: `cargo bench --bench signature`; `-- --quick` checks that it runs.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use uavsnn::events::{Event, SensorSize};
use uavsnn::network::Spikes;
use uavsnn::signature::spectrum::{RotorSpectrum, SpectrumConfig};
use uavsnn::signature::{Region, RotorConfig, RotorSignature};

#[allow(dead_code)] // the bench uses part of it
mod common;
use common::{network, windows};
#[path = "common/rotor.rs"]
mod rotor;
use rotor::{as_events, flicker_box};

/// The bins identification counts a box's events in (`uavsnn.features.RATE_BIN_US`).
const RATE_BIN_US: u64 = 5000;

fn bench(c: &mut Criterion) {
    let (width, height, density) = (240, 180, 0.01);
    let ws = windows(width, height, density);
    let events = as_events(&ws);
    let net = network(width, height);

    let mut g = c.benchmark_group("rotor");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));

    g.throughput(Throughput::Elements(events.len() as u64));
    let mut state = net.new_state();
    g.bench_function("network/240x180/1%", |b| {
        b.iter(|| {
            for w in &ws {
                let spikes = Spikes::new(&w.t, &w.x, &w.y).expect("equal columns");
                net.run_window(&mut state, spikes, w.t0, None, false)
                    .expect("valid window");
            }
        });
    });

    let sensor = SensorSize::new(width as u16, height as u16).expect("a sensor");
    let mut whole = RotorSignature::new(
        RotorConfig::default(),
        Region::sensor(sensor).expect("a region"),
    )
    .expect("defaults are valid");
    // The state persists from one iteration to the next, as over a stream: each pass is shifted
    // past the previous one in time (an add per event), and nothing is cleared.
    let span = ws.len() as u64 * common::LENGTH_US;
    let mut offset = 0;
    g.bench_function("signature/sensor/240x180/1%", |b| {
        b.iter(|| {
            for e in &events {
                whole.push(Event {
                    t: e.t + offset,
                    ..*e
                });
            }
            offset += span;
        });
    });
    std::hint::black_box(whole.estimate());

    let flicker = flicker_box();
    let mut boxed = RotorSignature::new(
        RotorConfig::default(),
        Region::new(0, 0, 32, 32).expect("a region"),
    )
    .expect("defaults are valid");
    g.throughput(Throughput::Elements(flicker.len() as u64));
    g.bench_function("signature/box/flicker", |b| {
        b.iter(|| {
            boxed.clear();
            boxed.extend(flicker.as_slice());
            std::hint::black_box(boxed.estimate())
        });
    });

    let start = flicker.first().map_or(0, |e| e.t);
    let bins = usize::try_from((flicker.last().map_or(0, |e| e.t) - start) / RATE_BIN_US + 1)
        .expect("a few bins");
    boxed
        .count_rate(start, RATE_BIN_US, bins)
        .expect("valid bins");
    g.bench_function("signature/box/flicker+rate", |b| {
        b.iter(|| {
            boxed.clear();
            boxed.extend(flicker.as_slice());
            std::hint::black_box((boxed.estimate(), boxed.rate_swing()))
        });
    });

    let mut spectrum = RotorSpectrum::new(
        SpectrumConfig::default(),
        Region::new(0, 0, 32, 32).expect("a region"),
    )
    .expect("defaults are valid");
    g.bench_function("spectrum/box/flicker", |b| {
        b.iter(|| {
            spectrum.clear();
            spectrum.extend(flicker.as_slice());
            std::hint::black_box(spectrum.estimate())
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
