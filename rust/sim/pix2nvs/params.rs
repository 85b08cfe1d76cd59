//! The simulator's parameters ([`Pix2NvsParams`]: PIX2NVS's own, and ours) and their bounds.

use crate::error::{Error, Result};

/// How the reference (memorised log luma) follows the video: PIX2NVS's `-r 1|2|3`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReferenceUpdate {
    /// `-r 1`: after each frame the reference is the frame.
    #[default]
    Frame,
    /// `-r 2`: the reference takes the frame's value only at pixels that emitted.
    EventCopy,
    /// `-r 3`: an emitting pixel's reference moves by the `n·θ` it emitted; the remainder stays.
    EventIncrement,
}

/// How events at the source resolution are pooled onto a smaller output sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pooling {
    /// Per output pixel and frame interval, only the events of the strongest source pixel.
    #[default]
    Strongest,
    /// Every event, with its coordinates scaled.
    All,
}

/// Parameters of PIX2NVS. Defaults are PIX2NVS's own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pix2NvsParams {
    /// Initial threshold `θ` on the change of natural-log luma (PIX2NVS: 0.4, range 0.2–0.7).
    pub threshold: f32,
    /// At most this many events per pixel per frame (PIX2NVS: 5, range 1–5).
    pub n_max: u32,
    /// Reference update mode (PIX2NVS: 1).
    pub reference: ReferenceUpdate,
    /// Side of the local-inhibition blocks; 1 disables inhibition (PIX2NVS: 1; allows 1, 2, 4).
    pub block_size: usize,
    /// Adaptive threshold step: ×(1+a) after emitting, ×(1−a) otherwise; 0 disables
    /// (PIX2NVS: 0.05, range 0–0.1; our default 0, as in PIX2NVS's worked example `-a 0`).
    pub adaptive: f32,
    /// Lowest value the adaptive threshold may reach (PIX2NVS: none, i.e. 0).
    pub threshold_min: f32,
    /// Highest value the adaptive threshold may reach (PIX2NVS: none, i.e. infinity).
    pub threshold_max: f32,
    /// Added to luma before the logarithm (not in PIX2NVS; keeps black pixels finite). Not
    /// used with `compat`.
    pub log_offset: f32,
    /// Reproduce the released program's events exactly, quirks included (module docs).
    pub compat: bool,
}

impl Default for Pix2NvsParams {
    fn default() -> Self {
        Self {
            threshold: 0.4,
            n_max: 5,
            reference: ReferenceUpdate::Frame,
            block_size: 1,
            adaptive: 0.0,
            threshold_min: 0.0,
            threshold_max: f32::INFINITY,
            log_offset: 1.0,
            compat: false,
        }
    }
}

/// Largest `n_max` accepted (events are counted in an `i8` per pixel and frame).
pub const MAX_N_MAX: u32 = 127;

impl Pix2NvsParams {
    /// Reject values that cannot make sense, naming the parameter and the value.
    pub fn validate(&self) -> Result<()> {
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err(Error::param(
                "threshold",
                format!("must be finite and > 0, got {}", self.threshold),
            ));
        }
        if !(1..=MAX_N_MAX).contains(&self.n_max) {
            return Err(Error::param(
                "n_max",
                format!("must be in 1..={MAX_N_MAX}, got {}", self.n_max),
            ));
        }
        if self.block_size == 0 || self.block_size > 256 {
            return Err(Error::param(
                "block_size",
                format!("must be in 1..=256, got {}", self.block_size),
            ));
        }
        if !(self.adaptive.is_finite() && (0.0..1.0).contains(&self.adaptive)) {
            return Err(Error::param(
                "adaptive",
                format!("must be in [0, 1), got {}", self.adaptive),
            ));
        }
        if !(self.threshold_min >= 0.0
            && self.threshold_min <= self.threshold
            && self.threshold <= self.threshold_max)
        {
            return Err(Error::param(
                "threshold_min, threshold_max",
                format!(
                    "need 0 <= threshold_min <= threshold <= threshold_max, got {} <= {} <= {}",
                    self.threshold_min, self.threshold, self.threshold_max
                ),
            ));
        }
        if self.compat && (self.threshold_min != 0.0 || self.threshold_max != f32::INFINITY) {
            return Err(Error::param(
                "threshold_min, threshold_max",
                "PIX2NVS has no bounds on its adaptive threshold: leave them unset with compat"
                    .to_string(),
            ));
        }
        if !(self.log_offset.is_finite() && self.log_offset > 0.0) {
            return Err(Error::param(
                "log_offset",
                format!("must be finite and > 0, got {}", self.log_offset),
            ));
        }
        Ok(())
    }
}
