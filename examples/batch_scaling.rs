//! Batch inference on 1 and 2 threads against references of the same shape measured in the
//! same run: how much of a second core this machine gives to any work, and how much of it the
//! engine's batch takes.
//!
//! ```sh
//! cargo run --release --example batch_scaling [ROUNDS] [WINDOWS]
//! ```
//!
//! The batch is the Criterion `batch_threads` group's (64 windows of 240×180 at 1 %, Table 1;
//! `WINDOWS` windows of the same recipe instead), also run on one state with `run_window` in turn
//! (no pool). The references spread 64 equal tasks over the same rayon pools: a chain of integer
//! arithmetic (no memory traffic), random writes over a private 2 MiB buffer each, and eight
//! independent chains that keep a core's integer units busy (what two hardware threads of one
//! core would share). The pools take turns for `ROUNDS` rounds (default 15); before each timed
//! run every worker of its pool is woken by an untimed task (so that no job pays for workers gone
//! to sleep after the other pool's turn, which the engine, timed first, otherwise did alone). The
//! least and the median wall time of each are printed, and their ratios 1 → 2 threads: on a
//! shared machine with slow spells the least is a calm-period figure and the median what a run
//! meets. Each batch is timed once, after other work: what a call pays to start (the second
//! worker's first job, states gone cold) weighs on 64 windows and much less on 640.

use std::hint::black_box;
use std::time::{Duration, Instant};

use rayon::prelude::*;
use uavsnn::network::infer;

#[allow(dead_code)] // each example uses part of it
#[path = "../benches/common/mod.rs"]
mod common;
use common::{batch_windows, network, BatchWindows};

/// One reference task: a chain of multiply-adds, about a millisecond's work / 16.
fn spin(seed: u64) -> u64 {
    let mut x = seed | 1;
    for _ in 0..200_000 {
        x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
    }
    x
}

/// A third reference task: eight independent chains of adds, rotates and xors, about as many
/// instructions per cycle as a core's integer units can retire — the work that two hardware
/// threads of one core would have to share, where two separate cores would not.
fn busy(seed: u64) -> u64 {
    let mut x = [0u64; 8];
    for (i, v) in x.iter_mut().enumerate() {
        *v = seed.wrapping_add(i as u64) | 1;
    }
    for _ in 0..25_000 {
        for v in &mut x {
            *v = v.rotate_left(7) ^ v.wrapping_add(0x9e37_79b9_7f4a_7c15);
        }
    }
    x.iter().fold(0, |a, &v| a ^ v)
}

/// A second reference task: random read-modify-writes over a private 2 MiB buffer (about an
/// engine state's size), the memory traffic of a window without its arithmetic.
fn touch(seed: u64) -> u64 {
    let mut buf = vec![0u32; 1 << 19];
    let mut x = seed | 1;
    for _ in 0..200_000 {
        x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let i = (x >> 45) as usize;
        buf[i] = buf[i].wrapping_add(x as u32);
    }
    buf.iter().map(|&v| u64::from(v)).sum()
}

/// 64 reference tasks `f(0..64)` spread over `pool`.
fn tasks(pool: &rayon::ThreadPool, f: fn(u64) -> u64) {
    let s: u64 = pool.install(|| (0..64u64).into_par_iter().map(f).sum());
    black_box(s);
}

/// Time `f` on `pool` after waking each of its workers with a short untimed task.
fn timed(pool: &rayon::ThreadPool, f: &mut impl FnMut(), times: &mut Vec<Duration>) {
    pool.broadcast(|_| black_box(spin(1)));
    let t = Instant::now();
    f();
    times.push(t.elapsed());
}

/// `(least, median)` of `times`.
fn summary(times: &[Duration]) -> (Duration, Duration) {
    let mut t = times.to_vec();
    t.sort_unstable();
    (t[0], t[t.len() / 2])
}

fn main() {
    let usage = "usage: batch_scaling [ROUNDS] [WINDOWS]";
    let arg = |i: usize, default: usize| {
        std::env::args()
            .nth(i)
            .map_or(default, |a| a.parse().expect(usage))
    };
    let (rounds, windows) = (arg(1, 15), arg(2, 64));
    let net = network(240, 180);
    let owned: BatchWindows = batch_windows(240, 180, 0.01, windows as u64);
    let batch = owned.batch();
    let pools: Vec<rayon::ThreadPool> = [1, 2]
        .iter()
        .map(|&n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .expect("a pool")
        })
        .collect();
    let mut engine: [Vec<Duration>; 2] = Default::default();
    let mut reference: [Vec<Duration>; 2] = Default::default();
    let mut memory: [Vec<Duration>; 2] = Default::default();
    let mut busy_ref: [Vec<Duration>; 2] = Default::default();
    let mut seq = Vec::new();
    let mut state = net.new_state();
    for _ in 0..rounds {
        timed(
            &pools[0],
            &mut || {
                for i in 0..batch.len() {
                    let w = batch.window(i).expect("valid");
                    net.run_window(&mut state, w, batch.t0[i], None, false)
                        .expect("valid");
                }
            },
            &mut seq,
        );
        for (i, pool) in pools.iter().enumerate() {
            timed(
                pool,
                &mut || {
                    pool.install(|| black_box(infer(&net, &batch, None, false).expect("valid")));
                },
                &mut engine[i],
            );
            timed(pool, &mut || tasks(pool, spin), &mut reference[i]);
            timed(pool, &mut || tasks(pool, touch), &mut memory[i]);
            timed(pool, &mut || tasks(pool, busy), &mut busy_ref[i]);
        }
    }
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let (seq_least, seq_median) = summary(&seq);
    println!(
        "one state, run_window in turn: {:.3} ms least, {:.3} ms median",
        ms(seq_least),
        ms(seq_median)
    );
    // Scaling 1 -> 2 threads of the least and of the median.
    let scaling = |d: &[Vec<Duration>; 2]| {
        let (one, two) = (summary(&d[0]), summary(&d[1]));
        (
            one.0.as_secs_f64() / two.0.as_secs_f64(),
            one.1.as_secs_f64() / two.1.as_secs_f64(),
        )
    };
    let line = |name: &str, d: &[Vec<Duration>; 2]| {
        let (one, two) = (summary(&d[0]), summary(&d[1]));
        let (s_least, s_median) = scaling(d);
        println!(
            "{name} least {:.3} ms on 1 thread, {:.3} ms on 2: {s_least:.2}x; \
             median {:.3} / {:.3} ms: {s_median:.2}x",
            ms(one.0),
            ms(two.0),
            ms(one.1),
            ms(two.1),
        );
    };
    line("engine batch:", &engine);
    line("reference:   ", &reference);
    line("memory ref.: ", &memory);
    line("busy ref.:   ", &busy_ref);
    let (e, r) = (scaling(&engine), scaling(&reference));
    println!(
        "engine's scaling over the reference's: {:.2} (least), {:.2} (median)",
        e.0 / r.0,
        e.1 / r.1
    );
}
