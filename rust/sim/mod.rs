//! Simulation kernels: ordinary video frames to events (SPEC §4).
//!
//! Two models, both deterministic for a given seed and both fed one frame at a time so that a
//! video of any length runs in bounded memory:
//!
//! - [`pix2nvs`]: the "sim" domain, PIX2NVS (Bi & Andreopoulos, ICIP 2017) as its released code
//!   behaves — luma, natural log, a threshold, at most `n_max` events per pixel per frame with
//!   timestamps interpolated between frames, three reference-update modes, local inhibition in
//!   blocks and an adaptive threshold; optionally pooled down to a smaller sensor afterwards, as
//!   the paper did with its 1920×1080 footage.
//! - [`dvs`]: the "dvs" domain, a sensor emulator in the spirit of v2e and ESIM — exact per-pixel
//!   threshold crossings on the log intensity interpolated linearly between frames, threshold
//!   mismatch, refractory period, leak, shot noise, hot pixels and an intensity-dependent
//!   photoreceptor bandwidth.
//!
//! The choices, and where they follow or leave the reference implementations, are written down
//! in each module and in `docs/simulation.md`.

pub mod dvs;
pub mod frame;
pub mod pix2nvs;

mod order;
mod seed;

pub use dvs::{DvsEmulator, DvsParams, SubSamples};
pub use frame::Frame;
pub use pix2nvs::{Pix2Nvs, Pix2NvsParams, Pooling, ReferenceUpdate};
