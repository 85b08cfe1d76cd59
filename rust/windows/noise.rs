//! Additive uniform noise on windows (SPEC §5, the paper's noise experiment).
//!
//! For each window, `n = round(fraction · W · H)` distinct pixels are drawn uniformly over the
//! sensor, each with a time drawn uniformly in `[t0, t0 + L)`. A pixel keeps its earliest spike
//! (on equal times the signal spike), so a noise event on an already active pixel can only move
//! its spike earlier. The signal-to-noise ratio of a window is `10·log10(S / n)` dB with `S` its
//! spikes before noise (`+inf` when `n = 0`, `−inf` when `S = 0 < n`).
//!
//! Each window draws from its own generator, seeded from `(seed, window index)`, so the result
//! does not depend on the number of threads; the index counts from `first`, so noise added to
//! a set of windows part by part (each part with the index of its first window) is the noise
//! added to the whole set at once.

use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

use super::{Spike, Windows, WindowsView};
use crate::error::{check_alloc, Error, Result};

/// Windows with noise, and what was added.
#[derive(Debug, Clone, PartialEq)]
pub struct NoisyWindows {
    /// The noisy windows. `n_preceding` is the expected number of distinct active pixels once
    /// the same noise falls on the preceding interval: `P + n − P·n/(W·H)`, rounded.
    pub windows: Windows,
    /// Signal-to-noise ratio of each window in dB.
    pub snr_db: Vec<f64>,
    /// Noise events drawn per window.
    pub noise_per_window: usize,
}

/// `SplitMix64`: decorrelates the per-window seeds.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Add uniform noise to every window of `view`; `n_preceding` is carried over (see
/// [`NoisyWindows::windows`]). Window `i` of `view` draws from `(seed, first + i)`: `first` is
/// the index of `view`'s first window in the set it is a part of (0 for a whole set).
pub fn add_noise(
    view: &WindowsView<'_>,
    n_preceding: &[u64],
    fraction: f64,
    seed: u64,
    first: u64,
) -> Result<NoisyWindows> {
    if !fraction.is_finite() || !(0.0..=1.0).contains(&fraction) {
        return Err(Error::param(
            "fraction",
            format!("must be in [0, 1], got {fraction}"),
        ));
    }
    if first.checked_add(view.len() as u64).is_none() {
        return Err(Error::param(
            "first",
            format!(
                "{first} plus {} windows passes the last index, {}",
                view.len(),
                u64::MAX
            ),
        ));
    }
    if n_preceding.len() != view.len() {
        return Err(Error::Shape {
            name: "n_preceding",
            expected: format!("{} entries (one per window)", view.len()),
            got: format!("{}", n_preceding.len()),
        });
    }
    let area = view.sensor.area();
    let (width, height) = (view.sensor.width, view.sensor.height);
    // Each run of windows marks the pixels it wrote, 8 bytes a pixel.
    check_alloc(
        "sensor_size",
        || format!("adding noise on a {width}x{height} sensor"),
        area,
        8,
    )?;
    let n_noise = ((fraction * area as f64).round() as usize).min(area);
    // The output's spikes, held as `Spike`s per run and then as columns.
    let spikes = view
        .len()
        .checked_mul(n_noise)
        .and_then(|n| n.checked_add(view.t.len()))
        .unwrap_or(usize::MAX);
    check_alloc(
        "fraction",
        || {
            format!(
                "{} windows with up to {n_noise} noise spikes each (fraction {fraction} of a \
                 {width}x{height} sensor)",
                view.len()
            )
        },
        spikes,
        std::mem::size_of::<Spike>() + 12,
    )?;
    let threads = rayon::current_num_threads();
    let runs = (view.len() / 64)
        .clamp(1, 4 * threads)
        .min(view.len().max(1));
    let per = view.len().div_ceil(runs).max(1);
    let parts: Vec<(Vec<usize>, Vec<Spike>)> = (0..view.len())
        .step_by(per)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|a| noise_run(view, a, (a + per).min(view.len()), n_noise, seed, first))
        .collect();

    let mut windows = Windows::empty(view.sensor, view.length_us);
    windows.t0 = view.t0.to_vec();
    let mut total = 0;
    for (counts, spikes) in parts {
        for c in counts {
            total += c;
            windows.offsets.push(total);
        }
        windows.t.extend(spikes.iter().map(|s| s.t));
        windows.x.extend(spikes.iter().map(|s| s.x));
        windows.y.extend(spikes.iter().map(|s| s.y));
    }
    let (a, n) = (area as f64, n_noise as f64);
    windows.n_preceding = n_preceding
        .iter()
        .map(|&p| {
            let p = p as f64;
            (p + n - p * n / a).round().min(a) as u64
        })
        .collect();
    let snr_db = (0..view.len())
        .map(|i| {
            let signal = view.range(i).len() as f64;
            if n_noise == 0 {
                f64::INFINITY
            } else {
                10.0 * (signal / n).log10()
            }
        })
        .collect();
    Ok(NoisyWindows {
        windows,
        snr_db,
        noise_per_window: n_noise,
    })
}

/// Noisy spikes of windows `a..b`: counts per window and the spikes in order.
fn noise_run(
    view: &WindowsView<'_>,
    a: usize,
    b: usize,
    n_noise: usize,
    seed: u64,
    first: u64,
) -> (Vec<usize>, Vec<Spike>) {
    let sensor = view.sensor;
    let width = sensor.width as usize;
    let mut mark = vec![0u64; sensor.area()];
    let mut counts = Vec::with_capacity(b - a);
    let mut out = Vec::new();
    let mut noise: Vec<Spike> = Vec::with_capacity(n_noise);
    for i in a..b {
        let stamp = i as u64 + 1;
        let t0 = view.t0[i];
        // No overflow: `add_noise` checked `first` plus the windows.
        let mut rng = Pcg64::seed_from_u64(mix(seed ^ mix(first + i as u64)));
        noise.clear();
        for pixel in sample(&mut rng, sensor.area(), n_noise) {
            // No overflow: `WindowsView::new` keeps `t0` and the length at most 2^62.
            noise.push(Spike {
                t: t0 + rng.random_range(0..view.length_us),
                x: (pixel % width) as u16,
                y: (pixel / width) as u16,
            });
        }
        noise.sort_by_key(|s| s.t);
        let before = out.len();
        let range = view.range(i);
        let signal = range.clone().map(|j| Spike {
            t: view.t[j],
            x: view.x[j],
            y: view.y[j],
        });
        // Merge by time, signal first on ties; keep each pixel's first spike.
        let mut signal = signal.peekable();
        let mut noisy = noise.iter().copied().peekable();
        loop {
            let next = match (signal.peek(), noisy.peek()) {
                (Some(s), Some(n)) if n.t < s.t => noisy.next(),
                (Some(_), _) => signal.next(),
                (None, Some(_)) => noisy.next(),
                (None, None) => break,
            };
            let Some(s) = next else { break };
            let cell = &mut mark[sensor.index(s.x, s.y)];
            if *cell != stamp {
                *cell = stamp;
                out.push(s);
            }
        }
        counts.push(out.len() - before);
    }
    (counts, out)
}
