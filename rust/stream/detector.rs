//! The streaming detector: events in, conv3 detections out, as soon as they are decided.
//!
//! Overlapping windows run as staggered network states: every window that holds the current
//! time has its own state, at most `ceil(L / step)` of them, recycled when a window ends. Each
//! event is an input spike of every live window in which its pixel has not fired yet (its first
//! event there, docs/model.md §1); whether it has is read from the pixel's previous event time,
//! which the PENT counter keeps anyway. A window's PENT estimate is taken when it opens: the
//! distinct pixels active in the `L` microseconds before it (the "preceding" estimate, §4); its
//! conv1 thresholds are set from it before its first spike goes in.
//!
//! Each chunk is read twice (a slice of at most [`PUSH_SLICE`] events at a time): in time order
//! to open windows, take their estimates and find every event's input spikes, then window by
//! window to run them, so that one network state stays in cache while it takes all its spikes
//! of the slice (the states of overlapping windows would otherwise evict each other at every
//! event).
//!
//! Spikes at one timestamp are decided together (§3), so a detection at time `t` leaves the
//! detector as soon as an event later than `t` arrives, or at [`Detector::flush`]: events of
//! time `t` may still come in the next chunk.

use std::collections::VecDeque;

use crate::error::{check_alloc, Error, Result};
use crate::events::{validate_source, Event, EventSource, SensorSize};
use crate::network::Detection;
use crate::windows::MAX_TIME_US;

use super::preceding::PrecedingCounter;
use super::schedule::{window_step, WindowSchedule};

/// A conv3 detection (docs/model.md §5) and the index of the window it fired in, counted from
/// the stream's first window (window `k` starts at `start + k·step`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamDetection {
    pub window: u64,
    pub detection: Detection,
}

/// What the detector needs from a network: one state per live window, fed the window's input
/// spikes in time order and settled one timestamp at a time.
pub trait WindowEngine {
    /// The state of one window (potentials, latches, box tracking...).
    type State;

    /// The input size the engine expects ([`Detector::new`] refuses one with a zero side,
    /// [`SensorSize::validate`]).
    fn sensor(&self) -> Result<SensorSize>;

    /// A fresh state; states are reused through [`WindowEngine::begin`].
    fn new_state(&self) -> Self::State;

    /// Bytes one state takes (a detector holds one per live window), for the memory cap
    /// [`Detector::new`] checks; 0 for states too small to count.
    fn state_bytes(&self) -> usize {
        0
    }

    /// Start a window at `t0` whose PENT estimate is `n_in` input spikes.
    fn begin(&self, state: &mut Self::State, t0: u64, n_in: u64) -> Result<()>;

    /// Add one input spike. Its time is at least that of the previous spike; spikes of one
    /// time arrive together, and that time is settled before a later one is pushed.
    fn push(&self, state: &mut Self::State, t: u64, x: u16, y: u16) -> Result<()>;

    /// Every input spike up to the time of the last push has arrived: decide the crossings at
    /// that time through the whole network and append the conv3 spikes it causes.
    fn settle(&self, state: &mut Self::State, out: &mut Vec<Detection>) -> Result<()>;
}

/// The most windows a stream may hold live at once, `ceil(L / step)`: each holds a network state
/// (`Geometry::state_bytes`: 1.7 MiB for Table 1's layers on a 240×180 sensor, 35 MiB on
/// 1280×720), so an overlap of 0.9999 would need ten thousand of them. With `step = L·(1 − o)` this allows overlaps up to `1 − 1/64 ≈ 0.984`.
pub const MAX_LIVE_WINDOWS: u64 = 64;

/// Events a push reads at a time. A larger chunk is checked whole first, then run in slices of
/// this many, so that the input spikes it holds (one record per event) take at most about
/// 2 MB whatever the chunk's size; the detections are the same (the detector's output does
/// not depend on how a stream is cut into chunks).
pub const PUSH_SLICE: usize = 1 << 16;

