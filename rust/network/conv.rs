//! A conv layer's per-window state: potentials, latching, candidates and lateral inhibition
//! (docs/model.md §3).
//!
//! **Exact decisions, fast accumulation.** The model's potential is the exact sum of float32
//! weights (computed in float64, where it is exact). The hot loop keeps a float32 running sum
//! instead, `[row][col][map]`, so that one input spike updates, per output row, one contiguous
//! run of `k × maps` floats against one contiguous run of weights (see `weights`). A float32
//! sum of `n` non-negative terms is within a relative `γ = n · 2⁻²⁴` of the exact sum `V`, so
//! with `m = n · 2⁻²³ ≥ 2γ`:
//!
//! - a neuron whose float32 sum `s` is below `θ_lo = θ · (1 − m)` has not crossed;
//! - one with `s ≥ θ_hi = θ · (1 + m)` has;
//! - in between (a band of a few millionths of θ, rarely visited), its exact potential is
//!   gathered from the inputs that fired and compared with θ;
//! - two potentials whose float32 sums differ by more than the error bounds compare like
//!   their exact values; closer ones are compared exactly.
//!
//! Exact potentials are also gathered where they are reported (recorded spikes, winners). So
//! every decision and every reported potential is the model's exact one.
//!
//! **Latching.** A neuron that crossed has its float32 potential set to `−∞` once its group is
//! decided, so it never passes the filter again in the window.
//!
//! **Sparse reset.** The layer records where its input spikes landed; the next window zeroes
//! exactly those runs, so nothing is swept and the hot loop carries no per-position stamps.
//! Lateral-inhibition locks are generation stamps.

use super::geometry::ConvGeom;

/// A neuron that crossed its threshold in the current timestamp group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Crossing {
    /// Position index `row * out_w + col`.
    pub pos: u32,
    pub map: u32,
    /// Exact potential with every input up to the group's time (NaN until gathered).
    pub v: f64,
    /// Float32 running potential at the end of the group.
    pub v32: f32,
}

/// Which inputs of a conv layer fired in the current window: a generation-stamp array laid out
/// `[row][col][channel]` (pixels have one channel).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fired<'a> {
    pub stamps: &'a [u32],
    pub width: usize,
    pub channels: usize,
    pub generation: u32,
}

impl Fired<'_> {
    #[inline]
    fn fired(&self, c: usize, row: usize, col: usize) -> bool {
        self.stamps[(row * self.width + col) * self.channels + c] == self.generation
    }
}

/// Per-window state of one conv layer.
#[derive(Debug, Clone)]
pub(crate) struct ConvState {
    pub geom: ConvGeom,
    /// Float32 running potentials `[row][col][map]` (`−∞` once crossed).
    pot: Vec<f32>,
    /// Generation in which a map fired at a position (lateral inhibition).
    lock: Vec<u32>,
    /// Group in which `best` was last written, per position.
    best_group: Vec<u32>,
    /// Best crossing at a position in the current group (index into `crossed`).
    best: Vec<u32>,
    /// Exact thresholds per map.
    thr: Vec<f64>,
    /// `θ_hi` per map: float32 sums at or above it have surely crossed.
    thr_hi: Vec<f32>,
    /// Filter thresholds `θ_lo` per map, tiled `k` times to match one row's run.
    thr_lo: Vec<f32>,
    /// Relative error bound `m` of the float32 sums.
    margin: f64,
    /// Neurons `(pos, map)` whose float32 sum reached `θ_lo` in the current group.
    candidates: Vec<(u32, u32)>,
    /// Earlier candidates whose exact potential was still below θ (re-checked every group).
    band: Vec<(u32, u32)>,
    /// Neurons that crossed in the current group.
    crossed: Vec<Crossing>,
    /// Positions holding a best crossing in the current group.
    touched: Vec<u32>,
    /// Input positions `(row, col)` added this window (what the next window must zero).
    inputs: Vec<(u32, u32)>,
}

impl ConvState {
    pub fn new(geom: ConvGeom) -> Self {
        let positions = geom.out_h * geom.out_w;
        Self {
            geom,
            pot: vec![0.0; positions * geom.maps],
            lock: vec![0; positions],
            best_group: vec![0; positions],
            best: vec![0; positions],
            thr: vec![f64::INFINITY; geom.maps],
            thr_hi: vec![f32::INFINITY; geom.maps],
            thr_lo: vec![f32::INFINITY; geom.k * geom.maps],
            margin: geom.kernel_len() as f64 * f64::from(f32::EPSILON),
            candidates: Vec::new(),
            band: Vec::new(),
            crossed: Vec::new(),
            touched: Vec::new(),
            inputs: Vec::new(),
        }
    }

