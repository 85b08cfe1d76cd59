//! The detector's scheduling, input spikes, PENT estimate and validation, checked against a
//! brute-force reading of docs/model.md §1 and §4 and against the batch path's `make_windows`,
//! through an engine that reports every input spike it receives.

use std::cell::Cell;

use proptest::prelude::*;

use super::*;
use crate::error::{Error, Result};
use crate::events::{Event, EventSource, PackedEvents, SensorSize, PACKED_EVENT_SIZE};
use crate::network::{infer, Detection, Network, NetworkConfig, PentEstimate, Spikes, WindowBatch};
use crate::windows::{make_windows, WindowConfig};

const W: u16 = 5;
const H: u16 = 4;

/// Reports each input spike as a "detection" at its pixel (`x0`, `y0`): `map` = the window's
/// PENT estimate, `row` = the spike's offset from `t0`. Asserts the engine contract: times never decrease and one time is
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

    fn sensor(&self) -> Result<SensorSize> {
        SensorSize::new(W, H)
    }

    fn new_state(&self) -> EchoState {
        self.states_made.set(self.states_made.get() + 1);
        EchoState::default()
    }

    fn begin(&self, state: &mut EchoState, t0: u64, n_in: u64) -> Result<()> {
        *state = EchoState {
            t0,
            n_in,
            ..EchoState::default()
        };
        Ok(())
    }

    fn push(&self, state: &mut EchoState, t: u64, x: u16, y: u16) -> Result<()> {
        if let Some(&(pending_t, _, _)) = state.pending.last() {
            assert_eq!(pending_t, t, "a later time was pushed before settling");
        }
        assert!(state.settled_t.is_none_or(|s| s < t), "time went back");
        state.pending.push((t, x, y));
        Ok(())
    }

    fn settle(&self, state: &mut EchoState, out: &mut Vec<Detection>) -> Result<()> {
        for (t, x, y) in state.pending.drain(..) {
            out.push(echoed(t, x, y, state.n_in, t - state.t0));
            state.settled_t = Some(t);
        }
        Ok(())
    }
}

fn echoed(t: u64, x: u16, y: u16, n_in: u64, offset: u64) -> Detection {
    Detection {
        t,
        map: n_in as u16,
        row: offset as u16,
        col: 0,
        x: 0.0,
        y: 0.0,
        x0: x,
        y0: y,
        x1: x + 1,
        y1: y + 1,
    }
}

/// What the detector returned, reduced to `(window, t, x, y, n_in, t - t0)` and sorted.
type Echoed = (u64, u64, u16, u16, u16, u16);

fn key(d: &StreamDetection) -> Echoed {
    let e = &d.detection;
    (d.window, e.t, e.x0, e.y0, e.map, e.row)
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
fn brute(events: &[Event], window_us: u64, overlap: f64) -> Vec<Echoed> {
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
                out.push((k, e.t, e.x, e.y, before.len() as u16, (e.t - t0) as u16));
            }
        }
        k += 1;
    }
    out.sort_unstable();
    out
}

/// The batch path's windows (`make_windows`), reported the way [`Echo`] reports them.
fn batch(events: &[Event], window_us: u64, overlap: f64) -> Vec<Echoed> {
    let sensor = SensorSize::new(W, H).unwrap();
    let config = WindowConfig::new(window_us, overlap).unwrap();
    let w = make_windows(events, sensor, &config).unwrap();
    let mut out = Vec::new();
    for i in 0..w.len() {
        for j in w.offsets[i]..w.offsets[i + 1] {
            out.push((
                i as u64,
                w.t[j],
                w.x[j],
                w.y[j],
                w.n_preceding[i] as u16,
                (w.t[j] - w.t0[i]) as u16,
            ));
        }
    }
    out.sort_unstable();
    out
}

