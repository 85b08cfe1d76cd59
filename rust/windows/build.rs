//! Building windows: runs of consecutive windows swept in parallel (the method and its cost
//! are described in the parent module).

use rayon::prelude::*;

use super::{Grid, MedianFilter, Windows};
use crate::error::{Error, Result};
use crate::events::{Event, EventSource, SensorSize};

/// Most windows in one run: run-relative window indices (plus one) are stored per pixel as
/// `u16`.
const RUN_MAX_WINDOWS: usize = u16::MAX as usize - 1;

/// Events per parallel run below which windowing stays on one thread.
const EVENTS_PER_RUN: usize = 250_000;

/// Split `n` windows into runs of consecutive windows: one per [`EVENTS_PER_RUN`] events, a few
/// per thread at most.
pub(super) fn plan_runs(n: usize, events: usize) -> Vec<(usize, usize)> {
    if n == 0 {
        return Vec::new();
    }
    let threads = rayon::current_num_threads();
    let wanted = (events / EVENTS_PER_RUN).clamp(1, 4 * threads).min(n);
    // A run indexes its windows with u16 (a small per-pixel table stays in cache).
    let per = n.div_ceil(wanted).min(RUN_MAX_WINDOWS);
    (0..n).step_by(per).map(|a| (a, (a + per).min(n))).collect()
}

/// Integer types whose all-zero bit pattern is the value 0 (what `zeroed` may hand out).
///
/// # Safety
/// Implementors must be plain integers: every bit pattern valid, all-zero meaning 0.
unsafe trait Zero: Copy {}
// SAFETY: plain integers.
unsafe impl Zero for u16 {}
// SAFETY: plain integers.
unsafe impl Zero for u64 {}

/// A column of `len` zeros whose untouched pages the system maps only when written (like
/// `vec![0; len]`), or an error (not an abort) naming the parameter `name` when the memory is
/// not there.
fn zeroed<T: Zero>(name: &'static str, len: usize) -> Result<Vec<T>> {
    let short = || {
        Error::param(
            name,
            format!("{len} spikes do not fit in memory; window a shorter range"),
        )
    };
    if len == 0 {
        return Ok(Vec::new());
    }
    let layout = std::alloc::Layout::array::<T>(len).map_err(|_| short())?;
    // SAFETY: the layout has a non-zero size (len > 0 and T is an integer).
    let ptr = unsafe { std::alloc::alloc_zeroed(layout) }.cast::<T>();
    if ptr.is_null() {
        return Err(short());
    }
    // SAFETY: `ptr` was allocated by the global allocator with the layout of `[T; len]`, which is
    // what a boxed slice of `len` values frees; its values are zeros, valid for `T: Zero`.
    let column = unsafe { Box::from_raw(std::ptr::slice_from_raw_parts_mut(ptr, len)) };
    Ok(column.into_vec())
}

