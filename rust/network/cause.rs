//! The input spikes that caused a detection (docs/model.md §5), for its box.
//!
//! A conv neuron that fires at `t` was caused by the inputs of its receptive field that fired at
//! or before `t` (they are what its potential summed); a pool neuron that fires at `t` by the
//! neurons of its map in its block that fired at `t` (its first spikes). Following these links
//! down from a conv3 spike reaches the sensor pixels that caused it; its box is their bounding
//! box.
//!
//! Per event, only the pool layers note their causes (one bit per conv spike that lands in a
//! pool neuron as it fires, see `PoolState::on_spikes`). When a conv3 neuron fires, the links are
//! followed, with every pool neuron's box kept once computed in the window, so a window's boxes
//! together cost at most one visit of each conv neuron's receptive field that some detection
//! reaches; and a pool neuron's box walks the fields of its causes together (`block_box`), so
//! that an input is visited once per pool box rather than once per cause whose field holds it.
//! Boxes are kept as lanes whose union is one lane-wise minimum (`Lanes`).

use std::ops::Range;

use super::conv::{each_fired_input, Fired};
use super::geometry::{Divider, Geometry};
use super::pool::PoolState;
use crate::simd::{fired_mask, min_u16x4, Avx2};

/// A half-open pixel box `(x0, y0, x1, y1)`.
pub(crate) type PixelBox = (u16, u16, u16, u16);

/// A pixel box as four 16-bit lanes of a word, `x0, y0, !x1, !y1` from the lowest (`!x` is
/// `u16::MAX − x`), so that the union of two is their lane-wise minimum: on x86-64 two SSE2
/// instructions on the lanes together, instead of two `min`s and two `max`es one at a time.
/// `EMPTY` holds no pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Lanes(u64);

const EMPTY: Lanes = Lanes(u64::MAX);

impl Lanes {
    fn new(x0: u16, y0: u16, x1: u16, y1: u16) -> Self {
        let lane = |v: u16, k: u32| u64::from(v) << (16 * k);
        Self(lane(x0, 0) | lane(y0, 1) | lane(!x1, 2) | lane(!y1, 3))
    }

    fn pixel_box(self) -> PixelBox {
        let lane = |k: u32| (self.0 >> (16 * k)) as u16;
        (lane(0), lane(1), !lane(2), !lane(3))
    }
}

/// The lane-wise minimum of two boxes' lanes (the box that holds both, see `Lanes`).
#[inline]
fn union(a: Lanes, b: Lanes) -> Lanes {
    Lanes(min_u16x4(a.0, b.0))
}

/// What the links are followed through: the window's pixels and pool layers.
pub(crate) struct Window<'a> {
    pub geom: &'a Geometry,
    /// Each conv layer's lanes of a receptive field's row (`ConvState::input_split`; for
    /// `conv_box`, the walk of pool boxes whose causes' fields are not walked together).
    pub splits: [&'a [(u32, u32)]; 3],
    pub width: usize,
    pub generation: u32,
    /// Per pixel: generation in which it fired, and when.
    pub pixel_fired: &'a [u32],
    pub pixel_time: &'a [u64],
    pub pool: &'a [PoolState; 2],
}

/// Per-window state for the boxes of detections: each pool neuron's box, once computed.
#[derive(Debug, Clone)]
pub(crate) struct Causes {
    /// Per pool1 / pool2 neuron: generation in which its box was computed, and the box (side
    /// by side: a box computed already costs one read).
    boxes: [Vec<(u32, Lanes)>; 2],
    /// Division by each conv layer's output width.
    split: [Divider; 3],
    /// Division by each pool layer's kernel side (block bit → block row and column).
    side: [Divider; 2],
    /// Division by each pool layer's maps and output width (neuron index → map, row, column).
    maps: [Divider; 2],
    pool_w: [Divider; 2],
    /// Whether a pool layer's box walks the fields of its causes together (`block_box`): when
    /// its block side is at most one more than the conv kernel's, so that the columns the
    /// causes of a row read are one run.
    merge: [bool; 2],
    /// Scratch of `block_box`, per pool layer: per block row holding causes, the input rows
    /// and columns their fields read.
    strips: [Vec<(usize, usize, usize, usize)>; 2],
    /// Whether the CPU has AVX2 (asked once: the walk is compiled for it, see `conv3_box`).
    avx2: Option<Avx2>,
}

