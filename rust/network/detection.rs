//! Detections (docs/model.md §5): every conv3 spike, with where it looks in sensor pixels.
//!
//! Coordinates are continuous sensor coordinates in which pixel `(x, y)` covers
//! `[x, x + 1) × [y, y + 1)`: a box `x0, y0, x1, y1` is half-open and holds the pixels
//! `x0 ≤ x < x1`, `y0 ≤ y < y1`, and a centre is the middle of such a box. This is the
//! convention of label boxes (`x, y, w, h` → `x0 = x`, `x1 = x + w`).

use std::ops::Range;

use super::cause::PixelBox;

/// One conv3 spike reported as a detection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// Spike time (µs, absolute).
    pub t: u64,
    pub map: u16,
    /// conv3 position.
    pub row: u16,
    pub col: u16,
    /// Centre of the neuron's receptive field in sensor coordinates.
    pub x: f32,
    pub y: f32,
    /// Bounding box of the input spikes that caused this spike, followed down through the
    /// layers (docs/model.md §5; half-open; the receptive field itself if, degenerately, there
    /// are none).
    pub x0: u16,
    pub y0: u16,
    pub x1: u16,
    pub y1: u16,
}

/// Build the detection of a conv3 spike whose receptive field is `rows × cols` and whose
/// causes lie in `causes` (see `cause`).
pub(crate) fn detection(
    t: u64,
    map: u32,
    row: usize,
    col: usize,
    rows: &Range<usize>,
    cols: &Range<usize>,
    causes: Option<PixelBox>,
) -> Detection {
    let (x0, y0, x1, y1) = causes.unwrap_or((
        cols.start as u16,
        rows.start as u16,
        cols.end as u16,
        rows.end as u16,
    ));
    Detection {
        t,
        map: map as u16,
        row: row as u16,
        col: col as u16,
        x: (cols.start + cols.end) as f32 / 2.0,
        y: (rows.start + rows.end) as f32 / 2.0,
        x0,
        y0,
        x1,
        y1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_is_the_causes_or_else_the_field() {
        let d = detection(9, 1, 2, 3, &(30..40), &(0..10), Some((1, 31, 8, 37)));
        assert_eq!(
            (d.x, d.y, d.x0, d.y0, d.x1, d.y1),
            (5.0, 35.0, 1, 31, 8, 37)
        );
        let d = detection(9, 1, 2, 3, &(30..40), &(0..10), None);
        assert_eq!((d.x0, d.y0, d.x1, d.y1), (0, 30, 10, 40));
    }
}