fn run(events: &[Event], cuts: &[usize], config: StreamConfig) -> (Vec<Echoed>, usize) {
    let mut d = Detector::new(echo(), config).unwrap();
    let mut out = Vec::new();
    let mut from = 0;
    for &cut in cuts {
        let to = cut.clamp(from, events.len());
        d.push(&events[from..to], &mut out).unwrap();
        from = to;
    }
    d.push(&events[from..], &mut out).unwrap();
    d.flush(&mut out).unwrap();
    let made = d.engine().states_made.get();
    assert!(d.states_allocated() <= made);
    // Pushes and the flush append in time order (and window order within a time).
    assert!(out.is_sorted_by_key(|o| (o.detection.t, o.window)));
    let mut got: Vec<Echoed> = out.iter().map(key).collect();
    got.sort_unstable();
    (got, made)
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

proptest! {
    /// Advancing the stream's time between chunks (a watermark up to the next chunk's first
    /// time) gives the same detections, each no later than without it.
    #[test]
    fn advancing_between_chunks_changes_no_detection(
        events in arb_events(),
        cuts in prop::collection::vec(0usize..120, 0..12),
        window_us in 1u64..40,
        overlap in prop::sample::select(vec![0.0, 0.5, 0.9]),
    ) {
        let mut cuts = cuts;
        cuts.sort_unstable();
        let mut d = Detector::new(echo(), config(window_us, overlap)).unwrap();
        let mut out = Vec::new();
        let mut from = 0;
        for &cut in &cuts {
            let to = cut.clamp(from, events.len());
            d.push(&events[from..to], &mut out).unwrap();
            if let Some(next) = events.as_slice().get(to) {
                let before = out.len();
                d.advance(next.t, &mut out).unwrap();
                // All it decided is before the next event's time.
                prop_assert!(out[before..].iter().all(|o| o.detection.t < next.t));
            }
            from = to;
        }
        d.push(&events[from..], &mut out).unwrap();
        d.flush(&mut out).unwrap();
        let mut got: Vec<Echoed> = out.iter().map(key).collect();
        got.sort_unstable();
        prop_assert_eq!(&got, &brute(&events, window_us, overlap));
    }
}

#[test]
fn advancing_a_quiet_stream_decides_its_last_windows() {
    let mut d = Detector::new(echo(), config(100, 0.0)).unwrap();
    let mut out = Vec::new();
    d.push(&[ev(10, 1, 1), ev(10, 2, 2), ev(150, 3, 3)], &mut out)
        .unwrap();
    assert_eq!(out.len(), 2); // t=10, decided by t=150
    d.advance(150, &mut out).unwrap();
    assert_eq!(out.len(), 2, "t=150 may still receive events");
    d.advance(151, &mut out).unwrap();
    assert_eq!(out.len(), 3);
    // Windows from the first event: [10, 110), [110, 210).
    assert_eq!(d.live_windows(), 1); // window 1 is still open
    d.advance(210, &mut out).unwrap();
    assert_eq!(d.live_windows(), 0);
    // A watermark is a promise: earlier events, or going back, are refused.
    assert!(d.push(&[ev(209, 1, 1)], &mut out).is_err());
    assert!(d.advance(209, &mut out).is_err());
    assert!(d.advance(1 << 63, &mut out).is_err());
    d.push(&[ev(210, 1, 1)], &mut out).unwrap();
    d.flush(&mut out).unwrap();
    assert_eq!(out.len(), 4);
    assert!(d.advance(300, &mut out).is_err(), "flushed");
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
    assert!(out.iter().all(|o| o.detection.t == 10 && o.window == 0));
    d.flush(&mut out).unwrap();
    assert_eq!(out.len(), 4);
    assert_eq!(d.stats().detections, 4);
}

#[test]
fn windows_in_a_silent_gap_are_skipped_but_numbered() {
    let mut d = Detector::new(echo(), config(10, 0.5)).unwrap();
    let mut out = Vec::new();
    d.push(&[ev(0, 0, 0), ev(1_000_000, 1, 1)], &mut out)
        .unwrap();
    d.flush(&mut out).unwrap();
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
    d.flush(&mut out).unwrap();
    assert_eq!(out.len(), 1);
    let d0 = out[0].detection;
    assert_eq!((out[0].window, d0.map, d0.row), (0, 2, 5));
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
        d.flush(&mut out).unwrap();
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
        d.flush(&mut out).unwrap();
        assert_eq!((out, d.stats()), reference, "after {chunk:?}");
    }
}

