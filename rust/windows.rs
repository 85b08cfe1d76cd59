//! Windows: the time-embedded frames of SPEC §2 and `docs/model.md` §1.
//!
//! A window is `[t0, t0 + L)`. Windows start every `step = L·(1 − o)` µs (see [`window_step`])
//! from `start` (the first event's time unless given) while `t0 < end` (one past the last event's
//! time unless given). A window's *input spikes* are, for each pixel with at least one event in
//! it, that pixel's first event in the window (polarities merged), in time order and, on equal
//! times, in order of arrival. Empty windows are kept, so that window `i` always starts at
//! `start + i·step`.
//!
//! The result is in compressed sparse rows ([`Windows`]): the spikes of window `i` are
//! `offsets[i]..offsets[i + 1]` of the columns `t`, `x`, `y`.
//!
//! # Cost
//!
//! One sweep over the events in time order counts each window's spikes and keeps the events
//! that are some window's input spike; a second pass over those writes them straight to their
//! final place, so the output is allocated once and nothing is copied (disjoint windows need
//! only the sweep: their spikes arrive in final order).
//! An event at time `t` whose pixel last fired at `t_prev` is the pixel's first event in exactly
//! the windows with `max(t − L, t_prev) < t0 ≤ t`, a range of window indices. Cursors that follow
//! the stream over the windows, and a per-pixel table remembering the range's end at the
//! pixel's previous event, give that range without a division or a search, so the work is
//! `O(events × windows per event)` (`windows per event` = `ceil(L / step)`) and nothing is ever
//! cleared per window. Events are read in place (any [`EventSource`], such as NumPy's packed
//! records). Long recordings are cut into runs of consecutive windows processed in parallel
//! (rayon), each run reading only the events that can reach it.

mod build;
mod frames;
mod median;
mod noise;

pub use frames::{frames, frames_into, frames_len};
pub(crate) use median::MedianFilter;
pub use median::{median_keep, MEDIAN_MIN_ACTIVE};
pub use noise::{add_noise, NoisyWindows};

use build::{build, build_disjoint, plan_runs};

use crate::error::{check_alloc, Error, Result};
use crate::events::{validate_source, EventSource, SensorSize};

/// Largest timestamp (and window length) windowing accepts: 2^62 µs, about 146,000 years.
/// Keeping every time below it makes all window arithmetic free of overflow.
pub const MAX_TIME_US: u64 = 1 << 62;

/// Most windows one call may produce (each costs about 32 bytes before any spike); a larger
/// request is almost always a unit mistake (nanoseconds given as microseconds, a step of 1 µs
/// over hours) and is refused rather than exhausting memory.
pub const MAX_WINDOWS: usize = 50_000_000;

/// The step between window starts, `L·(1 − o)` rounded down to whole microseconds, at least 1.
///
/// A product within `1e-9` (relative) of an integer counts as that integer, so that binary
/// floating point does not turn 10 ms at 90 % overlap into 999 µs.
pub fn window_step(length_us: u64, overlap: f64) -> Result<u64> {
    if length_us == 0 {
        return Err(Error::param(
            "length_us",
            "the window length must be at least 1 µs, got 0",
        ));
    }
    if length_us > MAX_TIME_US {
        return Err(Error::param(
            "length_us",
            format!("the window length must be at most 2^62 µs, got {length_us}"),
        ));
    }
    if !overlap.is_finite() || !(0.0..1.0).contains(&overlap) {
        return Err(Error::param(
            "overlap",
            format!("the overlap must be in [0, 1), got {overlap}"),
        ));
    }
    let exact = length_us as f64 * (1.0 - overlap);
    let nearest = exact.round();
    let step = if (exact - nearest).abs() <= 1e-9 * exact.max(1.0) {
        nearest
    } else {
        exact.floor()
    };
    Ok((step as u64).clamp(1, length_us))
}

/// How to cut a stream into windows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowConfig {
    /// Window length `L` in µs.
    pub length_us: u64,
    /// Step between window starts in µs (from [`window_step`]).
    pub step_us: u64,
    /// Apply the 3×3 median filter to each window's active pixels (see [`median_keep`]).
    pub median: bool,
    /// Start of the first window; the first event's time when `None`.
    pub start_us: Option<u64>,
    /// Windows start strictly before this time, and events at or after it are ignored; one past
    /// the last event's time when `None`.
    pub end_us: Option<u64>,
}

