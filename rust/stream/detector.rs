//! The streaming detector: events in, conv3 detections out, as soon as they are decided.
//!
//! Overlapping windows run as staggered network states: every window that holds the current
//! time has its own state, at most `ceil(L / step)` of them, recycled when a window ends. Each
//! event is an input spike of every live window in which its pixel has not fired yet (its first
//! event there, docs/model.md §1); whether it has is read from the pixel's previous event time,
//! which the PENT counter keeps anyway. A window's PENT threshold is set when it opens, from the
//! distinct pixels active in the `L` microseconds before it (the "preceding" estimate, §4).
//!
//! Spikes at one timestamp are decided together (§3), so a detection at time `t` leaves the
//! detector as soon as an event later than `t` arrives, or at [`Detector::flush`]: events of
//! time `t` may still come in the next chunk.

use std::collections::VecDeque;

use crate::error::{Error, Result};
use crate::events::{validate, Event, SensorSize};
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

    /// The input size the engine expects.
    fn sensor(&self) -> Result<SensorSize>;

    /// A fresh state; states are reused through [`WindowEngine::begin`].
    fn new_state(&self) -> Self::State;

    /// Start a window at `t0` whose PENT estimate is `n_in` input spikes.
    fn begin(&self, state: &mut Self::State, t0: u64, n_in: u64) -> Result<()>;

    /// Add one input spike. Its time is at least that of the previous spike; spikes of one
    /// time arrive together, and that time is settled before a later one is pushed.
    fn push(&self, state: &mut Self::State, t: u64, x: u16, y: u16) -> Result<()>;

    /// Every input spike up to the time of the last push has arrived: decide the crossings at
    /// that time through the whole network and append the conv3 spikes it causes.
    fn settle(&self, state: &mut Self::State, out: &mut Vec<Detection>) -> Result<()>;
}

/// Window length, overlap and (optionally) the first window's start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamConfig {
    /// Window length `L` in microseconds.
    pub window_us: u64,
    /// Overlap `o ∈ [0, 1)` between consecutive windows.
    pub overlap: f64,
    /// Start of window 0; `None` for the first event's time.
    pub start_us: Option<u64>,
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
    state: S,
    /// Received a spike at the current time that is not settled yet.
    unsettled: bool,
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
    scratch: Vec<Detection>,
}

