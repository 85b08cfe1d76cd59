//! A max-pool layer's per-window state (docs/model.md §3): a pool neuron `(m, q)` fires at the
//! time of the first spike of map `m` in its block. It has no potential and does not inhibit.

use super::conv::{Crossing, Fire};
use super::geometry::{Divider, PoolGeom};

/// A spike leaving a pool layer: `(map, row, col)`, all at the group's time.
pub(crate) type PoolSpike = (u32, u32, u32);

/// A key of `PoolState::row_keys` or `col_keys`: a neuron index, a block row or column, a place.
fn key(base: u32, q: usize, place: usize) -> u64 {
    debug_assert!(
        u16::try_from(q).is_ok() && place < 64,
        "fields in their bits"
    );
    u64::from(base) << 32 | (q as u64) << 8 | place as u64
}

/// A tiling pool layer taking a conv group's spikes as they fire (`PoolState::sink`).
pub(crate) struct PoolSink<'a> {
    pool: &'a mut PoolState,
    generation: u32,
    t: u64,
    out: &'a mut Vec<PoolSpike>,
    /// Conv spikes taken.
    pub fired: usize,
}

impl Fire for PoolSink<'_> {
    // Pool neurons fire on conv spikes, whatever their potentials.
    const EXACT: bool = false;

    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn fire(&mut self, c: Crossing) {
        self.fired += 1;
        self.pool.take_tiled(self.generation, self.t, c, self.out);
    }
}

/// Per-window state of one pool layer.
#[derive(Debug, Clone)]
pub(crate) struct PoolState {
    pub geom: PoolGeom,
    /// Generation in which a neuron `[row][col][map]` fired.
    fired: Vec<u32>,
    /// Its firing time (meaningful only where `fired` is the current generation).
    time: Vec<u64>,
    /// Per neuron, `words` bit words over its `k × k` block (row-major): which conv neurons of
    /// its map fired at its firing time (its causes, for boxes; meaningful where it fired).
    causes: Vec<u64>,
    words: usize,
    /// Division by the stride.
    stride: Divider,
    /// Whether `on_spikes` takes its one-block path: blocks tile the layer (`k = stride`), hold
    /// at most 64 conv neurons (one cause word), and two keys' indices sum without overflow.
    tiles: bool,
    /// Where blocks tile the layer, a key per conv row and per conv column, summed per spike:
    /// bits 32-63 hold the index of the row's block row's first neuron (`qy · out_w · maps`)
    /// or of the column's block's (`qx · maps`), or the number of neurons where the row
    /// (column) is in no block, so that the sum's index is out of range exactly where the
    /// spike is in no block; bits 8-23 hold `qy` (`qx`), and bits 0-7 the row's place in the
    /// block times `k` (the column's place), so that the sum's low byte is the spike's bit in
    /// the block's cause word. A spike's neuron and bit are then two loads and an addition.
    row_keys: Vec<u64>,
    col_keys: Vec<u64>,
    /// A conv position's row: `⌊pos / in_w⌋` by one multiplication.
    rows: Divider,
}

impl PoolState {
    pub fn new(geom: PoolGeom) -> Self {
        let n = geom.neurons();
        let none = u32::try_from(n).expect("pool neurons fit 32 bits");
        let s = geom.stride;
        // Two indices of at most `n` each sum below 2^32.
        let tiles = geom.k == s && geom.k * geom.k <= 64 && 2 * u64::from(none) < 1 << 32;
        let keys = |len: usize, out: usize, step: usize, place: usize| -> Vec<u64> {
            if !tiles {
                return Vec::new();
            }
            (0..len)
                .map(|i| {
                    let q = i / s;
                    let base = if q < out { (q * step) as u32 } else { none };
                    key(base, q, i % s * place)
                })
                .collect()
        };
        Self {
            geom,
            fired: vec![0; n],
            time: vec![0; n],
            causes: vec![0; n * (geom.k * geom.k).div_ceil(64)],
            words: (geom.k * geom.k).div_ceil(64),
            stride: Divider::new(s),
            tiles,
            row_keys: keys(geom.in_h, geom.out_h, geom.out_w * geom.maps, geom.k),
            col_keys: keys(geom.in_w, geom.out_w, geom.maps, 1),
            rows: Divider::new(geom.in_w),
        }
    }

    /// Forget every stamp (after the generation counter wrapped).
    pub fn clear_stamps(&mut self) {
        self.fired.fill(0);
    }

