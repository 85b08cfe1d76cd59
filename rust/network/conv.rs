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
//! **Waking by count** (layers with many maps whose positions need many inputs to cross; the
//! choice is made per window, see `set_wake`). All weights are ≥ 0, so a neuron whose `n`
//! fired inputs are fewer than its map needs (the `n` largest weights of its kernel falling
//! short of θ, see `weights`) cannot have crossed. Such a layer counts, per position, the
//! inputs that fired (one counter for all maps) and keeps no potentials at positions still
//! short of the fewest inputs any map needs. A position that reaches it *wakes* once its group
//! is added: its float32 potentials are gathered from the inputs that fired, its maps at or
//! above `θ_lo` become candidates, and from then on it is added to like any other. One input
//! spike of conv2 thus costs `k²` counter increments, plus `maps` additions only where the
//! counts are already high, instead of `k² × maps` additions everywhere.
//!
//! **Sparse reset.** The layer records where its input spikes landed; the next window zeroes
//! those runs (or the positions that woke), in fixed blocks that may reach past a run into
//! potentials that are zero anyway (`ZERO_BLOCK`), so nothing is swept and the hot loop
//! carries no per-position stamps. A position that fired under lateral inhibition has all its
//! maps latched, which is all the lock it needs.
//!
//! **conv1's shape.** Nearly every conv1 input lies away from the borders, where its footprint
//! is the whole 5 × 5 kernel of 4 maps: such inputs take a path compiled for that shape
//! (`add_whole`, `add_rows_fixed`).

use std::ops::Range;

use super::geometry::{ConvGeom, Divider};
use super::weights::ConvWeights;
use crate::simd::{
    add_detect, add_rows, add_rows_fixed, count_rows, count_rows_unchecked, fired_mask, zero_all,
    Avx2, FIXED_KERNEL, FIXED_ROWS, FIXED_RUN, LANES, WORD_ROWS,
};

/// The bit of a position's input count that says it is awake (counts stay below it, and
/// awake counts stay positive as `i16`, for the vector compare).
const AWAKE: u16 = 1 << 14;

/// Fewest maps for which a layer wakes by count: the count saves `maps − 1` additions per
/// input and position, which pays for the waking (measured on the bench scenes: conv1's 4 maps
/// are cheaper added densely).
const WAKE_MAPS: usize = 8;

/// A layer wakes by count only where a position needs at least this many kernel widths of
/// fired inputs to wake. Where it needs fewer, nearly every position an input reaches wakes
/// within a few inputs, and gathering its potentials costs more than adding them as they come
/// (measured on the bench scenes: conv2 with Table 1's threshold 45 wakes at 48 inputs and
/// gains 1.7× by count; with the recipe's threshold 10 it wakes at 11 inputs and loses 1.4×,
/// as conv3 does at 3).
const WAKE_WIDTHS: usize = 2;

/// Potentials that `reset` zeroes with one fixed-size store, and the padding at the end of
/// `ConvState::pot` that lets the last block of a run reach past the layer. A block may also
/// reach past its run into potentials that are zero already or zeroed by the same reset, so
/// a run costs a few vector stores instead of a `memset` call.
const ZERO_BLOCK: usize = 32;

/// Where one input spike's additions landed: `rows` output rows, one `out_w` apart, of `cols`
/// positions from position `first` (what the next window must zero).
#[derive(Debug, Clone, Copy)]
struct Footprint {
    first: u32,
    rows: u16,
    cols: u16,
}

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

/// Where `resolve` sends the neurons that fire, in firing order: a list of crossings, or for
/// conv1 in a window neither recorded nor trained, pool1 itself (`pool::PoolSink`), which
/// takes each spike as it fires instead of a second pass over a list.
pub(crate) trait Fire {
    /// Whether it may want the exact potentials (`resolve`'s `exact`): where not, `resolve`
    /// is compiled without them, whatever the optimiser makes of its callers.
    const EXACT: bool = true;

    /// Fire one neuron.
    fn fire(&mut self, c: Crossing);

    /// Fire `crossed`'s neurons in order, leaving it empty.
    fn fire_all(&mut self, crossed: &mut Vec<Crossing>) {
        for c in crossed.drain(..) {
            self.fire(c);
        }
    }
}

impl Fire for Vec<Crossing> {
    #[inline]
    fn fire(&mut self, c: Crossing) {
        self.push(c);
    }

