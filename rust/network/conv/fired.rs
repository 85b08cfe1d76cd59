//! Which inputs of a conv layer fired in the window, and the walks over a receptive field's
//! fired inputs that exact potentials, waking and the causal boxes (`network::cause`) share.

use super::ConvGeom;
use crate::simd::{fired_mask, Avx2};

/// Which inputs of a conv layer fired in the current window: a generation-stamp array laid out
/// `[row][col][channel]` (pixels have one channel).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fired<'a> {
    pub stamps: &'a [u32],
    pub width: usize,
    pub channels: usize,
    pub generation: u32,
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
/// those that fired are visited, in memory order. Always inlined, so that `gather`'s
/// additions are compiled for AVX2 whichever code-generation unit holds it.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(super) fn each_fired_lane(
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