impl Causes {
    pub fn new(geom: &Geometry) -> Self {
        let pool = |l: usize| geom.pool[l].neurons();
        Self {
            boxes: [vec![(0, EMPTY); pool(0)], vec![(0, EMPTY); pool(1)]],
            split: geom.conv.map(|g| Divider::new(g.out_w)),
            side: geom.pool.map(|g| Divider::new(g.k)),
            maps: geom.pool.map(|g| Divider::new(g.maps)),
            pool_w: geom.pool.map(|g| Divider::new(g.out_w)),
            merge: [0, 1].map(|l| geom.pool[l].k <= geom.conv[l].k + 1),
            strips: Default::default(),
            avx2: Avx2::detect(),
        }
    }

    /// Walk the causes with the scalar kernels, as on a CPU without AVX2.
    #[cfg(test)]
    pub fn set_scalar(&mut self) {
        self.avx2 = None;
    }

    /// Forget every stamp (after the window generation counter wrapped).
    pub fn clear_stamps(&mut self) {
        for v in &mut self.boxes {
            v.fill((0, EMPTY));
        }
    }

    /// The box of the pixels that caused conv3 neuron `pos` (any map) to fire at `t`, if any.
    ///
    /// The walk is compiled twice, with `avx2` a constant: where the CPU has AVX2, the functions
    /// it goes through (`conv3_rows`, `new_pool_box`) are compiled for it (`Avx2::vectorize`),
    /// so that the stamp tests of the rows (`fired_mask`) are inlined into them instead of
    /// called.
    pub fn conv3_box(&mut self, w: &Window<'_>, pos: usize, t: u64) -> Option<PixelBox> {
        let b = match self.avx2 {
            Some(avx2) => avx2.vectorize(
                #[inline(always)]
                move || self.conv3_rows(Some(avx2), w, pos, t),
            ),
            None => self.conv3_rows(None, w, pos, t),
        };
        (b != EMPTY).then(|| b.pixel_box())
    }