    fn fire_all(&mut self, crossed: &mut Vec<Crossing>) {
        self.append(crossed);
    }
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

/// Per-window state of one conv layer.
#[derive(Debug, Clone)]
#[allow(clippy::struct_excessive_bools)] // flags the hot paths test, not a state machine
pub(crate) struct ConvState {
    pub geom: ConvGeom,
    /// Float32 running potentials `[row][col][map]` (`−∞` once crossed), then `ZERO_BLOCK`
    /// zeros of padding.
    pot: Vec<f32>,
    /// Per lane of a row's run: (position offset, map), to avoid dividing in the hot loop.
    lane_split: Vec<(u32, u32)>,
    /// Per input of a row of a receptive field, `[col][channel]`: (column offset, channel).
    input_split: Vec<(u32, u32)>,
    /// Per input of such a row: `c·k² + k − 1 − col`, its part of the index of its run of
    /// `maps` weights in the engine layout (waking adds the row's and the clipping's parts);
    /// zeros after them up to `WAKE_LANES` values, so that a lane of a row of at most 64 (a
    /// trailing-zero count) indexes a `WAKE_LANES` array without a test.
    wake_base: Vec<u32>,
    /// Exact thresholds per map.
    thr: Vec<f64>,
    /// `θ_hi` per map: float32 sums at or above it have surely crossed.
    thr_hi: Vec<f32>,
    /// Filter thresholds `θ_lo` per map, tiled `k` times to match one row's run.
    thr_lo: Vec<f32>,
    /// Whether every `θ_lo` is above 0, the potential of a neuron without inputs (`add_whole`'s
    /// `fresh` needs every neuron below `θ_lo` at rest).
    lo_positive: bool,
    /// Relative error bound `m` of the float32 sums.
    margin: f64,
    /// `(1 − m, 1 + m)`: the factors that bound an exact sum from its float32 one (`beats`).
    bounds: (f64, f64),
    /// Neurons `(pos, map)` whose float32 sum reached `θ_lo` in the current group.
    candidates: Vec<(u32, u32)>,
    /// Where `candidates` fall out of `(pos, map)` order, noted as each batch of them (one
    /// input's, or one waking position's: ascending) is pushed (`note_run`): the first index of
    /// each run after the first (`breaks_len` of them, kept up to `MAX_RUNS`), and whether their
    /// positions alone stay in order. `resolve` reads them instead of scanning.
    breaks: [u32; MAX_RUNS],
    breaks_len: usize,
    pos_sorted: bool,
    /// The candidates of a group's first whole input (`add_whole`), held as its lanes' bits
    /// while no other input of the group has any (most groups are one input): they are in
    /// position order already, so `resolve` walks them position by position (`fire_held`)
    /// without listing them or checking their order. Listed in `candidates` (`list_held`) as
    /// soon as anything else is. Never set with `candidates` non-empty.
    held: Option<WholeCandidates>,
    /// Per position `p` of a whole footprint (`p / k` rows and `p mod k` columns from its
    /// first): its offset from the first, `(p / k) · out_w + p mod k`.
    /// Padded to `OFFSET_SLOTS`, so that the index of any nibble of a word needs no bounds
    /// check.
    whole_offsets: [u32; OFFSET_SLOTS],
    /// Earlier candidates whose exact potential was still below θ (re-checked every group).
    band: Vec<(u32, u32)>,
    /// Neurons that crossed in the current group (without lateral inhibition).
    crossed: Vec<Crossing>,
    /// Scratch of lateral inhibition for groups whose candidates are not in position order:
    /// the candidates as `pos << 32 | map` keys sorted by position, and the merge's buffer.
    order: Vec<u64>,
    merged: Vec<u64>,
    /// Where the inputs added this window landed (what the next window must zero).
    inputs: Vec<Footprint>,
    /// Potentials written this window by `inputs`, counted with repeats (the cost of
    /// replaying them).
    touched_lanes: usize,
    /// The first potentials (first position · `MAPS`) of the whole footprints added this
    /// window (`add_whole`'s, of `FIXED_ROWS` rows of `FIXED_RUN` lanes each), kept apart
    /// from `inputs` so that pushing one is one value and zeroing it needs no test of its
    /// shape (nor a multiplication).
    wholes: Vec<u32>,
    /// Scratch: per 8 lanes of a run, which reached `θ_lo` (whole words of 64 lanes, read as
    /// such by `push_candidates`).
    masks: Vec<u8>,
    /// Whether the CPU has AVX2 (asked once, at construction).
    avx2: Option<Avx2>,
    /// Whether this layer wakes positions by count in the current window (see the module docs
    /// and `set_wake`).
    gated: bool,
    /// Whether it may: enough maps, and counts that fit the vectors (fixed by the geometry).
    can_gate: bool,
    /// A choice forced by tests (`set_gated`) instead of the rule of `set_wake`.
    #[cfg(test)]
    forced: Option<bool>,
    /// Per position: how many of its inputs fired this window, `| AWAKE` once awake
    /// (`LANES` more at the end, never counted, so that a row's vector never reads past it).
    counts: Vec<u16>,
    /// The count at which a position wakes: the fewest inputs any map needs to cross.
    wake_at: u16,
    /// Positions that reached `wake_at` in the current group (woken in `resolve`).
    waking: Vec<u32>,
    /// Positions awake this window (what the next window must zero).
    awake: Vec<u32>,
    /// Per input row `iy`: `[rows.start · out_w, rows.len()]` of the output rows whose
    /// kernel covers it (`outputs_of`); per input column: `[cols.start, cols.len()]`. What
    /// `count_spikes` reads instead of computing the two ranges per spike.
    row_spans: Vec<[u32; 2]>,
    col_spans: Vec<[u32; 2]>,
    /// Division by the output width (position → row, column).
    split: Divider,
    /// The inputs that `add_whole` takes (when the layer adds densely), where it may: the layer
    /// has `FIXED_ROWS` rows of `FIXED_RUN` lanes and the CPU has AVX2.
    whole: Option<Whole>,
}

/// The candidates of one whole input (`add_whole`): lane `l` of output row `r`'s run is bit
/// `(r mod WORD_ROWS) · FIXED_RUN + l` of `words[r / WORD_ROWS]`, so that each word is walked
/// with 64-bit operations and holds whole positions. Its `MAPS` lanes from `MAPS · p` are the
/// maps of position `WORD_POSITIONS · word + p` of the footprint (see `whole_offsets`).
#[derive(Debug, Clone, Copy)]
struct WholeCandidates {
    first: u32,
    words: [u64; 2],
}

/// A whole conv1 footprint's maps per position, positions per word, and positions.
const MAPS: usize = FIXED_RUN / FIXED_ROWS;
const WORD_POSITIONS: usize = WORD_ROWS * FIXED_RUN / MAPS;
const WHOLE_POSITIONS: usize = FIXED_ROWS * FIXED_ROWS;
/// `WORD_POSITIONS + 64 / MAPS`, rounded up to a power of two: above any
/// `WORD_POSITIONS · word + nibble` of a word's 64 bits.
const OFFSET_SLOTS: usize = (WORD_POSITIONS + 64 / MAPS).next_power_of_two();
/// The bits of one position's maps.
const POSITION_MAPS: u32 = (1 << MAPS) - 1;

/// The inputs of a layer whose footprint is the whole kernel: input rows and columns whose `k`
/// output rows (columns) are all inside the layer, `rows` from `row0` and `cols` from `col0`
/// (as first and length, so that an input is tested with one compare per axis, and its
/// distance from the first is its footprint's first output row or column); and the proof that
/// the CPU has AVX2, which `add_rows_fixed` needs.
#[derive(Debug, Clone)]
struct Whole {
    row0: usize,
    /// The rows, or 0 while the layer wakes by count (`set_wake`), when no input is whole.
    rows: usize,
    col0: usize,
    cols: usize,
    /// The rows whole footprints have (what `rows` is while the layer adds densely).
    all_rows: usize,
    /// The potentials of one output row, `out_w · MAPS`: the stride of a footprint's rows.
    stride: usize,
    /// `θ_lo` of one row's run: `thr_lo`'s first `FIXED_RUN`, copied by `set_thresholds`, so
    /// that an input reads them without a bounds check.
    thr: [f32; FIXED_RUN],
    /// Channel 0's kernel of the weights last given to `load_kernel`: what `add_inline`'s
    /// inputs read (off `self`, so that the loop keeps no pointer to the weights).
    kernel: [f32; FIXED_KERNEL],
    avx2: Avx2,
}

impl Whole {
    /// The whole footprints of a layer of `out_w` positions a row whose potentials `pot`
    /// holds: asserts that the last lies inside it (what `add_whole` relies on).
    fn new(rows: Range<usize>, cols: Range<usize>, out_w: usize, pot: usize, avx2: Avx2) -> Self {
        let stride = out_w * MAPS;
        if !rows.is_empty() && !cols.is_empty() {
            let last = (rows.len() - 1) * out_w + cols.len() - 1;
            assert!(
                last * MAPS + (FIXED_ROWS - 1) * stride + FIXED_RUN <= pot,
                "whole footprints inside the layer"
            );
        }
        Self {
            row0: rows.start,
            rows: rows.len(),
            col0: cols.start,
            cols: cols.len(),
            all_rows: rows.len(),
            stride,
            thr: [f32::INFINITY; FIXED_RUN],
            kernel: [0.0; FIXED_KERNEL],
            avx2,
        }
    }
}

impl ConvState {
    pub fn new(geom: ConvGeom) -> Self {
        let positions = geom.out_h * geom.out_w;
        let margin = geom.kernel_len() as f64 * f64::from(f32::EPSILON);
        Self {
            geom,
            pot: vec![0.0; positions * geom.maps + ZERO_BLOCK],
            lane_split: (0..geom.k * geom.maps)
                .map(|l| ((l / geom.maps) as u32, (l % geom.maps) as u32))
                .collect(),
            input_split: (0..geom.k * geom.in_ch)
                .map(|l| ((l / geom.in_ch) as u32, (l % geom.in_ch) as u32))
                .collect(),
            wake_base: (0..(geom.k * geom.in_ch).max(WAKE_LANES))
                .map(|l| {
                    if l >= geom.k * geom.in_ch {
                        return 0; // past a row's inputs
                    }
                    let (col, c) = (l / geom.in_ch, l % geom.in_ch);
                    (c * geom.k * geom.k + geom.k - 1 - col) as u32
                })
                .collect(),
            thr: vec![f64::INFINITY; geom.maps],
            thr_hi: vec![f32::INFINITY; geom.maps],
            thr_lo: vec![f32::INFINITY; geom.k * geom.maps],
            lo_positive: true,
            margin,
            bounds: (1.0 - margin, 1.0 + margin),
            candidates: Vec::new(),
            breaks: [0; MAX_RUNS],
            breaks_len: 0,
            pos_sorted: true,
            held: None,
            whole_offsets: std::array::from_fn(|p| {
                if p < WHOLE_POSITIONS {
                    ((p / FIXED_ROWS) * geom.out_w + p % FIXED_ROWS) as u32
                } else {
                    0 // never set in a word
                }
            }),
            band: Vec::new(),
            crossed: Vec::new(),
            order: Vec::new(),
            merged: Vec::new(),
            inputs: Vec::new(),
            touched_lanes: 0,
            wholes: Vec::new(),
            masks: vec![0; (geom.k * geom.maps).div_ceil(64) * 8],
            avx2: Avx2::detect(),
            gated: false,
            can_gate: geom.k <= LANES && geom.kernel_len() < AWAKE.into(),
            #[cfg(test)]
            forced: None,
            counts: vec![0; positions + LANES],
            wake_at: 0,
            waking: Vec::new(),
            awake: Vec::new(),
            row_spans: (0..geom.in_h)
                .map(|iy| {
                    let rows = geom.outputs_of(iy, geom.out_h);
                    [(rows.start * geom.out_w) as u32, rows.len() as u32]
                })
                .collect(),
            col_spans: (0..geom.in_w)
                .map(|ix| {
                    let cols = geom.outputs_of(ix, geom.out_w);
                    [cols.start as u32, cols.len() as u32]
                })
                .collect(),
            split: Divider::new(geom.out_w),
            whole: Avx2::detect()
                .filter(|_| geom.k == FIXED_ROWS && geom.k * geom.maps == FIXED_RUN)
                .map(|avx2| {
                    Whole::new(
                        geom.whole_footprints(geom.out_h),
                        geom.whole_footprints(geom.out_w),
                        geom.out_w,
                        positions * geom.maps + ZERO_BLOCK,
                        avx2,
                    )
                }),
        }
    }