/// The windows of `grid`, run by run in parallel: a counting sweep sizes every window and keeps
/// the events that are their pixel's first in some window (with that range of windows), then a
/// filling pass writes each of them straight to its final places in the columns. The output is
/// allocated once, at its exact size, and the events are swept once.
pub(super) fn build<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    grid: Grid,
    end: u64,
    median: bool,
    runs: &[(usize, usize)],
) -> Result<Windows> {
    let counted: Vec<(Vec<usize>, Vec<u64>, Firsts)> = runs
        .par_iter()
        .map(|&(ka, kb)| -> Result<_> {
            // Spike counts and n_preceding as difference arrays: each event adds 1 to a range
            // of windows (maybe empty, which adds nothing: no branch on it).
            let mut spikes = vec![0i64; kb - ka + 1];
            let mut diff = vec![0i64; kb - ka + 1];
            let (i0, i1) = event_range(events, grid, (ka, kb), end);
            let mut firsts = Firsts::with_room(i1 - i0)?;
            sweep(
                events,
                sensor,
                grid,
                (ka, kb),
                end,
                |a, b, e| {
                    spikes[a] += 1;
                    spikes[b] -= 1;
                    firsts.push(a, b, e);
                },
                |a, b| {
                    diff[a] += 1;
                    diff[b] -= 1;
                },
            );
            let running = |d: &[i64]| {
                let mut sum = 0i64;
                d[..kb - ka]
                    .iter()
                    .map(|v| {
                        sum += v;
                        sum
                    })
                    .collect::<Vec<i64>>()
            };
            let counts = running(&spikes).into_iter().map(|c| c as usize).collect();
            let preceding = running(&diff).into_iter().map(|c| c as u64).collect();
            Ok((counts, preceding, firsts))
        })
        .collect::<Result<_>>()?;

    let mut offsets = Vec::with_capacity(grid.n + 1);
    let mut n_preceding = Vec::with_capacity(grid.n);
    let mut total = 0usize;
    offsets.push(0);
    let mut all_firsts = Vec::with_capacity(runs.len());
    for (counts, preceding, firsts) in counted {
        for c in counts {
            total += c;
            offsets.push(total);
        }
        n_preceding.extend(preceding);
        all_firsts.push(firsts);
    }
    let mut t = zeroed::<u64>("length_us", total)?;
    let mut x = zeroed::<u16>("length_us", total)?;
    let mut y = zeroed::<u16>("length_us", total)?;

    // Each run fills its own slice of the columns.
    let mut slices = Vec::with_capacity(runs.len());
    let (mut rest_t, mut rest_x, mut rest_y) = (&mut t[..], &mut x[..], &mut y[..]);
    for &(ka, kb) in runs {
        let len = offsets[kb] - offsets[ka];
        let (head_t, tail_t) = rest_t.split_at_mut(len);
        let (head_x, tail_x) = rest_x.split_at_mut(len);
        let (head_y, tail_y) = rest_y.split_at_mut(len);
        slices.push((head_t, head_x, head_y));
        (rest_t, rest_x, rest_y) = (tail_t, tail_x, tail_y);
    }
    let kept: Vec<Vec<usize>> = runs
        .par_iter()
        .zip(slices)
        .zip(all_firsts)
        .map(
            |((&(ka, kb), (ts, xs, ys)), firsts)| -> Result<Vec<usize>> {
                let base = offsets[ka];
                let mut cursor: Vec<usize> = offsets[ka..kb].iter().map(|o| o - base).collect();
                for k in 0..firsts.len {
                    let (a, b) = (firsts.a[k] as usize, firsts.b[k] as usize);
                    for c in &mut cursor[a..b] {
                        let j = *c;
                        ts[j] = firsts.t[k];
                        xs[j] = firsts.x[k];
                        ys[j] = firsts.y[k];
                        *c = j + 1;
                    }
                }
                drop(firsts);
                if !median {
                    return Ok(Vec::new());
                }
                // Filter each window in place, its kept spikes moved to the front of the run.
                let mut filter = MedianFilter::new(sensor)?;
                let mut write = 0;
                Ok((ka..kb)
                    .map(|k| {
                        let (a, b) = (offsets[k] - base, offsets[k + 1] - base);
                        let keep = filter.compact(&mut ts[a..b], &mut xs[a..b], &mut ys[a..b]);
                        ts.copy_within(a..a + keep, write);
                        xs.copy_within(a..a + keep, write);
                        ys.copy_within(a..a + keep, write);
                        write += keep;
                        keep
                    })
                    .collect())
            },
        )
        .collect::<Result<_>>()?;

    if median {
        // Close the gaps the filter left between runs, and recount the offsets.
        let mut write = 0;
        for (&(ka, _), counts) in runs.iter().zip(&kept) {
            let from = offsets[ka];
            let len: usize = counts.iter().sum();
            t.copy_within(from..from + len, write);
            x.copy_within(from..from + len, write);
            y.copy_within(from..from + len, write);
            write += len;
        }
        t.truncate(write);
        x.truncate(write);
        y.truncate(write);
        let mut total = 0;
        offsets = std::iter::once(0)
            .chain(kept.iter().flatten().map(|c| {
                total += c;
                total
            }))
            .collect();
    }
    Ok(Windows {
        sensor,
        length_us: grid.length,
        t0: (0..grid.n).map(|k| grid.t0(k)).collect(),
        offsets,
        t,
        x,
        y,
        n_preceding,
    })
}

/// Windows that do not overlap (`step = L`), in one sweep: each event reaches at most one
/// window and windows come one after the other, so spikes are appended to the columns in their
/// final order; runs are then joined.
///
/// Slot `s` of a run is `[t0(ka) + (s − 1)·L, t0(ka) + s·L)`: slot 0 is window `ka`'s preceding
/// interval and slot `s ≥ 1` is window `ka + s − 1`, which is also window `ka + s`'s preceding
/// interval. So counting each slot's distinct pixels gives both the spikes (slots `1..=n`) and
/// `n_preceding` (slots `0..n`), with one small table per pixel (the last slot it fired in).
pub(super) fn build_disjoint<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    grid: Grid,
    end: u64,
    median: bool,
    runs: &[(usize, usize)],
) -> Result<Windows> {
    let parts: Vec<Windows> = runs
        .par_iter()
        .map(|&(ka, kb)| disjoint_run(events, sensor, grid, end, median, (ka, kb)))
        .collect::<Result<_>>()?;
    let mut parts = parts.into_iter();
    let Some(mut w) = parts.next() else {
        return Ok(Windows::empty(sensor, grid.length));
    };
    for part in parts {
        let base = w.t.len();
        w.t0.extend_from_slice(&part.t0);
        w.offsets.extend(part.offsets[1..].iter().map(|o| o + base));
        w.t.extend_from_slice(&part.t);
        w.x.extend_from_slice(&part.x);
        w.y.extend_from_slice(&part.y);
        w.n_preceding.extend_from_slice(&part.n_preceding);
    }
    Ok(w)
}

