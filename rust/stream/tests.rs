//! The detector's scheduling, input spikes, PENT estimate and validation, checked against a
//! brute-force reading of docs/model.md §1 and §4 and against the batch path's `make_windows`,
//! through an engine that reports every input spike it receives.

use std::cell::Cell;

use proptest::prelude::*;

use super::*;
use crate::error::Error;
use crate::events::{Event, SensorSize};
use crate::windows::{make_windows, WindowConfig};

const W: u16 = 5;
const H: u16 = 4;

/// Reports each input spike as a "detection": `map` = the window's PENT estimate, `row` = the
/// spike's offset from `t0`. Asserts the engine contract: times never decrease and one time is
/// settled before a later one is pushed.
struct Echo {
    states_made: Cell<usize>,
}

#[derive(Default)]
struct EchoState {
    t0: u64,
    n_in: u64,
    pending: Vec<(u64, u16, u16)>,
    settled_t: Option<u64>,
}

impl WindowEngine for Echo {
    type State = EchoState;

    fn sensor(&self) -> SensorSize {
        SensorSize::new(W, H).unwrap()
    }

    fn new_state(&self) -> EchoState {
        self.states_made.set(self.states_made.get() + 1);
        EchoState::default()
    }

    fn begin(&self, state: &mut EchoState, t0: u64, n_in: u64) {
        *state = EchoState {
            t0,
            n_in,
            ..EchoState::default()
        };
    }

    fn push(&self, state: &mut EchoState, t: u64, x: u16, y: u16) {
        if let Some(&(pending_t, _, _)) = state.pending.last() {
            assert_eq!(pending_t, t, "a later time was pushed before settling");
        }
        assert!(state.settled_t.map_or(true, |s| s < t), "time went back");
        state.pending.push((t, x, y));
    }

    fn settle(&self, state: &mut EchoState, out: &mut Vec<Detection>) {
        for (t, x, y) in state.pending.drain(..) {
            out.push(Detection {
                t,
                x,
                y,
                map: state.n_in as u16,
                row: (t - state.t0) as u16,
                ..Detection::default()
            });
            state.settled_t = Some(t);
        }
    }
}

fn echo() -> Echo {
    Echo {
        states_made: Cell::new(0),
    }
}

fn ev(t: u64, x: u16, y: u16) -> Event {
    Event { t, x, y, p: true }
}

fn config(window_us: u64, overlap: f64) -> StreamConfig {
    StreamConfig {
        window_us,
        overlap,
        start_us: None,
    }
}

/// docs/model.md §1 and §4 read literally: every window from the first event's time on, its
/// input spikes (each pixel's first event), and the distinct pixels active before it.
fn brute(events: &[Event], window_us: u64, overlap: f64) -> Vec<Detection> {
    let Some(first) = events.first() else {
        return Vec::new();
    };
    let last = events[events.len() - 1].t;
    let step = window_step(window_us, overlap).unwrap();
    let mut out = Vec::new();
    let mut k = 0;
    while first.t + k * step <= last {
        let t0 = first.t + k * step;
        let mut before: Vec<(u16, u16)> = events
            .iter()
            .filter(|e| e.t >= t0.saturating_sub(window_us) && e.t < t0)
            .map(|e| (e.x, e.y))
            .collect();
        before.sort_unstable();
        before.dedup();
        let mut fired = Vec::new();
        for e in events.iter().filter(|e| e.t >= t0 && e.t < t0 + window_us) {
            if !fired.contains(&(e.x, e.y)) {
                fired.push((e.x, e.y));
                out.push(Detection {
                    window: k,
                    t: e.t,
                    x: e.x,
                    y: e.y,
                    map: before.len() as u16,
                    row: (e.t - t0) as u16,
                    ..Detection::default()
                });
            }
        }
        k += 1;
    }
    out.sort_unstable();
    out
}