    /// Zero the potentials that the last window touched.
    pub fn reset(&mut self) {
        let g = self.geom;
        let maps = g.maps;
        for &(iy, ix) in &self.inputs {
            let cols = g.outputs_of(ix as usize, g.out_w);
            for oy in g.outputs_of(iy as usize, g.out_h) {
                let start = (oy * g.out_w + cols.start) * maps;
                self.pot[start..start + cols.len() * maps].fill(0.0);
            }
        }
        self.inputs.clear();
        self.candidates.clear();
        self.band.clear();
        self.crossed.clear();
    }

    /// Forget the window stamps (after the window generation counter wrapped).
    pub fn clear_window_stamps(&mut self) {
        self.lock.fill(0);
    }

    /// Forget the group stamps (after the group counter wrapped).
    pub fn clear_group_stamps(&mut self) {
        self.best_group.fill(0);
    }

    /// Set the per-map thresholds for the coming window.
    pub fn set_thresholds(&mut self, thresholds: impl Fn(usize) -> f32) {
        let maps = self.geom.maps;
        for (m, t) in self.thr.iter_mut().enumerate() {
            *t = f64::from(thresholds(m));
        }
        for (hi, &t) in self.thr_hi.iter_mut().zip(&self.thr) {
            *hi = round_up(t * (1.0 + self.margin));
        }
        let slack = (1.0 - self.margin).max(0.0);
        for (i, lo) in self.thr_lo.iter_mut().enumerate() {
            *lo = round_down(self.thr[i % maps] * slack);
        }
    }

    /// Add input spike `(c, iy, ix)` (engine-layout weights `w`) to every neuron whose kernel
    /// covers it; neurons whose float32 sum reaches `θ_lo` become candidates of the group.
    #[inline]
    pub fn add(&mut self, w: &[f32], c: usize, iy: usize, ix: usize) {
        let g = self.geom;
        let maps = g.maps;
        let cols = g.outputs_of(ix, g.out_w);
        if cols.is_empty() {
            return;
        }
        self.inputs.push((iy as u32, ix as u32));
        let run = cols.len() * maps;
        // Kernel column index j = k − 1 − dx of the first output column.
        let j0 = g.k - 1 - (ix + g.p_lo - cols.start);
        for oy in g.outputs_of(iy, g.out_h) {
            let dy = iy + g.p_lo - oy;
            let wstart = ((c * g.k + dy) * g.k + j0) * maps;
            let start = (oy * g.out_w + cols.start) * maps;
            let pot = &mut self.pot[start..start + run];
            let weights = &w[wstart..wstart + run];
            let thr = &self.thr_lo[..run];
            if reaches(pot, weights, thr) {
                for (i, (v, &dw)) in pot.iter_mut().zip(weights).enumerate() {
                    let old = *v;
                    *v = old + dw;
                    if old < thr[i] && *v >= thr[i] {
                        let (pos, map) = ((start + i) / maps, (start + i) % maps);
                        self.candidates.push((pos as u32, map as u32));
                    }
                }
            } else {
                add_run(pot, weights);
            }
        }
    }

    /// The exact potential of neuron `(map, pos)`: the float64 sum of the weights of its inputs
    /// that fired.
    fn exact(&self, kernels: &[f32], fired: Fired<'_>, pos: usize, map: usize) -> f64 {
        let g = self.geom;
        let (oy, ox) = (pos / g.out_w, pos % g.out_w);
        let kernel = &kernels[map * g.kernel_len()..(map + 1) * g.kernel_len()];
        let rows = g.inputs_of(oy, g.in_h);
        let cols = g.inputs_of(ox, g.in_w);
        let mut v = 0.0;
        for c in 0..g.in_ch {
            for iy in rows.clone() {
                let dy = iy + g.p_lo - oy;
                for ix in cols.clone() {
                    if fired.fired(c, iy, ix) {
                        let dx = ix + g.p_lo - ox;
                        v += f64::from(kernel[(c * g.k + dy) * g.k + dx]);
                    }
                }
            }
        }
        v
    }

