//! Detections (docs/model.md §5): every conv3 spike, with where it looks in sensor pixels.
//!
//! Coordinates are continuous sensor coordinates in which pixel `(x, y)` covers
//! `[x, x + 1) × [y, y + 1)`: a box `x0, y0, x1, y1` is half-open and holds the pixels
//! `x0 ≤ x < x1`, `y0 ≤ y < y1`, and a centre is the middle of such a box. This is the
//! convention of label boxes (`x, y, w, h` → `x0 = x`, `x1 = x + w`).

use std::ops::Range;

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
    /// Bounding box of the window's input spikes with time `≤ t` inside the receptive field
    /// (half-open; the receptive field itself if, degenerately, there are none).
    pub x0: u16,
    pub y0: u16,
    pub x1: u16,
    pub y1: u16,
}

/// The window's input spikes so far, as columns (for boxes).
#[derive(Debug, Clone, Default)]
pub(crate) struct Inputs {
    pub x: Vec<u16>,
    pub y: Vec<u16>,
}

impl Inputs {
    pub fn clear(&mut self) {
        self.x.clear();
        self.y.clear();
    }

    pub fn push(&mut self, x: u16, y: u16) {
        self.x.push(x);
        self.y.push(y);
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Bounding box `(x0, y0, x1, y1)` (half-open) of the spikes inside `rows × cols`, if any.
    pub fn bounding_box(
        &self,
        rows: &Range<usize>,
        cols: &Range<usize>,
    ) -> Option<(u16, u16, u16, u16)> {
        let (rx0, rx1) = (cols.start as u32, cols.end as u32);
        let (ry0, ry1) = (rows.start as u32, rows.end as u32);
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0u32, 0u32);
        for (&x, &y) in self.x.iter().zip(&self.y) {
            let (x, y) = (u32::from(x), u32::from(y));
            if x >= rx0 && x < rx1 && y >= ry0 && y < ry1 {
                x0 = x0.min(x);
                x1 = x1.max(x + 1);
                y0 = y0.min(y);
                y1 = y1.max(y + 1);
            }
        }
        (x0 != u32::MAX).then_some((x0 as u16, y0 as u16, x1 as u16, y1 as u16))
    }
}

/// Build the detection of a conv3 spike whose receptive field is `rows × cols`.
pub(crate) fn detection(
    t: u64,
    map: u32,
    row: usize,
    col: usize,
    rows: &Range<usize>,
    cols: &Range<usize>,
    inputs: &Inputs,
) -> Detection {
    let (x0, y0, x1, y1) = inputs.bounding_box(rows, cols).unwrap_or((
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
    fn box_holds_only_spikes_in_the_field() {
        let mut inputs = Inputs::default();
        for (x, y) in [(1, 1), (5, 6), (7, 3), (20, 20)] {
            inputs.push(x, y);
        }
        assert_eq!(inputs.bounding_box(&(0..10), &(0..10)), Some((1, 1, 8, 7)));
        assert_eq!(
            inputs.bounding_box(&(10..30), &(10..30)),
            Some((20, 20, 21, 21))
        );
        assert_eq!(inputs.bounding_box(&(30..40), &(0..10)), None);
        let d = detection(9, 1, 2, 3, &(30..40), &(0..10), &inputs);
        assert_eq!(
            (d.x, d.y, d.x0, d.y0, d.x1, d.y1),
            (5.0, 35.0, 0, 30, 10, 40)
        );
    }
}
