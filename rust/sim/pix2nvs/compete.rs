//! Steps 2–5 of the module's documentation: local inhibition, the competing pixel's events,
//! its reference and its threshold.

use super::{Emitter, Pix2NvsParams, PixelState, ReferenceUpdate};

/// Decide one competing pixel (steps 3–5); returns its emission, if any.
#[inline]
fn decide(p: &Pix2NvsParams, s: &mut PixelState, input: f32) -> Option<(i8, f32, f32, f32)> {
    let delta = input - s.reference;
    let theta = s.threshold;
    let magnitude = delta.abs();
    if magnitude > theta {
        let n = ((magnitude / theta) as u32).min(p.n_max);
        let signed = if delta > 0.0 { n as i8 } else { -(n as i8) };
        match p.reference {
            ReferenceUpdate::EventCopy => s.reference = input,
            ReferenceUpdate::EventIncrement => s.reference += f32::from(signed) * theta,
            ReferenceUpdate::Frame => {}
        }
        if p.adaptive > 0.0 {
            s.threshold = (theta * (1.0 + p.adaptive)).min(p.threshold_max);
        }
        Some((signed, theta / magnitude, magnitude, theta))
    } else {
        if p.adaptive > 0.0 {
            s.threshold = (theta * (1.0 - p.adaptive)).max(p.threshold_min);
        }
        None
    }
}

/// One band of `rows` source rows starting at row `y0`: every inhibition block in it.
pub(super) fn compete_band(
    p: &Pix2NvsParams,
    state: &mut [PixelState],
    input: &[f32],
    w: usize,
    y0: usize,
    emitters: &mut Vec<Emitter>,
) {
    let b = p.block_size;
    let emit = |emitters: &mut Vec<Emitter>, i: usize, (count, step, magnitude, theta)| {
        emitters.push(Emitter {
            x: (i % w) as u16,
            y: (y0 + i / w) as u16,
            count,
            step,
            magnitude,
            theta,
        });
    };
    if b == 1 {
        // No inhibition: every pixel competes on its own.
        for (i, (s, &v)) in state.iter_mut().zip(input).enumerate() {
            if let Some(e) = decide(p, s, v) {
                emit(emitters, i, e);
            }
            if p.reference == ReferenceUpdate::Frame {
                s.reference = v;
            }
        }
        return;
    }
    for x0 in (0..w).step_by(b) {
        let bw = b.min(w - x0);
        let win = strongest(state, input, w, x0, bw);
        if let Some(e) = decide(p, &mut state[win], input[win]) {
            emit(emitters, win, e);
        }
        if p.reference == ReferenceUpdate::Frame {
            copy_block(state, input, w, x0, bw);
        }
    }
}

/// The pixel of the strongest change `|B - R|` in the block of columns `x0..x0 + bw` of a band
/// (`w` columns, every row of `input`). PIX2NVS scans x outer, y inner, and keeps the first
/// strict maximum above 0 (so an unchanged block competes with its top-left pixel).
pub(super) fn strongest(
    state: &[PixelState],
    input: &[f32],
    w: usize,
    x0: usize,
    bw: usize,
) -> usize {
    let rows = input.len() / w;
    let mut win = x0;
    let mut best = 0.0f32;
    for x in x0..x0 + bw {
        for y in 0..rows {
            let i = y * w + x;
            let d = (input[i] - state[i].reference).abs();
            if d > best {
                best = d;
                win = i;
            }
        }
    }
    win
}

/// Mode 1 (`-r 1`): the reference of the block of columns `x0..x0 + bw` of a band becomes the
/// frame.
pub(super) fn copy_block(state: &mut [PixelState], input: &[f32], w: usize, x0: usize, bw: usize) {
    let rows = input.len() / w;
    for y in 0..rows {
        for x in x0..x0 + bw {
            state[y * w + x].reference = input[y * w + x];
        }
    }
}
