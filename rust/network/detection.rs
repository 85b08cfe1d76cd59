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

/// The window's input spikes so far (for boxes): one bit per pixel, rows of 64-pixel words,
/// and the list of pixels set (what `clear` resets). A box then reads the receptive field's
/// rows word by word instead of every input spike of the window.
#[derive(Debug, Clone)]
pub(crate) struct Inputs {
    width: usize,
    height: usize,
    words: usize,
    bits: Vec<u64>,
    pixels: Vec<(u16, u16)>,
}

impl Inputs {
    pub fn new(width: usize, height: usize) -> Self {
        let words = width.div_ceil(64);
        Self {
            width,
            height,
            words,
            bits: vec![0; words * height],
            pixels: Vec::new(),
        }
    }

    pub fn clear(&mut self) {
        for &(x, y) in &self.pixels {
            self.bits[usize::from(y) * self.words + usize::from(x) / 64] = 0;
        }
        self.pixels.clear();
    }

    /// Add pixel `(x, y)` (inside the sensor; each pixel once per window).
    pub fn push(&mut self, x: u16, y: u16) {
        let (xs, ys) = (usize::from(x), usize::from(y));
        self.bits[ys * self.words + xs / 64] |= 1 << (xs % 64);
        self.pixels.push((x, y));
    }

    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    /// Bounding box `(x0, y0, x1, y1)` (half-open) of the spikes inside `rows × cols`, if any.
    pub fn bounding_box(
        &self,
        rows: &Range<usize>,
        cols: &Range<usize>,
    ) -> Option<(u16, u16, u16, u16)> {
        let (c0, c1) = (cols.start, cols.end.min(self.width));
        let (r0, r1) = (rows.start, rows.end.min(self.height));
        if c0 >= c1 || r0 >= r1 {
            return None;
        }
        let (w0, w1) = (c0 / 64, (c1 - 1) / 64);
        // The field's bits in its first and last word.
        let first = u64::MAX << (c0 % 64);
        let last = u64::MAX >> (63 - (c1 - 1) % 64);
        let (mut x0, mut x1) = (usize::MAX, 0);
        let (mut y0, mut y1) = (usize::MAX, 0);
        for y in r0..r1 {
            let row = &self.bits[y * self.words + w0..=y * self.words + w1];
            let mut any = false;
            for (i, &word) in row.iter().enumerate() {
                let mut m = word;
                if i == 0 {
                    m &= first;
                }
                if i == row.len() - 1 {
                    m &= last;
                }
                if m != 0 {
                    let base = (w0 + i) * 64;
                    x0 = x0.min(base + m.trailing_zeros() as usize);
                    x1 = x1.max(base + 64 - m.leading_zeros() as usize);
                    any = true;
                }
            }
            if any {
                y0 = y0.min(y);
                y1 = y + 1;
            }
        }
        (x0 != usize::MAX).then_some((x0 as u16, y0 as u16, x1 as u16, y1 as u16))
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

    /// Boxes from the bit rows equal those of a scan of every spike, on random pixels and
    /// fields (fields reaching past the sensor and across words included), after clears.
    #[test]
    fn box_equals_a_scan_of_every_spike() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |m: usize| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % m as u64) as usize
        };
        for (width, height) in [(1, 1), (64, 3), (65, 9), (240, 180), (130, 7)] {
            let mut inputs = Inputs::new(width, height);
            for _ in 0..20 {
                inputs.clear();
                let mut pixels = Vec::new();
                let n = next(width * height / 4 + 2);
                for _ in 0..n {
                    let (x, y) = (next(width) as u16, next(height) as u16);
                    if !pixels.contains(&(x, y)) {
                        pixels.push((x, y));
                        inputs.push(x, y);
                    }
                }
                for _ in 0..20 {
                    let (a, b) = (next(width + 4), next(width + 4));
                    let (c, d) = (next(height + 4), next(height + 4));
                    let (cols, rows) = (a.min(b)..a.max(b), c.min(d)..c.max(d));
                    let mut want: Option<(u16, u16, u16, u16)> = None;
                    for &(x, y) in &pixels {
                        if cols.contains(&usize::from(x)) && rows.contains(&usize::from(y)) {
                            let b = want.get_or_insert((x, y, x + 1, y + 1));
                            *b = (b.0.min(x), b.1.min(y), b.2.max(x + 1), b.3.max(y + 1));
                        }
                    }
                    assert_eq!(inputs.bounding_box(&rows, &cols), want, "{rows:?} {cols:?}");
                }
            }
        }
    }

    #[test]
    fn box_holds_only_spikes_in_the_field() {
        let mut inputs = Inputs::new(40, 40);
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
