//! The engine's inputs: one window's spikes ([`Spikes`]) and many windows in the column layout
//! of `uavsnn.windows.Windows` ([`WindowBatch`]), validated before any work starts.

use crate::error::{Error, Result};

/// One window's input spikes as columns: `t` (µs, absolute, sorted), `x`, `y`.
#[derive(Debug, Clone, Copy)]
pub struct Spikes<'a> {
    t: &'a [u64],
    x: &'a [u16],
    y: &'a [u16],
}

impl<'a> Spikes<'a> {
    /// Columns of equal length (their values are checked when they reach the network).
    pub fn new(t: &'a [u64], x: &'a [u16], y: &'a [u16]) -> Result<Self> {
        if x.len() != t.len() || y.len() != t.len() {
            return Err(Error::Shape {
                name: "spikes",
                expected: "t, x and y of equal length".into(),
                got: format!("{}, {} and {}", t.len(), x.len(), y.len()),
            });
        }
        Ok(Self { t, x, y })
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    pub fn t(&self) -> &'a [u64] {
        self.t
    }

    pub fn x(&self) -> &'a [u16] {
        self.x
    }

    pub fn y(&self) -> &'a [u16] {
        self.y
    }

    /// The spikes `range` of these columns.
    #[must_use]
    pub fn slice(&self, range: std::ops::Range<usize>) -> Spikes<'a> {
        Spikes {
            t: &self.t[range.clone()],
            x: &self.x[range.clone()],
            y: &self.y[range],
        }
    }
}

/// Many windows, as `uavsnn.windows.Windows` holds them: window `i`'s spikes are
/// `offsets[i]..offsets[i + 1]` of the columns.
///
/// [`WindowBatch::new`] checks everything. The fields are public, so a batch written as a
/// struct literal may be inconsistent: [`window`](Self::window), [`infer`](super::infer) and
/// [`Trainer::step`](super::Trainer::step) re-check each window they read in `O(1)` (its
/// index, offsets and count, and that its last spike is before `t0 + L`); the network checks
/// the spikes themselves (on the sensor, sorted, none before `t0`).
#[derive(Debug, Clone, Copy)]
pub struct WindowBatch<'a> {
    /// `(width, height)` of the sensor.
    pub sensor: (usize, usize),
    /// Window length `L` (µs).
    pub length_us: u64,
    pub t0: &'a [u64],
    pub offsets: &'a [i64],
    pub spikes: Spikes<'a>,
    /// Distinct active pixels in `[t0 − L, t0)` (PENT `"preceding"`).
    pub n_preceding: &'a [i64],
}

impl<'a> WindowBatch<'a> {
    /// Check the columns' shapes and every spike: inside the sensor, inside its window
    /// `[t0, t0 + L)`, sorted by time within the window.
    pub fn new(
        sensor: (usize, usize),
        length_us: u64,
        t0: &'a [u64],
        offsets: &'a [i64],
        spikes: Spikes<'a>,
        n_preceding: &'a [i64],
    ) -> Result<Self> {
        let n = t0.len();
        if length_us == 0 {
            return Err(Error::param("length_us", "must be at least 1 µs, got 0"));
        }
        if offsets.len() != n + 1 {
            return Err(Error::Shape {
                name: "offsets",
                expected: format!("{} values (windows + 1)", n + 1),
                got: format!("{}", offsets.len()),
            });
        }
        if n_preceding.len() != n {
            return Err(Error::Shape {
                name: "n_preceding",
                expected: format!("{n} values (one per window)"),
                got: format!("{}", n_preceding.len()),
            });
        }
        if offsets[0] != 0 || offsets[n] != spikes.len() as i64 {
            return Err(Error::Shape {
                name: "offsets",
                expected: format!(
                    "to start at 0 and end at {} (the spike count)",
                    spikes.len()
                ),
                got: format!("{} .. {}", offsets[0], offsets[n]),
            });
        }
        if let Some(i) = (0..n).find(|&i| offsets[i + 1] < offsets[i]) {
            return Err(Error::Shape {
                name: "offsets",
                expected: "non-decreasing offsets".into(),
                got: format!(
                    "offsets[{}] = {} > offsets[{}] = {}",
                    i,
                    offsets[i],
                    i + 1,
                    offsets[i + 1]
                ),
            });
        }
        if let Some(i) = n_preceding.iter().position(|&v| v < 0) {
            return Err(Error::param(
                "n_preceding",
                format!("counts must be >= 0; window {i} has {}", n_preceding[i]),
            ));
        }
        let batch = Self {
            sensor,
            length_us,
            t0,
            offsets,
            spikes,
            n_preceding,
        };
        for i in 0..n {
            batch.check_window(i)?;
        }
        Ok(batch)
    }

