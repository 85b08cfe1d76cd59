//! A max-pool layer's per-window state (docs/model.md §3): a pool neuron `(m, q)` fires at the
//! time of the first spike of map `m` in its block. It has no potential and does not inhibit.

use super::conv::Crossing;
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
    /// Per conv row: the index of its block row's first neuron (`qy · out_w · maps`, or the
    /// number of neurons where the row is in no block), the block row `qy`, and its row in the
    /// block times `k`; per conv column: `qx · maps` (or the number of neurons), `qx`, and its
    /// column in the block. Where blocks tile the layer (`k = stride`), a spike's neuron index
    /// is then two loads and two additions, out of range exactly where it is in no block.
    row_block: Vec<[u32; 3]>,
    col_block: Vec<[u32; 3]>,
}

impl PoolState {
    pub fn new(geom: PoolGeom) -> Self {
        let n = geom.neurons();
        let none = u32::try_from(n).expect("pool neurons fit 32 bits");
        let s = geom.stride;
        Self {
            geom,
            fired: vec![0; n],
            time: vec![0; n],
            causes: vec![0; n * (geom.k * geom.k).div_ceil(64)],
            words: (geom.k * geom.k).div_ceil(64),
            stride: Divider::new(s),
            row_block: (0..geom.in_h)
                .map(|r| {
                    let q = r / s;
                    let base = if q < geom.out_h {
                        (q * geom.out_w * geom.maps) as u32
                    } else {
                        none
                    };
                    [base, q as u32, (r % s * geom.k) as u32]
                })
                .collect(),
            col_block: (0..geom.in_w)
                .map(|c| {
                    let q = c / s;
                    let base = if q < geom.out_w {
                        (q * geom.maps) as u32
                    } else {
                        none
                    };
                    [base, q as u32, (c % s) as u32]
                })
                .collect(),
        }
    }

    /// Forget every stamp (after the generation counter wrapped).
    pub fn clear_stamps(&mut self) {
        self.fired.fill(0);
    }

    /// A conv group's `spikes` at time `t`, in order (positions split into row and column by
    /// `split`): for each, fire every pool neuron of its map whose block holds it and that has
    /// not fired yet, and note the spike as a cause of those that fire at `t`. Inlined into
    /// the per-layer step, the loop inside: no call per spike, nor per group.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn on_spikes(
        &mut self,
        generation: u32,
        t: u64,
        spikes: &[Crossing],
        split: Divider,
        out: &mut Vec<PoolSpike>,
    ) {
        let g = self.geom;
        if g.k != g.stride || self.words != 1 {
            for c in spikes {
                let (row, col) = split.div_rem(c.pos as usize);
                self.on_spike_blocks(generation, t, c.map, row, col, out);
            }
            return;
        }
        // Blocks that tile the layer, of up to 64 conv neurons (Table 1's pools): the one
        // block holding a spike, if any (with valid padding, the last rows or columns may be
        // in none), and one cause word per neuron. `take`'s rule, written out for one word:
        // going through `take`'s general path (index and cause words per spike) measured 4.3 %
        // more instructions on Table 1's network at 1 % on 240x180 (5.846 -> 6.098 M).
        let n = self.fired.len();
        let (fired, time, causes) = (
            &mut self.fired[..],
            &mut self.time[..n],
            &mut self.causes[..n],
        );
        for c in spikes {
            let (row, col) = split.div_rem(c.pos as usize);
            let ([rb, qy, by], [cb, qx, bx]) = (self.row_block[row], self.col_block[col]);
            let i = rb as usize + cb as usize + c.map as usize;
            if i >= n {
                continue; // in no block
            }
            let bit = 1u64 << (by + bx);
            if fired[i] != generation {
                fired[i] = generation;
                time[i] = t;
                causes[i] = bit;
                out.push((c.map, qy, qx));
            } else if time[i] == t {
                causes[i] |= bit;
            }
            // Else it fired earlier (most spikes of a busy block): this spike is not one of
            // its causes.
        }
    }

    /// `on_spikes` for one spike of map `map` at conv position `(row, col)`, where blocks
    /// overlap or leave gaps (`k ≠ stride`) or hold more than 64 conv neurons: every block
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
