//! [`Pix2NvsParams::compat`]: the released program's events exactly, quirks included — its
//! luma read from the BMP bytes, C's float-to-int conversion, and its updates of the block's
//! top-left pixel.

use super::compete::{copy_block, strongest};
use super::{Emitter, Pix2NvsParams, PixelState, ReferenceUpdate};
use crate::sim::frame::Frame;

/// The 24-bit BMP bytes of `frame` as ffmpeg writes them (rows bottom up, each padded to a
/// multiple of 4 bytes, pixels in B, G, R order), counted from the start of the pixel data;
/// 0 for padding and past the end.
#[inline]
fn bmp_byte(frame: &Frame<'_>, w: usize, h: usize, a: usize) -> u8 {
    let stride = (3 * w).div_ceil(4) * 4;
    let (row, col) = (a / stride, a % stride);
    if row >= h || col >= 3 * w {
        return 0;
    }
    let (x, y, c) = (col / 3, h - 1 - row, col % 3);
    match frame {
        Frame::Bgr(v) => v[[y, x, c]],
        Frame::Gray(v) => v[[y, x]],
        Frame::GrayF32(_) => 0, // refused before conversion
    }
}

/// Row `y` of `frame` as PIX2NVS's `readframe.cpp` and `log_frame.cpp` see it: `ln(Y)` in
/// single precision, `Y` computed in double from the BMP bytes two bytes after the pixel's own.
///
/// `readframe.cpp` skips `sizeof(BITMAPFILEHEADER) + sizeof(BITMAPINFOHEADER)` bytes, 56 with
/// the compiler's padding of its unpacked file-header struct, where the pixels start at byte
/// 54. Its blue, green and red of pixel `k` (counted without row padding) are therefore the
/// bytes `2 + 3k`, `3 + 3k`, `4 + 3k` of the pixel data: the red of pixel `k` and the blue and
/// green of the next — of the row above at a row's right end, and past the buffer (read as 0
/// here; undefined in the program) for the top right pixel.
pub(super) fn compat_luma_row(frame: &Frame<'_>, y: usize, out: &mut [f32]) {
    let (w, h) = frame.size();
    let file_row = h - 1 - y;
    for (x, o) in out.iter_mut().enumerate() {
        let a = 2 + 3 * (w * file_row + x);
        let blue = f64::from(bmp_byte(frame, w, h, a));
        let green = f64::from(bmp_byte(frame, w, h, a + 1));
        let red = f64::from(bmp_byte(frame, w, h, a + 2));
        let luma = (0.299 * red + 0.587 * green + 0.114 * blue) as f32;
        *o = luma.ln();
    }
}

/// C's `(int)` of a float on x86-64 (`cvttss2si`): truncation, and `i32::MIN` for NaN, the
/// infinities and anything out of range.
#[inline]
pub(super) fn x86_int(v: f32) -> i32 {
    if v.is_finite() && v > -2_147_483_648.0 && v < 2_147_483_648.0 {
        v as i32
    } else {
        i32::MIN
    }
}

/// One band of blocks as `generate_events.cpp` processes it: the winner decides with its own
/// threshold, but modes 2 and 3 and the adaptive threshold update the block's top-left pixel;
/// `print_event.cpp`'s count is `(int)(ΔB/θ)` capped at `n_max` (an infinite change, from a
/// black pixel's `-inf`, gives `INT_MIN`: no event, and mode 3 moves the reference by
/// `INT_MIN·θ`).
pub(super) fn compete_band_compat(
    p: &Pix2NvsParams,
    state: &mut [PixelState],
    input: &[f32],
    w: usize,
    y0: usize,
    emitters: &mut Vec<Emitter>,
) {
    let b = p.block_size;
    let (up, down) = (1.0 + p.adaptive, 1.0 - p.adaptive);
    for x0 in (0..w).step_by(b) {
        let win = strongest(state, input, w, x0, b);
        let delta = input[win] - state[win].reference;
        let theta = state[win].threshold;
        let origin = x0; // the block's top-left pixel: row 0 of the band, column x0
        let on = delta > theta;
        if on || delta < -theta {
            let magnitude = if on { delta } else { -delta };
            let moddiff = x86_int(magnitude / theta);
            let evenum = if moddiff > p.n_max as i32 {
                p.n_max as i32
            } else {
                moddiff
            };
            if evenum > 0 {
                emitters.push(Emitter {
                    x: (win % w) as u16,
                    y: (y0 + win / w) as u16,
                    count: if on { evenum as i8 } else { -(evenum as i8) },
                    step: theta / magnitude,
                    magnitude,
                    theta,
                });
            }
            let o = &mut state[origin];
            match p.reference {
                ReferenceUpdate::EventCopy => o.reference = input[origin],
                ReferenceUpdate::EventIncrement => {
                    let moved = evenum as f32 * o.threshold;
                    o.reference = if on {
                        o.reference + moved
                    } else {
                        o.reference - moved
                    };
                }
                ReferenceUpdate::Frame => {}
            }
            o.threshold *= up;
        } else {
            state[origin].threshold *= down;
        }
        if p.reference == ReferenceUpdate::Frame {
            copy_block(state, input, w, x0, b);
        }
    }
}