    fn check_window(&self, i: usize) -> Result<()> {
        let (start, end) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
        let t0 = self.t0[i];
        let t_end = t0.saturating_add(self.length_us);
        let (w, h) = self.sensor;
        let mut last = t0;
        for j in start..end {
            let (t, x, y) = (self.spikes.t[j], self.spikes.x[j], self.spikes.y[j]);
            let reason = if usize::from(x) >= w || usize::from(y) >= h {
                format!("(x={x}, y={y}) of window {i} is outside the {w}x{h} sensor")
            } else if t < t0 || t >= t_end {
                format!("t={t} is outside its window {i} [{t0}, {t_end})")
            } else if t < last {
                format!("t={t} goes backwards in window {i} (previous spike at t={last})")
            } else {
                last = t;
                continue;
            };
            return Err(Error::InvalidEvent { index: j, reason });
        }
        Ok(())
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.t0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t0.is_empty()
    }

    /// Window `i`'s spikes.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`i`) when there is no window `i`; [`Error::Shape`] when the
    /// batch's columns disagree about it (possible only for a batch not made by [`Self::new`]).
    pub fn window(&self, i: usize) -> Result<Spikes<'a>> {
        self.checked_window(i).map(|w| w.spikes)
    }

    /// Window `i`, re-checked in `O(1)`: it exists in every column, its offsets lie in order
    /// within the spikes, its `n_preceding` is not negative, and its last spike is before
    /// `t0 + L` (the network checks the others: sorted, from `t0` on, on the sensor).
    pub(crate) fn checked_window(&self, i: usize) -> Result<BatchWindow<'a>> {
        let n = self.t0.len();
        if i >= n {
            return Err(Error::param(
                "i",
                format!("window {i} is out of range for {n} windows"),
            ));
        }
        let shape = |name, expected: String, got: String| Error::Shape {
            name,
            expected,
            got,
        };
        if self.offsets.len() != n + 1 {
            return Err(shape(
                "offsets",
                format!("{} values (windows + 1)", n + 1),
                format!("{}", self.offsets.len()),
            ));
        }
        if self.n_preceding.len() != n {
            return Err(shape(
                "n_preceding",
                format!("{n} values (one per window)"),
                format!("{}", self.n_preceding.len()),
            ));
        }
        let (a, b) = (self.offsets[i], self.offsets[i + 1]);
        let (start, end) = match (usize::try_from(a), usize::try_from(b)) {
            (Ok(start), Ok(end)) if start <= end && end <= self.spikes.len() => (start, end),
            _ => {
                return Err(shape(
                    "offsets",
                    format!(
                        "offsets[{i}] <= offsets[{}] within the {} spikes",
                        i + 1,
                        self.spikes.len()
                    ),
                    format!("{a} .. {b}"),
                ))
            }
        };
        let n_preceding = u64::try_from(self.n_preceding[i]).map_err(|_| {
            Error::param(
                "n_preceding",
                format!(
                    "counts must be >= 0; window {i} has {}",
                    self.n_preceding[i]
                ),
            )
        })?;
        if self.length_us == 0 {
            return Err(Error::param("length_us", "must be at least 1 µs, got 0"));
        }
        let t0 = self.t0[i];
        let spikes = self.spikes.slice(start..end);
        if let Some(&last) = spikes.t().last() {
            let t_end = t0.saturating_add(self.length_us);
            if last >= t_end {
                return Err(Error::InvalidEvent {
                    index: end - 1,
                    reason: format!("t={last} is outside its window {i} [{t0}, {t_end})"),
                });
            }
        }
        Ok(BatchWindow {
            t0,
            spikes,
            n_preceding,
        })
    }
}

