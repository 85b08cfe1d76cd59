//! Adding input spikes: each input's weights to the potentials its footprint covers, the
//! neurons that reach `θ_lo` noted as candidates of the group (whole conv1 footprints through
//! `add_rows_fixed`, held as bits), and the counting of layers that wake by count.

use super::{ConvState, Footprint, WholeCandidates, AWAKE, MAPS, OFFSET_SLOTS, WORD_POSITIONS};
use crate::simd::{
    add_detect, add_rows, add_rows_fixed, count_rows, count_rows_unchecked, Avx2, FIXED_KERNEL,
    FIXED_ROWS, FIXED_RUN, LANES,
};

impl ConvState {
    /// Add input spike `(c, iy, ix)` (engine-layout weights `w`) to every neuron whose kernel
    /// covers it; neurons whose float32 sum reaches `θ_lo` become candidates of the group.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn add(&mut self, w: &[f32], c: usize, iy: usize, ix: usize) {
        self.add_in::<false>(w, c, iy, ix);
    }

    /// `add` of channel 0 from a caller compiled for AVX2 (see `add_rows_fixed`'s `INLINE`),
    /// whose whole inputs read the kernel copied by `load_kernel`: `w` must be the weights
    /// last given to it.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn add_inline(&mut self, w: &[f32], iy: usize, ix: usize) {
        self.add_in::<true>(w, 0, iy, ix);
    }

    /// `add`, with `add_rows_fixed`'s `INLINE`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn add_in<const INLINE: bool>(&mut self, w: &[f32], c: usize, iy: usize, ix: usize) {
        // An input's footprint is whole where it is `oy < rows` rows below the first such row
        // and `ox < cols` columns right of the first such column (one wrapping compare each);
        // its footprint's first output position is then `(oy, ox)`. (`rows` is 0 while the
        // layer wakes by count.)
        match &self.whole {
            Some(whole) => {
                let (oy, ox) = (iy.wrapping_sub(whole.row0), ix.wrapping_sub(whole.col0));
                if oy < whole.rows && ox < whole.cols {
                    // SAFETY: `first` is `oy · out_w + ox` with `oy < rows`, `ox < cols`.
                    unsafe { self.add_whole::<INLINE>(w, c, oy * self.geom.out_w + ox) };
                } else {
                    self.add_clipped(w, c, iy, ix);
                }
            }
            None => self.add_clipped(w, c, iy, ix),
        }
    }

    /// `add` for every input but the whole ones of `add_whole`: footprints clipped by the
    /// borders, layers other than conv1, layers that wake by count. Out of line, so that `add`
    /// inlines into its callers' loops with only `add_whole`'s few registers to save.
    #[inline(never)]
    pub(super) fn add_clipped(&mut self, w: &[f32], c: usize, iy: usize, ix: usize) {
        self.list_held();
        let g = self.geom;
        let maps = g.maps;
        let cols = g.outputs_of(ix, g.out_w);
        if cols.is_empty() {
            return;
        }
        let rows = g.outputs_of(iy, g.out_h);
        self.touched.inputs.push(Footprint {
            first: (rows.start * g.out_w + cols.start) as u32,
            rows: rows.len() as u16,
            cols: cols.len() as u16,
        });
        // Kernel column index j = k − 1 − dx of the first output column; each output row
        // further down reads the kernel row above (dy falls by one).
        let j0 = g.k - 1 - (ix + g.p_lo - cols.start);
        let dy0 = iy + g.p_lo - rows.start;
        if self.gated {
            self.touched.lanes += rows.len() * cols.len();
            // Count the input at every output row first (one vector pass where the CPU has
            // AVX2), then add it to the rows that have awake positions.
            let mut hit_rows = [0u32; FUSED_ROWS];
            let hit_rows = &mut hit_rows[..rows.len()];
            let p0 = rows.start * g.out_w + cols.start;
            if !count_rows(
                self.avx2,
                &mut self.count.counts,
                p0,
                g.out_w,
                cols.len(),
                self.count.wake_at,
                hit_rows,
            ) {
                return; // the common case: every position still short of waking
            }
            for (step, &hits) in hit_rows.iter().enumerate() {
                if hits != 0 {
                    let wstart = ((c * g.k + dy0 - step) * g.k + j0) * maps;
                    self.add_awake(w, wstart, p0 + step * g.out_w, hits);
                }
            }
        } else {
            let run = cols.len() * maps;
            self.touched.lanes += rows.len() * run;
            if let Some(avx2) = self.avx2.filter(|_| run <= 32 && rows.len() <= FUSED_ROWS) {
                // One vector pass over every row, then the candidates of the rows that had any.
                let mut masks = [0u32; FUSED_ROWS];
                let masks = &mut masks[..rows.len()];
                let (p0, w0) = (
                    (rows.start * g.out_w + cols.start) * maps,
                    ((c * g.k + dy0) * g.k + j0) * maps,
                );
                let (p_stride, w_stride) = (g.out_w * maps, g.k * maps);
                let thr = &self.thr.lo[..run];
                if add_rows(
                    avx2,
                    &mut self.pot,
                    p0,
                    p_stride,
                    w,
                    w0,
                    w_stride,
                    thr,
                    masks,
                ) {
                    self.push_row_candidates(masks, rows.start * g.out_w + cols.start);
                }
                return;
            }
            for (step, oy) in rows.enumerate() {
                let wstart = ((c * g.k + dy0 - step) * g.k + j0) * maps;
                self.add_run(w, wstart, oy * g.out_w + cols.start, cols.len());
            }
        }
    }

    /// Add a pool layer's spikes of one group, `(channel, row, col)` each, in order: what
    /// `add` does spike by spike (a layer after conv1 has no whole inputs, so `add` takes
    /// `add_clipped` for each). A layer that wakes by count on a CPU with AVX2 counts them in
    /// one loop compiled for it (`count_spikes`), without a call per spike or
    /// `add_clipped`'s general setup: nearly every spike only counts (Table 1's conv2).
    /// Inlined, so that the counted path costs its caller one call.
    #[inline]
    pub fn add_spikes(&mut self, w: &[f32], spikes: &[(u32, u32, u32)]) {
        if let Some(avx2) = self.avx2.filter(|_| self.gated) {
            // `add_clipped` lists the held candidates first; a layer that wakes by count has
            // none (only `add_whole` holds them, and only where the layer adds densely).
            debug_assert!(self.held.is_none(), "no held candidates while counting");
            avx2.vectorize(
                #[inline(always)]
                move || self.count_spikes(avx2, w, spikes),
            );
            return;
        }
        self.add_each(w, spikes);
    }

    /// `add_spikes` through `add`, spike by spike.
    #[inline(never)]
    pub(super) fn add_each(&mut self, w: &[f32], spikes: &[(u32, u32, u32)]) {
        for &(c, iy, ix) in spikes {
            self.add(w, c as usize, iy as usize, ix as usize);
        }
    }

    /// `add_spikes` for a layer that wakes by count on a CPU with AVX2, compiled for it
    /// (`Avx2::vectorize`): per spike, its output rows (`row_spans`, `col_spans`) counted one
    /// vector each (`count_rows_unchecked`, inlined), and only where some position reached its
    /// waking count the rest of `add_clipped` (`add_counted`).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(super) fn count_spikes(&mut self, avx2: Avx2, w: &[f32], spikes: &[(u32, u32, u32)]) {
        /// Output rows of a whole footprint of Table 1's conv2, whose counting is unrolled.
        const CONV2_ROWS: usize = 10;
        let out_w = self.geom.out_w;
        // Written by `count_rows_unchecked` for every row it counts before `add_counted` reads
        // them: zeroed once, not per spike.
        let mut hits = [0u32; FUSED_ROWS];
        for &(c, iy, ix) in spikes {
            let ([r0, rows], [c0, cols]) = (
                self.count.row_spans[iy as usize],
                self.count.col_spans[ix as usize],
            );
            if cols == 0 {
                continue;
            }
            let p0 = (r0 + c0) as usize;
            self.touched.inputs.push(Footprint {
                first: p0 as u32,
                rows: rows as u16,
                cols: cols as u16,
            });
            let (rows, len) = (rows as usize, cols as usize);
            self.touched.lanes += rows * len;
            if rows == 0 {
                continue;
            }
            let counts = &mut self.count.counts[p0..p0 + (rows - 1) * out_w + LANES];
            assert!(len <= LANES, "one vector of counts per row");
            let wake_at = self.count.wake_at;
            // A footprint of Table 1's conv2 (`k` = 10) unclipped by the layer's edges, most
            // of them: counted by a copy with its rows unrolled.
            let reached = if rows == CONV2_ROWS {
                // SAFETY: each of the `rows` rows holds LANES counts (inside `counts`, whose
                // range is checked above); len <= LANES.
                unsafe {
                    count_rows_unchecked(avx2, counts, out_w, len, wake_at, &mut hits[..CONV2_ROWS])
                }
            } else {
                // SAFETY: as above.
                unsafe {
                    count_rows_unchecked(avx2, counts, out_w, len, wake_at, &mut hits[..rows])
                }
            };
            if reached {
                self.add_counted(w, c as usize, iy as usize, ix as usize, p0, &hits[..rows]);
            }
        }
    }

    /// The rest of `add_clipped`'s counted path for an input `(c, iy, ix)` that brought some
    /// positions of its output rows (from position `p0`, one `out_w` apart) to their waking
    /// count: `hits` has a row's bits as `count_rows` gives them; the awake positions of each
    /// row are added to and the others queued to wake. Out of line (a few inputs in a hundred
    /// at 1 %).
    #[cold]
    #[inline(never)]
    pub(super) fn add_counted(
        &mut self,
        w: &[f32],
        c: usize,
        iy: usize,
        ix: usize,
        p0: usize,
        hits: &[u32],
    ) {
        let g = self.geom;
        let (rows, cols) = (g.outputs_of(iy, g.out_h), g.outputs_of(ix, g.out_w));
        let j0 = g.k - 1 - (ix + g.p_lo - cols.start);
        let dy0 = iy + g.p_lo - rows.start;
        for (step, &hits) in hits.iter().enumerate() {
            if hits != 0 {
                let wstart = ((c * g.k + dy0 - step) * g.k + j0) * g.maps;
                self.add_awake(w, wstart, p0 + step * g.out_w, hits);
            }
        }
    }

    /// `add` for an input whose footprint is the whole kernel (`Whole`) in a
    /// layer of `FIXED_ROWS` rows of `FIXED_RUN` lanes that adds densely on a CPU with AVX2:
    /// nearly every input of conv1, whose footprint's first output position is `first` (where
    /// the input is under the kernel's last row and column). Nothing is clipped, so the
    /// offsets are those of the kernel's last row and column, and the rows go through
    /// `add_rows_fixed`.
    ///
    /// # Safety
    /// `first` must be `oy · out_w + ox` with `oy < whole.rows` and `ox < whole.cols` (a
    /// whole footprint's first output position, as `add_in` finds it).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(super) unsafe fn add_whole<const INLINE: bool>(
        &mut self,
        w: &[f32],
        c: usize,
        first: usize,
    ) {
        let Some(whole) = &self.whole else {
            unreachable!("add_whole without Whole")
        };
        self.touched.wholes.push((first * MAPS) as u32);
        // With nothing of the group pending and nothing in the band, every neuron is below
        // `θ_lo` or latched: it starts at 0, below every `θ_lo` (`lo_positive`), reaches
        // `θ_lo` only by an add that makes it a candidate, and `resolve` latches each candidate
        // or keeps it in the band. The add's crossings are then the lanes it takes to `θ_lo` or
        // above (latched ones stay `−∞`): `add_rows_fixed`'s `fresh`.
        // (Tested together, without a branch each.)
        let pending = self.held.is_some() | !self.candidates.is_empty();
        let fresh = !pending & self.band.is_empty() & self.thr.lo_positive;
        let kernel = if INLINE {
            debug_assert!(
                c == 0 && whole.kernel[..] == w[..FIXED_KERNEL],
                "kernel loaded"
            );
            &whole.kernel
        } else {
            w[c * FIXED_KERNEL..][..FIXED_KERNEL]
                .try_into()
                .expect("one channel's kernel")
        };
        // The rows' potentials as one slice of exactly their span, without a test (so that
        // `add_rows_fixed`'s of its length folds away too).
        let stride = whole.stride;
        let span = (FIXED_ROWS - 1) * stride + FIXED_RUN;
        debug_assert!(first * MAPS + span <= self.pot.len());
        // SAFETY: `first = oy · out_w + ox` with `oy < rows ≤ all_rows` and `ox < cols` (this
        // function's contract), at most the last whole footprint's, whose rows `Whole::new` asserted
        // to lie inside `pot` (made with the length it was given, never resized).
        let start = unsafe { self.pot.as_mut_ptr().add(first * MAPS) };
        // SAFETY: as above: the `span` values from `start` lie inside `pot`, which nothing else
        // borrows while this slice lives.
        let pot = unsafe { std::slice::from_raw_parts_mut(start, span) };
        let words = add_rows_fixed::<INLINE>(whole.avx2, pot, stride, kernel, &whole.thr, fresh);
        if words != [0; 2] {
            let held = WholeCandidates {
                first: first as u32,
                words,
            };
            if pending {
                self.list_held();
                self.held = Some(held);
                self.list_held();
            } else {
                self.held = Some(held);
            }
        }
    }

    /// Note where the batch of candidates pushed from index `start` on (ascending in
    /// `(pos, map)`) joins the ones before it (see `breaks`).
    #[inline]
    pub(super) fn note_run(&mut self, start: usize) {
        if start == 0 || start >= self.candidates.len() {
            return;
        }
        let (a, b) = (self.candidates[start - 1], self.candidates[start]);
        if b < a {
            self.pos_sorted &= b.0 >= a.0;
            if let Some(slot) = self.breaks.get_mut(self.breaks_len) {
                *slot = start as u32;
            }
            self.breaks_len += 1;
        }
    }

    /// Forget the runs of `candidates` (once they are cleared).
    #[inline]
    pub(super) fn clear_runs(&mut self) {
        self.breaks_len = 0;
        self.pos_sorted = true;
    }

    /// Move the candidates held as bits (`held`), if any, to `candidates`. The test inline,
    /// the listing (rare) out of line.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(super) fn list_held(&mut self) {
        if let Some(held) = self.held.take() {
            self.list(held);
        }
    }

    /// `list_held` of `held`.
    #[inline(never)]
    pub(super) fn list(&mut self, held: WholeCandidates) {
        let start = self.candidates.len();
        // The walk of `WholeCandidates::positions`, written out (the iterator costs more), a
        // copy per word (their positions' slots from a constant).
        let [w0, w1] = held.words;
        self.list_word(held.first, 0, w0);
        self.list_word(held.first, 1, w1);
        debug_assert!(
            held.positions()
                .flat_map(|(p, maps)| {
                    let pos = held.first + self.whole_offsets[p];
                    (0..MAPS as u32)
                        .filter(move |m| maps >> m & 1 != 0)
                        .map(move |m| (pos, m))
                })
                .eq(self.candidates[start..].iter().copied()),
            "the candidates of `positions`, in order"
        );
        self.note_run(start);
    }

    /// `list` of word `word` of the held candidates, `bits`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(super) fn list_word(&mut self, first: u32, word: usize, mut bits: u64) {
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize;
            // Below `OFFSET_SLOTS` already: the remainder only tells the compiler so.
            let slot = (word * WORD_POSITIONS + lane / MAPS) % OFFSET_SLOTS;
            let pos = first + self.whole_offsets[slot];
            self.candidates.push((pos, (lane % MAPS) as u32));
            bits &= bits - 1;
        }
    }

    /// Record the neurons whose lanes are set in `masks` (one per output row of a run from
    /// position `first`, one `out_w` apart) as candidates.
    #[inline]
    pub(super) fn push_row_candidates(&mut self, masks: &[u32], first: usize) {
        let start = self.candidates.len();
        for (step, &mask) in masks.iter().enumerate() {
            let pos0 = (first + step * self.geom.out_w) as u32;
            let mut mask = mask;
            while mask != 0 {
                let (dp, map) = self.lane_split[mask.trailing_zeros() as usize];
                self.candidates.push((pos0 + dp, map));
                mask &= mask - 1;
            }
        }
        self.note_run(start);
    }

    /// Add one input to the positions of one output row (from `p0`) whose bits are set in
    /// `hits` and that are awake, in runs of consecutive ones (kernel row from `wstart`);
    /// positions that just reached the waking count are queued to wake.
    #[inline]
    pub(super) fn add_awake(&mut self, w: &[f32], wstart: usize, p0: usize, mut hits: u32) {
        let maps = self.geom.maps;
        let mut run: Option<(usize, usize)> = None;
        while hits != 0 {
            let d = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let n = self.count.counts[p0 + d];
            if n & AWAKE == 0 {
                if n == self.count.wake_at {
                    self.count.waking.push((p0 + d) as u32);
                }
                continue;
            }
            run = match run {
                Some((from, to)) if to == d => Some((from, d + 1)),
                Some((from, to)) => {
                    self.add_run(w, wstart + from * maps, p0 + from, to - from);
                    Some((d, d + 1))
                }
                None => Some((d, d + 1)),
            };
        }
        if let Some((from, to)) = run {
            self.add_run(w, wstart + from * maps, p0 + from, to - from);
        }
    }

    /// Add the weights from `wstart` to the `len` consecutive positions from `pos0` of one
    /// output row; neurons whose float32 sum reaches `θ_lo` become candidates.
    #[inline]
    pub(super) fn add_run(&mut self, w: &[f32], wstart: usize, pos0: usize, len: usize) {
        let maps = self.geom.maps;
        let run = len * maps;
        let start = pos0 * maps;
        let hit = add_detect(
            self.avx2,
            &mut self.pot[start..start + run],
            &w[wstart..wstart + run],
            &self.thr.lo[..run],
            &mut self.masks,
        );
        if hit {
            let start = self.candidates.len();
            push_candidates(
                &self.masks,
                run,
                &self.lane_split,
                pos0 as u32,
                &mut self.candidates,
            );
            self.note_run(start);
        }
    }
}