impl<E: WindowEngine> Detector<E> {
    /// A detector running `engine` over windows of `config`.
    pub fn new(engine: E, config: StreamConfig) -> Result<Self> {
        let step = window_step(config.window_us, config.overlap)?;
        if let Some(start) = config.start_us.filter(|&s| s > MAX_TIME_US) {
            return Err(Error::param(
                "start_us",
                format!("must be at most 2^62 µs, got {start}"),
            ));
        }
        let sensor = engine.sensor()?;
        Ok(Self {
            counter: PrecedingCounter::new(sensor.area(), config.window_us),
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

    /// Network states allocated (live and spare): bounded by `ceil(L / step)`.
    pub fn states_allocated(&self) -> usize {
        self.live.len() + self.spare.len()
    }

    /// Whether [`Detector::flush`] ended the stream.
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// Check a chunk against the sensor, its own order and the stream so far, changing nothing.
    pub fn check(&self, events: &[Event]) -> Result<()> {
        if self.finished {
            return Err(Error::Stream(
                "the stream was flushed; call reset() before pushing more events".into(),
            ));
        }
        validate(events, self.sensor, None, 0)?;
        if let Some(last) = events.last().filter(|e| e.t > MAX_TIME_US) {
            return Err(Error::InvalidEvent {
                index: events.len() - 1,
                reason: format!("t={} is beyond the largest time streamed (2^62 µs)", last.t),
            });
        }
        if let (Some(first), Some(last)) = (events.first(), self.last_t) {
            if first.t < last {
                return Err(Error::Stream(format!(
                    "time goes backwards across chunks: this chunk starts at t={} but the \
                     stream is already at t={last}",
                    first.t
                )));
            }
        }
        Ok(())
    }

    /// Feed a chunk of events (any size, in time order, not earlier than the previous chunk)
    /// and append the detections it decides to `out`. A bad chunk is rejected whole, before
    /// anything changes. (An error from the engine itself after that would be a bug:
    /// [`Error::Internal`] territory.)
    pub fn push(&mut self, events: &[Event], out: &mut Vec<StreamDetection>) -> Result<()> {
        self.check(events)?;
        let before = out.len();
        let result = events.iter().try_for_each(|e| self.accept(e, out));
        self.stats.detections += (out.len() - before) as u64;
        result
    }

    /// End of the stream: settle the last timestamp, close every window and append the
    /// remaining detections. Later pushes fail until [`Detector::reset`].
    pub fn flush(&mut self, out: &mut Vec<StreamDetection>) -> Result<()> {
        if self.finished {
            return Ok(());
        }
        let before = out.len();
        let result = self.settle(out);
        while let Some(w) = self.live.pop_front() {
            self.spare.push(w.state);
        }
        self.finished = true;
        self.stats.detections += (out.len() - before) as u64;
        result
    }

    /// Forget the stream (keeping allocations): the next event starts a new one.
    pub fn reset(&mut self) {
        while let Some(w) = self.live.pop_front() {
            self.spare.push(w.state);
        }
        self.counter.clear();
        self.schedule = None;
        self.next_window = 0;
        self.last_t = None;
        self.finished = false;
        self.stats = StreamStats::default();
    }

    fn accept(&mut self, e: &Event, out: &mut Vec<StreamDetection>) -> Result<()> {
        let schedule = *self.schedule.get_or_insert_with(|| {
            WindowSchedule::with_step(
                self.config.start_us.unwrap_or(e.t),
                self.config.window_us,
                self.step,
            )
        });
        if self.last_t.is_some_and(|last| e.t > last) {
            self.settle(out)?;
        }
        while self.live.front().is_some_and(|w| w.end <= e.t) {
            if let Some(w) = self.live.pop_front() {
                self.spare.push(w.state);
            }
        }
        if let Some(range) = schedule.live_at(e.t) {
            let first = self.next_window.max(*range.start());
            for index in first..=*range.end() {
                self.open(&schedule, index)?;
            }
            self.next_window = self.next_window.max(range.end() + 1);
        }
        let previous = self.counter.push(e.t, self.sensor.index(e.x, e.y));
        for w in &mut self.live {
            // The pixel's first event in this window: it has not fired since the window opened.
            if previous.map_or(true, |p| p < w.t0) {
                self.engine.push(&mut w.state, e.t, e.x, e.y)?;
                w.unsettled = true;
            }
        }
        self.last_t = Some(e.t);
        self.stats.events += 1;
        Ok(())
    }

    fn open(&mut self, schedule: &WindowSchedule, index: u64) -> Result<()> {
        let t0 = schedule.start_of(index);
        let n_in = self.counter.count_before(t0) as u64;
        let mut state = self.spare.pop().unwrap_or_else(|| self.engine.new_state());
        self.engine.begin(&mut state, t0, n_in)?;
        self.live.push_back(LiveWindow {
            index,
            t0,
            end: schedule.end_of(index),
            state,
            unsettled: false,
        });
        self.stats.windows_opened += 1;
        Ok(())
    }

    fn settle(&mut self, out: &mut Vec<StreamDetection>) -> Result<()> {
        for w in &mut self.live {
            if w.unsettled {
                w.unsettled = false;
                self.scratch.clear();
                self.engine.settle(&mut w.state, &mut self.scratch)?;
                out.extend(self.scratch.iter().map(|&detection| StreamDetection {
                    window: w.index,
                    detection,
                }));
            }
        }
        Ok(())
    }
}
