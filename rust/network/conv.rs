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

/// Lateral inhibition at one position (one cache line holds all of it).
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    /// Generation in which a map fired here.
    lock: u32,
    /// Group in which `best` was last written.
    group: u32,
    /// Best crossing here in the current group (index into `crossed`).
    best: u32,
}

/// Per-window state of one conv layer.
#[derive(Debug, Clone)]
pub(crate) struct ConvState {
    pub geom: ConvGeom,
    /// Float32 running potentials `[row][col][map]` (`−∞` once crossed).
    pot: Vec<f32>,
    /// Lateral-inhibition state per position.
    slots: Vec<Slot>,
    /// Per lane of a row's run: (position offset, map), to avoid dividing in the hot loop.
    lane_split: Vec<(u32, u32)>,
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
    /// Potentials written this window, counted with repeats (the cost of replaying `inputs`).
    touched_lanes: usize,
    /// Scratch: per 8 lanes of a run, which reached `θ_lo`.
    masks: Vec<u8>,
    /// Whether the CPU has AVX2 (asked once, at construction).
    avx2: bool,
}

impl ConvState {
    pub fn new(geom: ConvGeom) -> Self {
        let positions = geom.out_h * geom.out_w;
        Self {
            geom,
            pot: vec![0.0; positions * geom.maps],
            slots: vec![Slot::default(); positions],
            lane_split: (0..geom.k * geom.maps)
                .map(|l| ((l / geom.maps) as u32, (l % geom.maps) as u32))
                .collect(),
            thr: vec![f64::INFINITY; geom.maps],
            thr_hi: vec![f32::INFINITY; geom.maps],
            thr_lo: vec![f32::INFINITY; geom.k * geom.maps],
            margin: geom.kernel_len() as f64 * f64::from(f32::EPSILON),
            candidates: Vec::new(),
            band: Vec::new(),
            crossed: Vec::new(),
            touched: Vec::new(),
            inputs: Vec::new(),
            touched_lanes: 0,
            masks: vec![0; (geom.k * geom.maps).div_ceil(8)],
            avx2: has_avx2(),
        }
    }

    /// Zero the potentials that the last window touched.
    ///
    /// Replaying the window's inputs costs what their additions cost; where that would exceed
    /// one pass over the layer (a busy window on a small layer), one contiguous fill is cheaper
    /// and does the same. Either way the cost never exceeds the window's own work.
    pub fn reset(&mut self) {
        let g = self.geom;
        let maps = g.maps;
        if self.touched_lanes >= self.pot.len() {
            self.pot.fill(0.0);
        } else {
            for &(iy, ix) in &self.inputs {
                let cols = g.outputs_of(ix as usize, g.out_w);
                for oy in g.outputs_of(iy as usize, g.out_h) {
                    let start = (oy * g.out_w + cols.start) * maps;
                    self.pot[start..start + cols.len() * maps].fill(0.0);
                }
            }
        }
        self.touched_lanes = 0;
        self.inputs.clear();
        self.candidates.clear();
        self.band.clear();
        self.crossed.clear();
    }

    /// Forget the window stamps (after the window generation counter wrapped).
    pub fn clear_window_stamps(&mut self) {
        for s in &mut self.slots {
            s.lock = 0;
        }
    }

