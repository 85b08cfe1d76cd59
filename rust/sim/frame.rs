//! Input frames and the pixel response that turns them into (log) intensity.
//!
//! Frames arrive as 8-bit gray, 8-bit BGR (OpenCV's order) or 32-bit float gray, each possibly a
//! strided view (a centred crop of a decoded video frame is not contiguous). Luma follows
//! ITU-R BT.601, `Y = 0.299 R + 0.587 G + 0.114 B`, kept in floating point as PIX2NVS does
//! (its `readframe.cpp`), not rounded to 8 bits as `cv2.cvtColor` would. Float frames use the
//! same 0–255 scale as 8-bit ones.
//!
//! For 8-bit input the response is a lookup table: BT.601 luma times 1000 is the exact integer
//! `299 R + 587 G + 114 B` (0 ..= 255000), so one table of 255001 entries gives the response of
//! any BGR pixel without a logarithm per pixel.

use std::sync::OnceLock;

use ndarray::{ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// One video frame, borrowed. Rows are `y`, columns `x`, origin at the top left.
#[derive(Debug, Clone, Copy)]
pub enum Frame<'a> {
    /// 8-bit gray, shape `(height, width)`.
    Gray(ArrayView2<'a, u8>),
    /// 8-bit colour in OpenCV's BGR order, shape `(height, width, 3)`.
    Bgr(ArrayView3<'a, u8>),
    /// Float gray on the 0–255 scale, shape `(height, width)`; finite and non-negative.
    GrayF32(ArrayView2<'a, f32>),
}

impl Frame<'_> {
    /// `(width, height)` of the frame.
    pub fn size(&self) -> (usize, usize) {
        match self {
            Frame::Gray(v) => (v.ncols(), v.nrows()),
            Frame::Bgr(v) => (v.shape()[1], v.shape()[0]),
            Frame::GrayF32(v) => (v.ncols(), v.nrows()),
        }
    }

    /// Check that the frame is `width`×`height` (and has 3 channels, or finite non-negative
    /// values, as its kind requires). `index` names the frame in the error.
    pub fn check(&self, width: usize, height: usize, index: usize) -> Result<()> {
        let (w, h) = self.size();
        if (w, h) != (width, height) {
            return Err(Error::Simulation(format!(
                "frame {index} is {w}x{h}, expected {width}x{height} like the frames before it"
            )));
        }
        match self {
            Frame::Bgr(v) if v.shape()[2] != 3 => Err(Error::Simulation(format!(
                "frame {index} has {} channels, expected 3 (BGR)",
                v.shape()[2]
            ))),
            // A pass without early exit first (4x fewer instructions); the search only when
            // it fails.
            Frame::GrayF32(v) if v.fold(true, |ok, &p| ok && (0.0..f32::INFINITY).contains(&p)) => {
                Ok(())
            }
            Frame::GrayF32(v) => match v.iter().position(|&p| !p.is_finite() || p < 0.0) {
                Some(i) => Err(Error::Simulation(format!(
                    "frame {index}: pixel (x={}, y={}) has intensity {}, expected a finite \
                         value >= 0",
                    i % w,
                    i / w,
                    v.iter().nth(i).copied().unwrap_or(f32::NAN)
                ))),
                None => Ok(()),
            },
            _ => Ok(()),
        }
    }
}

/// The previous frame's time `last`, once frame `index` at `t_us` is checked to come strictly
/// after it: the check both simulators make before a frame changes their state.
pub(crate) fn after_previous(last: Option<u64>, t_us: u64, index: usize) -> Result<Option<u64>> {
    match last {
        Some(prev) if t_us <= prev => Err(Error::Simulation(format!(
            "frame {index}: timestamp {t_us} us is not after the previous frame's {prev} us"
        ))),
        prev => Ok(prev),
    }
}

/// Check a sensor size for both simulators: at least 1×1, at most 65535×65535 (event
/// coordinates are 16-bit). `what` names the size in the error.
pub(crate) fn check_size(what: &'static str, width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 || width > usize::from(u16::MAX) || height > usize::from(u16::MAX)
    {
        return Err(Error::param(
            what,
            format!("must be between 1x1 and 65535x65535, got {width}x{height}"),
        ));
    }
    Ok(())
}

/// How a pixel turns luma `Y` (0–255 scale) into the quantity whose changes make events.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Response {
    /// `ln(Y + offset)` (PIX2NVS uses `ln(Y)`; the offset keeps black pixels finite).
    Log { offset: f32 },
    /// v2e's `lin_log`: linear below `threshold`, `ln(Y)` above, continuous at `threshold`.
    LinLog { threshold: f32 },
}

impl Response {
    /// The response to one luma value.
    #[inline]
    pub fn eval(self, luma: f64) -> f32 {
        match self {
            Response::Log { offset } => (luma + f64::from(offset)).ln() as f32,
            Response::LinLog { threshold } => {
                let th = f64::from(threshold);
                (if luma <= th {
                    luma * th.ln() / th
                } else {
                    luma.ln()
                }) as f32
            }
        }
    }
}

/// Converts frames into a response image (and optionally the luma image), with lookup tables
/// for 8-bit input built on first use.
#[derive(Debug)]
pub struct Converter {
    response: Response,
    gray: [f32; 256],
    bgr: OnceLock<Vec<f32>>,
}

/// `299 R + 587 G + 114 B`: BT.601 luma times 1000, exact.
#[inline]
fn luma_key(b: u8, g: u8, r: u8) -> usize {
    299 * r as usize + 587 * g as usize + 114 * b as usize
}

impl Converter {
    pub fn new(response: Response) -> Self {
        let mut gray = [0.0f32; 256];
        for (v, out) in gray.iter_mut().enumerate() {
            *out = response.eval(v as f64);
        }
        Self {
            response,
            gray,
            bgr: OnceLock::new(),
        }
    }

    fn bgr_table(&self) -> &[f32] {
        self.bgr.get_or_init(|| {
            (0..=255_000u32)
                .map(|k| self.response.eval(f64::from(k) / 1000.0))
                .collect()
        })
    }

    /// Fill `out` (one row, `width` values) with the response of row `y` of `frame`, and
    /// `luma` with its BT.601 luma when given.
    pub fn convert_row(
        &self,
        frame: &Frame<'_>,
        y: usize,
        out: &mut [f32],
        mut luma: Option<&mut [f32]>,
    ) {
        match frame {
            Frame::Gray(v) => {
                let row = v.row(y);
                if let (Some(px), None) = (row.as_slice(), luma.as_deref()) {
                    for (o, &p) in out.iter_mut().zip(px) {
                        *o = self.gray[p as usize];
                    }
                    return;
                }
                for (x, (o, &p)) in out.iter_mut().zip(row.iter()).enumerate() {
                    *o = self.gray[p as usize];
                    if let Some(l) = luma.as_deref_mut() {
                        l[x] = f32::from(p);
                    }
                }
            }
            Frame::Bgr(v) => {
                let table = self.bgr_table();
                let row = v.index_axis(Axis(0), y);
                if let Some(px) = row.as_slice() {
                    for (x, (o, c)) in out.iter_mut().zip(px.chunks_exact(3)).enumerate() {
                        let k = luma_key(c[0], c[1], c[2]);
                        *o = table[k];
                        if let Some(l) = luma.as_deref_mut() {
                            l[x] = k as f32 / 1000.0;
                        }
                    }
                } else {
                    for (x, (o, c)) in out.iter_mut().zip(row.outer_iter()).enumerate() {
                        let k = luma_key(c[0], c[1], c[2]);
                        *o = table[k];
                        if let Some(l) = luma.as_deref_mut() {
                            l[x] = k as f32 / 1000.0;
                        }
                    }
                }
            }
            Frame::GrayF32(v) => {
                for (x, (o, &p)) in out.iter_mut().zip(v.row(y).iter()).enumerate() {
                    *o = self.response.eval(f64::from(p));
                    if let Some(l) = luma.as_deref_mut() {
                        l[x] = p;
                    }
                }
            }
        }
    }

    /// Fill `out` (row-major, `width*height`) with the response of `frame`, and `luma` with
    /// its BT.601 luma when given. Rows run in parallel; the result does not depend on it.
    pub fn convert(&self, frame: &Frame<'_>, out: &mut [f32], luma: Option<&mut [f32]>) {
        let (w, _) = frame.size();
        if w == 0 {
            return;
        }
        match luma {
            Some(luma) => out
                .par_chunks_mut(w)
                .zip(luma.par_chunks_mut(w))
                .enumerate()
                .for_each(|(y, (o, l))| self.convert_row(frame, y, o, Some(l))),
            None => out
                .par_chunks_mut(w)
                .enumerate()
                .for_each(|(y, o)| self.convert_row(frame, y, o, None)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{s, Array2, Array3};

    #[test]
    fn bgr_luma_is_bt601_in_float() {
        let conv = Converter::new(Response::Log { offset: 0.0 });
        let mut img = Array3::<u8>::zeros((1, 2, 3));
        img[[0, 0, 0]] = 10; // B
        img[[0, 0, 1]] = 20; // G
        img[[0, 0, 2]] = 30; // R
        img[[0, 1, 2]] = 255;
        let mut out = vec![0.0; 2];
        let mut luma = vec![0.0; 2];
        conv.convert(&Frame::Bgr(img.view()), &mut out, Some(&mut luma));
        let y0 = 0.299 * 30.0 + 0.587 * 20.0 + 0.114 * 10.0;
        assert!((luma[0] - y0).abs() < 1e-4, "{luma:?}");
        assert!((out[0] - y0.ln()).abs() < 1e-5);
        assert!((luma[1] - 0.299 * 255.0).abs() < 1e-4);
    }

    #[test]
    fn strided_crop_matches_contiguous_copy() {
        let conv = Converter::new(Response::LinLog { threshold: 20.0 });
        let full =
            Array3::<u8>::from_shape_fn((4, 6, 3), |(y, x, c)| (y * 37 + x * 11 + c * 5) as u8);
        let crop = full.slice(s![.., 1..5, ..]);
        let copy = crop.to_owned();
        let (mut a, mut b) = (vec![0.0; 16], vec![0.0; 16]);
        conv.convert(&Frame::Bgr(crop), &mut a, None);
        conv.convert(&Frame::Bgr(copy.view()), &mut b, None);
        assert_eq!(a, b);
    }

    #[test]
    fn linlog_is_continuous_and_rejects_bad_float_frames() {
        let r = Response::LinLog { threshold: 20.0 };
        assert!((r.eval(20.0) - r.eval(20.000_001)).abs() < 1e-5);
        assert!(r.eval(0.0).abs() < 1e-12);
        let mut f = Array2::<f32>::zeros((2, 2));
        f[[1, 0]] = f32::NAN;
        let err = Frame::GrayF32(f.view()).check(2, 2, 7).unwrap_err();
        assert!(err.to_string().contains("frame 7"), "{err}");
        assert!(Frame::GrayF32(f.view()).check(3, 2, 0).is_err());
    }
}