    /// Decide the crossings of the group just added and append the neurons that fire to
    /// `out`, with their exact potential when `exact` (else `v` is NaN). `kernels` are the
    /// canonical weights and `fired` the layer's inputs that fired so far.
    ///
    /// With lateral inhibition, a position that already fired this window fires nothing; among
    /// a position's crossings in the group the highest potential fires, ties going to the
    /// lowest map, and the position is locked. Without it, every crossing fires. Every neuron
    /// that crossed is latched.
    pub fn resolve(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        generation: u32,
        group: u32,
        inhibit: bool,
        exact: bool,
        out: &mut Vec<Crossing>,
    ) {
        let maps = self.geom.maps;
        // Which candidates crossed (the band's neurons stay candidates until they do).
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.append(&mut self.band);
        for &(pos, map) in &candidates {
            let i = pos as usize * maps + map as usize;
            let v32 = self.pot[i];
            let mut c = Crossing {
                pos,
                map,
                v: f64::NAN,
                v32,
            };
            if v32 < self.thr_hi[map as usize] {
                c.v = self.exact(kernels, fired, pos as usize, map as usize);
                if c.v < self.thr[map as usize] {
                    self.band.push((pos, map));
                    continue;
                }
            }
            self.crossed.push(c);
        }
        candidates.clear();
        self.candidates = candidates;
        for c in &mut self.crossed {
            self.pot[c.pos as usize * maps + c.map as usize] = f32::NEG_INFINITY;
        }
        if exact {
            for i in 0..self.crossed.len() {
                let c = self.crossed[i];
                if c.v.is_nan() {
                    self.crossed[i].v = self.exact(kernels, fired, c.pos as usize, c.map as usize);
                }
            }
        }
        if !inhibit {
            out.append(&mut self.crossed);
            return;
        }
        for i in 0..self.crossed.len() {
            let c = self.crossed[i];
            let p = c.pos as usize;
            if self.lock[p] == generation {
                continue;
            }
            if self.best_group[p] == group {
                let b = self.crossed[self.best[p] as usize];
                if self.beats(kernels, fired, c, b) {
                    self.best[p] = i as u32;
                }
            } else {
                self.best_group[p] = group;
                self.best[p] = i as u32;
                self.touched.push(c.pos);
            }
        }
        for &pos in &self.touched {
            let p = pos as usize;
            self.lock[p] = generation;
            out.push(self.crossed[self.best[p] as usize]);
        }
        self.touched.clear();
        self.crossed.clear();
    }

    /// Whether crossing `a` wins lateral inhibition over `b` (same position and group): the
    /// higher exact potential, then the lower map. Float32 sums decide where their error
    /// bounds cannot overlap; otherwise the exact potentials are gathered.
    fn beats(&self, kernels: &[f32], fired: Fired<'_>, a: Crossing, b: Crossing) -> bool {
        let (va, vb) = if a.v.is_nan() || b.v.is_nan() {
            let (sa, sb) = (f64::from(a.v32), f64::from(b.v32));
            let m = self.margin;
            if sa * (1.0 - m) > sb * (1.0 + m) {
                return true;
            }
            if sb * (1.0 - m) > sa * (1.0 + m) {
                return false;
            }
            let exact = |c: Crossing| {
                if c.v.is_nan() {
                    self.exact(kernels, fired, c.pos as usize, c.map as usize)
                } else {
                    c.v
                }
            };
            (exact(a), exact(b))
        } else {
            (a.v, b.v)
        };
        match va.total_cmp(&vb) {
            std::cmp::Ordering::Greater => true,
            std::cmp::Ordering::Equal => a.map < b.map,
            std::cmp::Ordering::Less => false,
        }
    }
}

/// The smallest float32 not below `x` (for `x ≥ 0`).
fn round_up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x {
        // y < x, y ≥ 0 and finite (x is finite and y rounded down): the next bit pattern up.
        f32::from_bits(y.to_bits() + 1)
    } else {
        y
    }
}

/// The largest float32 not above `x` (for `x ≥ 0`).
fn round_down(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x {
        // y > x ≥ 0, so y is positive and its predecessor is one bit pattern below.
        f32::from_bits(y.to_bits() - 1)
    } else {
        y
    }
}

/// Whether adding `w` to `pot` takes any value from below its threshold to at or above it
/// (read only). Branch-free so that it vectorises; the AVX2 copy is picked at run time.
#[inline]
fn reaches(pot: &[f32], w: &[f32], thr: &[f32]) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        if avx2() {
            // SAFETY: the CPU supports AVX2 (checked at run time just above).
            return unsafe { reaches_avx2(pot, w, thr) };
        }
    }
    reaches_plain(pot, w, thr)
}

