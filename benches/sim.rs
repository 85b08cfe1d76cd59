//! Criterion benchmarks of the simulation kernels, in steady state (one simulator fed frame
//! after frame; construction is not timed).
//!
//! - `dvs/*`: the DVS emulator on one thread (a rayon pool of one) on a sine grating drifting
//!   fast at 240×180, several events per pixel per frame; ideal sensor and the default noisy
//!   one; throughput in events. Reference: evlib's published ESIM figure, 20.7 M events/s per
//!   thread. A direct measurement printed first gives the ratio by wall time and by the worker
//!   thread's CPU time (the fair one on a shared machine).
//! - `pix2nvs/*`: frames per second at 240×180 gray, and the paper's path — 1440×1080 BGR (a
//!   1080p frame cropped to 4:3) pooled onto 240×180 — on one thread and on all threads.

use std::time::{Duration, Instant};

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use ndarray::{Array2, Array3};
use uavsnn::events::Event;
use uavsnn::sim::{DvsEmulator, DvsParams, Frame, Pix2Nvs, Pix2NvsParams, Pooling};

/// evlib's published ESIM throughput, events per second per thread.
const ESIM_EVENTS_PER_S: f64 = 20.7e6;

/// Frames of one grating cycle: 7 px per frame over a 24 px period, so the cycle repeats
/// seamlessly.
const CYCLE: usize = 24;

/// A sine grating drifting fast: every pixel crosses several thresholds per frame.
fn grating(width: usize, height: usize) -> Vec<Array2<u8>> {
    (0..CYCLE)
        .map(|k| {
            Array2::from_shape_fn((height, width), |(y, x)| {
                let phase = (x as f64 + 0.5 * y as f64 - 7.0 * k as f64) / 24.0;
                (128.0 + 120.0 * (std::f64::consts::TAU * phase).sin()) as u8
            })
        })
        .collect()
}

/// A bright disc moving over a checkered background, in BGR.
fn shapes_bgr(width: usize, height: usize, frames: usize) -> Vec<Array3<u8>> {
    (0..frames)
        .map(|k| {
            Array3::from_shape_fn((height, width, 3), |(y, x, c)| {
                let cx = (200 + 25 * k) as f64;
                let cy = (height / 2) as f64 + 40.0 * (k as f64 * 0.3).sin();
                let r = ((x as f64 - cx).powi(2) + (y as f64 - cy).powi(2)).sqrt();
                let texture = ((x / 16 + y / 16) % 2) as f64 * 30.0;
                let v = if r < 90.0 { 230.0 } else { 60.0 + texture };
                (v * (0.8 + 0.1 * c as f64)) as u8
            })
        })
        .collect()
}

fn one_thread() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool")
}

/// CPU time the calling thread has run, from Linux's `/proc/thread-self/schedstat`; `None`
/// elsewhere. On a shared machine this, unlike wall time, does not count waiting for a core.
fn thread_cpu() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = stat.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

/// An emulator that has seen one cycle, so that timing starts in steady state.
fn warm_emulator(params: DvsParams, frames: &[Array2<u8>], t: &mut u64) -> DvsEmulator {
    let (h, w) = frames[0].dim();
    let mut emu = DvsEmulator::new(params, w, h, 1).expect("valid parameters");
    let mut out = Vec::new();
    for f in frames {
        *t += 1000;
        emu.push(&Frame::Gray(f.view()), *t, &mut out)
            .expect("valid frame");
    }
    emu
}

/// Events of `cycles` grating cycles (1 kHz frames); returns the count.
fn run_cycles(emu: &mut DvsEmulator, frames: &[Array2<u8>], t: &mut u64, cycles: usize) -> usize {
    let mut out = Vec::new();
    let mut n = 0;
    for _ in 0..cycles {
        for f in frames {
            *t += 1000;
            out.clear();
            emu.push(&Frame::Gray(f.view()), *t, &mut out)
                .expect("valid frame");
            n += out.len();
        }
    }
    n
}