/// Window length, overlap and (optionally) the first window's start.
///
/// The default is the Python package's (`uavsnn.provenance.DEFAULT_WINDOW_US` and
/// `DEFAULT_OVERLAP`, its `Detector`'s windows for a model that records none): windows of
/// 50 ms (`window_us: 50_000`) overlapping by half (`overlap: 0.5`), from the first event
/// (`start_us: None`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamConfig {
    /// Window length `L` in microseconds.
    pub window_us: u64,
    /// Overlap `o ∈ [0, 1)` between consecutive windows.
    pub overlap: f64,
    /// Start of window 0; `None` for the first event's time.
    pub start_us: Option<u64>,
}

impl Default for StreamConfig {
    /// 50 ms windows overlapping by half from the first event, as in the Python package.
    fn default() -> Self {
        Self {
            window_us: 50_000,
            overlap: 0.5,
            start_us: None,
        }
    }
}

/// Counters kept by the detector.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StreamStats {
    /// Events accepted.
    pub events: u64,
    /// Windows that received a state (windows lying wholly in a silent gap are skipped).
    pub windows_opened: u64,
    /// Detections returned.
    pub detections: u64,
}

struct LiveWindow<S> {
    index: u64,
    t0: u64,
    end: u64,
    /// PENT's estimate, taken when the window opened.
    n_in: u64,
    /// Begun lazily, at the window's first input spike.
    state: Option<S>,
    /// Time of the spikes pushed and not settled yet.
    pending_t: Option<u64>,
}

/// An input spike of the current chunk, and the windows `first..=last` it is the first
/// spike of.
#[derive(Debug, Clone, Copy)]
struct ChunkSpike {
    t: u64,
    x: u16,
    y: u16,
    first: u64,
    last: u64,
}

/// Streaming detection over any [`WindowEngine`].
pub struct Detector<E: WindowEngine> {
    engine: E,
    sensor: SensorSize,
    config: StreamConfig,
    step: u64,
    schedule: Option<WindowSchedule>,
    counter: PrecedingCounter,
    live: VecDeque<LiveWindow<E::State>>,
    spare: Vec<E::State>,
    next_window: u64,
    last_t: Option<u64>,
    finished: bool,
    stats: StreamStats,
    spikes: Vec<ChunkSpike>,
    scratch: Vec<Detection>,
}

impl<E: WindowEngine> Detector<E> {
    /// A detector running `engine` over windows of `config`.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] for a window length or overlap out of range (or an overlap
    /// keeping more than [`MAX_LIVE_WINDOWS`] windows live), a start beyond 2^62 µs, or
    /// `sensor_size` when the engine's sensor has a zero side ([`SensorSize::validate`]) or its
    /// per-pixel memory is above the cap; what [`WindowEngine::sensor`] returns.
    pub fn new(engine: E, config: StreamConfig) -> Result<Self> {
        let step = window_step(config.window_us, config.overlap)?;
        let live = config.window_us.div_ceil(step);
        if live > MAX_LIVE_WINDOWS {
            return Err(Error::param(
                "overlap",
                format!(
                    "an overlap of {} keeps {live} windows live at once (window {} µs, step \
                     {step} µs); at most {MAX_LIVE_WINDOWS} are allowed, an overlap of at most \
                     {:.4}",
                    config.overlap,
                    config.window_us,
                    1.0 - 1.0 / MAX_LIVE_WINDOWS as f64
                ),
            ));
        }
        if let Some(start) = config.start_us.filter(|&s| s > MAX_TIME_US) {
            return Err(Error::param(
                "start_us",
                format!("must be at most 2^62 µs, got {start}"),
            ));
        }
        // Each live window holds a state: their sum is one request the overlap sizes.
        check_alloc(
            "overlap",
            || {
                format!(
                    "the network states of {live} live windows (an overlap of {})",
                    config.overlap
                )
            },
            usize::try_from(live).unwrap_or(usize::MAX),
            engine.state_bytes(),
        )?;
        let sensor = engine.sensor()?.validate()?;
        // The counter keeps 8 bytes a pixel and queues up to two 16-byte entries a pixel.
        check_alloc(
            "sensor_size",
            || {
                format!(
                    "a stream's per-pixel memory on a {}x{} sensor",
                    sensor.width, sensor.height
                )
            },
            sensor.area(),
            8 + 2 * 16,
        )?;
        Ok(Self {
            counter: PrecedingCounter::new(sensor.area(), config.window_us)?,
            engine,
            sensor,
            config,
            step,
            schedule: None,
            live: VecDeque::new(),
            spare: Vec::new(),
            next_window: 0,
            last_t: None,
            finished: false,
            stats: StreamStats::default(),
            spikes: Vec::new(),
            scratch: Vec::new(),
        })
    }