    /// A conv group's `spikes` at time `t`, in order: for each, fire every pool neuron of its map whose block holds it and that has
    /// not fired yet, and note the spike as a cause of those that fire at `t`. Inlined into
    /// the per-layer step, the loop inside: no call per spike, nor per group.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn on_spikes(
        &mut self,
        generation: u32,
        t: u64,
        spikes: &[Crossing],
        out: &mut Vec<PoolSpike>,
    ) {
        if !self.tiles {
            for c in spikes {
                let (row, col) = self.rows.div_rem(c.pos as usize);
                self.on_spike_blocks(generation, t, c.map, row, col, out);
            }
            return;
        }
        // Blocks that tile the layer, of up to 64 conv neurons (Table 1's pools): the one
        // block holding a spike, if any, and one cause word per neuron (`take_tiled`). (A
        // copy of `take_tiled`'s body here, its slices hoisted out of the loop, saved
        // 0.05-0.2 % of instructions: not kept.)
        for &c in spikes {
            self.take_tiled(generation, t, c, out);
        }
    }

    /// Whether `on_spikes` takes its one-block path, and a `PoolSink` may stand for it.
    pub fn tiles(&self) -> bool {
        self.tiles
    }

    /// `on_spikes` for spikes as the conv layer fires them, at time `t`, pool spikes going to
    /// `out`. Only where `tiles` holds.
    pub fn sink<'a>(
        &'a mut self,
        generation: u32,
        t: u64,
        out: &'a mut Vec<PoolSpike>,
    ) -> PoolSink<'a> {
        debug_assert!(self.tiles, "one block per spike");
        PoolSink {
            pool: self,
            generation,
            t,
            out,
            fired: 0,
        }
    }

    /// `on_spikes`' one-block path for one spike (also `PoolSink`'s): the one block holding
    /// it, if any (with valid padding, the last rows or columns may be in none). Going through
    /// `take`'s general path (index and cause words per spike) measured 4.3 % more
    /// instructions on Table 1's network at 1 % on 240x180 (5.846 -> 6.098 M).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn take_tiled(&mut self, generation: u32, t: u64, c: Crossing, out: &mut Vec<PoolSpike>) {
        let (row, col) = self.rows.div_rem(c.pos as usize);
        let (rk, ck) = (self.row_keys[row], self.col_keys[col]);
        let sum = rk + ck;
        let i = (sum >> 32) as usize + c.map as usize;
        let n = self.fired.len();
        if i >= n {
            return; // in no block
        }
        let bit = 1u64.wrapping_shl(sum as u32);
        // `time` holds `n` entries and `causes` `n · words` (`new`; neither is resized), so
        // `i < n` is inside both: indexed without their own bounds checks, which a spike paid
        // for on every path (the optimiser cannot know their lengths from `fired`'s).
        debug_assert!(self.time.len() == n && self.causes.len() >= n);
        if self.fired[i] != generation {
            self.fired[i] = generation;
            // SAFETY: `i < n`, and `time` and `causes` hold at least `n` entries (above).
            unsafe { *self.time.get_unchecked_mut(i) = t };
            // SAFETY: as above.
            unsafe { *self.causes.get_unchecked_mut(i) = bit };
            out.push((c.map, (rk >> 8) as u16 as u32, (ck >> 8) as u16 as u32));
        // SAFETY: as above.
        } else if unsafe { *self.time.get_unchecked(i) } == t {
            // SAFETY: as above.
            unsafe { *self.causes.get_unchecked_mut(i) |= bit };
        }
    }

    /// `on_spikes` for one spike of map `map` at conv position `(row, col)`, where blocks
    /// overlap or leave gaps (`k ≠ stride`) or hold more than 64 conv neurons (or the layer
    /// has too many neurons for `tiles`' keys): every block
    /// holding the spike. Kept out of line, so that `on_spikes` holds only the loop of
    /// Table 1's pools.
    #[inline(never)]
    fn on_spike_blocks(
        &mut self,
        generation: u32,
        t: u64,
        map: u32,
        row: usize,
        col: usize,
        out: &mut Vec<PoolSpike>,
    ) {
        let g = self.geom;
        for qy in self.outputs_of(row, g.out_h) {
            for qx in self.outputs_of(col, g.out_w) {
                let bit = (row - qy * g.stride) * g.k + (col - qx * g.stride);
                self.take(generation, t, map, qy, qx, bit, out);
            }
        }
    }

    /// A spike at block position `bit` of pool neuron `(map, qy, qx)`: fire it if it has not
    /// fired yet, and note the spike as a cause if it fires at `t`.
    #[inline]
    fn take(
        &mut self,
        generation: u32,
        t: u64,
        map: u32,
        qy: usize,
        qx: usize,
        bit: usize,
        out: &mut Vec<PoolSpike>,
    ) {
        let g = self.geom;
        let i = (qy * g.out_w + qx) * g.maps + map as usize;
        let first = self.fired[i] != generation;
        if first {
            self.fired[i] = generation;
            self.time[i] = t;
            out.push((map, qy as u32, qx as u32));
        } else if self.time[i] != t {
            // Fired earlier (most spikes of a busy block): this spike is not one of its
            // causes, and its cause words are not even looked up.
            return;
        }
        let words = &mut self.causes[i * self.words..(i + 1) * self.words];
        if first {
            match words {
                // Blocks of up to 64 (Table 1's 5 × 5): one store, not a call of `memset`.
                [only] => *only = 0,
                _ => words.fill(0),
            }
        }
        words[bit / 64] |= 1 << (bit % 64);
    }

    /// `PoolGeom::outputs_of` without hardware divisions.
    #[inline]
    fn outputs_of(&self, i: usize, out: usize) -> std::ops::Range<usize> {
        let g = self.geom;
        let from = (i + 1).saturating_sub(g.k);
        // ⌈from / s⌉ = ⌊(from + s − 1) / s⌋.
        let lo = self.stride.div(from + g.stride - 1);
        let hi = (self.stride.div(i) + 1).min(out);
        lo..hi.max(lo)
    }

    /// The fired stamps, `[row][col][map]`.
    pub fn stamps(&self) -> &[u32] {
        &self.fired
    }

    /// The firing times, `[row][col][map]` (meaningful where the stamp is the generation).
    pub fn times(&self) -> &[u64] {
        &self.time
    }

    /// Which conv neurons of map `map` caused pool neuron `(map, qy, qx)` to fire (meaningful
    /// where it fired in this window): bit `b` of the words is block position
    /// `(qy · stride + b / k, qx · stride + b mod k)`.
    pub fn causes_of(&self, map: usize, qy: usize, qx: usize) -> &[u64] {
        let g = self.geom;
        let i = (qy * g.out_w + qx) * g.maps + map;
        &self.causes[i * self.words..(i + 1) * self.words]
    }

    /// When pool neuron `(map, row, col)` fired in this window, if it did.
    #[inline]
    pub fn fired_at(&self, generation: u32, map: usize, row: usize, col: usize) -> Option<u64> {
        let i = (row * self.geom.out_w + col) * self.geom.maps + map;
        (self.fired[i] == generation).then_some(self.time[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::config::{NetworkConfig, Padding, PoolConfig};
    use crate::network::geometry::Geometry;

    /// The one-block path of tiling pools fires the same neurons in the same order, at the
    /// same times and with the same causes, as the general path, blocks in no block included
    /// (valid padding).
    #[test]
    fn tiles_equal_general_path() {
        let mut rng = crate::network::xorshift(23u64);
        for (k, padding) in [
            (2, Padding::Same),
            (5, Padding::Same),
            (5, Padding::Valid),
            (3, Padding::Valid),
            (8, Padding::Same),
        ] {
            let mut c = NetworkConfig {
                width: 43,
                height: 31,
                padding,
                ..NetworkConfig::default()
            };
            c.pool1 = PoolConfig {
                kernel: k,
                stride: k,
            };
            c.conv2.kernel = 1;
            c.pool2 = PoolConfig {
                kernel: 1,
                stride: 1,
            };
            c.conv3.kernel = 1;
            let geom = Geometry::new(&c).unwrap();
            let (cg, pg) = (geom.conv[0], geom.pool[0]);
            let mut a = PoolState::new(pg);
            assert!(a.tiles, "k {k}");
            let mut b = a.clone();
            b.tiles = false;
            assert_eq!(cg.out_w, pg.in_w);
            for t in 0..30u64 {
                let spikes: Vec<Crossing> = (0..rng() % 12)
                    .map(|_| Crossing {
                        pos: (rng() % (cg.out_h * cg.out_w) as u64) as u32,
                        map: (rng() % cg.maps as u64) as u32,
                        v: f64::NAN,
                        v32: 0.0,
                    })
                    .collect();
                let (mut out_a, mut out_b) = (Vec::new(), Vec::new());
                a.on_spikes(1, t / 3, &spikes, &mut out_a);
                b.on_spikes(1, t / 3, &spikes, &mut out_b);
                assert_eq!(out_a, out_b, "k {k}, t {t}");
            }
            assert_eq!(
                (&a.fired, &a.time, &a.causes),
                (&b.fired, &b.time, &b.causes)
            );
            assert!(a.fired.contains(&1));
        }
    }
}