/// Record the neurons of a run of `lanes` whose lanes are set in `masks` as candidates, read
/// 64 lanes at a time (conv2's and conv3's runs are 200 lanes long, with few set): `masks`
/// holds whole words of 64 lanes, and the bytes past the run's, left from earlier runs, are
/// masked off.
#[cold]
pub(super) fn push_candidates(
    masks: &[u8],
    lanes: usize,
    split: &[(u32, u32)],
    pos0: u32,
    out: &mut Vec<(u32, u32)>,
) {
    // Room for every lane, written in place (at most one candidate per lane).
    out.reserve(lanes);
    let spare = &mut out.spare_capacity_mut()[..lanes];
    let mut n = 0;
    let words = masks[..lanes.div_ceil(64) * 8].chunks_exact(8);
    for (word, bytes) in words.enumerate() {
        let mut mask = u64::from_le_bytes(bytes.try_into().expect("8 bytes"));
        let left = lanes - word * 64;
        if left < 64 {
            mask &= (1 << left) - 1;
        }
        while mask != 0 {
            let (dp, map) = split[word * 64 + mask.trailing_zeros() as usize];
            spare[n].write((pos0 + dp, map));
            n += 1;
            mask &= mask - 1;
        }
    }
    // SAFETY: the `n` values after the length were written just above (`n ≤ lanes`: each is
    // a different bit below `lanes`), within the reserved capacity.
    unsafe { out.set_len(out.len() + n) };
}

/// Most output rows that `add_rows` takes at once.
pub(super) const FUSED_ROWS: usize = 16;
