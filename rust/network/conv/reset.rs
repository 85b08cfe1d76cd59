//! Sparse reset: the next window zeroes only what the last one touched (its inputs'
//! footprints, whole footprints, awake positions), or the whole layer where that is cheaper.

use super::{ConvState, Footprint, ZERO_BLOCK};
use crate::simd::{zero_all, Avx2, FIXED_ROWS, FIXED_RUN, LANES};

impl ConvState {
    /// Zero the potentials that the last window touched.
    ///
    /// Replaying the window's inputs costs what their additions cost; where that would exceed
    /// one pass over the layer (a busy window on a small layer), one contiguous fill is cheaper
    /// and does the same. Either way the cost never exceeds the window's own work.
    pub fn reset(&mut self) {
        let g = self.geom;
        let maps = g.maps;
        if self.gated {
            for &pos in &self.touched.awake {
                zero_blocks(&mut self.pot, pos as usize * maps, maps);
            }
            if self.touched.lanes >= self.count.counts.len() {
                zero_all(self.avx2, &mut self.count.counts);
            } else {
                for f in &self.touched.inputs {
                    for r in 0..usize::from(f.rows) {
                        // One vector of counts (`cols ≤ k ≤ LANES`; `counts` has `LANES` of
                        // padding); the lanes past the run are zero or zeroed here too.
                        let start = f.first as usize + r * g.out_w;
                        self.count.counts[start..start + LANES].copy_from_slice(&[0; LANES]);
                    }
                }
            }
        } else if self.touched.lanes + self.touched.wholes.len() * FIXED_ROWS * FIXED_RUN
            >= g.neurons()
        {
            zero_all(self.avx2, &mut self.pot);
        } else {
            zero_footprints(
                self.avx2,
                &mut self.pot,
                &self.touched.inputs,
                g.out_w,
                maps,
            );
            zero_wholes(
                self.avx2,
                &mut self.pot,
                &self.touched.wholes,
                g.out_w * maps,
            );
        }
        self.touched.lanes = 0;
        self.touched.inputs.clear();
        self.touched.wholes.clear();
        self.touched.awake.clear();
        self.count.waking.clear();
        self.candidates.clear();
        self.clear_runs();
        self.held = None;
        self.band.clear();
        self.crossed.clear();
    }
}

/// Zero `buf[start..start + len]` in blocks of `ZERO_BLOCK`, the last of which may reach up to
/// `ZERO_BLOCK − 1` values further (see `ZERO_BLOCK`: the caller's buffer must hold them, and
/// they must be zero or be zeroed too).
#[inline]
pub(super) fn zero_blocks(buf: &mut [f32], start: usize, len: usize) {
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
pub(super) fn zero_footprints(
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
pub(super) fn zero_wholes(avx2: Option<Avx2>, pot: &mut [f32], wholes: &[u32], stride: usize) {
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
pub(super) fn zero_wholes_body(pot: &mut [f32], wholes: &[u32], stride: usize) {
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
pub(super) fn zero_footprints_body(
    pot: &mut [f32],
    inputs: &[Footprint],
    out_w: usize,
    maps: usize,
) {
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