    /// Per lane of a receptive field's row `[col][channel]`: (column offset, channel).
    pub fn input_split(&self) -> &[(u32, u32)] {
        &self.input_split
    }

    /// Divides a position index by the output width: `div_rem` gives `(row, col)`.
    #[inline]
    pub fn splitter(&self) -> Divider {
        self.split
    }

    /// Force whether this layer wakes positions by count from the next window on, instead of
    /// the rule of `set_wake`; results are the same either way. Call between windows.
    #[cfg(test)]
    pub fn set_gated(&mut self, gated: bool) {
        self.forced = Some(gated);
    }

    /// Zero the potentials that the last window touched.
    ///
    /// Replaying the window's inputs costs what their additions cost; where that would exceed
    /// one pass over the layer (a busy window on a small layer), one contiguous fill is cheaper
    /// and does the same. Either way the cost never exceeds the window's own work.
    pub fn reset(&mut self) {
        let g = self.geom;
        let maps = g.maps;
        if self.gated {
            for &pos in &self.awake {
                zero_blocks(&mut self.pot, pos as usize * maps, maps);
            }
            if self.touched_lanes >= self.counts.len() {
                zero_all(self.avx2, &mut self.counts);
            } else {
                for f in &self.inputs {
                    for r in 0..usize::from(f.rows) {
                        // One vector of counts (`cols ≤ k ≤ LANES`; `counts` has `LANES` of
                        // padding); the lanes past the run are zero or zeroed here too.
                        let start = f.first as usize + r * g.out_w;
                        self.counts[start..start + LANES].copy_from_slice(&[0; LANES]);
                    }
                }
            }
        } else if self.touched_lanes + self.wholes.len() * FIXED_ROWS * FIXED_RUN >= g.neurons() {
            zero_all(self.avx2, &mut self.pot);
        } else {
            zero_footprints(self.avx2, &mut self.pot, &self.inputs, g.out_w, maps);
            zero_wholes(self.avx2, &mut self.pot, &self.wholes, g.out_w * maps);
        }
        self.touched_lanes = 0;
        self.inputs.clear();
        self.wholes.clear();
        self.awake.clear();
        self.waking.clear();
        self.candidates.clear();
        self.clear_runs();
        self.held = None;
        self.band.clear();
        self.crossed.clear();
    }

    /// Set the per-map thresholds for the coming window.
    pub fn set_thresholds(&mut self, thresholds: impl Fn(usize) -> f32) {
        let maps = self.geom.maps;
        let mut same = true;
        for (m, t) in self.thr.iter_mut().enumerate() {
            let new = f64::from(thresholds(m));
            same &= t.to_bits() == new.to_bits();
            *t = new;
        }
        if same {
            // The rest follows from the thresholds (and the fixed margin) alone: conv2's and
            // conv3's, the same every window, are not tiled again.
            return;
        }
        for (hi, &t) in self.thr_hi.iter_mut().zip(&self.thr) {
            *hi = round_up(t * (1.0 + self.margin));
        }
        let slack = (1.0 - self.margin).max(0.0);
        for (lo, &t) in self.thr_lo.iter_mut().zip(&self.thr) {
            *lo = round_down(t * slack);
        }
        // The other `k − 1` tiles repeat the first.
        for i in maps..self.thr_lo.len() {
            self.thr_lo[i] = self.thr_lo[i - maps];
        }
        self.lo_positive = self.thr_lo[..maps].iter().all(|&lo| lo > 0.0);
        if let Some(whole) = &mut self.whole {
            whole.thr.copy_from_slice(&self.thr_lo[..FIXED_RUN]);
        }
    }

    /// Set how many fired inputs wake a position (after `set_thresholds` and `reset`, with the
    /// layer's weights): the fewest with which any map's largest weights reach its `θ_lo`; and
    /// from it whether the window wakes positions by count: with at least `WAKE_MAPS` maps and
    /// `WAKE_WIDTHS · k` inputs to wake.
    ///
    /// The choice may change from window to window: after `reset` every potential and count is
    /// zero whichever way the last window ran (a layer that wakes by count writes potentials
    /// only at awake positions, and zeroes them there), so both ways start from the same state.
    pub fn set_wake(&mut self, weights: &ConvWeights) {
        let lo = 1.0 - self.margin;
        let inputs = self.geom.kernel_len();
        let fewest = (0..self.geom.maps).fold(usize::MAX, |fewest, m| {
            let target = self.thr[m] * lo;
            // A map lowers the fewest so far only where one input fewer reaches its target:
            // one sum read instead of a search, for nearly every map after the first.
            if fewest == 0 || (fewest <= inputs + 1 && !weights.reaches(m, fewest - 1, target)) {
                fewest
            } else {
                fewest.min(weights.inputs_to_reach(m, target))
            }
        });
        // Never 0 (a position with no input has no potential); beyond any count if unreachable.
        self.wake_at = fewest.clamp(1, usize::from(AWAKE - 1)) as u16;
        let rule = self.geom.maps >= WAKE_MAPS && fewest >= WAKE_WIDTHS * self.geom.k;
        #[cfg(test)]
        let rule = self.forced.unwrap_or(rule);
        self.gated = self.can_gate && rule;
        if let Some(whole) = &mut self.whole {
            // `add` tests for a whole input only: none is while the layer wakes by count.
            whole.rows = if self.gated { 0 } else { whole.all_rows };
        }
    }

