//! Dense time-embedded frames (`docs/model.md` §1): a `float32` image per window whose value at
//! a pixel is `t − t0` of its input spike in µs, and `+inf` where the pixel is silent.

use rayon::prelude::*;

use super::WindowsView;
use crate::error::{Error, Result};

/// The frames of windows `indices` (in that order), row-major `(k, height, width)`.
///
/// Fails, rather than aborting the process, when the frames do not fit in memory. If a window
/// holds a pixel twice (possible only in windows built outside this module), its first spike
/// wins.
pub fn frames(view: &WindowsView<'_>, indices: &[usize]) -> Result<Vec<f32>> {
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
    let total = indices.len().checked_mul(area).ok_or_else(|| {
        Error::param(
            "indices",
            format!("{} frames of {area} pixels overflow", indices.len()),
        )
    })?;
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
    out.resize(total, f32::INFINITY);
    if area == 0 {
        return Ok(out);
    }
    out.par_chunks_mut(area)
        .zip(indices.par_iter())
        .for_each(|(frame, &i)| {
            let t0 = view.t0[i];
            for j in view.range(i) {
                let cell = &mut frame[view.sensor.index(view.x[j], view.y[j])];
                if cell.is_infinite() {
                    *cell = (view.t[j] - t0) as f32;
                }
            }
        });
    Ok(out)
}