#[test]
fn a_flushed_stream_refuses_events_until_reset() {
    let mut d = Detector::new(echo(), config(10, 0.0)).unwrap();
    let mut out = Vec::new();
    d.push(&[ev(5, 0, 0)], &mut out).unwrap();
    d.flush(&mut out).unwrap();
    assert!(d.is_finished());
    assert!(matches!(
        d.push(&[ev(6, 0, 0)], &mut out),
        Err(Error::Stream(_))
    ));
    d.reset();
    let mut again = Vec::new();
    d.push(&[ev(1, 0, 0)], &mut again).unwrap();
    d.flush(&mut again).unwrap();
    assert_eq!(again.len(), 1);
    assert_eq!((again[0].window, again[0].detection.t), (0, 1));
}

#[test]
fn empty_chunks_are_fine_and_parameters_are_checked() {
    let mut d = Detector::new(echo(), config(10, 0.0)).unwrap();
    let mut out = Vec::new();
    d.push(&[], &mut out).unwrap();
    d.flush(&mut out).unwrap();
    assert!(out.is_empty());
    assert!(Detector::new(echo(), config(0, 0.0)).is_err());
    assert!(Detector::new(echo(), config(10, 1.0)).is_err());
    assert!(Detector::new(echo(), config(10, f64::NAN)).is_err());
    let late_start = StreamConfig {
        start_us: Some(u64::MAX),
        ..config(10, 0.0)
    };
    assert!(Detector::new(echo(), late_start).is_err());
    let err = d.push(&[ev(u64::MAX, 0, 0)], &mut out).unwrap_err();
    assert!(matches!(err, Error::Stream(_)), "{err}"); // flushed first
    d.reset();
    let err = d
        .push(&[ev(1, 0, 0), ev(u64::MAX, 0, 0)], &mut out)
        .unwrap_err();
    assert!(matches!(err, Error::InvalidEvent { index: 1, .. }), "{err}");
    // The first event past 2^62 µs is named, not the chunk's last.
    let past = crate::windows::MAX_TIME_US + 5;
    for (chunk, first) in [
        (vec![ev(1, 0, 0), ev(past, 0, 0), ev(past + 1, 0, 0)], 1),
        (vec![ev(past, 0, 0), ev(past, 1, 0)], 0),
        (
            vec![ev(1, 0, 0), ev(2, 0, 0), ev(3, 0, 0), ev(past, 0, 0)],
            3,
        ),
    ] {
        let err = d.push(&chunk, &mut out).unwrap_err();
        assert!(
            matches!(err, Error::InvalidEvent { index, .. } if index == first),
            "{chunk:?}: {err}"
        );
        assert!(err.to_string().contains(&format!("t={past} ")), "{err}");
    }
}

#[test]
fn overlaps_with_too_many_live_windows_are_refused() {
    // 64 live windows at most: L / step = 6400 / 100.
    let most = 1.0 - 1.0 / MAX_LIVE_WINDOWS as f64;
    assert!(Detector::new(echo(), config(6400, most)).is_ok());
    for overlap in [0.99, 0.9999, 0.999_999_9] {
        let err = Detector::new(echo(), config(50_000, overlap))
            .err()
            .expect("refused");
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "overlap",
                    ..
                }
            ),
            "{err}"
        );
    }
    // A short window whose step rounds down to 1 µs keeps L windows live.
    assert!(Detector::new(echo(), config(64, 0.99)).is_ok());
    assert!(Detector::new(echo(), config(65, 0.99)).is_err());
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

/// A small network whose conv3 fires often, with PENT on (so the preceding estimate matters).
fn small_network(seed: u64) -> Network {
    let mut c = NetworkConfig {
        width: 40,
        height: 30,
        ..NetworkConfig::default()
    };
    c.pent.beta = 2.0;
    c.pent.theta_min = 1.5;
    c.pent.estimate = PentEstimate::Preceding;
    c.conv2.threshold = 3.0;
    c.conv3.threshold = 1.5;
    Network::new(c, seed).unwrap()
}

/// A blob drifting right over sparse noise, on the small network's 40×30 sensor.
fn blob_events(seed: u64, n: usize) -> Vec<Event> {
    let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    let mut next = |m: u64| {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 33) % m
    };
    let mut t = 5_000;
    (0..n)
        .map(|i| {
            t += next(40);
            let (x, y) = if next(4) == 0 {
                (next(40), next(30))
            } else {
                let cx = 5 + (i as u64 * 30 / n as u64);
                (cx + next(5), 12 + next(5))
            };
            ev(t, x as u16, y as u16)
        })
        .collect()
}

