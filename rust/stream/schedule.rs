//! When windows start and which of them hold a given instant (docs/model.md §1).
//!
//! Window `k` covers `[start + k·step, start + k·step + length)`. With an overlap `o`, `step` is
//! `length·(1 − o)` rounded down to whole microseconds, at least 1, by the batch path's own
//! [`window_step`], so that the streaming and batch paths number windows alike.

use std::ops::RangeInclusive;

use crate::error::Result;
pub use crate::windows::window_step;

/// The start times of a stream's windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WindowSchedule {
    start: u64,
    length: u64,
    step: u64,
}

impl WindowSchedule {
    /// Windows of `length_us` starting every `length_us·(1 − overlap)` from `start_us`.
    pub fn new(start_us: u64, length_us: u64, overlap: f64) -> Result<Self> {
        let step = window_step(length_us, overlap)?;
        Ok(Self::with_step(start_us, length_us, step))
    }

    /// Windows of `length_us` starting every `step_us` (both at least 1) from `start_us`.
    pub(crate) fn with_step(start_us: u64, length_us: u64, step_us: u64) -> Self {
        Self {
            start: start_us,
            length: length_us.max(1),
            step: step_us.max(1),
        }
    }

    /// Start of the first window.
    pub fn start(&self) -> u64 {
        self.start
    }

    /// Window length in microseconds.
    pub fn length(&self) -> u64 {
        self.length
    }

    /// Microseconds between two window starts.
    pub fn step(&self) -> u64 {
        self.step
    }

    /// Start time of window `k`.
    pub fn start_of(&self, k: u64) -> u64 {
        self.start.saturating_add(k.saturating_mul(self.step))
    }

    /// End (exclusive) of window `k`.
    pub fn end_of(&self, k: u64) -> u64 {
        self.start_of(k).saturating_add(self.length)
    }

    /// The most windows that can hold one instant: `ceil(length / step)`.
    pub fn max_live(&self) -> usize {
        self.length.div_ceil(self.step) as usize
    }

    /// The first window starting strictly after `t`.
    pub fn first_starting_after(&self, t: u64) -> u64 {
        match t.checked_sub(self.start) {
            None => 0,
            Some(since) => since / self.step + 1,
        }
    }

    /// Indices of the windows that hold time `t` (`None` before the first window starts).
    pub fn live_at(&self, t: u64) -> Option<RangeInclusive<u64>> {
        let since = t.checked_sub(self.start)?;
        let last = since / self.step;
        let first = if since >= self.length {
            (since - self.length) / self.step + 1
        } else {
            0
        };
        Some(first..=last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    /// The live windows straight from the definition, by enumeration.
    fn live_brute(s: &WindowSchedule, t: u64) -> Vec<u64> {
        (0..=t)
            .filter(|&k| s.start_of(k) <= t && t < s.end_of(k))
            .collect()
    }

    #[test]
    fn live_windows_match_the_definition() {
        for (start, length, overlap) in [(0, 10, 0.0), (5, 10, 0.5), (3, 7, 0.9), (0, 1, 0.0)] {
            let s = WindowSchedule::new(start, length, overlap).unwrap();
            for t in 0..60 {
                let got: Vec<u64> = s.live_at(t).map(Iterator::collect).unwrap_or_default();
                assert_eq!(
                    got,
                    live_brute(&s, t),
                    "start {start} L {length} o {overlap} t {t}"
                );
                assert!(got.len() <= s.max_live());
                let after = s.first_starting_after(t);
                assert!(s.start_of(after) > t);
                assert!(after == 0 || s.start_of(after - 1) <= t);
            }
        }
    }

    #[test]
    fn step_rounds_down_and_is_at_least_one() {
        assert_eq!(window_step(10, 0.5).unwrap(), 5);
        assert_eq!(window_step(7, 0.5).unwrap(), 3);
        assert_eq!(window_step(3, 0.9).unwrap(), 1);
        assert_eq!(window_step(50, 0.9).unwrap(), 5);
        assert_eq!(window_step(10_000, 0.9).unwrap(), 1000);
        assert_eq!(WindowSchedule::new(0, 10, 0.9).unwrap().max_live(), 10);
    }

    #[test]
    fn absurd_parameters_are_rejected() {
        assert!(matches!(
            window_step(0, 0.0),
            Err(Error::InvalidParameter {
                name: "length_us",
                ..
            })
        ));
        for o in [f64::NAN, -0.1, 1.0, f64::INFINITY] {
            let err = window_step(10, o).unwrap_err();
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
    }
}