    /// Add input spike `(c, iy, ix)` (engine-layout weights `w`) to every neuron whose kernel
    /// covers it; neurons whose float32 sum reaches `θ_lo` become candidates of the group.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn add(&mut self, w: &[f32], c: usize, iy: usize, ix: usize) {
        // SAFETY: without `WHOLE`, `add_in` has no contract.
        unsafe { self.add_in::<false, false>(w, c, iy, ix) };
    }

    /// `add` of channel 0 from a caller compiled for AVX2 (see `add_rows_fixed`'s `INLINE`),
    /// whose whole inputs read the kernel copied by `load_kernel`: `w` must be the weights
    /// last given to it.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn add_inline(&mut self, w: &[f32], iy: usize, ix: usize) {
        // SAFETY: without `WHOLE`, `add_in` has no contract.
        unsafe { self.add_in::<true, false>(w, 0, iy, ix) };
    }

    /// `add_inline` for a layer that has whole inputs, without testing for them per input.
    ///
    /// # Safety
    /// `has_whole` must be true (as it stays: `whole` is set by `new` alone).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub unsafe fn add_inline_whole(&mut self, w: &[f32], iy: usize, ix: usize) {
        // SAFETY: `add_in`'s contract is this function's.
        unsafe { self.add_in::<true, true>(w, 0, iy, ix) };
    }

    /// Whether the layer has whole inputs (`Whole`): fixed from `new` on.
    pub fn has_whole(&self) -> bool {
        self.whole.is_some()
    }

    /// Copy channel 0's kernel of the engine-layout weights `w` for `add_inline` (where the
    /// layer has whole inputs): once before a run of its inputs, not per input.
    pub fn load_kernel(&mut self, w: &[f32]) {
        if let Some(whole) = &mut self.whole {
            whole.kernel = *w.first_chunk().expect("one channel's kernel");
        }
    }

    /// `add`, with `add_rows_fixed`'s `INLINE`; `WHOLE` where the caller knows the layer has
    /// whole inputs, so that `whole` is not tested.
    ///
    /// # Safety
    /// With `WHOLE`, `has_whole` must be true; without it, none.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    unsafe fn add_in<const INLINE: bool, const WHOLE: bool>(
        &mut self,
        w: &[f32],
        c: usize,
        iy: usize,
        ix: usize,
    ) {
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
            // SAFETY: with `WHOLE`, the caller guarantees `has_whole` (this function's contract).
            None if WHOLE => unsafe { std::hint::unreachable_unchecked() },
            None => self.add_clipped(w, c, iy, ix),
        }
    }

    /// `add` for every input but the whole ones of `add_whole`: footprints clipped by the
    /// borders, layers other than conv1, layers that wake by count. Out of line, so that `add`
    /// inlines into its callers' loops with only `add_whole`'s few registers to save.
    #[inline(never)]
    fn add_clipped(&mut self, w: &[f32], c: usize, iy: usize, ix: usize) {
        self.list_held();
        let g = self.geom;
        let maps = g.maps;
        let cols = g.outputs_of(ix, g.out_w);
        if cols.is_empty() {
            return;
        }
        let rows = g.outputs_of(iy, g.out_h);
        self.inputs.push(Footprint {
            first: (rows.start * g.out_w + cols.start) as u32,
            rows: rows.len() as u16,
            cols: cols.len() as u16,
        });
        // Kernel column index j = k − 1 − dx of the first output column; each output row
        // further down reads the kernel row above (dy falls by one).
        let j0 = g.k - 1 - (ix + g.p_lo - cols.start);
        let dy0 = iy + g.p_lo - rows.start;
        if self.gated {
            self.touched_lanes += rows.len() * cols.len();
            // Count the input at every output row first (one vector pass where the CPU has
            // AVX2), then add it to the rows that have awake positions.
            let mut hit_rows = [0u32; FUSED_ROWS];
            let hit_rows = &mut hit_rows[..rows.len()];
            let p0 = rows.start * g.out_w + cols.start;
            if !count_rows(
                self.avx2,
                &mut self.counts,
                p0,
                g.out_w,
                cols.len(),
                self.wake_at,
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
            self.touched_lanes += rows.len() * run;
            if let Some(avx2) = self.avx2.filter(|_| run <= 32 && rows.len() <= FUSED_ROWS) {
                // One vector pass over every row, then the candidates of the rows that had any.
                let mut masks = [0u32; FUSED_ROWS];
                let masks = &mut masks[..rows.len()];
                let (p0, w0) = (
                    (rows.start * g.out_w + cols.start) * maps,
                    ((c * g.k + dy0) * g.k + j0) * maps,
                );
                let (p_stride, w_stride) = (g.out_w * maps, g.k * maps);
                let thr = &self.thr_lo[..run];
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
    fn add_each(&mut self, w: &[f32], spikes: &[(u32, u32, u32)]) {
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
    fn count_spikes(&mut self, avx2: Avx2, w: &[f32], spikes: &[(u32, u32, u32)]) {
        /// Output rows of a whole footprint of Table 1's conv2, whose counting is unrolled.
        const CONV2_ROWS: usize = 10;
        let out_w = self.geom.out_w;
        // Written by `count_rows_unchecked` for every row it counts before `add_counted` reads
        // them: zeroed once, not per spike.
        let mut hits = [0u32; FUSED_ROWS];
        for &(c, iy, ix) in spikes {
            let ([r0, rows], [c0, cols]) =
                (self.row_spans[iy as usize], self.col_spans[ix as usize]);
            if cols == 0 {
                continue;
            }
            let p0 = (r0 + c0) as usize;
            self.inputs.push(Footprint {
                first: p0 as u32,
                rows: rows as u16,
                cols: cols as u16,
            });
            let (rows, len) = (rows as usize, cols as usize);
            self.touched_lanes += rows * len;
            if rows == 0 {
                continue;
            }
            let counts = &mut self.counts[p0..p0 + (rows - 1) * out_w + LANES];
            assert!(len <= LANES, "one vector of counts per row");
            let wake_at = self.wake_at;
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
    fn add_counted(&mut self, w: &[f32], c: usize, iy: usize, ix: usize, p0: usize, hits: &[u32]) {
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
    unsafe fn add_whole<const INLINE: bool>(&mut self, w: &[f32], c: usize, first: usize) {
        let Some(whole) = &self.whole else {
            unreachable!("add_whole without Whole")
        };
        self.wholes.push((first * MAPS) as u32);
        // With nothing of the group pending and nothing in the band, every neuron is below
        // `θ_lo` or latched: it starts at 0, below every `θ_lo` (`lo_positive`), reaches
        // `θ_lo` only by an add that makes it a candidate, and `resolve` latches each candidate
        // or keeps it in the band. The add's crossings are then the lanes it takes to `θ_lo` or
        // above (latched ones stay `−∞`): `add_rows_fixed`'s `fresh`.
        // (Tested together, without a branch each.)
        let pending = self.held.is_some() | !self.candidates.is_empty();
        let fresh = !pending & self.band.is_empty() & self.lo_positive;
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
    fn note_run(&mut self, start: usize) {
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
    fn clear_runs(&mut self) {
        self.breaks_len = 0;
        self.pos_sorted = true;
    }

    /// Move the candidates held as bits (`held`), if any, to `candidates`. The test inline,
    /// the listing (rare) out of line.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn list_held(&mut self) {
        if let Some(held) = self.held.take() {
            self.list(held);
        }
    }

    /// `list_held` of `held`.
    #[inline(never)]
    fn list(&mut self, held: WholeCandidates) {
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
    fn list_word(&mut self, first: u32, word: usize, mut bits: u64) {
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
    fn push_row_candidates(&mut self, masks: &[u32], first: usize) {
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
    fn add_awake(&mut self, w: &[f32], wstart: usize, p0: usize, mut hits: u32) {
        let maps = self.geom.maps;
        let mut run: Option<(usize, usize)> = None;
        while hits != 0 {
            let d = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let n = self.counts[p0 + d];
            if n & AWAKE == 0 {
                if n == self.wake_at {
                    self.waking.push((p0 + d) as u32);
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
    fn add_run(&mut self, w: &[f32], wstart: usize, pos0: usize, len: usize) {
        let maps = self.geom.maps;
        let run = len * maps;
        let start = pos0 * maps;
        let hit = add_detect(
            self.avx2,
            &mut self.pot[start..start + run],
            &w[wstart..wstart + run],
            &self.thr_lo[..run],
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

    /// Wake the positions that reached `wake_at` in the group just added: gather their float32
    /// potentials from the inputs that fired (engine-layout weights `w`), in the order of
    /// `each_fired_input`; maps at or above `θ_lo` become candidates. Out of line, so that
    /// `resolve`, which calls it for few groups, is compiled without it.
    #[inline(never)]
    fn wake(&mut self, w: &[f32], fired: Fired<'_>) {
        let g = self.geom;
        let maps = g.maps;
        let waking = std::mem::take(&mut self.waking);
        for &pos in &waking {
            let p = pos as usize;
            self.counts[p] |= AWAKE;
            self.awake.push(pos);
            let (oy, ox) = self.split.div_rem(p);
            let pot = &mut self.pot[p * maps..(p + 1) * maps];
            gather(self.avx2, &g, fired, &self.wake_base, w, oy, ox, pot);
            let start = self.candidates.len();
            let thr_lo = &self.thr_lo[..maps];
            if let (Ok(v), Ok(lo)) = (
                <&[f32; GATHER_MAPS]>::try_from(&*pot),
                <&[f32; GATHER_MAPS]>::try_from(thr_lo),
            ) {
                // Table 1's conv2: the maps compared as vectors into one mask, its bits pushed.
                let mut mask = 0u32;
                for (m, (&v, &lo)) in v.iter().zip(lo).enumerate() {
                    mask |= u32::from(v >= lo) << m;
                }
                while mask != 0 {
                    self.candidates.push((pos, mask.trailing_zeros()));
                    mask &= mask - 1;
                }
            } else {
                // The maps' thresholds as a slice of their length: no test per map.
                for (m, (&v, &lo)) in pot.iter().zip(thr_lo).enumerate() {
                    if v >= lo {
                        self.candidates.push((pos, m as u32));
                    }
                }
            }
            self.note_run(start);
        }
        self.waking = waking;
        self.waking.clear();
    }

    /// The exact potential of neuron `(map, pos)`: the float64 sum of the weights of its inputs
    /// that fired. A field of one channel and the whole `FIXED_ROWS × FIXED_ROWS` kernel
    /// (conv1's, nearly always) takes `exact_whole`.
    fn exact(&self, kernels: &[f32], fired: Fired<'_>, pos: usize, map: usize) -> f64 {
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
    fn exact_general(&self, kernels: &[f32], fired: Fired<'_>, pos: usize, map: usize) -> f64 {
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

    /// Whether `resolve` may find crossings in the group just added: some neuron reached `θ_lo`
    /// or its waking count, or an earlier one is still in the band.
    #[inline]
    pub fn may_fire(&self) -> bool {
        !(self.candidates.is_empty()
            && self.held.is_none()
            && self.band.is_empty()
            && self.waking.is_empty())
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
            if inhibit && self.band.is_empty() && self.waking.is_empty() {
                // The common case of conv1: one input's candidates, and nothing else.
                self.held = None;
                self.fire_held(weights.canonical(), fired, exact, held, out);
                return;
            }
            self.list_held();
        }
        if !self.waking.is_empty() {
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
    fn crossing(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        pos: u32,
        map: u32,
    ) -> Option<Crossing> {
        let v32 = self.pot[pos as usize * self.geom.maps + map as usize];
        let sure = self.thr_hi[map as usize];
        self.crossing_at(kernels, fired, pos, map, v32, sure)
    }

    /// `crossing` of a candidate whose float32 sum `v32` and map's `θ_hi` (`sure`) were read
    /// already (`fire_held` reads a position's maps, and conv1's thresholds, in one load).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn crossing_at(
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
            if c.v < self.thr[map as usize] {
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
    fn fire_in_order(
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
    fn fire_held(
        &mut self,
        kernels: &[f32],
        fired: Fired<'_>,
        exact: bool,
        held: WholeCandidates,
        out: &mut impl Fire,
    ) {
        let thr_hi: [f32; MAPS] = self.thr_hi[..MAPS].try_into().expect("MAPS thresholds");
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
    fn fire_word(
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
    fn fire_position(
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
    fn beats(&self, kernels: &[f32], fired: Fired<'_>, a: Crossing, b: Crossing) -> bool {
        let (va, vb) = if a.v.is_nan() || b.v.is_nan() {
            let (sa, sb) = (f64::from(a.v32), f64::from(b.v32));
            let (lo, hi) = self.bounds;
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

impl WholeCandidates {
    /// The positions with candidates, in position order: `(p, maps)` with `p` the position in
    /// the footprint (see `ConvState::whole_offsets`) and `maps` its maps' bits (bit `m` for
    /// map `m`).
    #[inline]
    fn positions(self) -> impl Iterator<Item = (usize, u32)> {
        self.words
            .into_iter()
            .enumerate()
            .flat_map(|(word, mut bits)| {
                std::iter::from_fn(move || {
                    if bits == 0 {
                        return None;
                    }
                    let p = bits.trailing_zeros() as usize / MAPS;
                    let maps = (bits >> (p * MAPS)) as u32 & POSITION_MAPS;
                    bits &= !(u64::from(POSITION_MAPS) << (p * MAPS));
                    Some((word * WORD_POSITIONS + p, maps))
                })
            })
    }
}

/// `ConvState::exact` for a neuron of one input channel whose receptive field is the whole
/// `FIXED_ROWS × FIXED_ROWS` kernel `kernel` (canonical `[dy][dx]`), from input row `iy0` and
/// column `ix0`: conv1's, nearly always. The same float64 sum in the same order (the fired
/// inputs row by row, each row's from the left, as `each_fired_input` visits them), each row's
/// stamps tested together instead of through the general walk.
#[inline]
fn exact_whole(
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
fn latch_position(pot: &mut [f32], pos: usize, maps: usize) {
    let run = &mut pot[pos * maps..(pos + 1) * maps];
    match <&mut [f32; 4]>::try_from(&mut *run) {
        // conv1's 4 maps: one vector store, not a loop of unknown length.
        Ok(four) => *four = [f32::NEG_INFINITY; 4],
        Err(_) => run.fill(f32::NEG_INFINITY),
    }
}

/// Zero `buf[start..start + len]` in blocks of `ZERO_BLOCK`, the last of which may reach up to
/// `ZERO_BLOCK − 1` values further (see `ZERO_BLOCK`: the caller's buffer must hold them, and
/// they must be zero or be zeroed too).
#[inline]
fn zero_blocks(buf: &mut [f32], start: usize, len: usize) {
    let mut b = start;
    while b < start + len {
        buf[b..b + ZERO_BLOCK].copy_from_slice(&[0.0; ZERO_BLOCK]);
        b += ZERO_BLOCK;
    }
}

/// Zero the runs of potentials (`[row][col][map]`, rows `out_w` positions apart) of every
/// footprint, in blocks of `ZERO_BLOCK` (see `zero_blocks`), or, for conv1's whole footprints,
/// exactly their `FIXED_ROWS` rows of `FIXED_RUN`. Compiled for AVX2 where the CPU has it, so
/// that a block is four stores and a whole footprint's row three.
#[inline]
fn zero_footprints(
    avx2: Option<Avx2>,
    pot: &mut [f32],
    inputs: &[Footprint],
    out_w: usize,
    maps: usize,
) {
    match avx2 {
        Some(avx2) => avx2.vectorize(
            #[inline(always)]
            move || zero_footprints_body(pot, inputs, out_w, maps),
        ),
        None => zero_footprints_body(pot, inputs, out_w, maps),
    }
}

/// Zero the whole footprints from the first potentials `wholes` (`ConvState::wholes`): each
/// `FIXED_ROWS` rows of `FIXED_RUN` potentials, `stride` apart. Compiled for AVX2 where the
/// CPU has it, so that a row is two vector stores and a half.
#[inline]
fn zero_wholes(avx2: Option<Avx2>, pot: &mut [f32], wholes: &[u32], stride: usize) {
    match avx2 {
        Some(avx2) => avx2.vectorize(
            #[inline(always)]
            move || zero_wholes_body(pot, wholes, stride),
        ),
        None => zero_wholes_body(pot, wholes, stride),
    }
}

/// The loop of `zero_wholes`, inlined into each of its compilations.
#[allow(clippy::inline_always)]
#[inline(always)]
fn zero_wholes_body(pot: &mut [f32], wholes: &[u32], stride: usize) {
    // The largest first potential, tested against the last whose rows end inside `pot`: one
    // vectorised pass (a few instructions per eight footprints) and one compare, instead of
    // a compare per footprint or a bounds check per row.
    if wholes.is_empty() {
        return;
    }
    let largest = wholes.iter().fold(0, |m, &first| m.max(first));
    let room = pot.len().checked_sub((FIXED_ROWS - 1) * stride + FIXED_RUN);
    assert!(
        room.is_some_and(|room| largest as usize <= room),
        "footprints inside the layer"
    );
    let p = pot.as_mut_ptr();
    for &first in wholes {
        let first = first as usize;
        for r in 0..FIXED_ROWS {
            // SAFETY: row `r` ends at `first + r · stride + FIXED_RUN`, at most `room +
            // (FIXED_ROWS − 1) · stride + FIXED_RUN = pot.len()` (`first ≤ largest ≤ room`,
            // asserted above).
            let row = unsafe { p.add(first + r * stride) };
            // SAFETY: as above: the row's `FIXED_RUN` values are inside `pot`.
            unsafe {
                row.cast::<[f32; FIXED_RUN]>()
                    .write_unaligned([0.0; FIXED_RUN]);
            };
        }
    }
}

/// The loop of `zero_footprints`, inlined into each of its compilations.
#[allow(clippy::inline_always)]
#[inline(always)]
fn zero_footprints_body(pot: &mut [f32], inputs: &[Footprint], out_w: usize, maps: usize) {
    let stride = out_w * maps;
    for f in inputs {
        let first = f.first as usize * maps;
        if usize::from(f.rows) == FIXED_ROWS && usize::from(f.cols) * maps == FIXED_RUN {
            // A whole conv1 footprint (`add_whole`): its rows of `FIXED_RUN` without a loop or
            // a bounds check per row (two vector stores and a half each).
            let end = first + (FIXED_ROWS - 1) * stride + FIXED_RUN;
            assert!(end <= pot.len(), "footprint inside the layer");
            let p = pot.as_mut_ptr();
            for r in 0..FIXED_ROWS {
                // SAFETY: row `r` ends at or before `end`, inside `pot` (asserted above).
                let row = unsafe { p.add(first + r * stride) };
                // SAFETY: as above: the row's `FIXED_RUN` values are inside `pot`.
                unsafe {
                    row.cast::<[f32; FIXED_RUN]>()
                        .write_unaligned([0.0; FIXED_RUN]);
                };
            }
            continue;
        }
        let span = (usize::from(f.cols) * maps).next_multiple_of(ZERO_BLOCK);
        let rows = (first..).step_by(stride).take(f.rows.into());
        if span == ZERO_BLOCK {
            // One block per row (conv1's runs of 20): its stores without a loop around them.
            for start in rows {
                pot[start..start + ZERO_BLOCK].copy_from_slice(&[0.0; ZERO_BLOCK]);
            }
        } else {
            for start in rows {
                for block in pot[start..start + span].chunks_exact_mut(ZERO_BLOCK) {
                    block.copy_from_slice(&[0.0; ZERO_BLOCK]);
                }
            }
        }
    }
}

/// Beyond this many runs, merging pairwise costs more than sorting (`sort_runs`).
const MAX_RUNS: usize = 8;

/// Sort `v` by merging its ascending runs (the candidates of one input come in position
/// order, so a group's keys are a few such runs), pairwise through `buffer`; with many runs, an
/// ordinary sort.
fn sort_runs(v: &mut Vec<u64>, buffer: &mut Vec<u64>) {
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
fn merge_runs(v: &mut Vec<u64>, buffer: &mut Vec<u64>, breaks: &[u32], len: usize) {
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
fn merge(a: &[u64], b: &[u64], out: &mut [u64]) {
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

/// Set `pot` (one position's maps) to the sum of the engine-layout weights `w` of every input of
/// output `(oy, ox)`'s receptive field that fired, in the order of `each_fired_input`; `base`
/// is `ConvState::wake_base`. Compiled for AVX2 where the CPU has it, so that the additions of
/// one input's maps run as vectors.
#[allow(clippy::too_many_arguments)]
#[inline]
fn gather(
    avx2: Option<Avx2>,
    g: &ConvGeom,
    fired: Fired<'_>,
    base: &[u32],
    w: &[f32],
    oy: usize,
    ox: usize,
    pot: &mut [f32],
) {
    match avx2 {
        Some(a) => a.vectorize(
            #[inline(always)]
            move || gather_body(Some(a), g, fired, base, w, oy, ox, pot),
        ),
        None => gather_body(None, g, fired, base, w, oy, ox, pot),
    }
}

/// The loop of `gather`, inlined into each of its compilations (always: inlined into the AVX2
/// one, its additions are compiled as AVX2 vectors).
#[allow(clippy::too_many_arguments, clippy::inline_always)]
#[inline(always)]
fn gather_body(
    avx2: Option<Avx2>,
    g: &ConvGeom,
    fired: Fired<'_>,
    base: &[u32],
    w: &[f32],
    oy: usize,
    ox: usize,
    pot: &mut [f32],
) {
    if let Ok(pot) = <&mut [f32; GATHER_MAPS]>::try_from(&mut *pot) {
        // The weights as their runs of `GATHER_MAPS`: one test per input, not two.
        // SAFETY: `[f32; GATHER_MAPS]` has `f32`'s alignment and no padding, and the
        // `w.len() / GATHER_MAPS` arrays lie inside `w`.
        let runs: &[[f32; GATHER_MAPS]] =
            unsafe { std::slice::from_raw_parts(w.as_ptr().cast(), w.len() / GATHER_MAPS) };
        // The same sums in the same order, kept in registers instead of memory.
        let mut sums = [0.0; GATHER_MAPS];
        each_fired_run(avx2, g, fired, base, oy, ox, |r| {
            for (d, &v) in sums.iter_mut().zip(&runs[r]) {
                *d += v;
            }
        });
        *pot = sums;
        return;
    }
    let maps = pot.len();
    pot.fill(0.0);
    each_fired_run(avx2, g, fired, base, oy, ox, |r| {
        for (d, &v) in pot.iter_mut().zip(&w[r * maps..(r + 1) * maps]) {
            *d += v;
        }
    });
}

/// The maps of Table 1's conv2, the one layer that wakes by count: `gather` adds them as a
/// run of known length, whose partial sums stay in vector registers.
const GATHER_MAPS: usize = 20;

/// The inputs of a row of Table 1's conv2's receptive field where it is not clipped (10
/// columns of 4 channels): `gather` tests them in a fixed number of vectors.
const CONV2_LANES: usize = 40;

/// The least length of `ConvState::wake_base`: one more than the greatest lane of a row of at
/// most 64 inputs.
const WAKE_LANES: usize = 65;

/// Call `f(r)` for every input of output `(oy, ox)`'s receptive field that fired, in the
/// order of `each_fired_lane`, with `r` the index of its run of weights (one per map) in the
/// engine layout (`base` is `ConvState::wake_base`).
#[allow(clippy::inline_always)]
#[inline(always)]
fn each_fired_run(
    avx2: Option<Avx2>,
    g: &ConvGeom,
    fired: Fired<'_>,
    base: &[u32],
    oy: usize,
    ox: usize,
    mut f: impl FnMut(usize),
) {
    let cols = g.inputs_of(ox, g.in_w);
    // Lane `(col, c)` of a row holds input column `cols.start + col`, kernel column
    // `dx = col + shift` (`shift` > 0 only where the field is clipped on the left).
    let shift = cols.start + g.p_lo - ox;
    // (c·k + dy)·k + k − 1 − dx, from the lane's precomputed part.
    let run = |l: u32, iy: usize| l as usize + (iy + g.p_lo - oy) * g.k - shift;
    let len = cols.len() * fired.channels;
    if len <= 64 {
        // A lane of `each_short_lane`, a trailing-zero count of a word, is at most 64, inside
        // `WAKE_LANES` values: read without a test.
        let short: &[u32; WAKE_LANES] = base[..WAKE_LANES].try_into().expect("padded");
        if len == CONV2_LANES {
            // `each_short_lane` for rows of a known length: each row's stamps tested in a
            // fixed number of vectors, without the loop over them.
            let rows = g.inputs_of(oy, g.in_h);
            let stride = fired.width * fired.channels;
            let first = (rows.start * fired.width + cols.start) * fired.channels;
            for (r, iy) in rows.enumerate() {
                let from = first + r * stride;
                let stamps: &[u32; CONV2_LANES] = fired.stamps[from..from + CONV2_LANES]
                    .try_into()
                    .expect("one row of the field");
                let mut mask = fired_mask(avx2, stamps, fired.generation);
                while mask != 0 {
                    let l = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    f(run(short[l], iy));
                }
            }
            return;
        }
        each_short_lane(g, fired, avx2, oy, ox, |iy, l| f(run(short[l], iy)));
    } else {
        each_fired_lane(g, fired, avx2, oy, ox, |iy, l| f(run(base[l], iy)));
    }
}

/// Call `f(c, iy, ix)` for every input `(channel, row, col)` of output `(oy, ox)`'s receptive
/// field that fired (see `each_fired_lane`); `split` maps a row's lane to its (column offset,
/// channel) (`ConvState::input_split`).
#[inline]
pub(crate) fn each_fired_input(
    g: &ConvGeom,
    fired: Fired<'_>,
    split: &[(u32, u32)],
    avx2: Option<Avx2>,
    oy: usize,
    ox: usize,
    mut f: impl FnMut(usize, usize, usize),
) {
    let start = g.inputs_of(ox, g.in_w).start;
    each_fired_lane(g, fired, avx2, oy, ox, |iy, l| {
        let (col, c) = split[l];
        f(c as usize, iy, start + col as usize);
    });
}

/// Call `f(iy, lane)` for every input of output `(oy, ox)`'s receptive field that fired: input
/// row `iy`, and `lane` its place in that row's inputs `[col][channel]` (clipped to the input).
/// A row's inputs are contiguous: they are tested 64 at a time without branching, and only
/// those that fired are visited, in memory order. Always inlined, so that `gather_avx2`'s
/// additions are compiled for AVX2 whichever code-generation unit holds it.
#[allow(clippy::inline_always)]
#[inline(always)]
fn each_fired_lane(
    g: &ConvGeom,
    fired: Fired<'_>,
    avx2: Option<Avx2>,
    oy: usize,
    ox: usize,
    mut f: impl FnMut(usize, usize),
) {
    let cols = g.inputs_of(ox, g.in_w);
    for iy in g.inputs_of(oy, g.in_h) {
        let from = (iy * fired.width + cols.start) * fired.channels;
        let row = &fired.stamps[from..from + cols.len() * fired.channels];
        for (chunk, stamps) in row.chunks(64).enumerate() {
            let mut mask = fired_mask(avx2, stamps, fired.generation);
            while mask != 0 {
                let l = chunk * 64 + mask.trailing_zeros() as usize;
                mask &= mask - 1;
                f(iy, l);
            }
        }
    }
}

/// `each_fired_lane` (the same calls in the same order) for `gather`, where a row of the
/// receptive field holds at most 64 inputs (every layer of Table 1): each row's stamps tested
/// as one word, without the loop over words. Kept beside `each_fired_lane` rather than as its
/// fast path: that walk is also `exact`'s, inlined into `resolve`, and taking this one into it
/// measured recipe 240x180 1 % at +0.9 % instructions (from how `resolve` was then compiled).
#[allow(clippy::inline_always)]
#[inline(always)]
fn each_short_lane(
    g: &ConvGeom,
    fired: Fired<'_>,
    avx2: Option<Avx2>,
    oy: usize,
    ox: usize,
    mut f: impl FnMut(usize, usize),
) {
    let cols = g.inputs_of(ox, g.in_w);
    let len = cols.len() * fired.channels;
    if len > 64 {
        each_fired_lane(g, fired, avx2, oy, ox, f);
        return;
    }
    let rows = g.inputs_of(oy, g.in_h);
    let stride = fired.width * fired.channels;
    let first = (rows.start * fired.width + cols.start) * fired.channels;
    for (r, iy) in rows.enumerate() {
        let from = first + r * stride;
        let mut mask = fired_mask(avx2, &fired.stamps[from..from + len], fired.generation);
        while mask != 0 {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            f(iy, l);
        }
    }
}

/// Record the neurons of a run of `lanes` whose lanes are set in `masks` as candidates, read
/// 64 lanes at a time (conv2's and conv3's runs are 200 lanes long, with few set): `masks`
/// holds whole words of 64 lanes, and the bytes past the run's, left from earlier runs, are
/// masked off.
#[cold]
fn push_candidates(
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

/// Most output rows that `add_rows` takes at once.
const FUSED_ROWS: usize = 16;

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

    /// `exact` (through `exact_whole` where the field is whole) equals the general walk, bit
    /// for bit, at every neuron of both paddings, with stamps of several generations.
    #[test]
    fn exact_whole_equals_general() {
        let mut rng = crate::network::xorshift(11u64);
        for padding in [Padding::Same, Padding::Valid] {
            let (g, w) = small(padding);
            let s = ConvState::new(g);
            for density in [2u64, 3, 8] {
                let stamps: Vec<u32> = (0..g.in_h * g.in_w)
                    .map(|_| {
                        if rng().is_multiple_of(density) {
                            7
                        } else {
                            (rng() % 7) as u32
                        }
                    })
                    .collect();
                let fired = Fired {
                    stamps: &stamps,
                    width: g.in_w,
                    channels: 1,
                    generation: 7,
                };
                for pos in 0..g.out_h * g.out_w {
                    for m in 0..g.maps {
                        let (fast, general) = (
                            s.exact(w.canonical(), fired, pos, m),
                            s.exact_general(w.canonical(), fired, pos, m),
                        );
                        assert_eq!(fast.to_bits(), general.to_bits(), "{padding:?} {pos} {m}");
                    }
                }
            }
        }
    }

    /// `sort_runs` sorts like `sort_unstable`, whatever the runs: none, a few (merged), many
    /// (sorted).
    #[test]
    fn sort_runs_sorts() {
        let mut rng = crate::network::xorshift(5u64);
        let mut next = |m: u64| {
            let s = rng();
            s % m
        };
        let mut buffer = Vec::new();
        for runs in 1..12u64 {
            for len in [0u64, 1, 2, 7, 40, 300] {
                let mut v: Vec<u64> = Vec::new();
                for _ in 0..runs {
                    let mut run: Vec<u64> = (0..len).map(|_| next(1000)).collect();
                    run.sort_unstable();
                    v.extend(run);
                }
                let mut want = v.clone();
                want.sort_unstable();
                sort_runs(&mut v, &mut buffer);
                assert_eq!(v, want, "{runs} runs of {len}");
            }
        }
    }

    /// `add_spikes` leaves a layer as `add` spike by spike does, waking by count or not:
    /// potentials, counts, candidates, positions to wake and footprints (Table 1's conv2 on a
    /// small sensor, so that many inputs are clipped, with thresholds that wake positions).
    #[test]
    fn add_spikes_equals_add() {
        let c = NetworkConfig {
            width: 64,
            height: 48,
            ..NetworkConfig::default()
        };
        let g = Geometry::new(&c).unwrap().conv[1];
        let w = ConvWeights::random(&g, 0.5, 0.3, 9, 1).unwrap();
        let mut rng = crate::network::xorshift(17u64);
        for (round, gated) in (0..40).zip([true, false].into_iter().cycle()) {
            let mut a = ConvState::new(g);
            a.set_thresholds(|m| 2.0 + (m + round) as f32 % 7.0);
            a.set_gated(gated);
            a.set_wake(&w);
            assert_eq!(a.gated, gated);
            let mut b = a.clone();
            let mut stamps = vec![0u32; g.in_h * g.in_w * g.in_ch];
            for _ in 0..4 {
                let spikes: Vec<(u32, u32, u32)> = (0..rng() % 40)
                    .map(|_| {
                        let v = rng();
                        (
                            (v % g.in_ch as u64) as u32,
                            (v / 8 % g.in_h as u64) as u32,
                            (v / 256 % g.in_w as u64) as u32,
                        )
                    })
                    .collect();
                a.add_spikes(w.engine(), &spikes);
                for &(c, iy, ix) in &spikes {
                    b.add(w.engine(), c as usize, iy as usize, ix as usize);
                }
                let footprints = |s: &ConvState| {
                    s.inputs
                        .iter()
                        .map(|f| (f.first, f.rows, f.cols))
                        .collect::<Vec<_>>()
                };
                assert_eq!(
                    a.pot.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    b.pot.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                );
                assert_eq!(a.counts, b.counts);
                assert_eq!(a.candidates, b.candidates);
                assert_eq!(a.waking, b.waking);
                assert_eq!(footprints(&a), footprints(&b));
                assert_eq!(a.touched_lanes, b.touched_lanes);
                assert_eq!((a.breaks_len, a.pos_sorted), (b.breaks_len, b.pos_sorted));
                // Wake what reached its count, so that later batches add to awake positions.
                for &(c, iy, ix) in &spikes {
                    stamps[(iy as usize * g.in_w + ix as usize) * g.in_ch + c as usize] = 1;
                }
                let fired = Fired {
                    stamps: &stamps,
                    width: g.in_w,
                    channels: g.in_ch,
                    generation: 1,
                };
                a.wake(w.engine(), fired);
                b.wake(w.engine(), fired);
            }
            if gated {
                assert!(a.counts.iter().any(|&n| n & AWAKE != 0), "round {round}");
            }
        }
    }

    /// `each_short_lane` makes `each_fired_lane`'s calls in the same order, rows of one word
    /// of stamps and longer ones (where it falls back), clipped fields included.
    #[test]
    fn each_short_lane_equals_each_fired_lane() {
        let mut rng = crate::network::xorshift(19u64);
        for (in_ch, k) in [(1, 5), (4, 10), (20, 5), (7, 10)] {
            let c = NetworkConfig {
                width: 40,
                height: 30,
                ..NetworkConfig::default()
            };
            let mut g = Geometry::new(&c).unwrap().conv[0];
            (g.in_ch, g.k, g.p_lo) = (in_ch, k, (k - 1) / 2);
            let stamps: Vec<u32> = (0..g.in_h * g.in_w * in_ch)
                .map(|_| (rng() % 3) as u32)
                .collect();
            let fired = Fired {
                stamps: &stamps,
                width: g.in_w,
                channels: in_ch,
                generation: 1,
            };
            for (oy, ox) in [(0, 0), (3, 7), (g.out_h - 1, g.out_w - 1), (g.out_h / 2, 1)] {
                let (mut a, mut b) = (Vec::new(), Vec::new());
                each_short_lane(&g, fired, Avx2::detect(), oy, ox, |iy, l| a.push((iy, l)));
                each_fired_lane(&g, fired, Avx2::detect(), oy, ox, |iy, l| b.push((iy, l)));
                assert!(!b.is_empty());
                assert_eq!(a, b, "{in_ch} channels, k {k}, ({oy}, {ox})");
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