    /// Forget the group stamps (after the group counter wrapped).
    pub fn clear_group_stamps(&mut self) {
        for s in &mut self.slots {
            s.group = 0;
        }
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
        let rows = g.outputs_of(iy, g.out_h);
        let run = cols.len() * maps;
        self.touched_lanes += rows.len() * run;
        // Kernel column index j = k − 1 − dx of the first output column; each output row
        // further down reads the kernel row above (dy falls by one).
        let j0 = g.k - 1 - (ix + g.p_lo - cols.start);
        let dy0 = iy + g.p_lo - rows.start;
        let thr = &self.thr_lo[..run];
        for (step, oy) in rows.enumerate() {
            let wstart = ((c * g.k + dy0 - step) * g.k + j0) * maps;
            let start = (oy * g.out_w + cols.start) * maps;
            let hit = add_detect(
                self.avx2,
                &mut self.pot[start..start + run],
                &w[wstart..wstart + run],
                thr,
                &mut self.masks,
            );
            if hit {
                push_candidates(
                    &self.masks[..run.div_ceil(8)],
                    &self.lane_split,
                    (start / maps) as u32,
                    &mut self.candidates,
                );
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
        if self.candidates.is_empty() && self.band.is_empty() {
            return;
        }
        let maps = self.geom.maps;
        // Which candidates crossed (the band's neurons stay candidates until they do).
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.append(&mut self.band);
        for &(pos, map) in &candidates {
            if inhibit && self.slots[pos as usize].lock == generation {
                continue; // another map fired here: this one never can
            }
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
            let slot = self.slots[c.pos as usize];
            if slot.lock == generation {
                continue;
            }
            if slot.group == group {
                let b = self.crossed[slot.best as usize];
                if self.beats(kernels, fired, c, b) {
                    self.slots[c.pos as usize].best = i as u32;
                }
            } else {
                self.slots[c.pos as usize] = Slot {
                    lock: slot.lock,
                    group,
                    best: i as u32,
                };
                self.touched.push(c.pos);
            }
        }
        for &pos in &self.touched {
            let slot = &mut self.slots[pos as usize];
            slot.lock = generation;
            out.push(self.crossed[slot.best as usize]);
            // No map may fire here any more: latch them all, so none becomes a candidate again.
            let p = pos as usize * maps;
            self.pot[p..p + maps].fill(f32::NEG_INFINITY);
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

/// Record the neurons of a run whose lanes are set in `masks` as candidates.
#[cold]
fn push_candidates(masks: &[u8], split: &[(u32, u32)], pos0: u32, out: &mut Vec<(u32, u32)>) {
    for (chunk, &mask) in masks.iter().enumerate() {
        let mut mask = mask;
        while mask != 0 {
            let (dp, map) = split[chunk * 8 + mask.trailing_zeros() as usize];
            out.push((pos0 + dp, map));
            mask &= mask - 1;
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

/// `pot += w`; bit `l % 8` of `masks[l / 8]` tells whether lane `l` went from below its
/// threshold `thr` to at or above it; returns whether any did. One pass with explicit AVX2
/// (picked at run time) or SSE2 vectors; `masks` holds at least `ceil(len / 8)` bytes.
#[inline]
fn add_detect(avx2: bool, pot: &mut [f32], w: &[f32], thr: &[f32], masks: &mut [u8]) -> bool {
    let n = pot.len();
    assert!(
        w.len() >= n && thr.len() >= n && masks.len() >= n.div_ceil(8),
        "runs of equal length"
    );
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: the lengths are asserted above; `avx2` comes from `has_avx2` (the CPU has
        // it), and SSE2 is part of x86-64.
        unsafe {
            if avx2 {
                simd::add_detect_avx2(pot, w, thr, masks)
            } else {
                simd::add_detect_sse2(pot, w, thr, masks)
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = avx2;
        add_detect_scalar(pot, w, thr, masks, 0)
    }
}

/// The scalar version, from lane `from` (a multiple of 8) to the end.
#[inline]
fn add_detect_scalar(
    pot: &mut [f32],
    w: &[f32],
    thr: &[f32],
    masks: &mut [u8],
    from: usize,
) -> bool {
    let mut any = 0u8;
    let chunks = from / 8..pot.len().div_ceil(8);
    for (chunk, slot) in chunks.clone().zip(&mut masks[chunks]) {
        let mut mask = 0u8;
        for i in chunk * 8..(chunk * 8 + 8).min(pot.len()) {
            let old = pot[i];
            let new = old + w[i];
            pot[i] = new;
            mask |= u8::from(old < thr[i] && new >= thr[i]) << (i % 8);
        }
        *slot = mask;
        any |= mask;
    }
    any != 0
}

#[cfg(target_arch = "x86_64")]
mod simd {
    //! The add-and-detect kernel with explicit vectors: per 8 lanes, loads of potentials,
    //! weights and thresholds, one store, and a movemask byte (almost always 0).
    use std::arch::x86_64::{
        __m256, _mm256_add_ps, _mm256_and_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_loadu_si256,
        _mm256_maskload_ps, _mm256_maskstore_ps, _mm256_movemask_ps, _mm256_storeu_ps, _mm_add_ps,
        _mm_and_ps, _mm_cmpge_ps, _mm_cmplt_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_storeu_ps,
        _CMP_GE_OQ, _CMP_LT_OQ,
    };

    /// Eight "on" lanes then eight "off": the window at `8 − r` enables the first `r` lanes.
    static TAIL: [i32; 16] = [-1, -1, -1, -1, -1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0];

    /// The crossing mask of one vector of lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn crossed(old: __m256, new: __m256, t: __m256) -> i32 {
        _mm256_movemask_ps(_mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(old, t),
            _mm256_cmp_ps::<_CMP_GE_OQ>(new, t),
        ))
    }

    /// # Safety
    /// The CPU must support AVX2; `w`, `thr` as long as `pot`, `masks` `ceil(len / 8)` bytes.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn add_detect_avx2(
        pot: &mut [f32],
        w: &[f32],
        thr: &[f32],
        masks: &mut [u8],
    ) -> bool {
        let n = pot.len();
        let (p, wp, tp, mp) = (
            pot.as_mut_ptr(),
            w.as_ptr(),
            thr.as_ptr(),
            masks.as_mut_ptr(),
        );
        let mut any = 0;
        let mut i = 0;
        while i + 8 <= n {
            // SAFETY: i + 8 <= n, the slices hold n values and masks n / 8 bytes.
            unsafe {
                let old = _mm256_loadu_ps(p.add(i));
                let new = _mm256_add_ps(old, _mm256_loadu_ps(wp.add(i)));
                _mm256_storeu_ps(p.add(i), new);
                let mask = crossed(old, new, _mm256_loadu_ps(tp.add(i)));
                *mp.add(i / 8) = mask as u8;
                any |= mask;
            }
            i += 8;
        }
        if i < n {
            // The last 1-7 lanes in one masked vector (masked-off lanes are neither read nor
            // written, and compare as 0 < 0: not crossed).
            // SAFETY: TAIL has 16 values and 8 − (n − i) is in 1..=7; enabled lanes are below n.
            unsafe {
                let lanes = _mm256_loadu_si256(TAIL.as_ptr().add(8 - (n - i)).cast());
                let old = _mm256_maskload_ps(p.add(i), lanes);
                let new = _mm256_add_ps(old, _mm256_maskload_ps(wp.add(i), lanes));
                _mm256_maskstore_ps(p.add(i), lanes, new);
                let mask = crossed(old, new, _mm256_maskload_ps(tp.add(i), lanes));
                *mp.add(i / 8) = mask as u8;
                any |= mask;
            }
        }
        any != 0
    }

    /// # Safety
    /// `w`, `thr` as long as `pot`, `masks` `ceil(len / 8)` bytes.
    pub(super) unsafe fn add_detect_sse2(
        pot: &mut [f32],
        w: &[f32],
        thr: &[f32],
        masks: &mut [u8],
    ) -> bool {
        let n = pot.len();
        let (p, wp, tp, mp) = (
            pot.as_mut_ptr(),
            w.as_ptr(),
            thr.as_ptr(),
            masks.as_mut_ptr(),
        );
        let mut any = 0;
        let mut i = 0;
        while i + 8 <= n {
            let mut mask = 0;
            for half in 0..2 {
                let j = i + 4 * half;
                // SAFETY: j + 4 <= n and the slices hold n values.
                unsafe {
                    let old = _mm_loadu_ps(p.add(j));
                    let new = _mm_add_ps(old, _mm_loadu_ps(wp.add(j)));
                    _mm_storeu_ps(p.add(j), new);
                    let t = _mm_loadu_ps(tp.add(j));
                    mask |= _mm_movemask_ps(_mm_and_ps(_mm_cmplt_ps(old, t), _mm_cmpge_ps(new, t)))
                        << (4 * half);
                }
            }
            // SAFETY: i / 8 < n / 8 bytes.
            unsafe { *mp.add(i / 8) = mask as u8 };
            any |= mask;
            i += 8;
        }
        let tail = i < n && super::add_detect_scalar(pot, w, thr, masks, i);
        any != 0 || tail
    }
}

/// Whether the CPU has AVX2.
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
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

    /// The vector kernels add and detect exactly like the scalar loop, at every length and
    /// alignment.
    #[test]
    fn add_detect_equals_scalar() {
        let mut s = 7u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 20) as f32
        };
        for n in 0..40 {
            for offset in 0..3 {
                let pot: Vec<f32> = (0..n + offset).map(|_| next() * 2.0).collect();
                let w: Vec<f32> = (0..n + offset).map(|_| next()).collect();
                let mut thr: Vec<f32> = (0..n + offset).map(|_| next() * 3.0).collect();
                if let Some(t) = thr.last_mut() {
                    *t = f32::INFINITY;
                }
                let (mut a, mut b) = (pot.clone(), pot.clone());
                let (mut ma, mut mb) = (vec![0u8; 8], vec![0u8; 8]);
                let any_a = add_detect(
                    has_avx2(),
                    &mut a[offset..],
                    &w[offset..],
                    &thr[offset..],
                    &mut ma,
                );
                let any_b =
                    add_detect_scalar(&mut b[offset..], &w[offset..], &thr[offset..], &mut mb, 0);
                assert_eq!((a, any_a), (b, any_b));
                assert_eq!(ma[..n.div_ceil(8)], mb[..n.div_ceil(8)]);
                #[cfg(target_arch = "x86_64")]
                {
                    let mut c = pot.clone();
                    let mut mc = vec![0u8; 8];
                    // SAFETY: lengths as required.
                    let any_c = unsafe {
                        simd::add_detect_sse2(
                            &mut c[offset..],
                            &w[offset..],
                            &thr[offset..],
                            &mut mc,
                        )
                    };
                    assert_eq!(any_c, any_b);
                    assert_eq!(mc[..n.div_ceil(8)], mb[..n.div_ceil(8)]);
                }
                assert!(any_b == mb.iter().any(|&m| m != 0));
            }
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