/// Windows `ka..kb` of a disjoint grid (see [`build_disjoint`]).
///
/// The loop has no branch on whether an event is new to its slot (a coin toss the CPU cannot
/// predict): every event is written at the columns' end, which only advances for a new pixel.
fn disjoint_run<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    grid: Grid,
    end: u64,
    median: bool,
    (ka, kb): (usize, usize),
) -> Result<Windows> {
    let n = kb - ka;
    let length = grid.length;
    let first = grid.t0(ka);
    // Events before the preceding interval of window ka, or at or after the end of window
    // kb − 1 (or `end`), reach nothing here.
    let i0 = events.count_before(first.saturating_sub(length));
    let i1 = events.count_before(end.min(grid.t0(kb - 1) + length));
    // At most one spike per event. Zeroed columns are mapped lazily, so the untouched room
    // costs no memory, and is given back at the end.
    let room = i1.saturating_sub(i0);
    let (mut t, mut x, mut y) = (
        zeroed::<u64>("events", room)?,
        zeroed::<u16>("events", room)?,
        zeroed::<u16>("events", room)?,
    );
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    let mut filter = median.then(|| MedianFilter::new(sensor)).transpose()?;
    // Distinct pixels per slot (slots 0..=n).
    let mut counts = vec![0u64; n + 1];
    // Per pixel: 1 + the last slot it fired in (0: not yet); slots fit: n < RUN_MAX_WINDOWS.
    let mut seen = vec![0u16; sensor.area()];
    let mut len = 0usize;
    let mut slot = 0usize;
    let mut slot_end = first;
    for i in i0..i1 {
        let e = events.get(i);
        while e.t >= slot_end {
            if slot >= 1 {
                len = close_window(&mut offsets, (&mut t, &mut x, &mut y), len, filter.as_mut());
            }
            slot += 1;
            slot_end += length;
        }
        let stamp = slot as u16 + 1;
        let cell = &mut seen[sensor.index(e.x, e.y)];
        let new = usize::from(*cell != stamp);
        *cell = stamp;
        counts[slot] += new as u64;
        // `len` counts spikes of earlier events only, so it is below `room`.
        t[len] = e.t;
        x[len] = e.x;
        y[len] = e.y;
        len += new & usize::from(slot != 0);
    }
    // Close the window the last event fell in, and the empty ones after it.
    if slot >= 1 {
        len = close_window(&mut offsets, (&mut t, &mut x, &mut y), len, filter.as_mut());
    }
    while offsets.len() <= n {
        offsets.push(len);
    }
    for column in [&mut x, &mut y] {
        column.truncate(len);
        column.shrink_to_fit();
    }
    t.truncate(len);
    t.shrink_to_fit();
    counts.truncate(n);
    Ok(Windows {
        sensor,
        length_us: length,
        t0: (ka..kb).map(|k| grid.t0(k)).collect(),
        offsets,
        t,
        x,
        y,
        n_preceding: counts,
    })
}

/// End the window whose spikes are `columns[offsets.last()..len]`: filter them if asked, and
/// record the window's end; returns the columns' new length.
fn close_window(
    offsets: &mut Vec<usize>,
    (t, x, y): (&mut [u64], &mut [u16], &mut [u16]),
    len: usize,
    filter: Option<&mut MedianFilter>,
) -> usize {
    let start = offsets[offsets.len() - 1];
    let len = match filter {
        Some(filter) => {
            start + filter.compact(&mut t[start..len], &mut x[start..len], &mut y[start..len])
        }
        None => len,
    };
    offsets.push(len);
    len
}

/// The events that are their pixel's first in at least one window of a run, with that range
/// of windows (run-relative): what the filling pass needs, so that it does not sweep the
/// events again. Columns have room for every event the run reads; zeroed columns are mapped
/// lazily, so the room that stays unused costs no memory.
struct Firsts {
    t: Vec<u64>,
    x: Vec<u16>,
    y: Vec<u16>,
    a: Vec<u16>,
    b: Vec<u16>,
    len: usize,
}

