//! The engine's inputs: one window's spikes ([`Spikes`]) and many windows in the column layout
//! of `uavsnn.windows.Windows` ([`WindowBatch`]), validated before any work starts.

use crate::error::{Error, Result};
use crate::windows::Windows;

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
    ///
    /// # Panics
    ///
    /// If `range` does not lie within `0..=self.len()`, or starts after it ends, as slicing a
    /// slice does. [`WindowBatch::window`] gives a window's spikes with a typed error instead.
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
/// [`WindowBatch::new`] checks everything; [`WindowBatch::with_windows`] makes a batch of the
/// [`Windows`] of [`make_windows`](crate::windows::make_windows). The fields are public, so a
/// batch written as a struct literal may be inconsistent: [`window`](Self::window),
/// [`infer`](super::infer) and [`Trainer::step`](super::Trainer::step) re-check each window
/// they read in `O(1)` (its index, offsets and count, and that its last spike is before
/// `t0 + L`); the network checks the spikes themselves (on the sensor, sorted, none before
/// `t0`).
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

    /// Run `f` on `windows` (what [`make_windows`](crate::windows::make_windows) gives) as a
    /// batch, checked as [`WindowBatch::new`] checks one, and return what `f` returns.
    ///
    /// A batch borrows its columns as `i64`, the layout of `uavsnn.windows.Windows`, while
    /// [`Windows`] owns `usize` offsets and `u64` counts: the two converted columns
    /// (`windows + 1` and `windows` values) live for the call, and the batch with them.
    ///
    /// # Errors
    ///
    /// As [`WindowBatch::new`] (the fields of [`Windows`] are public, so they may disagree),
    /// [`Error::Shape`] (`offsets`) or [`Error::InvalidParameter`] (`n_preceding`) for a
    /// value beyond `i64::MAX`, [`Error::InvalidParameter`] (`sensor_size`) for a sensor with
    /// a zero side ([`SensorSize::validate`](crate::SensorSize::validate)); then whatever `f`
    /// returns.
    ///
    /// ```
    /// use uavsnn::network::{infer, Network, NetworkConfig, WindowBatch};
    /// use uavsnn::windows::{make_windows, WindowConfig};
    /// use uavsnn::{Event, SensorSize};
    ///
    /// let config = NetworkConfig { width: 64, height: 48, ..NetworkConfig::default() };
    /// let net = Network::new(config, 0)?;
    /// // A vertical line of 5 pixels at t = 1000 µs, and again 20 ms later.
    /// let events: Vec<Event> = [1_000, 21_000]
    ///     .into_iter()
    ///     .flat_map(|t| (10..15).map(move |y| Event { t, x: 20, y, p: true }))
    ///     .collect();
    /// let sensor = SensorSize::new(64, 48)?;
    /// let windows = make_windows(&events, sensor, &WindowConfig::new(10_000, 0.0)?)?;
    /// let results = WindowBatch::with_windows(&windows, |batch| infer(&net, batch, None, false))?;
    /// assert_eq!(results.len(), 3); // [1000, 11000), [11000, 21000), [21000, 31000)
    /// assert!(results[0].counts[0] > 0 && results[1].counts[0] == 0); // conv1 fired, then not
    /// # Ok::<(), uavsnn::Error>(())
    /// ```
    pub fn with_windows<R, E: From<Error>>(
        windows: &Windows,
        f: impl FnOnce(&WindowBatch<'_>) -> std::result::Result<R, E>,
    ) -> std::result::Result<R, E> {
        let offsets = windows
            .offsets
            .iter()
            .enumerate()
            .map(|(i, &o)| {
                i64::try_from(o).map_err(|_| Error::Shape {
                    name: "offsets",
                    expected: "offsets of at most i64::MAX".into(),
                    got: format!("offsets[{i}] = {o}"),
                })
            })
            .collect::<Result<Vec<i64>>>()?;
        let n_preceding = windows
            .n_preceding
            .iter()
            .enumerate()
            .map(|(i, &n)| {
                i64::try_from(n).map_err(|_| {
                    Error::param(
                        "n_preceding",
                        format!("counts must be at most i64::MAX; window {i} has {n}"),
                    )
                })
            })
            .collect::<Result<Vec<i64>>>()?;
        let sensor = windows.sensor.validate()?;
        let sensor = (usize::from(sensor.width), usize::from(sensor.height));
        let spikes = Spikes::new(&windows.t, &windows.x, &windows.y)?;
        let batch = WindowBatch::new(
            sensor,
            windows.length_us,
            &windows.t0,
            &offsets,
            spikes,
            &n_preceding,
        )?;
        f(&batch)
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
    use crate::events::{Event, SensorSize};
    use crate::network::{infer, Network, NetworkConfig};
    use crate::windows::{make_windows, WindowConfig};

    /// Overlapping windows over a few lines of events on a 16 × 12 sensor, with "preceding"
    /// counts that are not all zero.
    fn some_windows() -> Windows {
        let events: Vec<Event> = (0..40u64)
            .map(|i| Event {
                t: 1_000 + 250 * i,
                x: 2 + (i % 10) as u16,
                y: 3 + (i / 10) as u16,
                p: i % 3 == 0,
            })
            .collect();
        let sensor = SensorSize::new(16, 12).unwrap();
        make_windows(&events, sensor, &WindowConfig::new(2_000, 0.5).unwrap()).unwrap()
    }

    #[test]
    fn a_batch_from_windows_is_the_hand_converted_one() {
        let w = some_windows();
        assert!(w.len() > 5 && w.n_preceding.iter().any(|&n| n > 0));
        let offsets: Vec<i64> = w.offsets.iter().map(|&o| o as i64).collect();
        let n_preceding: Vec<i64> = w.n_preceding.iter().map(|&n| n as i64).collect();
        let spikes = Spikes::new(&w.t, &w.x, &w.y).unwrap();
        let by_hand =
            WindowBatch::new((16, 12), 2_000, &w.t0, &offsets, spikes, &n_preceding).unwrap();
        let config = NetworkConfig {
            width: 16,
            height: 12,
            ..NetworkConfig::default()
        };
        let net = Network::new(config, 0).unwrap();
        let expected = infer(&net, &by_hand, Some(1), true).unwrap();
        let got = WindowBatch::with_windows(&w, |batch| {
            assert_eq!(batch.sensor, by_hand.sensor);
            assert_eq!(batch.length_us, by_hand.length_us);
            assert_eq!(batch.t0, by_hand.t0);
            assert_eq!(batch.offsets, by_hand.offsets);
            assert_eq!(batch.n_preceding, by_hand.n_preceding);
            for i in 0..batch.len() {
                assert_eq!(batch.window(i)?.t(), by_hand.window(i)?.t());
                assert_eq!(batch.window(i)?.x(), by_hand.window(i)?.x());
                assert_eq!(batch.window(i)?.y(), by_hand.window(i)?.y());
            }
            infer(&net, batch, Some(1), true)
        })
        .unwrap();
        assert_eq!(got, expected);
    }

    #[test]
    fn a_batch_from_windows_is_checked_and_passes_errors_through() {
        #[derive(Debug)]
        enum Mine {
            Engine(Error),
        }
        impl From<Error> for Mine {
            fn from(e: Error) -> Self {
                Mine::Engine(e)
            }
        }
        let w = some_windows();
        let run = |w: &Windows| WindowBatch::with_windows(w, |batch| Ok(batch.len()));
        assert_eq!(run(&w).unwrap(), w.len());
        assert_eq!(run(&Windows::empty(w.sensor, 10)).unwrap(), 0);
        // A 0x0 sensor (a SensorSize literal) ran `f` on a batch of no pixels.
        let zero = SensorSize {
            width: 0,
            height: 0,
        };
        let err = run(&Windows::empty(zero, 10)).unwrap_err();
        crate::events::assert_zero_sensor(&err);
        // `f`'s own error comes back as it is, whatever its type.
        let err = WindowBatch::with_windows(&w, |_| Err::<(), _>(Error::Internal("f".into())));
        assert!(matches!(err, Err(Error::Internal(m)) if m == "f"));
        // An error type of the caller's that engine errors convert into.
        let bad = Windows {
            length_us: 0,
            ..w.clone()
        };
        let err = WindowBatch::with_windows(&bad, |_| Ok::<(), Mine>(())).unwrap_err();
        assert!(matches!(
            err,
            Mine::Engine(Error::InvalidParameter {
                name: "length_us",
                ..
            })
        ));
        // Public fields that disagree, or do not fit the batch's `i64` columns.
        let mut offsets = w.clone();
        offsets.offsets[1] = usize::MAX;
        let mut shifted = w.clone();
        shifted.offsets.pop();
        for bad in [offsets, shifted] {
            assert!(
                matches!(
                    run(&bad),
                    Err(Error::Shape {
                        name: "offsets",
                        ..
                    })
                ),
                "{:?}",
                run(&bad)
            );
        }
        let mut counts = w.clone();
        counts.n_preceding[2] = u64::MAX;
        assert!(matches!(
            run(&counts),
            Err(Error::InvalidParameter {
                name: "n_preceding",
                ..
            })
        ));
        let mut short = w.clone();
        short.n_preceding.pop();
        assert!(matches!(
            run(&short),
            Err(Error::Shape {
                name: "n_preceding",
                ..
            })
        ));
        let mut columns = w.clone();
        columns.x.pop();
        assert!(matches!(
            run(&columns),
            Err(Error::Shape { name: "spikes", .. })
        ));
        let mut outside = w.clone();
        outside.x[0] = 16;
        assert!(matches!(
            run(&outside),
            Err(Error::InvalidEvent { index: 0, .. })
        ));
    }

    #[test]
    #[should_panic(expected = "out of range")]
    fn a_slice_beyond_the_spikes_panics() {
        let s = Spikes::new(&[5], &[1], &[1]).unwrap();
        assert_eq!(s.slice(0..1).len(), 1);
        assert!(s.slice(1..1).is_empty());
        let _ = s.slice(0..5);
    }

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