/// The batch path: `make_windows` then `network::infer` with the "preceding" estimate.
fn network_batch(net: &Network, events: &[Event], window_us: u64, overlap: f64) -> Vec<Found> {
    let sensor = SensorSize::new(40, 30).unwrap();
    let w = make_windows(
        events,
        sensor,
        &WindowConfig::new(window_us, overlap).unwrap(),
    )
    .unwrap();
    let offsets: Vec<i64> = w.offsets.iter().map(|&o| o as i64).collect();
    let n_preceding: Vec<i64> = w.n_preceding.iter().map(|&n| n as i64).collect();
    let spikes = Spikes::new(&w.t, &w.x, &w.y).unwrap();
    let batch =
        WindowBatch::new((40, 30), window_us, &w.t0, &offsets, spikes, &n_preceding).unwrap();
    let results = infer(net, &batch, Some(1), false).unwrap();
    let mut out: Vec<Found> = results
        .iter()
        .enumerate()
        .flat_map(|(i, r)| {
            r.detections.iter().map(move |&detection| {
                found(&StreamDetection {
                    window: i as u64,
                    detection,
                })
            })
        })
        .collect();
    out.sort_unstable();
    out
}

/// A detection as comparable bits: window, t, map, row, col, x, y, box.
type Found = (u64, u64, u16, u16, u16, u32, u32, [u16; 4]);