    /// `conv_box` of conv3 through `row_box`: its pool2 inputs are indexed as they lie.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn conv3_rows(&mut self, avx2: Option<Avx2>, w: &Window<'_>, pos: usize, t: u64) -> Lanes {
        let g = w.geom.conv[2];
        let (oy, ox) = self.split[2].div_rem(pos);
        let cols = g.inputs_of(ox, g.in_w);
        let mut b = EMPTY;
        for iy in g.inputs_of(oy, g.in_h) {
            self.row_box(avx2, w, 2, iy, cols.clone(), t, &mut b);
        }
        b
    }

    /// The box of the causes of conv layer `layer`'s neuron at `pos` firing at `t`: the inputs
    /// of its receptive field that fired at or before `t` (for pool boxes whose causes' fields
    /// are not walked together). `avx2` is the token where the walk is compiled for AVX2.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn conv_box(
        &mut self,
        avx2: Option<Avx2>,
        w: &Window<'_>,
        layer: usize,
        pos: usize,
        t: u64,
    ) -> Lanes {
        let g = w.geom.conv[layer];
        let (oy, ox) = self.split[layer].div_rem(pos);
        let (fired, times) = if layer == 0 {
            let pixels = Fired {
                stamps: w.pixel_fired,
                width: w.width,
                channels: 1,
                generation: w.generation,
            };
            (pixels, w.pixel_time)
        } else {
            let below = &w.pool[layer - 1];
            let pool = Fired {
                stamps: below.stamps(),
                width: below.geom.out_w,
                channels: g.in_ch,
                generation: w.generation,
            };
            (pool, below.times())
        };
        let mut b = EMPTY;
        each_fired_input(&g, fired, w.splits[layer], avx2, oy, ox, |c, iy, ix| {
            let i = (iy * fired.width + ix) * fired.channels + c;
            let tin = times[i];
            if tin > t {
                return; // fired later: not a cause
            }
            b = union(
                b,
                if layer == 0 {
                    let (x, y) = (ix as u16, iy as u16);
                    Lanes::new(x, y, x + 1, y + 1)
                } else {
                    self.pool_box(avx2, w, layer - 1, i, tin)
                },
            );
        });
        b
    }

    /// The box of the causes of pool layer `layer`'s neuron `i` (`[row][col][map]`), which
    /// fired at `tq`: the neurons of its map in its block that fired at `tq`. Inlined, so that
    /// the common case, a box computed already, costs no call.
    #[inline]
    fn pool_box(
        &mut self,
        avx2: Option<Avx2>,
        w: &Window<'_>,
        layer: usize,
        i: usize,
        tq: u64,
    ) -> Lanes {
        let (done, b) = self.boxes[layer][i];
        if done == w.generation {
            return b;
        }
        match avx2 {
            Some(a) => a.vectorize(
                #[inline(always)]
                move || self.new_pool_box(Some(a), w, layer, i, tq),
            ),
            None => self.new_pool_box_plain(w, layer, i, tq),
        }
    }

    /// `new_pool_box` without AVX2.
    #[inline(never)]
    fn new_pool_box_plain(&mut self, w: &Window<'_>, layer: usize, i: usize, tq: u64) -> Lanes {
        self.new_pool_box(None, w, layer, i, tq)
    }

    /// `pool_box` the first time in the window: compute it and keep it.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn new_pool_box(
        &mut self,
        avx2: Option<Avx2>,
        w: &Window<'_>,
        layer: usize,
        i: usize,
        tq: u64,
    ) -> Lanes {
        let pg = w.geom.pool[layer];
        let (q, map) = self.maps[layer].div_rem(i);
        let (qy, qx) = self.pool_w[layer].div_rem(q);
        let causes = w.pool[layer].causes_of(map, qy, qx);
        let b = if self.merge[layer] {
            self.block_box(avx2, w, layer, causes, qy, qx, tq)
        } else {
            let cg = w.geom.conv[layer];
            let mut b = EMPTY;
            for (dy, dx) in block_bits(self.side[layer], causes) {
                let pos = (qy * pg.stride + dy) * cg.out_w + qx * pg.stride + dx;
                b = union(b, self.conv_box(avx2, w, layer, pos, tq));
            }
            b
        };
        self.boxes[layer][i] = (w.generation, b);
        b
    }

    /// The box of the inputs that fired at or before `tq` in the fields of the conv neurons of
    /// layer `layer` whose block positions are set in `causes`, in pool neuron `(qy, qx)`'s
    /// block: the union of their `conv_box`es, in one walk of the union of their fields.
    ///
    /// A pool neuron's causes all fired at `tq`, so one time test serves them all; their fields
    /// overlap heavily (Table 1's pool2: up to 25 conv2 fields of 10 × 10 inside 14 × 14), and
    /// walking each field alone visits an input once per field that holds it. In an input row,
    /// the columns read by the causes whose fields hold the row are one run: their fields'
    /// columns start at most `k_pool − 1 ≤ k` apart, so each run reaches the next (clipping to
    /// the input keeps that), and so do those of the neurons between them, which are no causes.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn block_box(
        &mut self,
        avx2: Option<Avx2>,
        w: &Window<'_>,
        layer: usize,
        causes: &[u64],
        qy: usize,
        qx: usize,
        tq: u64,
    ) -> Lanes {
        let (pg, cg) = (w.geom.pool[layer], w.geom.conv[layer]);
        // Per block row: the first and last block column of a cause.
        let mut strips = std::mem::take(&mut self.strips[layer]);
        strips.clear();
        let mut row = usize::MAX;
        for (dy, dx) in block_bits(self.side[layer], causes) {
            let ox = qx * pg.stride + dx;
            if dy != row {
                // Bits come in row-major order: a new block row.
                row = dy;
                let rows = cg.inputs_of(qy * pg.stride + dy, cg.in_h);
                let cols = cg.inputs_of(ox, cg.in_w);
                strips.push((rows.start, rows.end, cols.start, cols.end));
            } else if let Some(s) = strips.last_mut() {
                s.3 = cg.inputs_of(ox, cg.in_w).end;
            }
        }
        let mut b = EMPTY;
        if let (Some(first), Some(last)) = (strips.first(), strips.last()) {
            // The fields' rows, from the first block row's to the last's.
            for iy in first.0..last.1 {
                let (mut lo, mut hi) = (usize::MAX, 0);
                for &(r0, r1, c0, c1) in &strips {
                    if (r0..r1).contains(&iy) {
                        lo = lo.min(c0);
                        hi = hi.max(c1);
                    }
                }
                if lo < hi {
                    self.row_box(avx2, w, layer, iy, lo..hi, tq, &mut b);
                }
            }
        }
        self.strips[layer] = strips;
        b
    }

    /// Widen `b` by the inputs of conv layer `layer` (pixels, or pool layer `layer − 1`'s
    /// neurons, every map) in input row `iy`, columns `cols`, that fired at or before `t`.
    ///
    /// Pixels box themselves: only a row's first and last such pixel widen the box, so they are
    /// looked for from each end of the row's fired ones.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn row_box(
        &mut self,
        avx2: Option<Avx2>,
        w: &Window<'_>,
        layer: usize,
        iy: usize,
        cols: Range<usize>,
        t: u64,
        b: &mut Lanes,
    ) {
        if layer == 0 {
            let from = iy * w.width + cols.start;
            let stamps = &w.pixel_fired[from..from + cols.len()];
            let times = &w.pixel_time[from..from + cols.len()];
            // Lane of the first and of the last pixel of the row that fired by `t`.
            let (mut first, mut last) = (None, 0);
            for (chunk, s) in stamps.chunks(64).enumerate() {
                let mut m = fired_mask(avx2, s, w.generation);
                if first.is_none() {
                    while m != 0 {
                        let l = chunk * 64 + m.trailing_zeros() as usize;
                        m &= m - 1;
                        if times[l] <= t {
                            (first, last) = (Some(l), l);
                            break;
                        }
                    }
                }
                // The last among those above the first.
                while m != 0 {
                    let top = 63 - m.leading_zeros() as usize;
                    m &= !(1 << top);
                    if times[chunk * 64 + top] <= t {
                        last = chunk * 64 + top;
                        break;
                    }
                }
            }
            if let Some(first) = first {
                let (x0, x1, y) = (cols.start + first, cols.start + last + 1, iy);
                *b = union(*b, Lanes::new(x0 as u16, y as u16, x1 as u16, y as u16 + 1));
            }
            return;
        }
        let below = &w.pool[layer - 1];
        let maps = below.geom.maps;
        let from = (iy * below.geom.out_w + cols.start) * maps;
        let stamps = &below.stamps()[from..from + cols.len() * maps];
        let times = below.times();
        for (chunk, s) in stamps.chunks(64).enumerate() {
            let mut m = fired_mask(avx2, s, w.generation);
            while m != 0 {
                let i = from + chunk * 64 + m.trailing_zeros() as usize;
                m &= m - 1;
                let tin = times[i];
                if tin <= t {
                    *b = union(*b, self.pool_box(avx2, w, layer - 1, i, tin));
                }
            }
        }
    }
}