    /// The engine.
    pub fn engine(&self) -> &E {
        &self.engine
    }

    /// The sensor size events are checked against.
    pub fn sensor(&self) -> SensorSize {
        self.sensor
    }

    /// Window length, overlap and start.
    pub fn config(&self) -> StreamConfig {
        self.config
    }

    /// Microseconds between window starts.
    pub fn step_us(&self) -> u64 {
        self.step
    }

    /// The window schedule, once the first window's start is known.
    pub fn schedule(&self) -> Option<WindowSchedule> {
        self.schedule
    }

    /// Counters so far.
    pub fn stats(&self) -> StreamStats {
        self.stats
    }

    /// Time of the last event accepted.
    pub fn last_t(&self) -> Option<u64> {
        self.last_t
    }

    /// Windows holding a network state now.
    pub fn live_windows(&self) -> usize {
        self.live.len()
    }

    /// Input-spike records the detector holds room for: at most [`PUSH_SLICE`].
    #[cfg(test)]
    pub(super) fn spike_capacity(&self) -> usize {
        self.spikes.capacity()
    }

    /// Network states allocated (live and spare): bounded by `ceil(L / step)`.
    pub fn states_allocated(&self) -> usize {
        self.live.iter().filter(|w| w.state.is_some()).count() + self.spare.len()
    }