/// One window of a [`WindowBatch`], as [`WindowBatch::checked_window`] gives it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BatchWindow<'a> {
    pub t0: u64,
    pub spikes: Spikes<'a>,
    pub n_preceding: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validates_shapes_and_spikes() {
        let t = [5u64, 6, 12, 13];
        let x = [1u16, 2, 3, 4];
        let y = [1u16, 1, 1, 1];
        let s = Spikes::new(&t, &x, &y).unwrap();
        let ok = WindowBatch::new((8, 8), 10, &[0, 10], &[0, 2, 4], s, &[0, 2]).unwrap();
        assert_eq!(ok.window(1).unwrap().t(), &[12, 13]);
        assert!(Spikes::new(&t, &x[..3], &y).is_err());
        let bad = [
            WindowBatch::new((8, 8), 10, &[0, 10], &[0, 2], s, &[0, 2]),
            WindowBatch::new((8, 8), 10, &[0, 10], &[0, 3, 4], s, &[0, 2]),
            WindowBatch::new((8, 8), 10, &[0, 10], &[0, 1, 4], s, &[0, 2]),
            WindowBatch::new((4, 4), 10, &[0, 10], &[0, 2, 4], s, &[0, 2]),
            WindowBatch::new((8, 8), 10, &[0, 10], &[0, 2, 4], s, &[0, -1]),
            WindowBatch::new((8, 8), 0, &[0, 10], &[0, 2, 4], s, &[0, 2]),
        ];
        for b in bad {
            assert!(b.is_err());
        }
        let t = [6u64, 5];
        let s = Spikes::new(&t, &x[..2], &y[..2]).unwrap();
        assert!(matches!(
            WindowBatch::new((8, 8), 10, &[0], &[0, 2], s, &[0]),
            Err(Error::InvalidEvent { index: 1, .. })
        ));
    }

    #[test]
    fn a_batch_literal_is_rechecked_window_by_window() {
        let t = [5u64, 6, 12, 13];
        let x = [1u16, 2, 3, 4];
        let y = [1u16, 1, 1, 1];
        let s = Spikes::new(&t, &x, &y).unwrap();
        let ok = WindowBatch::new((8, 8), 10, &[0, 10], &[0, 2, 4], s, &[0, 2]).unwrap();
        assert_eq!(ok.checked_window(1).unwrap().n_preceding, 2);
        assert!(matches!(
            ok.window(2),
            Err(Error::InvalidParameter { name: "i", .. })
        ));
        // Literals that used to index out of bounds, or read a negative count as 2^64 - 1.
        let offsets = |offsets| WindowBatch { offsets, ..ok };
        for bad in [&[0, 2][..], &[0, 5, 4], &[0, 3, 2], &[0, -1, 4], &[0, 2, 9]] {
            let err = offsets(bad).window(1).unwrap_err();
            assert!(
                matches!(
                    err,
                    Error::Shape {
                        name: "offsets",
                        ..
                    }
                ),
                "{bad:?}: {err}"
            );
        }
        let err = WindowBatch {
            n_preceding: &[],
            ..ok
        }
        .checked_window(0)
        .unwrap_err();
        assert!(
            matches!(
                err,
                Error::Shape {
                    name: "n_preceding",
                    ..
                }
            ),
            "{err}"
        );
        let err = WindowBatch {
            n_preceding: &[0, -3],
            ..ok
        }
        .checked_window(1)
        .unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "n_preceding",
                    ..
                }
            ),
            "{err}"
        );
        let err = WindowBatch { length_us: 0, ..ok }.window(0).unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "length_us",
                    ..
                }
            ),
            "{err}"
        );
        // A spike at or after t0 + L.
        let err = WindowBatch { length_us: 3, ..ok }.window(1).unwrap_err();
        assert!(matches!(err, Error::InvalidEvent { index: 3, .. }), "{err}");
        assert!(WindowBatch { length_us: 4, ..ok }.window(0).is_err());
        WindowBatch { length_us: 7, ..ok }.window(0).unwrap();
    }
}