impl Firsts {
    fn with_room(room: usize) -> Result<Self> {
        Ok(Self {
            t: zeroed("events", room)?,
            x: zeroed("events", room)?,
            y: zeroed("events", room)?,
            a: zeroed("events", room)?,
            b: zeroed("events", room)?,
            len: 0,
        })
    }

    /// Keep `e` if `a..b` is not empty, without a branch on it: the entry is always written
    /// and only counted when kept (`len` counts earlier events only, so it is in room).
    #[inline]
    fn push(&mut self, a: usize, b: usize, e: Event) {
        let k = self.len;
        self.t[k] = e.t;
        self.x[k] = e.x;
        self.y[k] = e.y;
        self.a[k] = a as u16;
        self.b[k] = b as u16;
        self.len = k + usize::from(a < b);
    }
}

/// The events that can reach windows `ka..kb` of `grid` (or their preceding intervals): those
/// from `t0(ka) − L` up to the last window's end or `end`, whichever is first.
fn event_range<E: EventSource + ?Sized>(
    events: &E,
    grid: Grid,
    (ka, kb): (usize, usize),
    end: u64,
) -> (usize, usize) {
    if kb <= ka {
        return (0, 0);
    }
    let i0 = events.count_before(grid.t0(ka).saturating_sub(grid.length));
    let i1 = events.count_before(end.min(grid.t0(kb - 1) + grid.length));
    (i0, i1.max(i0))
}

/// Walk the events that can reach windows `ka..kb` of `grid`, in time order, and report for
/// each event the range of windows `a..b` where it is its pixel's first (`spike(a, b, e)`,
/// relative to `ka`), and the range of windows `a..b` whose preceding interval `[t0 − L, t0)`
/// holds it as its pixel's first (`preceding(a, b)`). Ranges may be empty (`a == b`): callers
/// that can add an empty range for free save a branch the CPU cannot predict.
///
/// Three cursors follow the stream over the run's windows: `closed` counts windows with
/// `t0 + L ≤ t`, `opened` those with `t0 ≤ t`, `reach` those with `t0 ≤ t + L`. An event is its
/// pixel's first in windows `max(closed, fresh) .. opened`, where `fresh` is `opened` as it was
/// at the pixel's previous event, and in the preceding intervals of windows
/// `max(opened, fresh') .. reach`, with `fresh'` the previous event's `reach`. No division, no
/// search, nothing cleared per window.
fn sweep<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    grid: Grid,
    (ka, kb): (usize, usize),
    end: u64,
    mut spike: impl FnMut(usize, usize, Event),
    mut preceding: impl FnMut(usize, usize),
) {
    let length = grid.length;
    let n = kb.saturating_sub(ka);
    if n == 0 {
        return;
    }
    let t0 = |r: usize| grid.t0(ka + r);
    let (i0, i1) = event_range(events, grid, (ka, kb), end);
    // Per pixel: [first window where its next event is new, same for preceding intervals].
    let mut fresh = vec![[0u16; 2]; sensor.area()];
    let (mut closed, mut opened, mut reach) = (0usize, 0usize, 0usize);
    for i in i0..i1 {
        let e = events.get(i);
        while closed < n && t0(closed) + length <= e.t {
            closed += 1;
        }
        while opened < n && t0(opened) <= e.t {
            opened += 1;
        }
        while reach < n && t0(reach) <= e.t + length {
            reach += 1;
        }
        let cell = &mut fresh[sensor.index(e.x, e.y)];
        let a = (cell[0] as usize).max(closed);
        spike(a, a.max(opened), e);
        let a = (cell[1] as usize).max(opened);
        preceding(a, a.max(reach));
        // Run indices fit in u16: a run holds at most RUN_MAX_WINDOWS windows.
        *cell = [opened as u16, reach as u16];
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::*;

    /// Columns too large for memory are an error, not an abort; small ones are zeros.
    #[test]
    fn zeroed_columns_fail_softly() {
        assert_eq!(zeroed::<u16>("events", 5).unwrap(), vec![0u16; 5]);
        assert!(zeroed::<u64>("events", 0).unwrap().is_empty());
        // Beyond any layout, and beyond any address space (2^62 bytes).
        assert!(matches!(
            zeroed::<u64>("events", usize::MAX / 4),
            Err(Error::InvalidParameter { .. })
        ));
        assert!(matches!(
            zeroed::<u16>("events", 1 << 61),
            Err(Error::InvalidParameter { .. })
        ));
        assert!(Firsts::with_room(1 << 61).is_err());
    }
}
