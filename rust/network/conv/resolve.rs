//! Deciding a group's crossings: the float32 filter, exact potentials where it cannot tell,
//! lateral inhibition (the best crossing of a position fires and latches it), and the
//! merging of candidates that are not in position order.

use super::{
    each_fired_input, ConvState, Crossing, Fire, Fired, WholeCandidates, MAPS, OFFSET_SLOTS,
    POSITION_MAPS, WORD_POSITIONS,
};
use crate::network::weights::ConvWeights;
use crate::simd::FIXED_ROWS;

impl ConvState {
    /// The exact potential of neuron `(map, pos)`: the float64 sum of the weights of its inputs
    /// that fired. A field of one channel and the whole `FIXED_ROWS × FIXED_ROWS` kernel
    /// (conv1's, nearly always) takes `exact_whole`.
    pub(super) fn exact(&self, kernels: &[f32], fired: Fired<'_>, pos: usize, map: usize) -> f64 {
        let g = self.geom;
        if fired.channels == 1 && g.in_ch == 1 && g.k == FIXED_ROWS {
            let (oy, ox) = self.split.div_rem(pos);
            // `inputs_of`'s rows and columns are whole (`FIXED_ROWS` long, from `o − p_lo`)
            // where the field starts and ends inside the input: tested as such, without
            // clipping both ends.
            let whole =
                |o: usize, input: usize| o.checked_sub(g.p_lo).filter(|&i| i + FIXED_ROWS <= input);
            if let (Some(iy0), Some(ix0)) = (whole(oy, g.in_h), whole(ox, g.in_w)) {
                let kernel = kernels[map * FIXED_ROWS * FIXED_ROWS..][..FIXED_ROWS * FIXED_ROWS]
                    .try_into()
                    .expect("one channel's kernel");
                return exact_whole(kernel, fired, iy0, ix0);
            }
        }
        self.exact_general(kernels, fired, pos, map)
    }

    /// `exact` for any field, through `each_fired_input`. Out of line, so that `exact`'s
    /// common case saves no registers for it.
    #[inline(never)]
    pub(super) fn exact_general(
        &self,
        kernels: &[f32],
        fired: Fired<'_>,
        pos: usize,
        map: usize,
    ) -> f64 {
        let g = self.geom;
        let (oy, ox) = self.split.div_rem(pos);
        let kernel = &kernels[map * g.kernel_len()..(map + 1) * g.kernel_len()];
        let mut v = 0.0;
        each_fired_input(
            &g,
            fired,
            &self.input_split,
            self.avx2,
            oy,
            ox,
            |c, iy, ix| {
                let (dy, dx) = (iy + g.p_lo - oy, ix + g.p_lo - ox);
                v += f64::from(kernel[(c * g.k + dy) * g.k + dx]);
            },
        );
        v
    }

    /// Decide the crossings of the group just added and send the neurons that fire to `out`
    /// (`Fire`), in order, with their exact potential when `exact` (else `v` is NaN). `weights` are the
    /// layer's and `fired` its inputs that fired so far. Positions that reached their waking
    /// count in the group wake first.
    ///
    /// With lateral inhibition, a position that already fired this window fires nothing; among
    /// a position's crossings in the group the highest potential fires, ties going to the
    /// lowest map, and the position is locked. Without it, every crossing fires. Every neuron
    /// that crossed is latched.
    pub fn resolve<F: Fire>(
        &mut self,
        weights: &ConvWeights,
        fired: Fired<'_>,
        inhibit: bool,
        exact: bool,
        out: &mut F,
    ) {
        let exact = exact && F::EXACT;
        if let Some(held) = self.held {
            if inhibit && self.band.is_empty() && self.count.waking.is_empty() {
                // The common case of conv1: one input's candidates, and nothing else.
                self.held = None;
                self.fire_held(weights.canonical(), fired, exact, held, out);
                return;
            }
            self.list_held();
        }
        if !self.count.waking.is_empty() {
            self.wake(weights.engine(), fired);
        }
        if self.candidates.is_empty() && self.band.is_empty() {
            return;
        }
        let kernels = weights.canonical();
        let maps = self.geom.maps;
        // Which candidates crossed (the band's neurons stay candidates until they do). Their
        // runs are known as pushed, unless the band joins them (in no known order).
        let mut candidates = std::mem::take(&mut self.candidates);
        let runs = self
            .band
            .is_empty()
            .then_some((self.pos_sorted, self.breaks, self.breaks_len));
        self.clear_runs();
        if !self.band.is_empty() {
            candidates.append(&mut self.band);
        }
        if inhibit {
            // Those of one input come in position order, and most groups are one input; the
            // others are a few such runs (one per input), merged as packed `pos << 32 | map`
            // keys (`sort_runs`).
            let in_order = match runs {
                Some((pos_sorted, _, _)) => pos_sorted,
                None => candidates.windows(2).all(|p| p[0].0 <= p[1].0),
            };
            if in_order {
                self.fire_in_order(kernels, fired, exact, candidates.iter().copied(), out);
            } else {
                let mut order = std::mem::take(&mut self.order);
                order.clear();
                order.extend(
                    candidates
                        .iter()
                        .map(|&(pos, map)| u64::from(pos) << 32 | u64::from(map)),
                );
                match runs {
                    Some((_, breaks, len)) => {
                        merge_runs(
                            &mut order,
                            &mut self.merged,
                            &breaks[..len.min(MAX_RUNS)],
                            len,
                        );
                    }
                    None => sort_runs(&mut order, &mut self.merged),
                }
                let sorted = order.iter().map(|&key| ((key >> 32) as u32, key as u32));
                self.fire_in_order(kernels, fired, exact, sorted, out);
                self.order = order;
            }
            candidates.clear();
            self.candidates = candidates;
            return;
        }
        for &(pos, map) in &candidates {
            if let Some(c) = self.crossing(kernels, fired, pos, map) {
                self.crossed.push(c);
            }
        }
        candidates.clear();
        self.candidates = candidates;
        if exact {
            for i in 0..self.crossed.len() {
                let c = self.crossed[i];
                if c.v.is_nan() {
                    self.crossed[i].v = self.exact(kernels, fired, c.pos as usize, c.map as usize);
                }
            }
        }
        for c in &self.crossed {
            self.pot[c.pos as usize * maps + c.map as usize] = f32::NEG_INFINITY;
        }
        out.fire_all(&mut self.crossed);
    }

