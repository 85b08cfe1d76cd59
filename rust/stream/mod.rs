//! Low-latency detection on a live event stream (SPEC §6, issue 6).
//!
//! [`Detector`] takes chunks of events of any size in time order and returns each conv3
//! detection as soon as it is decided, without waiting for its window to close. Overlapping
//! windows run as staggered network states, PENT thresholds come from the "preceding" estimate
//! kept incrementally by [`PrecedingCounter`], and the whole stream runs in memory bounded by the
//! sensor area and the number of overlapping windows. [`PacketDecoder`] reads the UDP packet
//! formats of faery and aestream.
//!
//! The detections equal those of the batch path (`make_windows` + `Network::infer` with the
//! "preceding" PENT estimate) on the same recording, whatever the chunking.

mod detector;
mod engine;
mod packets;
mod preceding;
mod schedule;

pub use detector::{
    Detector, StreamConfig, StreamDetection, StreamStats, WindowEngine, MAX_LIVE_WINDOWS,
    PUSH_SLICE,
};
pub use engine::NetworkDetector;
pub use packets::{PacketDecoder, PacketFormat, MAX_HELD_BYTES, RESTART_AFTER};
pub use preceding::PrecedingCounter;
pub use schedule::{window_step, WindowSchedule};

#[cfg(test)]
mod tests;