impl WindowConfig {
    /// Windows of `length_us` with overlap `overlap` in `[0, 1)`, no median filter, spanning the
    /// whole stream.
    pub fn new(length_us: u64, overlap: f64) -> Result<Self> {
        Ok(Self {
            length_us,
            step_us: window_step(length_us, overlap)?,
            median: false,
            start_us: None,
            end_us: None,
        })
    }

    /// The same windows with the median filter switched on or off.
    #[must_use]
    pub fn with_median(mut self, median: bool) -> Self {
        self.median = median;
        self
    }

    /// The same windows restricted to `[start_us, end_us)` (`None` keeps the default).
    #[must_use]
    pub fn with_range(mut self, start_us: Option<u64>, end_us: Option<u64>) -> Self {
        self.start_us = start_us;
        self.end_us = end_us;
        self
    }
}

/// One input spike of a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Spike {
    /// Absolute time in µs.
    pub t: u64,
    /// Column.
    pub x: u16,
    /// Row.
    pub y: u16,
}

/// Many windows in compressed sparse rows.
///
/// The fields are public, so windows may be edited or built by hand: [`Windows::view`] (the
/// way into [`frames`] and [`add_noise`]) and
/// [`WindowBatch::with_windows`](crate::network::WindowBatch::with_windows) check them, the
/// sensor included ([`SensorSize::validate`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Windows {
    /// Sensor the coordinates refer to.
    pub sensor: SensorSize,
    /// Window length `L` in µs.
    pub length_us: u64,
    /// Window starts, `(n,)`.
    pub t0: Vec<u64>,
    /// Window `i`'s spikes are `offsets[i]..offsets[i + 1]`, `(n + 1,)`.
    pub offsets: Vec<usize>,
    /// Absolute spike times, sorted within each window.
    pub t: Vec<u64>,
    /// Spike columns.
    pub x: Vec<u16>,
    /// Spike rows.
    pub y: Vec<u16>,
    /// Distinct pixels with at least one event in `[t0 − L, t0)` (PENT's "preceding" estimate of
    /// `N_in`, `docs/model.md` §4), counted on the raw events before any median filter.
    pub n_preceding: Vec<u64>,
}

impl Windows {
    /// No windows (not checked: `sensor` and `length_us` are, where the windows are used).
    pub fn empty(sensor: SensorSize, length_us: u64) -> Self {
        Self {
            sensor,
            length_us,
            t0: Vec::new(),
            offsets: vec![0],
            t: Vec::new(),
            x: Vec::new(),
            y: Vec::new(),
            n_preceding: Vec::new(),
        }
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.t0.len()
    }

    /// Whether there are no windows.
    pub fn is_empty(&self) -> bool {
        self.t0.is_empty()
    }

    /// A borrowed view, checked as [`WindowsView::new`] checks one (`O(spikes)`): the fields
    /// are public, so windows edited or built outside this module may be inconsistent.
    ///
    /// # Errors
    ///
    /// As [`WindowsView::new`].
    pub fn view(&self) -> Result<WindowsView<'_>> {
        WindowsView::new(
            self.sensor,
            self.length_us,
            &self.t0,
            &self.offsets,
            &self.t,
            &self.x,
            &self.y,
        )
    }
}

/// Borrowed windows, always consistent: the only way to make one is [`WindowsView::new`] (or
/// [`Windows::view`]), which checks the columns, so that [`frames`] and [`add_noise`] can trust
/// them. The fields are read through accessors.
#[derive(Debug, Clone, Copy)]
pub struct WindowsView<'a> {
    sensor: SensorSize,
    length_us: u64,
    t0: &'a [u64],
    offsets: &'a [usize],
    t: &'a [u64],
    x: &'a [u16],
    y: &'a [u16],
}

