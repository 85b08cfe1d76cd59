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

mod add;
mod fired;
mod reset;
mod resolve;
#[cfg(test)]
mod tests;
mod wake;

use std::ops::Range;

use super::geometry::{ConvGeom, Divider};
use super::weights::ConvWeights;
use crate::simd::{Avx2, FIXED_KERNEL, FIXED_ROWS, FIXED_RUN, LANES, WORD_ROWS};

pub(crate) use fired::{each_fired_input, Fired};
use resolve::MAX_RUNS;
use wake::WAKE_LANES;

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
    /// The thresholds and the float32 filter's bounds (`set_thresholds`).
    thr: Thresholds,
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
    /// What this window wrote, for the next window's reset.
    touched: Touched,
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
    /// Waking by count: the inputs counted per position, and who wakes.
    count: Counting,
    /// Division by the output width (position → row, column).
    split: Divider,
    /// The inputs that `add_whole` takes (when the layer adds densely), where it may: the layer
    /// has `FIXED_ROWS` rows of `FIXED_RUN` lanes and the CPU has AVX2.
    whole: Option<Whole>,
}

/// Where this window's inputs landed: what the next window's reset zeroes (`reset.rs`).
#[derive(Debug, Clone, Default)]
struct Touched {
    /// The footprints of the inputs added (but `wholes`).
    inputs: Vec<Footprint>,
    /// Potentials written by `inputs`, counted with repeats (the cost of replaying them).
    lanes: usize,
    /// The first potentials (first position · `MAPS`) of the whole footprints added
    /// (`add_whole`'s, of `FIXED_ROWS` rows of `FIXED_RUN` lanes each), kept apart from
    /// `inputs` so that pushing one is one value and zeroing it needs no test of its shape
    /// (nor a multiplication).
    wholes: Vec<u32>,
    /// Positions awake (layers that wake by count).
    awake: Vec<u32>,
}

/// The counts of a layer that wakes by count (see the module docs and `wake.rs`).
#[derive(Debug, Clone)]
struct Counting {
    /// Per position: how many of its inputs fired this window, `| AWAKE` once awake
    /// (`LANES` more at the end, never counted, so that a row's vector never reads past it).
    counts: Vec<u16>,
    /// The count at which a position wakes: the fewest inputs any map needs to cross.
    wake_at: u16,
    /// Positions that reached `wake_at` in the current group (woken in `resolve`).
    waking: Vec<u32>,
    /// Per input row `iy`: `[rows.start · out_w, rows.len()]` of the output rows whose
    /// kernel covers it (`outputs_of`); per input column: `[cols.start, cols.len()]`. What
    /// `count_spikes` reads instead of computing the two ranges per spike.
    row_spans: Vec<[u32; 2]>,
    col_spans: Vec<[u32; 2]>,
}

/// A layer's thresholds per map, and what the float32 filter derives from them (see the
/// module docs): set per window by `ConvState::set_thresholds`.
#[derive(Debug, Clone)]
struct Thresholds {
    /// Exact thresholds per map.
    exact: Vec<f64>,
    /// `θ_hi` per map: float32 sums at or above it have surely crossed.
    hi: Vec<f32>,
    /// Filter thresholds `θ_lo` per map, tiled `k` times to match one row's run.
    lo: Vec<f32>,
    /// Whether every `θ_lo` is above 0, the potential of a neuron without inputs (`add_whole`'s
    /// `fresh` needs every neuron below `θ_lo` at rest).
    lo_positive: bool,
    /// Relative error bound `m` of the float32 sums.
    margin: f64,
    /// `(1 − m, 1 + m)`: the factors that bound an exact sum from its float32 one (`beats`).
    bounds: (f64, f64),
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
            thr: Thresholds {
                exact: vec![f64::INFINITY; geom.maps],
                hi: vec![f32::INFINITY; geom.maps],
                lo: vec![f32::INFINITY; geom.k * geom.maps],
                lo_positive: true,
                margin,
                bounds: (1.0 - margin, 1.0 + margin),
            },
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
            touched: Touched::default(),
            masks: vec![0; (geom.k * geom.maps).div_ceil(64) * 8],
            avx2: Avx2::detect(),
            gated: false,
            can_gate: geom.k <= LANES && geom.kernel_len() < AWAKE.into(),
            #[cfg(test)]
            forced: None,
            count: Counting {
                counts: vec![0; positions + LANES],
                wake_at: 0,
                waking: Vec::new(),
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
            },
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

