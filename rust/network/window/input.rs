//! How input spikes enter a window: one spike or one timestamp group at a time, each checked
//! ([`WindowState::push`], [`WindowState::push_group`]), or a window's spikes checked together
//! first and then taken without the per-spike checks (`push_spikes`).

use super::{Network, WindowState};
use crate::error::{Error, Result};
use crate::network::batch::Spikes;
use crate::network::detection::Detection;
use crate::network::layer::ConvLayer;

impl WindowState {
    /// Push one input spike (`t` ≥ the previous spike's, inside the sensor, ≥ `t0`). If it
    /// starts a new timestamp group, the previous group is processed first; returns the
    /// detections that this produced (empty most of the time).
    pub fn push(&mut self, net: &Network, t: u64, x: u16, y: u16) -> Result<&[Detection]> {
        let first = self.detections.len();
        self.accept(net, t, x, y)?;
        Ok(&self.detections[first..])
    }

    /// Push a whole timestamp group (every input spike at time `t`) and process it at once;
    /// returns the detections it (and any pending earlier group) produced.
    pub fn push_group(
        &mut self,
        net: &Network,
        t: u64,
        xs: &[u16],
        ys: &[u16],
    ) -> Result<&[Detection]> {
        if xs.len() != ys.len() {
            return Err(Error::Shape {
                name: "group",
                expected: "x and y of equal length".into(),
                got: format!("{} and {}", xs.len(), ys.len()),
            });
        }
        let first = self.detections.len();
        for (&x, &y) in xs.iter().zip(ys) {
            self.accept(net, t, x, y)?;
        }
        self.process_pending(net);
        Ok(&self.detections[first..])
    }

    #[inline]
    fn accept(&mut self, net: &Network, t: u64, x: u16, y: u16) -> Result<()> {
        self.check_open(net)?;
        let (xs, ys) = (usize::from(x), usize::from(y));
        if xs >= self.width || ys >= self.height {
            return Err(self.bad_event(format!(
                "(x={x}, y={y}) is outside the {}x{} sensor",
                self.width, self.height
            )));
        }
        if t < self.t0 {
            return Err(
                self.bad_event(format!("t={t} is before the window's start t0={}", self.t0))
            );
        }
        if let Some(last) = self.last_t {
            if t < last {
                return Err(
                    self.bad_event(format!("t={t} goes backwards (previous spike at t={last})"))
                );
            }
        }
        if self.pending_t.is_some_and(|p| t > p) {
            self.process_pending(net);
        }
        self.pushed += 1;
        self.last_t = Some(t);
        if self.training.is_some() && self.wta.done() {
            // The winners are known; later spikes cannot change the STDP update.
            return Ok(());
        }
        // SAFETY: inside the sensor (tested above).
        if unsafe { self.stamp(ys * self.width + xs, t) } {
            self.pending.push((x, y));
            self.pending_t = Some(t);
        }
        Ok(())
    }

    /// Note that `pixel` spiked at `t`; returns whether this is its first spike in the window
    /// (its input spike: later ones are ignored).
    ///
    /// # Safety
    /// `pixel` must be `y · width + x` of a spike inside the sensor (`x < width`,
    /// `y < height`), as `accept` and `all_valid` check.
    #[inline]
    unsafe fn stamp(&mut self, pixel: usize, t: u64) -> bool {
        debug_assert!(pixel < self.width * self.height);
        debug_assert_eq!(self.pixel_time.len(), self.pixel_fired.len());
        // SAFETY: `pixel < width · height` (the caller's contract), the length of both
        // `pixel_fired` and `pixel_time` (one value per pixel, made in `new`, never resized).
        let fired = unsafe { self.pixel_fired.get_unchecked_mut(pixel) };
        if *fired == self.generation {
            return false;
        }
        *fired = self.generation;
        // SAFETY: as above.
        unsafe { *self.pixel_time.get_unchecked_mut(pixel) = t };
        self.inputs += 1;
        true
    }

    /// Push a window's spikes (sorted by time) and process every timestamp group, the last one
    /// included, as [`Self::push_group`] would group by group.
    ///
    /// In an inference window with no group pending, spikes that are all valid (checked
    /// together first: inside the sensor, in time order, none before `t0` or the previous
    /// spike) go straight to conv1, without `accept`'s per-spike checks and the pending list.
    /// Otherwise they go group by group through `push_group`, so that an error, and the state
    /// it leaves, are the same.
    pub(crate) fn push_spikes(&mut self, net: &Network, spikes: Spikes<'_>) -> Result<()> {
        let (t, x, y) = (spikes.t(), spikes.x(), spikes.y());
        if self.all_valid(net, t, x, y) {
            // SAFETY: `all_valid` passed these spikes.
            unsafe { self.take_valid(net, t, x, y) };
            return Ok(());
        }
        let mut start = 0;
        while start < t.len() {
            let mut end = start + 1;
            while end < t.len() && t[end] == t[start] {
                end += 1;
            }
            self.push_group(net, t[start], &x[start..end], &y[start..end])?;
            start = end;
        }
        Ok(())
    }