impl<'a> WindowsView<'a> {
    /// Check that the columns describe valid windows: the sensor has no zero side
    /// ([`SensorSize::validate`]); `offsets` starts at 0, never decreases and ends at the
    /// number of spikes (all checked before any spike is read); every window start is at most
    /// [`MAX_TIME_US`] (so `t0 + length_us` cannot overflow); every spike lies on the sensor
    /// and inside its window, and spikes are sorted by time within each window.
    pub fn new(
        sensor: SensorSize,
        length_us: u64,
        t0: &'a [u64],
        offsets: &'a [usize],
        t: &'a [u64],
        x: &'a [u16],
        y: &'a [u16],
    ) -> Result<Self> {
        sensor.validate()?;
        if length_us == 0 || length_us > MAX_TIME_US {
            return Err(Error::param(
                "length_us",
                format!("must be in [1, 2^62] µs, got {length_us}"),
            ));
        }
        if offsets.len() != t0.len() + 1 {
            return Err(Error::Shape {
                name: "offsets",
                expected: format!("{} entries (windows + 1)", t0.len() + 1),
                got: format!("{}", offsets.len()),
            });
        }
        if t.len() != x.len() || t.len() != y.len() {
            return Err(Error::Shape {
                name: "t, x, y",
                expected: "three columns of equal length".into(),
                got: format!("{}, {}, {}", t.len(), x.len(), y.len()),
            });
        }
        if offsets[0] != 0 || offsets[offsets.len() - 1] != t.len() {
            return Err(Error::Shape {
                name: "offsets",
                expected: format!("to run from 0 to {} (the number of spikes)", t.len()),
                got: format!("{} .. {}", offsets[0], offsets[offsets.len() - 1]),
            });
        }
        // Every offset is checked before any spike is read: with the ends at 0 and `t.len()`,
        // non-decreasing offsets all lie in `0..=t.len()`.
        if let Some(i) = (1..offsets.len()).find(|&i| offsets[i] < offsets[i - 1]) {
            return Err(Error::Shape {
                name: "offsets",
                expected: "non-decreasing values".into(),
                got: format!(
                    "offsets[{}]={} > offsets[{i}]={}",
                    i - 1,
                    offsets[i - 1],
                    offsets[i]
                ),
            });
        }
        if let Some((i, &start)) = t0.iter().enumerate().find(|(_, &s)| s > MAX_TIME_US) {
            return Err(Error::param(
                "t0",
                format!(
                    "window starts must be at most 2^62 µs (MAX_TIME_US), so that \
                     t0 + length_us fits; t0[{i}] is {start}"
                ),
            ));
        }
        for (i, pair) in offsets.windows(2).enumerate() {
            let start = t0[i];
            for j in pair[0]..pair[1] {
                if !sensor.contains(x[j], y[j]) {
                    return Err(Error::InvalidEvent {
                        index: j,
                        reason: format!(
                            "spike (x={}, y={}) of window {i} is outside the {}x{} sensor",
                            x[j], y[j], sensor.width, sensor.height
                        ),
                    });
                }
                if j > pair[0] && t[j] < t[j - 1] {
                    return Err(Error::InvalidEvent {
                        index: j,
                        reason: format!(
                            "spike t={} of window {i} comes before the previous spike (t={})",
                            t[j],
                            t[j - 1]
                        ),
                    });
                }
                if t[j] < start || t[j] - start >= length_us {
                    return Err(Error::InvalidEvent {
                        index: j,
                        reason: format!(
                            "spike t={} of window {i} is outside [{start}, {start} + {length_us})",
                            t[j]
                        ),
                    });
                }
            }
        }
        Ok(Self {
            sensor,
            length_us,
            t0,
            offsets,
            t,
            x,
            y,
        })
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.t0.len()
    }

    /// Whether there are no windows.
    pub fn is_empty(&self) -> bool {
        self.t0.is_empty()
    }

    /// Sensor the coordinates refer to.
    pub fn sensor(&self) -> SensorSize {
        self.sensor
    }

    /// Window length `L` in µs.
    pub fn length_us(&self) -> u64 {
        self.length_us
    }

