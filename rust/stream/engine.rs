//! The network as the streaming detector's engine: one [`WindowState`] per live window, driven
//! through its incremental API (`begin`, `push`, `flush`).

use super::detector::{Detector, WindowEngine};
use crate::error::{Error, Result};
use crate::events::SensorSize;
use crate::network::{Detection, Network, WindowState};

/// A streaming detector running the network.
pub type NetworkDetector = Detector<Network>;

impl WindowEngine for Network {
    type State = WindowState;

    fn sensor(&self) -> Result<SensorSize> {
        let c = self.config();
        let side = |name: &'static str, v: usize| {
            u16::try_from(v).map_err(|_| {
                Error::param(name, format!("must be at most 65535 to stream, got {v}"))
            })
        };
        SensorSize::new(side("width", c.width)?, side("height", c.height)?)
    }

    fn new_state(&self) -> WindowState {
        Network::new_state(self)
    }

    fn state_bytes(&self) -> usize {
        // At most MAX_WINDOW_STATE_BYTES: a config needing more is refused when made.
        usize::try_from(self.geometry().state_bytes()).unwrap_or(usize::MAX)
    }

    /// PENT from the "preceding" estimate `n_in`, whatever the config's `pent.estimate`: a
    /// live stream cannot know a window's own count before the window is over.
    fn begin(&self, state: &mut WindowState, t0: u64, n_in: u64) -> Result<()> {
        state.begin(self, t0, &self.conv1_thresholds(n_in))
    }

    fn push(&self, state: &mut WindowState, t: u64, x: u16, y: u16) -> Result<()> {
        let decided = state.push(self, t, x, y)?;
        if decided.is_empty() {
            Ok(())
        } else {
            Err(Error::Internal(
                "a timestamp group was decided by push, not by settle".into(),
            ))
        }
    }

    fn settle(&self, state: &mut WindowState, out: &mut Vec<Detection>) -> Result<()> {
        out.extend_from_slice(state.flush(self)?);
        Ok(())
    }
}