fn found(d: &StreamDetection) -> Found {
    let e = &d.detection;
    (
        d.window,
        e.t,
        e.map,
        e.row,
        e.col,
        e.x.to_bits(),
        e.y.to_bits(),
        [e.x0, e.y0, e.x1, e.y1],
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn network_stream_equals_network_batch(
        seed in 0u64..1000,
        n in 50usize..600,
        cuts in prop::collection::vec(0usize..600, 0..10),
        window_us in prop::sample::select(vec![500u64, 1_000, 3_000]),
        overlap in prop::sample::select(vec![0.0, 0.5, 0.9]),
    ) {
        let net = small_network(seed);
        let events = blob_events(seed, n);
        let mut cuts = cuts;
        cuts.sort_unstable();
        let mut d = NetworkDetector::new(
            net.clone(),
            StreamConfig { window_us, overlap, start_us: None },
        ).unwrap();
        let mut out = Vec::new();
        let mut from = 0;
        for cut in cuts {
            let to = cut.clamp(from, events.len());
            d.push(&events[from..to], &mut out).unwrap();
            from = to;
        }
        d.push(&events[from..], &mut out).unwrap();
        d.flush(&mut out).unwrap();
        let mut got: Vec<Found> = out.iter().map(found).collect();
        got.sort_unstable();
        prop_assert_eq!(got, network_batch(&net, &events, window_us, overlap));
    }
}

#[test]
fn the_small_network_detects_the_blob() {
    // Guards the property above against passing vacuously.
    let net = small_network(1);
    let events = blob_events(1, 600);
    assert!(!network_batch(&net, &events, 3_000, 0.5).is_empty());
}

/// An engine of a given sensor (a literal: any size) and state size whose windows are never
/// run: only what [`Detector::new`] checks.
struct Inert {
    sensor: (u16, u16),
    state_bytes: usize,
}

impl WindowEngine for Inert {
    type State = ();

    fn sensor(&self) -> Result<SensorSize> {
        Ok(SensorSize {
            width: self.sensor.0,
            height: self.sensor.1,
        })
    }

    fn new_state(&self) {}

    fn state_bytes(&self) -> usize {
        self.state_bytes
    }

    fn begin(&self, (): &mut (), _: u64, _: u64) -> Result<()> {
        Ok(())
    }

    fn push(&self, (): &mut (), _: u64, _: u16, _: u16) -> Result<()> {
        Ok(())
    }

    fn settle(&self, (): &mut (), _: &mut Vec<Detection>) -> Result<()> {
        Ok(())
    }
}

#[test]
fn a_sensor_above_the_memory_cap_is_refused_before_allocating() {
    let huge = Inert {
        sensor: (u16::MAX, u16::MAX),
        state_bytes: 0,
    };
    let Err(err) = Detector::new(huge, config(1000, 0.0)) else {
        panic!("a 65535x65535 detector was accepted");
    };
    crate::error::assert_over_cap(&err, "sensor_size");
}

#[test]
fn live_windows_whose_states_exceed_the_memory_cap_are_refused() {
    let fat = || Inert {
        sensor: (64, 48),
        state_bytes: crate::MAX_ALLOC_BYTES / 2 + 1,
    };
    assert!(Detector::new(fat(), config(1000, 0.0)).is_ok()); // one live window
    let Err(err) = Detector::new(fat(), config(1000, 0.5)) else {
        panic!("two states of over half the cap were accepted");
    };
    crate::error::assert_over_cap(&err, "overlap");
}

/// A chunk of more than [`PUSH_SLICE`] events, pushed whole (as events or as packed records),
/// gives the detections of the same stream pushed in small chunks, in the same order, and the
/// detector holds room for one slice's input spikes, not the chunk's.
#[test]
fn a_large_chunk_runs_in_slices_with_the_same_detections() {
    let net = small_network(3);
    let events = blob_events(3, 2 * PUSH_SLICE + 1234);
    let config = StreamConfig {
        window_us: 2_000,
        overlap: 0.5,
        start_us: None,
    };
    let mut small = NetworkDetector::new(net.clone(), config).unwrap();
    let mut want = Vec::new();
    for chunk in events.chunks(977) {
        small.push(chunk, &mut want).unwrap();
    }
    small.flush(&mut want).unwrap();
    assert!(want.len() > 100, "{} detections", want.len());

    let mut packed = Vec::with_capacity(events.len() * PACKED_EVENT_SIZE);
    for e in &events {
        packed.extend_from_slice(&e.t.to_le_bytes());
        packed.extend_from_slice(&e.x.to_le_bytes());
        packed.extend_from_slice(&e.y.to_le_bytes());
        packed.push(u8::from(e.p));
    }
    let packed = PackedEvents::new(&packed).unwrap();
    for whole in [&events as &dyn EventSource, &packed] {
        let mut d = NetworkDetector::new(net.clone(), config).unwrap();
        let mut got = Vec::new();
        d.push(whole, &mut got).unwrap();
        assert!(d.spike_capacity() <= PUSH_SLICE, "{}", d.spike_capacity());
        d.flush(&mut got).unwrap();
        let found_all = |v: &[StreamDetection]| v.iter().map(found).collect::<Vec<_>>();
        assert_eq!(found_all(&got), found_all(&want));
        assert_eq!(d.stats(), small.stats());
    }
}

#[test]
fn an_engine_of_a_zero_sensor_is_refused() {
    // An engine's sensor may be a SensorSize literal: a 0x0 one made a detector that took
    // no event and blamed each on itself.
    let inert = |sensor| Inert {
        sensor,
        state_bytes: 0,
    };
    let err = Detector::new(inert((0, 0)), config(100, 0.5))
        .err()
        .unwrap();
    crate::events::assert_zero_sensor(&err);
    let sensor = Detector::new(inert((W, H)), config(100, 0.5))
        .unwrap()
        .sensor();
    assert_eq!(sensor, SensorSize::new(W, H).unwrap());
}

#[test]
fn the_default_stream_config_is_the_python_packages() {
    let config = StreamConfig::default();
    assert_eq!(
        config,
        StreamConfig {
            window_us: 50_000,
            overlap: 0.5,
            start_us: None,
        }
    );
    NetworkDetector::new(Network::new(NetworkConfig::default(), 0).unwrap(), config).unwrap();
    // The numbers the Python package keeps (`uavsnn.provenance`), read from its source where
    // the repository is there (the crate's package holds no Python).
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/python/uavsnn/provenance.py");
    let Ok(source) = std::fs::read_to_string(path) else {
        eprintln!("{path} is not here: the Python defaults not compared");
        return;
    };
    let constant = |name: &str| -> String {
        let prefix = format!("{name} = ");
        let line = source.lines().find_map(|l| l.strip_prefix(prefix.as_str()));
        let value = line.unwrap_or_else(|| panic!("no `{prefix}` line in {path}"));
        value.split('#').next().unwrap().trim().replace('_', "")
    };
    assert_eq!(
        constant("DEFAULT_WINDOW_US").parse::<u64>(),
        Ok(config.window_us)
    );
    assert_eq!(
        constant("DEFAULT_OVERLAP").parse::<f64>(),
        Ok(config.overlap)
    );
}