    /// Window starts, `(n,)`.
    pub fn t0(&self) -> &'a [u64] {
        self.t0
    }

    /// Window `i`'s spikes are `offsets[i]..offsets[i + 1]`, `(n + 1,)`.
    pub fn offsets(&self) -> &'a [usize] {
        self.offsets
    }

    /// Spike times.
    pub fn t(&self) -> &'a [u64] {
        self.t
    }

    /// Spike columns.
    pub fn x(&self) -> &'a [u16] {
        self.x
    }

    /// Spike rows.
    pub fn y(&self) -> &'a [u16] {
        self.y
    }

    /// The index range of window `i < len()`'s spikes in the columns.
    pub(crate) fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }
}

/// The arithmetic of window starts: `t0(k) = start + k·step` for `k < n`.
#[derive(Debug, Clone, Copy)]
struct Grid {
    start: u64,
    step: u64,
    length: u64,
    n: usize,
}

impl Grid {
    #[inline]
    fn t0(self, k: usize) -> u64 {
        self.start + k as u64 * self.step
    }
}

/// Cut `events` (sorted by time, on `sensor`) into windows.
///
/// The events are validated first (sorted, on the sensor, times ≤ [`MAX_TIME_US`]). An empty
/// stream gives no windows unless both `start_us` and `end_us` are given, in which case it gives
/// the empty windows of that range.
///
/// # Errors
///
/// [`Error::InvalidParameter`]: `sensor_size` for a sensor with a zero side
/// ([`SensorSize::validate`]) or one above the memory cap, or the config's field out of range;
/// [`Error::InvalidEvent`] for an event off the sensor, out of order or beyond
/// [`MAX_TIME_US`].
pub fn make_windows<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    config: &WindowConfig,
) -> Result<Windows> {
    sensor.validate()?;
    if config.length_us == 0 || config.length_us > MAX_TIME_US {
        return Err(Error::param(
            "length_us",
            format!("must be in [1, 2^62] µs, got {}", config.length_us),
        ));
    }
    let step = config.step_us;
    if step == 0 || step > config.length_us {
        return Err(Error::param(
            "step_us",
            format!("must be in [1, {}], got {step}", config.length_us),
        ));
    }
    validate_source(events, sensor, None, 0)?;
    let first = (!events.is_empty()).then(|| events.get(0));
    let last = (!events.is_empty()).then(|| events.get(events.len() - 1));
    if let Some(last) = last {
        if last.t > MAX_TIME_US {
            return Err(Error::InvalidEvent {
                index: events.len() - 1,
                reason: format!(
                    "t={} is beyond the largest time windowing accepts (2^62 µs)",
                    last.t
                ),
            });
        }
    }
    for (name, value) in [("start_us", config.start_us), ("end_us", config.end_us)] {
        if value.is_some_and(|v| v > MAX_TIME_US) {
            return Err(Error::param(
                name,
                format!("must be at most 2^62 µs, got {value:?}"),
            ));
        }
    }
    let Some(start) = config.start_us.or(first.map(|e| e.t)) else {
        return Ok(Windows::empty(sensor, config.length_us));
    };
    let end = match config.end_us {
        Some(end) if end < start => {
            return Err(Error::param(
                "end_us",
                format!("must not be before start_us={start}, got {end}"),
            ))
        }
        Some(end) => end,
        None => last.map_or(start, |e| (e.t + 1).max(start)),
    };
    let n = (end - start).div_ceil(step);
    if n > MAX_WINDOWS as u64 {
        return Err(Error::param(
            "length_us",
            format!(
                "{n} windows of step {step} µs over [{start}, {end}) exceed the limit of \
                 {MAX_WINDOWS}; check the time unit, or window a shorter range"
            ),
        ));
    }
    let grid = Grid {
        start,
        step,
        length: config.length_us,
        n: n as usize,
    };
    // Each run of windows keeps up to 16 bytes a pixel (first-spike tables, median marks).
    check_alloc(
        "sensor_size",
        || format!("windowing a {}x{} sensor", sensor.width, sensor.height),
        sensor.area(),
        16,
    )?;
    let runs = plan_runs(grid.n, events.len());
    if step == config.length_us {
        build_disjoint(events, sensor, grid, end, config.median, &runs)
    } else {
        build(events, sensor, grid, end, config.median, &runs)
    }
}

#[cfg(test)]
mod tests;