#[inline(always)] // so that the AVX2 copy gets its own code
#[allow(clippy::inline_always, clippy::needless_bitwise_bool)] // `&`, `|`: branch-free
fn reaches_plain(pot: &[f32], w: &[f32], thr: &[f32]) -> bool {
    let mut any = false;
    for ((&v, &dw), &t) in pot.iter().zip(w).zip(thr) {
        any |= (v < t) & (v + dw >= t);
    }
    any
}

/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn reaches_avx2(pot: &[f32], w: &[f32], thr: &[f32]) -> bool {
    reaches_plain(pot, w, thr)
}

/// `pot += w`; the AVX2 copy is picked at run time.
#[inline]
fn add_run(pot: &mut [f32], w: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if avx2() {
            // SAFETY: the CPU supports AVX2 (checked at run time just above).
            return unsafe { add_run_avx2(pot, w) };
        }
    }
    add_run_plain(pot, w);
}

#[inline(always)] // so that the AVX2 copy gets its own code
#[allow(clippy::inline_always)]
fn add_run_plain(pot: &mut [f32], w: &[f32]) {
    for (v, &dw) in pot.iter_mut().zip(w) {
        *v += dw;
    }
}

/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn add_run_avx2(pot: &mut [f32], w: &[f32]) {
    add_run_plain(pot, w);
}

/// Whether the CPU has AVX2 (asked once).
#[cfg(target_arch = "x86_64")]
fn avx2() -> bool {
    static HAS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *HAS.get_or_init(|| std::arch::is_x86_feature_detected!("avx2"))
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact equality is the property under test
mod tests {
    use super::*;
    use crate::network::config::{NetworkConfig, Padding};
    use crate::network::geometry::Geometry;
    use crate::network::weights::ConvWeights;

    fn small(padding: Padding) -> (ConvGeom, ConvWeights) {
        let mut c = NetworkConfig {
            width: 12,
            height: 10,
            padding,
            ..NetworkConfig::default()
        };
        c.conv2.kernel = 3;
        c.pool1.kernel = 1;
        c.pool1.stride = 1;
        c.pool2.kernel = 1;
        c.pool2.stride = 1;
        c.conv3.kernel = 1;
        let g = Geometry::new(&c).unwrap().conv[0];
        let w = ConvWeights::random(&g, 0.5, 0.3, 3, 0).unwrap();
        (g, w)
    }

    /// Running potentials track a direct cross-correlation of the spikes; exact potentials
    /// equal it; `reset` zeroes everything.
    #[test]
    fn potentials_equal_direct_correlation() {
        for padding in [Padding::Same, Padding::Valid] {
            let (g, w) = small(padding);
            let mut s = ConvState::new(g);
            s.set_thresholds(|_| 1e9);
            let spikes = [(0, 0), (3, 4), (9, 11), (5, 5), (9, 0)];
            let mut stamps = vec![0u32; g.in_h * g.in_w];
            for &(y, x) in &spikes {
                stamps[y * g.in_w + x] = 1;
            }
            let fired = Fired {
                stamps: &stamps,
                width: g.in_w,
                channels: 1,
                generation: 1,
            };
            for &(y, x) in &spikes {
                s.add(w.engine(), 0, y, x);
            }
            for oy in 0..g.out_h {
                for ox in 0..g.out_w {
                    for m in 0..g.maps {
                        let mut expected = 0.0f64;
                        for &(y, x) in &spikes {
                            let (dy, dx) = (
                                y as isize - oy as isize + g.p_lo as isize,
                                x as isize - ox as isize + g.p_lo as isize,
                            );
                            if (0..g.k as isize).contains(&dy) && (0..g.k as isize).contains(&dx) {
                                expected += f64::from(w.kernel(m)[dy as usize * g.k + dx as usize]);
                            }
                        }
                        let pos = oy * g.out_w + ox;
                        assert_eq!(s.exact(w.canonical(), fired, pos, m), expected);
                        let running = f64::from(s.pot[pos * g.maps + m]);
                        assert!((running - expected).abs() <= 1e-5 * expected.max(1.0));
                    }
                }
            }
            s.reset();
            assert!(s.pot.iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn filter_threshold_is_below_the_threshold() {
        let (g, _) = small(Padding::Same);
        let mut s = ConvState::new(g);
        s.set_thresholds(|m| [1.0, 3.0, 1e-30, f32::INFINITY][m]);
        for (m, &t) in s.thr.iter().enumerate() {
            assert!(f64::from(s.thr_lo[m]) <= t * (1.0 - 25.0 * 2f64.powi(-24)));
            assert!(f64::from(s.thr_hi[m]) >= t * (1.0 + 25.0 * 2f64.powi(-24)));
        }
    }
}
