//! Waking by count: a position that reached its waking count gets its float32 potentials
//! gathered from the inputs that fired (see the module docs of `conv`).

use super::fired::each_fired_lane;
use super::{ConvState, Fired, AWAKE};
use crate::network::geometry::ConvGeom;
use crate::simd::{fired_mask, Avx2};

impl ConvState {
    /// Wake the positions that reached `wake_at` in the group just added: gather their float32
    /// potentials from the inputs that fired (engine-layout weights `w`), in the order of
    /// `each_fired_input`; maps at or above `θ_lo` become candidates. Out of line, so that
    /// `resolve`, which calls it for few groups, is compiled without it.
    ///
    /// Where the CPU has AVX2 the whole loop is compiled for it (`Avx2::vectorize`), once per
    /// call rather than once per waking position, so that `gather`'s additions run as vectors
    /// without a call (and its arguments' copy into a closure) per position.
    #[inline(never)]
    pub(super) fn wake(&mut self, w: &[f32], fired: Fired<'_>) {
        match self.avx2 {
            Some(avx2) => avx2.vectorize(
                #[inline(always)]
                move || self.wake_body(Some(avx2), w, fired),
            ),
            None => self.wake_body(None, w, fired),
        }
    }

    /// The loop of `wake`, inlined into each of its compilations.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn wake_body(&mut self, avx2: Option<Avx2>, w: &[f32], fired: Fired<'_>) {
        let g = self.geom;
        let maps = g.maps;
        let waking = std::mem::take(&mut self.count.waking);
        for &pos in &waking {
            let p = pos as usize;
            self.count.counts[p] |= AWAKE;
            self.touched.awake.push(pos);
            let (oy, ox) = self.split.div_rem(p);
            let pot = &mut self.pot[p * maps..(p + 1) * maps];
            gather(avx2, &g, fired, &self.wake_base, w, oy, ox, pot);
            let start = self.candidates.len();
            let thr_lo = &self.thr.lo[..maps];
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
        self.count.waking = waking;
        self.count.waking.clear();
    }
}

/// Set `pot` (one position's maps) to the sum of the engine-layout weights `w` of every input of
/// output `(oy, ox)`'s receptive field that fired, in the order of `each_fired_input`; `base`
/// is `ConvState::wake_base`. Inlined into each compilation of `wake` (always: inlined into
/// the AVX2 one, its additions are compiled as AVX2 vectors).
#[allow(clippy::too_many_arguments, clippy::inline_always)]
#[inline(always)]
pub(super) fn gather(
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
pub(super) const GATHER_MAPS: usize = 20;

/// The inputs of a row of Table 1's conv2's receptive field where it is not clipped (10
/// columns of 4 channels): `gather` tests them in a fixed number of vectors.
pub(super) const CONV2_LANES: usize = 40;

/// The least length of `ConvState::wake_base`: one more than the greatest lane of a row of at
/// most 64 inputs.
pub(super) const WAKE_LANES: usize = 65;

/// Call `f(r)` for every input of output `(oy, ox)`'s receptive field that fired, in the
/// order of `each_fired_lane`, with `r` the index of its run of weights (one per map) in the
/// engine layout (`base` is `ConvState::wake_base`).
#[allow(clippy::inline_always)]
#[inline(always)]
pub(super) fn each_fired_run(
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
        // A lane of a row of at most 64 inputs (a trailing-zero count of a word) is inside
        // `WAKE_LANES` values: read without a test.
        let short: &[u32; WAKE_LANES] = base[..WAKE_LANES].try_into().expect("padded");
        if len == CONV2_LANES {
            // `each_fired_lane` for rows of a known length: each row's stamps tested in a
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
        each_fired_lane(g, fired, avx2, oy, ox, |iy, l| f(run(short[l], iy)));
    } else {
        each_fired_lane(g, fired, avx2, oy, ox, |iy, l| f(run(base[l], iy)));
    }
}