    /// Whether `take_valid` may take these spikes: see `push_spikes`. Compiled for AVX2 where
    /// the CPU has it, whose vectors compare 64-bit times and take the largest of unsigned
    /// 16-bit coordinates in one instruction each (SSE2 has neither).
    fn all_valid(&self, net: &Network, t: &[u64], x: &[u16], y: &[u16]) -> bool {
        match self.avx2 {
            Some(avx2) => avx2.vectorize(
                #[inline(always)]
                move || self.all_valid_body(net, t, x, y),
            ),
            None => self.all_valid_body(net, t, x, y),
        }
    }

    /// The checks of `all_valid`, inlined into each of its compilations.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn all_valid_body(&self, net: &Network, t: &[u64], x: &[u16], y: &[u16]) -> bool {
        let after = |first: u64| first >= self.t0 && self.last_t.is_none_or(|l| first >= l);
        // Passes without early exits (the spikes are valid but for a rare error), in forms the
        // compiler vectorises: the count of times that go backwards, the largest coordinates.
        let backwards = t
            .iter()
            .zip(t.iter().skip(1))
            .fold(0u64, |n, (&a, &b)| n + u64::from(b < a));
        let in_order = backwards == 0;
        let (max_x, max_y) = (
            x.iter().fold(0, |m, &v| m.max(v)),
            y.iter().fold(0, |m, &v| m.max(v)),
        );
        let inside =
            x.is_empty() || (usize::from(max_x) < self.width && usize::from(max_y) < self.height);
        self.open
            && self.made_for(net)
            && self.training.is_none()
            && self.pending_t.is_none()
            && t.first().is_none_or(|&first| after(first))
            && in_order
            && inside
    }

    /// Take spikes that `all_valid` passed: each group's input spikes are added to conv1 as
    /// they come and the group is run up the network once complete (what `accept` and
    /// `process_pending` do, without the pending list).
    ///
    /// # Safety
    /// `all_valid` must have passed `t`, `x`, `y` (every spike inside the sensor, which
    /// `stamp` relies on).
    ///
    /// Where the CPU has AVX2 the loop is compiled for it, so that conv1's fixed-shape vector
    /// add (`add_rows_fixed`, AVX2 only) is inlined into it instead of called per input.
    unsafe fn take_valid(&mut self, net: &Network, t: &[u64], x: &[u16], y: &[u16]) {
        match self.avx2 {
            Some(avx2) => avx2.vectorize(
                #[inline(always)]
                move || {
                    // SAFETY: our caller's contract.
                    unsafe { self.take_valid_body(net, t, x, y) };
                },
            ),
            // SAFETY: our caller's contract.
            None => unsafe { self.take_valid_body(net, t, x, y) },
        }
    }

    /// The loop of `take_valid`, inlined into each of its compilations. (Copies of it for
    /// conv1 with and without whole inputs, which spared the test per input, saved under 2 %
    /// of instructions: not kept.)
    ///
    /// # Safety
    /// As `take_valid`'s.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    unsafe fn take_valid_body(&mut self, net: &Network, t: &[u64], x: &[u16], y: &[u16]) {
        let w = net.conv_weights(ConvLayer::Conv1).engine();
        self.conv[0].load_kernel(w);
        // One pass over the zipped columns (no bounds checks per spike): a spike of a later
        // time completes the group before it, whose inputs are then run up the network.
        let mut group_t = t.first().copied().unwrap_or(0);
        let mut added = false;
        for ((&st, &sx), &sy) in t.iter().zip(x).zip(y) {
            if st != group_t {
                if added {
                    self.propagate(net, group_t);
                }
                group_t = st;
                added = false;
            }
            let (xs, ys) = (usize::from(sx), usize::from(sy));
            // SAFETY: inside the sensor (our caller's contract).
            if unsafe { self.stamp(ys * self.width + xs, st) } {
                self.conv[0].add_inline(w, ys, xs);
                added = true;
            }
        }
        if added {
            self.propagate(net, group_t);
        }
        self.pushed += t.len();
        if let Some(&last) = t.last() {
            self.last_t = Some(last);
        }
    }

    fn bad_event(&self, reason: String) -> Error {
        Error::InvalidEvent {
            index: self.pushed,
            reason,
        }
    }
}
