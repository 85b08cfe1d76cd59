//! The input spikes that caused a detection (docs/model.md §5), for its box.
//!
//! A conv neuron that fires at `t` was caused by the inputs of its receptive field that fired at
//! or before `t` (they are what its potential summed); a pool neuron that fires at `t` by the
//! neurons of its map in its block that fired at `t` (its first spikes). Following these links
//! down from a conv3 spike reaches the sensor pixels that caused it; its box is their bounding
//! box.
//!
//! Per event, only the pool layers note their causes (one bit per conv spike that lands in a
//! pool neuron as it fires, see `PoolState::on_spike`). When a conv3 neuron fires, the links are
//! followed, with every pool neuron's box kept once computed in the window, so a window's boxes
//! together cost at most one visit of each conv neuron's receptive field that some detection
//! reaches.

use super::conv::{each_fired_input, has_avx2, Fired};
use super::geometry::{Divider, Geometry};
use super::pool::PoolState;

/// A half-open pixel box `(x0, y0, x1, y1)`; `EMPTY` holds no pixel.
pub(crate) type PixelBox = (u16, u16, u16, u16);

const EMPTY: PixelBox = (u16::MAX, u16::MAX, 0, 0);

fn union(a: PixelBox, b: PixelBox) -> PixelBox {
    (a.0.min(b.0), a.1.min(b.1), a.2.max(b.2), a.3.max(b.3))
}

/// What the links are followed through: the window's pixels and pool layers.
pub(crate) struct Window<'a> {
    pub geom: &'a Geometry,
    /// Each conv layer's lanes of a receptive field's row (`ConvState::input_split`).
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
    /// Per pool1 / pool2 neuron: generation in which its box was computed, and the box.
    done: [Vec<u32>; 2],
    boxes: [Vec<PixelBox>; 2],
    /// Division by each conv layer's output width.
    split: [Divider; 3],
    /// Division by each pool layer's kernel side (block bit → block row and column).
    side: [Divider; 2],
    /// Whether the CPU has AVX2 (asked once, for the stamp tests).
    avx2: bool,
}

impl Causes {
    pub fn new(geom: &Geometry) -> Self {
        let pool = |l: usize| geom.pool[l].neurons();
        Self {
            done: [vec![0; pool(0)], vec![0; pool(1)]],
            boxes: [vec![EMPTY; pool(0)], vec![EMPTY; pool(1)]],
            split: geom.conv.map(|g| Divider::new(g.out_w)),
            side: geom.pool.map(|g| Divider::new(g.k)),
            avx2: has_avx2(),
        }
    }

    /// Forget every stamp (after the window generation counter wrapped).
    pub fn clear_stamps(&mut self) {
        for v in &mut self.done {
            v.fill(0);
        }
    }

    /// The box of the pixels that caused conv3 neuron `pos` (any map) to fire at `t`, if any.
    pub fn conv3_box(&mut self, w: &Window<'_>, pos: usize, t: u64) -> Option<PixelBox> {
        let b = self.conv_box(w, 2, pos, t);
        (b != EMPTY).then_some(b)
    }

    /// The box of the causes of conv layer `layer`'s neuron at `pos` firing at `t`: the inputs
    /// of its receptive field that fired at or before `t`.
    fn conv_box(&mut self, w: &Window<'_>, layer: usize, pos: usize, t: u64) -> PixelBox {
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
        let avx2 = self.avx2;
        each_fired_input(&g, fired, w.splits[layer], avx2, oy, ox, |c, iy, ix| {
            let tin = times[(iy * fired.width + ix) * fired.channels + c];
            if tin > t {
                return; // fired later: not a cause
            }
            b = union(
                b,
                if layer == 0 {
                    let (x, y) = (ix as u16, iy as u16);
                    (x, y, x + 1, y + 1)
                } else {
                    self.pool_box(w, layer - 1, c, iy, ix, tin)
                },
            );
        });
        b
    }

    /// The box of the causes of pool layer `layer`'s neuron `(map, qy, qx)`, which fired at
    /// `tq`: the neurons of `map` in its block that fired at `tq`.
    fn pool_box(
        &mut self,
        w: &Window<'_>,
        layer: usize,
        map: usize,
        qy: usize,
        qx: usize,
        tq: u64,
    ) -> PixelBox {
        let pg = w.geom.pool[layer];
        let i = (qy * pg.out_w + qx) * pg.maps + map;
        if self.done[layer][i] == w.generation {
            return self.boxes[layer][i];
        }
        let cg = w.geom.conv[layer];
        let mut b = EMPTY;
        for (word_index, &word) in w.pool[layer].causes_of(map, qy, qx).iter().enumerate() {
            let mut m = word;
            while m != 0 {
                let bit = word_index * 64 + m.trailing_zeros() as usize;
                m &= m - 1;
                let (dy, dx) = self.side[layer].div_rem(bit);
                let pos = (qy * pg.stride + dy) * cg.out_w + qx * pg.stride + dx;
                b = union(b, self.conv_box(w, layer, pos, tq));
            }
        }
        self.done[layer][i] = w.generation;
        self.boxes[layer][i] = b;
        b
    }
}