/// The block positions `(dy, dx)` set in a pool neuron's cause words, in bit order (row-major);
/// `side` divides by the block side.
fn block_bits(side: Divider, causes: &[u64]) -> impl Iterator<Item = (usize, usize)> + '_ {
    causes
        .iter()
        .enumerate()
        .flat_map(move |(word_index, &word)| {
            let mut m = word;
            std::iter::from_fn(move || {
                (m != 0).then(|| {
                    let bit = word_index * 64 + m.trailing_zeros() as usize;
                    m &= m - 1;
                    side.div_rem(bit)
                })
            })
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The union of lanes is the union of boxes: the least `x0, y0`, the greatest `x1, y1`.
    #[test]
    fn lanes_union_is_the_box_union() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            [0, 1, 2, 3].map(|k| (s >> (16 * k)) as u16)
        };
        for _ in 0..1000 {
            let (a, b) = (next(), next());
            let want = (
                a[0].min(b[0]),
                a[1].min(b[1]),
                a[2].max(b[2]),
                a[3].max(b[3]),
            );
            let (la, lb) = (
                Lanes::new(a[0], a[1], a[2], a[3]),
                Lanes::new(b[0], b[1], b[2], b[3]),
            );
            assert_eq!(union(la, lb).pixel_box(), want);
            assert_eq!(union(EMPTY, la), la);
        }
        assert_eq!(EMPTY.pixel_box(), (u16::MAX, u16::MAX, 0, 0));
    }
}