    /// Run this layer's scalar kernels (and no whole-footprint path), as on a CPU without AVX2.
    /// Call on a fresh state, before its first window.
    #[cfg(test)]
    pub fn set_scalar(&mut self) {
        self.avx2 = None;
        self.whole = None;
    }

    /// Set the per-map thresholds for the coming window.
    pub fn set_thresholds(&mut self, thresholds: impl Fn(usize) -> f32) {
        let maps = self.geom.maps;
        let mut same = true;
        for (m, t) in self.thr.exact.iter_mut().enumerate() {
            let new = f64::from(thresholds(m));
            same &= t.to_bits() == new.to_bits();
            *t = new;
        }
        if same {
            // The rest follows from the thresholds (and the fixed margin) alone: conv2's and
            // conv3's, the same every window, are not tiled again.
            return;
        }
        for (hi, &t) in self.thr.hi.iter_mut().zip(&self.thr.exact) {
            *hi = round_up(t * (1.0 + self.thr.margin));
        }
        let slack = (1.0 - self.thr.margin).max(0.0);
        for (lo, &t) in self.thr.lo.iter_mut().zip(&self.thr.exact) {
            *lo = round_down(t * slack);
        }
        // The other `k − 1` tiles repeat the first.
        for i in maps..self.thr.lo.len() {
            self.thr.lo[i] = self.thr.lo[i - maps];
        }
        self.thr.lo_positive = self.thr.lo[..maps].iter().all(|&lo| lo > 0.0);
        if let Some(whole) = &mut self.whole {
            whole.thr.copy_from_slice(&self.thr.lo[..FIXED_RUN]);
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
        let lo = 1.0 - self.thr.margin;
        let inputs = self.geom.kernel_len();
        let fewest = (0..self.geom.maps).fold(usize::MAX, |fewest, m| {
            let target = self.thr.exact[m] * lo;
            // A map lowers the fewest so far only where one input fewer reaches its target:
            // one sum read instead of a search, for nearly every map after the first.
            if fewest == 0 || (fewest <= inputs + 1 && !weights.reaches(m, fewest - 1, target)) {
                fewest
            } else {
                fewest.min(weights.inputs_to_reach(m, target))
            }
        });
        // Never 0 (a position with no input has no potential); beyond any count if unreachable.
        self.count.wake_at = fewest.clamp(1, usize::from(AWAKE - 1)) as u16;
        let rule = self.geom.maps >= WAKE_MAPS && fewest >= WAKE_WIDTHS * self.geom.k;
        #[cfg(test)]
        let rule = self.forced.unwrap_or(rule);
        self.gated = self.can_gate && rule;
        if let Some(whole) = &mut self.whole {
            // `add` tests for a whole input only: none is while the layer wakes by count.
            whole.rows = if self.gated { 0 } else { whole.all_rows };
        }
    }

    /// Copy channel 0's kernel of the engine-layout weights `w` for `add_inline` (where the
    /// layer has whole inputs): once before a run of its inputs, not per input.
    pub fn load_kernel(&mut self, w: &[f32]) {
        if let Some(whole) = &mut self.whole {
            whole.kernel = *w.first_chunk().expect("one channel's kernel");
        }
    }

    /// Whether `resolve` may find crossings in the group just added: some neuron reached `θ_lo`
    /// or its waking count, or an earlier one is still in the band.
    #[inline]
    pub fn may_fire(&self) -> bool {
        !(self.candidates.is_empty()
            && self.held.is_none()
            && self.band.is_empty()
            && self.count.waking.is_empty())
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