/// The batch path's windows (`make_windows`), reported the way [`Echo`] reports them.
fn batch(events: &[Event], window_us: u64, overlap: f64) -> Vec<Detection> {
    let sensor = SensorSize::new(W, H).unwrap();
    let config = WindowConfig::new(window_us, overlap).unwrap();
    let w = make_windows(events, sensor, &config).unwrap();
    let mut out = Vec::new();
    for i in 0..w.len() {
        for j in w.offsets[i]..w.offsets[i + 1] {
            out.push(Detection {
                window: i as u64,
                t: w.t[j],
                x: w.x[j],
                y: w.y[j],
                map: w.n_preceding[i] as u16,
                row: (w.t[j] - w.t0[i]) as u16,
                ..Detection::default()
            });
        }
    }
    out.sort_unstable();
    out
}

fn run(events: &[Event], cuts: &[usize], config: StreamConfig) -> (Vec<Detection>, usize) {
    let mut d = Detector::new(echo(), config).unwrap();
    let mut out = Vec::new();
    let mut from = 0;
    for &cut in cuts {
        let to = cut.clamp(from, events.len());
        d.push(&events[from..to], &mut out).unwrap();
        from = to;
    }
    d.push(&events[from..], &mut out).unwrap();
    d.flush(&mut out);
    let made = d.engine().states_made.get();
    assert!(d.states_allocated() <= made);
    out.sort_unstable();
    (out, made)
}

fn arb_events() -> impl Strategy<Value = Vec<Event>> {
    prop::collection::vec((0u64..6, 0..W, 0..H), 0..120).prop_map(|raw| {
        let mut t = 1000;
        raw.into_iter()
            .map(|(dt, x, y)| {
                t += dt * dt; // many equal times, some gaps
                ev(t, x, y)
            })
            .collect()
    })
}

proptest! {
    #[test]
    fn stream_equals_the_definition_whatever_the_chunking(
        events in arb_events(),
        cuts in prop::collection::vec(0usize..120, 0..12),
        window_us in 1u64..40,
        overlap in prop::sample::select(vec![0.0, 0.1, 0.5, 0.75, 0.9]),
    ) {
        let mut cuts = cuts;
        cuts.sort_unstable();
        let config = config(window_us, overlap);
        let (got, made) = run(&events, &cuts, config);
        prop_assert_eq!(&got, &brute(&events, window_us, overlap));
        prop_assert_eq!(&got, &batch(&events, window_us, overlap));
        let max_live = WindowSchedule::new(0, window_us, overlap).unwrap().max_live();
        prop_assert!(made <= max_live, "{} states for at most {} live windows", made, max_live);
    }
}

#[test]
fn detections_leave_as_soon_as_their_time_is_complete() {
    let mut d = Detector::new(echo(), config(100, 0.0)).unwrap();
    let mut out = Vec::new();
    d.push(&[ev(10, 1, 1), ev(10, 2, 2)], &mut out).unwrap();
    assert!(out.is_empty(), "t=10 may still receive events");
    d.push(&[ev(10, 3, 3)], &mut out).unwrap();
    assert!(out.is_empty());
    d.push(&[ev(11, 4, 3)], &mut out).unwrap();
    assert_eq!(out.len(), 3);
    assert!(out.iter().all(|o| o.t == 10 && o.window == 0));
    d.flush(&mut out);
    assert_eq!(out.len(), 4);
    assert_eq!(d.stats().detections, 4);
}

#[test]
fn windows_in_a_silent_gap_are_skipped_but_numbered() {
    let mut d = Detector::new(echo(), config(10, 0.5)).unwrap();
    let mut out = Vec::new();
    d.push(&[ev(0, 0, 0), ev(1_000_000, 1, 1)], &mut out)
        .unwrap();
    d.flush(&mut out);
    // Windows 0 (and none else) hold t=0; windows 199_999 and 200_000 hold t=1e6.
    let windows: Vec<u64> = out.iter().map(|o| o.window).collect();
    assert_eq!(windows, vec![0, 199_999, 200_000]);
    assert_eq!(d.stats().windows_opened, 3);
}

