//! Dense time-embedded frames (`docs/model.md` §1): a `float32` image per window whose value at
//! a pixel is `t − t0` of its input spike in µs, and `+inf` where the pixel is silent.
//!
//! # Cost
//!
//! The output is the work: `4·W·H` bytes per window, most of them `+inf`. Each frame is filled
//! and then written with its spikes while it is still in cache, so memory is written once
//! (filling everything first and scattering after would fetch every frame from memory again).

use rayon::prelude::*;

use super::WindowsView;
use crate::error::{check_alloc, Error, Result};

/// Frames per block in [`frames`]: a block of about 1 MiB is filled and written while in cache.
const BLOCK_BYTES: usize = 1 << 20;

/// Check `indices` against `view` and return the number of `f32` values their frames take:
/// at most [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES) bytes of them.
pub fn frames_len(view: &WindowsView<'_>, indices: &[usize]) -> Result<usize> {
    if let Some((pos, &bad)) = indices.iter().enumerate().find(|(_, &i)| i >= view.len()) {
        return Err(Error::param(
            "indices",
            format!(
                "indices[{pos}]={bad} is out of range for {} windows",
                view.len()
            ),
        ));
    }
    let area = view.sensor.area();
    let (width, height) = (view.sensor.width, view.sensor.height);
    let total = indices.len().saturating_mul(area);
    check_alloc(
        "indices",
        || {
            format!(
                "{} float32 frames of {width}x{height} (ask for fewer windows at a time)",
                indices.len()
            )
        },
        total,
        4,
    )?;
    Ok(total)
}

/// The frames of windows `indices` (in that order), row-major `(k, height, width)`.
///
/// Fails, rather than aborting the process, when the frames do not fit in memory. If a window
/// holds a pixel twice (possible only in windows built outside this module), its first spike
/// wins.
pub fn frames(view: &WindowsView<'_>, indices: &[usize]) -> Result<Vec<f32>> {
    let total = frames_len(view, indices)?;
    let mut out: Vec<f32> = Vec::new();
    out.try_reserve_exact(total).map_err(|_| {
        Error::param(
            "indices",
            format!(
                "{} frames of {}x{} float32 ({} bytes) do not fit in memory",
                indices.len(),
                view.sensor.width,
                view.sensor.height,
                total as u128 * 4
            ),
        )
    })?;
    let area = view.sensor.area();
    if area == 0 {
        return Ok(out);
    }
    let per_block = (BLOCK_BYTES / (4 * area)).max(1);
    for block in indices.chunks(per_block) {
        let base = out.len();
        out.resize(base + block.len() * area, f32::INFINITY);
        out[base..]
            .par_chunks_mut(area)
            .zip(block.par_iter())
            .for_each(|(frame, &i)| write_spikes(view, i, frame));
    }
    Ok(out)
}

/// [`frames`] written into `out` (of [`frames_len`] values, any contents), for callers that
/// own the buffer (such as a NumPy array). Fails when `indices` are out of range or `out` has
/// the wrong length.
pub fn frames_into(view: &WindowsView<'_>, indices: &[usize], out: &mut [f32]) -> Result<()> {
    let total = frames_len(view, indices)?;
    if out.len() != total {
        return Err(Error::Shape {
            name: "out",
            expected: format!("{total} values ({} frames)", indices.len()),
            got: format!("{}", out.len()),
        });
    }
    let area = view.sensor.area();
    if area == 0 {
        return Ok(());
    }
    out.par_chunks_mut(area)
        .zip(indices.par_iter())
        .for_each(|(frame, &i)| {
            frame.fill(f32::INFINITY);
            write_spikes(view, i, frame);
        });
    Ok(())
}

/// Write window `i`'s spikes into `frame` (all `+inf`), the first spike of a pixel winning.
#[inline]
fn write_spikes(view: &WindowsView<'_>, i: usize, frame: &mut [f32]) {
    let t0 = view.t0[i];
    let range = view.range(i);
    let (t, x, y) = (
        &view.t[range.clone()],
        &view.x[range.clone()],
        &view.y[range],
    );
    for ((&t, &x), &y) in t.iter().zip(x).zip(y) {
        let cell = &mut frame[view.sensor.index(x, y)];
        if cell.is_infinite() {
            *cell = (t - t0) as f32;
        }
    }
}
