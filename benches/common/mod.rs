//! The synthetic bench scenes and networks, shared by the Criterion benches (`benches/engine.rs`) and the
//! instruction-count driver (`examples/engine_work.rs`): short edges sweeping sideways (what
//! Gabor kernels respond to) for 80 % of the active pixels, uniform noise for the rest, the first
//! spike per pixel, one 50 ms window each.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use uavsnn::network::{Network, NetworkConfig, Spikes, WindowBatch};

/// Window length.
pub const LENGTH_US: u64 = 50_000;
/// Windows per measured iteration (different scenes, so that caches see realistic traffic).
pub const WINDOWS: usize = 8;

/// One window's input spikes.
pub struct Window {
    pub t0: u64,
    pub t: Vec<u64>,
    pub x: Vec<u16>,
    pub y: Vec<u16>,
}

/// A synthetic window with `density` of the pixels active: moving edges plus noise, the first
/// spike per pixel, sorted by time.
pub fn scene(width: usize, height: usize, density: f64, seed: u64, t0: u64) -> Window {
    let mut rng = Pcg64::seed_from_u64(seed);
    let target = ((width * height) as f64 * density).round().max(1.0) as usize;
    let mut seen = vec![false; width * height];
    let mut spikes: Vec<(u64, u16, u16)> = Vec::with_capacity(target);
    let mut add = |spikes: &mut Vec<(u64, u16, u16)>, t: u64, x: i64, y: i64| {
        if (0..width as i64).contains(&x) && (0..height as i64).contains(&y) {
            let i = y as usize * width + x as usize;
            if !seen[i] {
                seen[i] = true;
                spikes.push((t, x as u16, y as u16));
            }
        }
    };
    let edges = target * 4 / 5;
    while spikes.len() < edges {
        // An edge of 5-20 pixels sweeping sideways for 1-4 pixels.
        let (x0, y0) = (
            rng.random_range(0..width) as f64,
            rng.random_range(0..height) as f64,
        );
        let angle = rng.random_range(0.0..std::f64::consts::PI);
        let (len, sweep) = (rng.random_range(5..21), rng.random_range(1..5));
        let start = rng.random_range(0..LENGTH_US / 2);
        let pace = rng.random_range(50..500);
        for s in 0..sweep {
            for i in 0..len {
                let x = x0 + f64::from(i) * angle.cos() - f64::from(s) * angle.sin();
                let y = y0 + f64::from(i) * angle.sin() + f64::from(s) * angle.cos();
                let t = t0 + start + u64::from(s as u32) * pace + u64::from(i as u32) * 7;
                add(&mut spikes, t.min(t0 + LENGTH_US - 1), x as i64, y as i64);
            }
        }
    }
    while spikes.len() < target {
        let t = t0 + rng.random_range(0..LENGTH_US);
        let (x, y) = (rng.random_range(0..width), rng.random_range(0..height));
        add(&mut spikes, t, x as i64, y as i64);
    }
    spikes.sort_by_key(|s| s.0);
    Window {
        t0,
        t: spikes.iter().map(|s| s.0).collect(),
        x: spikes.iter().map(|s| s.1).collect(),
        y: spikes.iter().map(|s| s.2).collect(),
    }
}

pub fn windows(width: usize, height: usize, density: f64) -> Vec<Window> {
    (0..WINDOWS)
        .map(|i| scene(width, height, density, 17 + i as u64, i as u64 * LENGTH_US))
        .collect()
}

/// Table 1 on a `width × height` sensor, weights from seed 1.
pub fn network(width: usize, height: usize) -> Network {
    let config = NetworkConfig {
        width,
        height,
        ..NetworkConfig::default()
    };
    Network::new(config, 1).expect("the default config is valid")
}

/// Conv2's threshold in the project's training recipe (`uavsnn.experiments.RECIPE_SETTINGS`).
pub const RECIPE_CONV2_THRESHOLD: f32 = 10.0;

/// Table 1 with the recipe's conv2 threshold: with untrained weights, conv2 and conv3 fire
/// about as often as in the trained models (conv2 ≈ 500 spikes per window at 1 %, not 0.2).
pub fn recipe_network(width: usize, height: usize) -> Network {
    let mut config = NetworkConfig {
        width,
        height,
        ..NetworkConfig::default()
    };
    config.conv2.threshold = RECIPE_CONV2_THRESHOLD;
    Network::new(config, 1).expect("the recipe's config is valid")
}

/// `n` scenes (seeds 100, 101, …, one `LENGTH_US` apart) as the columns of a batch.
pub struct BatchWindows {
    pub t0: Vec<u64>,
    pub offsets: Vec<i64>,
    pub t: Vec<u64>,
    pub x: Vec<u16>,
    pub y: Vec<u16>,
    pub n_preceding: Vec<i64>,
    pub sensor: (usize, usize),
}

pub fn batch_windows(width: usize, height: usize, density: f64, n: u64) -> BatchWindows {
    let ws: Vec<Window> = (0..n)
        .map(|i| scene(width, height, density, 100 + i, i * LENGTH_US))
        .collect();
    let mut offsets = vec![0i64];
    for w in &ws {
        offsets.push(offsets[offsets.len() - 1] + w.t.len() as i64);
    }
    BatchWindows {
        t0: ws.iter().map(|w| w.t0).collect(),
        offsets,
        t: ws.iter().flat_map(|w| w.t.clone()).collect(),
        x: ws.iter().flat_map(|w| w.x.clone()).collect(),
        y: ws.iter().flat_map(|w| w.y.clone()).collect(),
        n_preceding: vec![0; n as usize],
        sensor: (width, height),
    }
}

impl BatchWindows {
    /// The batch, borrowing the columns.
    pub fn batch(&self) -> WindowBatch<'_> {
        WindowBatch::new(
            self.sensor,
            LENGTH_US,
            &self.t0,
            &self.offsets,
            Spikes::new(&self.t, &self.x, &self.y).expect("equal columns"),
            &self.n_preceding,
        )
        .expect("valid windows")
    }
}
