//! The engine allocates nothing per event once warm, and its state grows with the number of
//! neurons, not with the number of events (issue 3): a counting global allocator watches one
//! thread while windows are pushed through a state. (An integration test, so that the allocator
//! stays out of the library build.)

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use uavsnn::network::{ConvGeom, Network, NetworkConfig, PoolGeom, Spikes, WindowState};

/// The system allocator, counting the calls made by the current thread.
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    /// Bytes allocated minus bytes freed by the current thread.
    static LIVE: Cell<isize> = const { Cell::new(0) };
}

fn count() {
    // `try_with`: the thread's slots may already be gone while the thread exits.
    let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
}

fn hold(bytes: isize) {
    let _ = LIVE.try_with(|n| n.set(n.get() + bytes));
}

// SAFETY: every call is forwarded to `System` unchanged; counting allocates nothing.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        hold(layout.size() as isize);
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        hold(layout.size() as isize);
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        hold(new_size as isize - layout.size() as isize);
        // SAFETY: forwarded with the caller's pointer and layouts.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        hold(-(layout.size() as isize));
        // SAFETY: forwarded with the caller's pointer and layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

fn live_bytes() -> isize {
    LIVE.with(Cell::get)
}

/// A window of `n` input spikes at distinct pixels: short lines (what conv1 responds to) in
/// bursts, so that every layer fires, then sorted by time.
fn window(width: usize, height: usize, n: usize, seed: u64, t0: u64) -> Vec<(u64, u16, u16)> {
    let mut s = seed | 1;
    let mut next = |m: u64| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s % m
    };
    let mut seen = vec![false; width * height];
    let mut v = Vec::with_capacity(n);
    while v.len() < n {
        let (x0, y0, t) = (next(width as u64), next(height as u64), t0 + next(40_000));
        let vertical = next(2) == 0;
        for i in 0..12 {
            let (x, y) = if vertical { (x0, y0 + i) } else { (x0 + i, y0) };
            let (x, y) = (x as usize, y as usize);
            if x < width && y < height && !seen[y * width + x] && v.len() < n {
                seen[y * width + x] = true;
                v.push((t + i * 5, x as u16, y as u16));
            }
        }
    }
    v.sort_unstable_by_key(|e| e.0);
    v
}

fn push_all(net: &Network, state: &mut WindowState, w: &[(u64, u16, u16)], t0: u64) -> usize {
    let thresholds = net.conv1_thresholds(w.len() as u64);
    let before = allocations();
    state.begin(net, t0, &thresholds).unwrap();
    for &(t, x, y) in w {
        state.push(net, t, x, y).unwrap();
    }
    state.finish(net).unwrap();
    allocations() - before
}

#[test]
fn nothing_is_allocated_per_event_once_warm() {
    let (width, height) = (240, 180);
    let config = NetworkConfig {
        width,
        height,
        ..NetworkConfig::default()
    };
    let net = Network::new(config, 1).unwrap();
    // 1 % and 5 % of the pixels: conv2 and conv3 fire in the denser windows.
    let windows: Vec<_> = (0..6u64)
        .map(|i| {
            let n = if i % 2 == 0 { 432 } else { 2160 };
            window(width, height, n, 17 + i, i * 50_000)
        })
        .collect();
    let mut state = net.new_state();
    let mut spikes = [0u64; 5];
    for (i, w) in windows.iter().enumerate() {
        push_all(&net, &mut state, w, i as u64 * 50_000);
        for (total, n) in spikes.iter_mut().zip(state.counts()) {
            *total += n;
        }
    }
    assert!(
        spikes.iter().all(|&n| n > 0),
        "every layer fires: {spikes:?}"
    );
    // Warm: the same windows again, through the streaming API and through run_window.
    for (i, w) in windows.iter().enumerate() {
        let t0 = i as u64 * 50_000;
        assert_eq!(push_all(&net, &mut state, w, t0), 0, "window {i}");
        let (t, x, y): (Vec<u64>, Vec<u16>, Vec<u16>) = (
            w.iter().map(|e| e.0).collect(),
            w.iter().map(|e| e.1).collect(),
            w.iter().map(|e| e.2).collect(),
        );
        let spikes = Spikes::new(&t, &x, &y).unwrap();
        let before = allocations();
        net.run_window(&mut state, spikes, t0, None, false).unwrap();
        // Only conv1's thresholds, once per window, whatever the number of events.
        assert!(allocations() - before <= 1, "window {i}");
    }
}

/// `w` with every event repeated `times` times at later timestamps of the same pixel (raw
/// events of a busy sensor: only a pixel's first spike in the window is its input spike).
fn repeated(w: &[(u64, u16, u16)], times: u64) -> Vec<(u64, u16, u16)> {
    let mut v: Vec<_> = (0..times)
        .flat_map(|k| w.iter().map(move |&(t, x, y)| (t + k * 1_000, x, y)))
        .collect();
    v.sort_by_key(|e| e.0);
    v
}

/// The bytes a fresh state holds on the heap after `windows` went through it, the traces of
/// every layer recorded, with the neurons and pixels of its network.
fn state_bytes(width: usize, height: usize, windows: &[Vec<(u64, u16, u16)>]) -> (isize, usize) {
    let config = NetworkConfig {
        width,
        height,
        ..NetworkConfig::default()
    };
    let net = Network::new(config, 1).unwrap();
    let g = net.geometry();
    let neurons = g.conv.iter().map(ConvGeom::neurons).sum::<usize>()
        + g.pool.iter().map(PoolGeom::neurons).sum::<usize>();
    let before = live_bytes();
    let mut state = net.new_state();
    state.set_record(true);
    for (i, w) in windows.iter().enumerate() {
        let t0 = i as u64 * 50_000;
        // Freed before `held` is read.
        let w: Vec<_> = w.iter().map(|&(t, x, y)| (t0 + t, x, y)).collect();
        push_all(&net, &mut state, &w, t0);
    }
    let held = live_bytes() - before;
    drop(state);
    (held, neurons + width * height)
}

#[test]
fn state_grows_with_the_neurons_not_with_the_events() {
    let mut per_unit = Vec::new();
    for (width, height) in [(120, 90), (240, 180)] {
        // Every pixel of the sensor spikes: the most input spikes a window can have.
        let full = window(width, height, width * height, 5, 0);
        let sparse = window(width, height, width * height / 100, 9, 0);
        let (once, units) = state_bytes(width, height, &[sparse.clone(), full.clone()]);
        // Eight times the raw events, and then many more windows: not one byte more.
        let busy = repeated(&full, 8);
        let (more, _) = state_bytes(width, height, &[sparse.clone(), busy.clone()]);
        assert_eq!(more, once, "{width}x{height}: 8x the events");
        let long: Vec<_> = (0..6)
            .flat_map(|_| [sparse.clone(), busy.clone()])
            .collect();
        let (longer, _) = state_bytes(width, height, &long);
        assert_eq!(longer, once, "{width}x{height}: 12 windows");
        per_unit.push(once as f64 / units as f64);
    }
    // Four times the neurons and pixels, four times the bytes: the same bytes per unit.
    let ratio = per_unit[1] / per_unit[0];
    assert!(
        (0.85..1.15).contains(&ratio),
        "bytes per neuron or pixel: {per_unit:?}"
    );
}