    /// Whether [`Detector::flush`] ended the stream.
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// Check a chunk against the sensor, its own order and the stream so far, changing nothing.
    pub fn check<S: EventSource + ?Sized>(&self, events: &S) -> Result<()> {
        if self.finished {
            return Err(Error::Stream(
                "the stream was flushed; call reset() before pushing more events".into(),
            ));
        }
        validate_source(events, self.sensor, None, 0)?;
        let Some(n) = events.len().checked_sub(1) else {
            return Ok(());
        };
        let first = events.get(0);
        if events.get(n).t > MAX_TIME_US {
            // The chunk is in time order: the first event past the limit, by bisection.
            let (mut lo, mut hi) = (0, n);
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if events.get(mid).t > MAX_TIME_US {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            return Err(Error::InvalidEvent {
                index: lo,
                reason: format!(
                    "t={} is beyond the largest time streamed (2^62 µs)",
                    events.get(lo).t
                ),
            });
        }
        if let Some(previous) = self.last_t.filter(|&p| first.t < p) {
            return Err(Error::Stream(format!(
                "time goes backwards across chunks: this chunk starts at t={} but the stream \
                 is already at t={previous}",
                first.t
            )));
        }
        Ok(())
    }

    /// Feed a chunk of events (any size, in time order, not earlier than the previous chunk)
    /// and append the detections it decides to `out`, in time order. A bad chunk is rejected
    /// whole, before anything changes. (An error from the engine itself after that would be a
    /// bug: [`Error::Internal`] territory.)
    ///
    /// The chunk is read in two passes: first in time order, to open windows, take their PENT
    /// estimates and find each event's input spikes; then window by window, so that one
    /// window's network state stays hot in cache while it takes all its spikes of the chunk; a
    /// chunk of more than [`PUSH_SLICE`] events is read so a slice at a time, after the whole of
    /// it was checked. `events` may be a slice of [`Event`]s or packed records
    /// ([`crate::events::PackedEvents`]), read in place.
    pub fn push<S: EventSource + ?Sized>(
        &mut self,
        events: &S,
        out: &mut Vec<StreamDetection>,
    ) -> Result<()> {
        self.push_while(events, out, || true).map(|_| ())
    }

    /// [`push`](Self::push), asking `go_on` after each slice of [`PUSH_SLICE`] events whether
    /// to read the next (a caller that must stay responsive, to Ctrl-C say). Returns whether
    /// the whole chunk was read: when `go_on` stops it, the slices before are read and their
    /// detections appended, the rest is not, and the stream stands part way through the
    /// chunk (the caller decides whether to go on from there, or to reset it).
    ///
    /// # Errors
    ///
    /// As [`push`](Self::push).
    pub fn push_while<S: EventSource + ?Sized>(
        &mut self,
        events: &S,
        out: &mut Vec<StreamDetection>,
        mut go_on: impl FnMut() -> bool,
    ) -> Result<bool> {
        self.check(events)?;
        let before = out.len();
        let mut result = Ok(());
        let mut from = 0;
        while from < events.len() && result.is_ok() {
            if from > 0 && !go_on() {
                break;
            }
            let to = events.len().min(from + PUSH_SLICE);
            self.spikes.clear();
            for i in from..to {
                self.schedule_event(&events.get(i));
            }
            result = self.run_windows(events.get(to - 1).t, out);
            from = to;
        }
        self.emitted(out, before);
        result.map(|()| from >= events.len())
    }

    /// The stream has reached time `t` without more events: a promise (a watermark) that
    /// every event still to come is at or after `t`. Decides what a later event would decide —
    /// the timestamps before `t`, and the windows that end by `t` — and appends those
    /// detections to `out`, so that a quiet stream's last windows need not wait for its next
    /// event. The detections are those the stream gives without the call, only sooner; a chunk
    /// that starts before `t` is refused afterwards.
    ///
    /// # Errors
    ///
    /// [`Error::Stream`] when the stream was flushed or is already past `t`;
    /// [`Error::InvalidEvent`] for a `t` beyond 2^62 µs. Nothing changes then.
    pub fn advance(&mut self, t: u64, out: &mut Vec<StreamDetection>) -> Result<()> {
        if self.finished {
            return Err(Error::Stream(
                "the stream was flushed; call reset() before advancing it".into(),
            ));
        }
        if t > MAX_TIME_US {
            return Err(Error::InvalidEvent {
                index: 0,
                reason: format!("t={t} is beyond the largest time streamed (2^62 µs)"),
            });
        }
        if let Some(previous) = self.last_t.filter(|&p| t < p) {
            return Err(Error::Stream(format!(
                "cannot advance to t={t}: the stream is already at t={previous}"
            )));
        }
        let before = out.len();
        self.spikes.clear();
        let result = self.run_windows(t, out);
        self.emitted(out, before);
        self.last_t = Some(t);
        result
    }

    /// End of the stream: settle the last timestamp, close every window and append the
    /// remaining detections, in time order as a push appends them. Later pushes fail until
    /// [`Detector::reset`].
    pub fn flush(&mut self, out: &mut Vec<StreamDetection>) -> Result<()> {
        if self.finished {
            return Ok(());
        }
        let before = out.len();
        let mut result = Ok(());
        for w in &mut self.live {
            if result.is_ok() {
                result = settle(&self.engine, w, &mut self.scratch, out);
            }
        }
        self.release_all();
        self.finished = true;
        self.emitted(out, before);
        result
    }

    /// Forget the stream (keeping allocations): the next event starts a new one.
    pub fn reset(&mut self) {
        self.release_all();
        self.counter.clear();
        self.schedule = None;
        self.next_window = 0;
        self.last_t = None;
        self.finished = false;
        self.stats = StreamStats::default();
    }

    /// Put the detections appended to `out` since `before` in time order and count them.
    fn emitted(&mut self, out: &mut [StreamDetection], before: usize) {
        // Stable: one window's detections of one time stay in firing order.
        out[before..].sort_by_key(|d| (d.detection.t, d.window));
        self.stats.detections += (out.len() - before) as u64;
    }

    fn release_all(&mut self) {
        while let Some(w) = self.live.pop_front() {
            self.spare.extend(w.state);
        }
    }

    /// First pass, in time order: open the windows that start by `e.t` (their PENT estimate is
    /// read now, before `e` is counted) and record `e` as an input spike of the live windows
    /// in which its pixel has not fired yet.
    fn schedule_event(&mut self, e: &Event) {
        let schedule = *self.schedule.get_or_insert_with(|| {
            WindowSchedule::with_step(
                self.config.start_us.unwrap_or(e.t),
                self.config.window_us,
                self.step,
            )
        });
        let live = schedule.live_at(e.t);
        if let Some(range) = &live {
            // Windows lying wholly in a silent gap (before `range.start()`) are skipped.
            for index in self.next_window.max(*range.start())..=*range.end() {
                let t0 = schedule.start_of(index);
                self.live.push_back(LiveWindow {
                    index,
                    t0,
                    end: schedule.end_of(index),
                    n_in: self.counter.count_valid(t0) as u64,
                    state: None,
                    pending_t: None,
                });
                self.stats.windows_opened += 1;
            }
            self.next_window = self.next_window.max(range.end() + 1);
        }
        let previous = self.counter.push_valid(e.t, self.sensor.index(e.x, e.y));
        if let Some(range) = live {
            // The pixel's first event in window k when it has not fired since t0(k).
            let first = previous.map_or(*range.start(), |p| {
                schedule.first_starting_after(p).max(*range.start())
            });
            if first <= *range.end() {
                self.spikes.push(ChunkSpike {
                    t: e.t,
                    x: e.x,
                    y: e.y,
                    first,
                    last: *range.end(),
                });
            }
        }
        self.last_t = Some(e.t);
        self.stats.events += 1;
    }

    /// Second pass, window by window: feed each live window its spikes of the chunk, settling
    /// every timestamp that the chunk shows complete (a later event exists), and recycle the
    /// windows that the chunk has passed.
    fn run_windows(&mut self, chunk_end: u64, out: &mut Vec<StreamDetection>) -> Result<()> {
        let Self {
            engine,
            live,
            spare,
            spikes,
            scratch,
            ..
        } = self;
        for w in live.iter_mut() {
            let from = spikes.partition_point(|s| s.t < w.t0);
            let to = spikes.partition_point(|s| s.t < w.end);
            for s in &spikes[from..to] {
                if s.first > w.index || w.index > s.last {
                    continue;
                }
                if w.pending_t.is_some_and(|p| s.t > p) {
                    settle(engine, w, scratch, out)?;
                }
                let state = if let Some(state) = &mut w.state {
                    state
                } else {
                    let mut state = spare.pop().unwrap_or_else(|| engine.new_state());
                    engine.begin(&mut state, w.t0, w.n_in)?;
                    w.state.insert(state)
                };
                engine.push(state, s.t, s.x, s.y)?;
                w.pending_t = Some(s.t);
            }
            if w.pending_t.is_some_and(|p| chunk_end > p) {
                settle(engine, w, scratch, out)?;
            }
            if w.end <= chunk_end {
                // The stream has passed this window: its state goes to the next one.
                spare.extend(w.state.take());
            }
        }
        while live.front().is_some_and(|w| w.end <= chunk_end) {
            live.pop_front();
        }
        Ok(())
    }
}

/// Decide a window's pending timestamp and append the detections it makes.
fn settle<E: WindowEngine>(
    engine: &E,
    w: &mut LiveWindow<E::State>,
    scratch: &mut Vec<Detection>,
    out: &mut Vec<StreamDetection>,
) -> Result<()> {
    let (Some(state), Some(_)) = (w.state.as_mut(), w.pending_t.take()) else {
        return Ok(());
    };
    scratch.clear();
    engine.settle(state, scratch)?;
    out.extend(scratch.iter().map(|&detection| StreamDetection {
        window: w.index,
        detection,
    }));
    Ok(())
}