/// The printed ratio against ESIM: best of a few runs of four cycles.
fn report_dvs_ratio(frames: &[Array2<u8>]) {
    let pool = one_thread();
    for (name, params) in [
        ("ideal", DvsParams::ideal()),
        ("default", DvsParams::default()),
    ] {
        let mut t = 0;
        let mut emu = warm_emulator(params, frames, &mut t);
        let (mut wall, mut cpu) = (Duration::MAX, Duration::MAX);
        let mut events = 0;
        for _ in 0..7 {
            let start = Instant::now();
            let (n, used) = pool.install(|| {
                let c0 = thread_cpu();
                let n = run_cycles(&mut emu, frames, &mut t, 4);
                (
                    n,
                    thread_cpu().zip(c0).map(|(c1, c0)| c1.saturating_sub(c0)),
                )
            });
            events = n;
            wall = wall.min(start.elapsed());
            cpu = cpu.min(used.unwrap_or(Duration::MAX));
        }
        for (clock, d) in [("wall", wall), ("thread CPU", cpu)] {
            if d == Duration::MAX {
                continue;
            }
            let rate = events as f64 / d.as_secs_f64();
            println!(
                "dvs emulator ({name}), one thread, {clock} time: {:.1} M events/s \
                 ({events} events in {:.1} ms, {:.1} ns/event) = {:.2} x ESIM's published \
                 {:.1} M events/s per thread",
                rate / 1e6,
                d.as_secs_f64() * 1e3,
                d.as_secs_f64() * 1e9 / events as f64,
                rate / ESIM_EVENTS_PER_S,
                ESIM_EVENTS_PER_S / 1e6
            );
        }
    }
}

fn bench_dvs(c: &mut Criterion) {
    let frames = grating(240, 180);
    report_dvs_ratio(&frames);
    let pool = one_thread();
    let mut group = c.benchmark_group("dvs");
    group.sample_size(20);
    for (name, params) in [
        ("ideal", DvsParams::ideal()),
        ("default", DvsParams::default()),
    ] {
        let mut t = 0;
        let mut emu = warm_emulator(params, &frames, &mut t);
        let per_cycle = run_cycles(&mut emu, &frames, &mut t, 1);
        group.throughput(Throughput::Elements(per_cycle as u64));
        group.bench_function(BenchmarkId::new("events_1thread_240x180", name), |b| {
            b.iter(|| pool.install(|| run_cycles(&mut emu, &frames, &mut t, 1)));
        });
    }
    group.finish();
}

/// One frame per iteration through a persistent simulator.
fn bench_frames<F: Sync>(
    c: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    mut sim: Pix2Nvs,
    frames: &[F],
    view: impl Fn(&F) -> Frame<'_> + Sync,
    pool: Option<&rayon::ThreadPool>,
) {
    let mut out: Vec<Event> = Vec::new();
    let mut t = 0u64;
    let mut k = 0usize;
    let mut step = |sim: &mut Pix2Nvs| {
        t += 33_333;
        out.clear();
        sim.push(&view(&frames[k % frames.len()]), t, &mut out)
            .expect("valid frame");
        k += 1;
    };
    step(&mut sim);
    c.throughput(Throughput::Elements(1));
    c.bench_function(name, |b| match pool {
        Some(pool) => b.iter(|| pool.install(|| step(&mut sim))),
        None => b.iter(|| step(&mut sim)),
    });
}

fn bench_pix2nvs(c: &mut Criterion) {
    let mut group = c.benchmark_group("pix2nvs");
    group.sample_size(30);
    let pool = one_thread();
    let params = Pix2NvsParams::default();

    let small = grating(240, 180);
    let sim = Pix2Nvs::new(params, 240, 180, None).expect("valid parameters");
    bench_frames(
        &mut group,
        "frames_1thread_240x180_gray",
        sim,
        &small,
        |f| Frame::Gray(f.view()),
        Some(&pool),
    );

    // A back-and-forth sequence, so that the cycle has no jump.
    let mut big = shapes_bgr(1440, 1080, 6);
    big.extend(big.clone().into_iter().rev());
    for (name, pool) in [
        ("frames_1thread_1440x1080_bgr_to_240x180", Some(&pool)),
        ("frames_all_threads_1440x1080_bgr_to_240x180", None),
    ] {
        let output = Some((240, 180, Pooling::Strongest));
        let sim = Pix2Nvs::new(params, 1440, 1080, output).expect("valid parameters");
        bench_frames(&mut group, name, sim, &big, |f| Frame::Bgr(f.view()), pool);
    }
    group.finish();
}

criterion_group!(benches, bench_dvs, bench_pix2nvs);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