    /// Whether candidate `(pos, map)` has crossed: its crossing, with the exact potential if
    /// the float32 sum could not tell; `None` if it is latched (another map fired there since)
    /// or still below θ (then it goes back to the band).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(super) fn crossing(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        pos: u32,
        map: u32,
    ) -> Option<Crossing> {
        let v32 = self.pot[pos as usize * self.geom.maps + map as usize];
        let sure = self.thr.hi[map as usize];
        self.crossing_at(kernels, fired, pos, map, v32, sure)
    }

    /// `crossing` of a candidate whose float32 sum `v32` and map's `θ_hi` (`sure`) were read
    /// already (`fire_held` reads a position's maps, and conv1's thresholds, in one load).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub(super) fn crossing_at(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        pos: u32,
        map: u32,
        v32: f32,
        sure: f32,
    ) -> Option<Crossing> {
        if v32 == f32::NEG_INFINITY {
            return None;
        }
        let mut c = Crossing {
            pos,
            map,
            v: f64::NAN,
            v32,
        };
        if v32 < sure {
            c.v = self.exact(kernels, fired, pos as usize, map as usize);
            if c.v < self.thr.exact[map as usize] {
                self.band.push((pos, map));
                return None;
            }
        }
        Some(c)
    }

    /// `resolve` under lateral inhibition, for candidates in position order, in one pass:
    /// each position's crossings are consecutive, so its best (see `beats`) is known, fired
    /// and the position latched as soon as the next position's come (latching it cannot
    /// affect them). The spikes go up in position order; the order changes no result
    /// (decisions are exact whatever order float32 sums are taken in).
    pub(super) fn fire_in_order(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        exact: bool,
        candidates: impl Iterator<Item = (u32, u32)>,
        out: &mut impl Fire,
    ) {
        let maps = self.geom.maps;
        let mut best: Option<Crossing> = None;
        for (pos, map) in candidates {
            let Some(mut c) = self.crossing(kernels, fired, pos, map) else {
                continue;
            };
            if exact && c.v.is_nan() {
                c.v = self.exact(kernels, fired, pos as usize, map as usize);
            }
            match best {
                Some(b) if b.pos == pos => {
                    if self.beats(kernels, fired, c, b) {
                        best = Some(c);
                    }
                }
                Some(b) => {
                    out.fire(b);
                    latch_position(&mut self.pot, b.pos as usize, maps);
                    best = Some(c);
                }
                None => best = Some(c),
            }
        }
        if let Some(b) = best {
            out.fire(b);
            latch_position(&mut self.pot, b.pos as usize, maps);
        }
    }

    /// `fire_in_order` for the candidates of one whole input, held as bits: position by
    /// position (in position order), its crossings' best fires and the position is latched.
    pub(super) fn fire_held(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        exact: bool,
        held: WholeCandidates,
        out: &mut impl Fire,
    ) {
        let thr_hi: [f32; MAPS] = self.thr.hi[..MAPS].try_into().expect("MAPS thresholds");
        // The walk of `WholeCandidates::positions`, written out (the iterator costs more), a
        // copy per word (their positions' slots from a constant), both reading the one copy of
        // the thresholds.
        let [w0, w1] = held.words;
        self.fire_word(kernels, fired, exact, held.first, 0, w0, &thr_hi, out);
        self.fire_word(kernels, fired, exact, held.first, 1, w1, &thr_hi, out);
    }

    /// `fire_held` for word `word` of the held candidates, `bits`.
    #[allow(clippy::too_many_arguments, clippy::inline_always)]
    #[inline(always)]
    pub(super) fn fire_word(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        exact: bool,
        first: u32,
        word: usize,
        mut bits: u64,
        thr_hi: &[f32; MAPS],
        out: &mut impl Fire,
    ) {
        while bits != 0 {
            let p = bits.trailing_zeros() as usize / MAPS;
            let maps = (bits >> (p * MAPS)) as u32 & POSITION_MAPS;
            bits &= !(u64::from(POSITION_MAPS) << (p * MAPS));
            // Below `OFFSET_SLOTS` already: the remainder only tells the compiler so.
            let slot = (word * WORD_POSITIONS + p) % OFFSET_SLOTS;
            let pos = first + self.whole_offsets[slot];
            // `crossing` for each map, from one load of the position's potentials (none
            // changes before the position is decided).
            let at = pos as usize * MAPS;
            let cell: &mut [f32; MAPS] = (&mut self.pot[at..at + MAPS])
                .try_into()
                .expect("MAPS maps");
            // `maps` is not 0: one map is one bit (cheaper here than `is_power_of_two`).
            #[allow(clippy::manual_is_power_of_two)]
            let one = maps & (maps - 1) == 0;
            if one && !exact {
                // The common case: one map, whose float32 sum is surely above θ (what
                // `crossing_at` finds without gathering), fires alone. A latched map (`−∞`)
                // never passes: `θ_hi` is not `−∞` (it rounds up `θ · (1 + m)`, θ > 0).
                // Read and latched through one bounds check.
                let map = maps.trailing_zeros();
                let (v32, sure) = (cell[map as usize % MAPS], thr_hi[map as usize % MAPS]);
                if v32 >= sure {
                    out.fire(Crossing {
                        pos,
                        map,
                        v: f64::NAN,
                        v32,
                    });
                    *cell = [f32::NEG_INFINITY; MAPS];
                    continue;
                }
            }
            let v = *cell;
            self.fire_position(kernels, fired, exact, pos, maps, v, *thr_hi, out);
        }
    }

    /// `fire_held` for position `pos` whose candidate maps are the bits of `maps` (their
    /// float32 sums `v`, `θ_hi` `thr_hi`) where its common case does not decide it: its
    /// crossings' best fires and the position is latched. Out of line, so that the common
    /// case keeps its registers.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub(super) fn fire_position(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        exact: bool,
        pos: u32,
        mut maps: u32,
        v: [f32; MAPS],
        thr_hi: [f32; MAPS],
        out: &mut impl Fire,
    ) {
        let mut best: Option<Crossing> = None;
        while maps != 0 {
            let map = maps.trailing_zeros();
            maps &= maps - 1;
            let (v32, sure) = (v[map as usize % MAPS], thr_hi[map as usize % MAPS]);
            let Some(mut c) = self.crossing_at(kernels, fired, pos, map, v32, sure) else {
                continue;
            };
            if exact && c.v.is_nan() {
                c.v = self.exact(kernels, fired, pos as usize, map as usize);
            }
            match best {
                Some(b) if !self.beats(kernels, fired, c, b) => {}
                _ => best = Some(c),
            }
        }
        if let Some(b) = best {
            out.fire(b);
            latch_position(&mut self.pot, pos as usize, MAPS);
        }
    }

    /// Whether crossing `a` wins lateral inhibition over `b` (same position and group): the
    /// higher exact potential, then the lower map. Float32 sums decide where their error
    /// bounds cannot overlap; otherwise the exact potentials are gathered.
    pub(super) fn beats(
        &self,
        kernels: &[f32],
        fired: Fired<'_>,
        a: Crossing,
        b: Crossing,
    ) -> bool {
        let (va, vb) = if a.v.is_nan() || b.v.is_nan() {
            let (sa, sb) = (f64::from(a.v32), f64::from(b.v32));
            let (lo, hi) = self.thr.bounds;
            if sa * lo > sb * hi {
                return true;
            }
            if sb * lo > sa * hi {
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

/// `ConvState::exact` for a neuron of one input channel whose receptive field is the whole
/// `FIXED_ROWS × FIXED_ROWS` kernel `kernel` (canonical `[dy][dx]`), from input row `iy0` and
/// column `ix0`: conv1's, nearly always. The same float64 sum in the same order (the fired
/// inputs row by row, each row's from the left, as `each_fired_input` visits them), each row's
/// stamps tested together instead of through the general walk.
#[inline]
pub(super) fn exact_whole(
    kernel: &[f32; FIXED_ROWS * FIXED_ROWS],
    fired: Fired<'_>,
    iy0: usize,
    ix0: usize,
) -> f64 {
    let mut v = 0.0;
    for (dy, krow) in kernel.chunks_exact(FIXED_ROWS).enumerate() {
        let from = (iy0 + dy) * fired.width + ix0;
        let row: &[u32; FIXED_ROWS] = fired.stamps[from..from + FIXED_ROWS]
            .try_into()
            .expect("one row of the field");
        let mut mask = 0u32;
        for (b, &stamp) in row.iter().enumerate() {
            mask |= u32::from(stamp == fired.generation) << b;
        }
        while mask != 0 {
            v += f64::from(krow[mask.trailing_zeros() as usize]);
            mask &= mask - 1;
        }
    }
    v
}

/// Latch every map of position `pos` (set its `maps` float32 potentials to `−∞`).
#[inline]
pub(super) fn latch_position(pot: &mut [f32], pos: usize, maps: usize) {
    let run = &mut pot[pos * maps..(pos + 1) * maps];
    match <&mut [f32; 4]>::try_from(&mut *run) {
        // conv1's 4 maps: one vector store, not a loop of unknown length.
        Ok(four) => *four = [f32::NEG_INFINITY; 4],
        Err(_) => run.fill(f32::NEG_INFINITY),
    }
}

/// Beyond this many runs, merging pairwise costs more than sorting (`sort_runs`).
pub(super) const MAX_RUNS: usize = 8;

/// Sort `v` by merging its ascending runs (the candidates of one input come in position
/// order, so a group's keys are a few such runs), pairwise through `buffer`; with many runs, an
/// ordinary sort.
pub(super) fn sort_runs(v: &mut Vec<u64>, buffer: &mut Vec<u64>) {
    let mut breaks = [0u32; MAX_RUNS];
    let mut len = 0;
    for i in 1..v.len() {
        if v[i] < v[i - 1] {
            if len == MAX_RUNS {
                v.sort_unstable();
                return;
            }
            breaks[len] = i as u32;
            len += 1;
        }
    }
    merge_runs(v, buffer, &breaks[..len], len);
}

/// `sort_runs` of `v` whose runs are known: each starts at one of `breaks` but the first;
/// `len` breaks in all, of which those past `MAX_RUNS` are not kept (an ordinary sort then).
pub(super) fn merge_runs(v: &mut Vec<u64>, buffer: &mut Vec<u64>, breaks: &[u32], len: usize) {
    if len >= MAX_RUNS {
        v.sort_unstable();
        return;
    }
    let mut ends = [0usize; MAX_RUNS];
    for (end, &b) in ends.iter_mut().zip(breaks) {
        *end = b as usize;
    }
    ends[len] = v.len();
    let mut runs = len + 1;
    // The buffer as long as `v`, so that swapping them keeps both so.
    buffer.resize(v.len(), 0);
    while runs > 1 {
        let (mut start, mut merged) = (0, 0);
        let mut r = 0;
        while r < runs {
            let mid = ends[r];
            let end = if r + 1 < runs { ends[r + 1] } else { mid };
            merge(&v[start..mid], &v[mid..end], &mut buffer[start..end]);
            ends[merged] = end;
            merged += 1;
            start = end;
            r += 2;
        }
        std::mem::swap(v, buffer);
        runs = merged;
    }
}

/// Merge the ascending `a` and `b` into `out` (`a.len() + b.len()` values), `b`'s after
/// `a`'s equal ones; each step takes one value without a branch on which.
#[inline]
pub(super) fn merge(a: &[u64], b: &[u64], out: &mut [u64]) {
    assert_eq!(out.len(), a.len() + b.len(), "room for both");
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let take_b = b[j] < a[i];
        out[i + j] = if take_b { b[j] } else { a[i] };
        j += usize::from(take_b);
        i += usize::from(!take_b);
    }
    // What is left of one of them (the other is used up): a few values, copied in a loop
    // rather than through two `memcpy` calls.
    for (o, &x) in out[i + j..].iter_mut().zip(a[i..].iter().chain(&b[j..])) {
        *o = x;
    }
}
