//! Pooling onto a smaller output sensor ([`super::Pooling`]): the geometry, and the strongest
//! emitter per output pixel.

use super::{push_events, Band, Pooling};
use crate::events::Event;

/// Output pooling geometry: the output column and row of each source column and row.
#[derive(Debug, Clone)]
pub(super) struct Pool {
    pub(super) mode: Pooling,
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) x_of: Vec<u16>,
    pub(super) y_of: Vec<u16>,
    /// Per output pixel, the strongest emitter so far this frame: (magnitude, band, index).
    best: Vec<(f32, u32, u32)>,
    touched: Vec<u32>,
}

impl Pool {
    /// Pooling of `width`×`height` source pixels onto `w`×`h` output pixels.
    pub(super) fn new(mode: Pooling, width: usize, height: usize, w: usize, h: usize) -> Self {
        Self {
            mode,
            width: w,
            height: h,
            x_of: index_map(width, w),
            y_of: index_map(height, h),
            best: vec![(0.0, u32::MAX, 0); w * h],
            touched: Vec::new(),
        }
    }
}

/// The output index (column or row) of each of `from` source indices mapped onto `to`.
fn index_map(from: usize, to: usize) -> Vec<u16> {
    (0..from).map(|i| (i * to / from) as u16).collect()
}

/// Per output pixel, the events of the strongest emitter in its area (ties: the first found,
/// bands top to bottom, blocks left to right).
pub(super) fn pool_strongest(
    pool: &mut Pool,
    bands: &[Band],
    out: &mut Vec<Event>,
    t_prev: u64,
    dt: u64,
    compat: bool,
) {
    for &o in &pool.touched {
        pool.best[o as usize] = (0.0, u32::MAX, 0);
    }
    pool.touched.clear();
    for (k, band) in bands.iter().enumerate() {
        for (i, e) in band.emitters.iter().enumerate() {
            let o =
                pool.y_of[e.y as usize] as usize * pool.width + pool.x_of[e.x as usize] as usize;
            let best = &mut pool.best[o];
            if best.1 == u32::MAX {
                pool.touched.push(o as u32);
                *best = (e.magnitude, k as u32, i as u32);
            } else if e.magnitude > best.0 {
                *best = (e.magnitude, k as u32, i as u32);
            }
        }
    }
    out.clear();
    for &o in &pool.touched {
        let (_, k, i) = pool.best[o as usize];
        let e = &bands[k as usize].emitters[i as usize];
        let (x, y) = (o as usize % pool.width, o as usize / pool.width);
        push_events(out, e, x as u16, y as u16, t_prev, dt, compat);
    }
}
