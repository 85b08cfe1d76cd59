//! A max-pool layer's per-window state (docs/model.md §3): a pool neuron `(m, q)` fires at the
//! time of the first spike of map `m` in its block. It has no potential and does not inhibit.

use super::geometry::{Divider, PoolGeom};

/// A spike leaving a pool layer: `(map, row, col)`, all at the group's time.
pub(crate) type PoolSpike = (u32, u32, u32);

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
    /// Per conv row: its block row and, times `k`, its row in the block; per conv column: its
    /// block column and its column in the block (`on_spike` where blocks tile the layer,
    /// `k = stride`: two loads instead of two divisions per spike).
    row_block: Vec<(u32, u32)>,
    col_block: Vec<(u32, u32)>,
}

impl PoolState {
    pub fn new(geom: PoolGeom) -> Self {
        let n = geom.neurons();
        Self {
            geom,
            fired: vec![0; n],
            time: vec![0; n],
            causes: vec![0; n * (geom.k * geom.k).div_ceil(64)],
            words: (geom.k * geom.k).div_ceil(64),
            stride: Divider::new(geom.stride),
            row_block: (0..geom.in_h)
                .map(|r| ((r / geom.stride) as u32, (r % geom.stride * geom.k) as u32))
                .collect(),
            col_block: (0..geom.in_w)
                .map(|c| ((c / geom.stride) as u32, (c % geom.stride) as u32))
                .collect(),
        }
    }

    /// Forget every stamp (after the generation counter wrapped).
    pub fn clear_stamps(&mut self) {
        self.fired.fill(0);
    }

    /// A spike of map `map` at conv position `(row, col)` at time `t`: fire every pool neuron of
    /// that map whose block holds it and that has not fired yet, and note the spike as a cause
    /// of those that fire at `t`.
    #[inline]
    pub fn on_spike(
        &mut self,
        generation: u32,
        t: u64,
        map: u32,
        row: usize,
        col: usize,
        out: &mut Vec<PoolSpike>,
    ) {
        let g = self.geom;
        if g.k == g.stride {
            // Blocks that tile the layer (Table 1's pools): the one block holding the spike,
            // if any (with valid padding, the last rows or columns may be in none).
            let ((qy, by), (qx, bx)) = (self.row_block[row], self.col_block[col]);
            let (qy, qx) = (qy as usize, qx as usize);
            if qy < g.out_h && qx < g.out_w {
                self.take(generation, t, map, qy, qx, (by + bx) as usize, out);
            }
            return;
        }
        self.on_spike_overlapping(generation, t, map, row, col, out);
    }

    /// `on_spike` for blocks that overlap or leave gaps (`k ≠ stride`): every block holding the
    /// spike. Kept out of line, so that `on_spike` holds only the one-block path (Table 1's
    /// pools) and saves fewer registers per spike (inlining `on_spike` into `propagate`
    /// measured more instructions).
    #[inline(never)]
    fn on_spike_overlapping(
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