#[test]
fn a_given_start_places_window_zero() {
    let mut d = Detector::new(
        echo(),
        StreamConfig {
            start_us: Some(100),
            ..config(10, 0.0)
        },
    )
    .unwrap();
    let mut out = Vec::new();
    // Before the start: no window, but it counts for the first window's PENT estimate.
    d.push(&[ev(95, 0, 0), ev(96, 1, 0), ev(105, 2, 2)], &mut out)
        .unwrap();
    d.flush(&mut out);
    assert_eq!(out.len(), 1);
    assert_eq!((out[0].window, out[0].map, out[0].row), (0, 2, 5));
}

type IsExpected = fn(&Error) -> bool;

/// The state after a rejected chunk is the state before it: the rest of the stream gives what
/// it would have given without the bad chunk.
#[test]
fn bad_chunks_are_typed_errors_and_change_nothing() {
    let good_a = [ev(5, 0, 0), ev(7, 1, 1)];
    let good_b = [ev(9, 2, 2), ev(30, 3, 3)];
    let reference = {
        let mut d = Detector::new(echo(), config(10, 0.5)).unwrap();
        let mut out = Vec::new();
        d.push(&good_a, &mut out).unwrap();
        d.push(&good_b, &mut out).unwrap();
        d.flush(&mut out);
        (out, d.stats())
    };
    let bad: [(&[Event], IsExpected); 4] = [
        // Out of order inside the chunk.
        (&[ev(8, 0, 0), ev(7, 1, 0)], |e| {
            matches!(e, Error::InvalidEvent { index: 1, .. })
        }),
        // Earlier than the stream so far.
        (&[ev(6, 0, 0)], |e| matches!(e, Error::Stream(_))),
        // Outside the sensor, in x and in y.
        (&[ev(8, W, 0)], |e| {
            matches!(e, Error::InvalidEvent { index: 0, .. })
        }),
        (&[ev(8, 0, 0), ev(8, 0, H)], |e| {
            matches!(e, Error::InvalidEvent { index: 1, .. })
        }),
    ];
    for (chunk, is_expected) in bad {
        let mut d = Detector::new(echo(), config(10, 0.5)).unwrap();
        let mut out = Vec::new();
        d.push(&good_a, &mut out).unwrap();
        let stats = d.stats();
        let err = d.push(chunk, &mut out).unwrap_err();
        assert!(is_expected(&err), "{chunk:?}: {err}");
        assert_eq!(d.stats(), stats);
        assert_eq!(d.last_t(), Some(7));
        d.push(&good_b, &mut out).unwrap();
        d.flush(&mut out);
        assert_eq!((out, d.stats()), reference, "after {chunk:?}");
    }
}

#[test]
fn a_flushed_stream_refuses_events_until_reset() {
    let mut d = Detector::new(echo(), config(10, 0.0)).unwrap();
    let mut out = Vec::new();
    d.push(&[ev(5, 0, 0)], &mut out).unwrap();
    d.flush(&mut out);
    assert!(d.is_finished());
    assert!(matches!(
        d.push(&[ev(6, 0, 0)], &mut out),
        Err(Error::Stream(_))
    ));
    d.reset();
    let mut again = Vec::new();
    d.push(&[ev(1, 0, 0)], &mut again).unwrap();
    d.flush(&mut again);
    assert_eq!(again.len(), 1);
    assert_eq!((again[0].window, again[0].t), (0, 1));
}

#[test]
fn empty_chunks_are_fine_and_parameters_are_checked() {
    let mut d = Detector::new(echo(), config(10, 0.0)).unwrap();
    let mut out = Vec::new();
    d.push(&[], &mut out).unwrap();
    d.flush(&mut out);
    assert!(out.is_empty());
    assert!(Detector::new(echo(), config(0, 0.0)).is_err());
    assert!(Detector::new(echo(), config(10, 1.0)).is_err());
    assert!(Detector::new(echo(), config(10, f64::NAN)).is_err());
}

#[test]
fn a_long_stream_keeps_a_bounded_number_of_states() {
    let mut d = Detector::new(echo(), config(50, 0.9)).unwrap();
    let mut out = Vec::new();
    for t in 0..20_000u64 {
        d.push(&[ev(t, (t % 5) as u16, (t % 4) as u16)], &mut out)
            .unwrap();
        out.clear();
        assert!(d.states_allocated() <= 10);
    }
}
