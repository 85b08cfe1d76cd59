//! A fixed amount of rotor-signature work, for counting instructions per event (the streams of
//! `benches/signature.rs`):
//!
//! ```sh
//! cargo build --release --example signature_work
//! valgrind --tool=callgrind --toggle-collect='signature_work::run_all' \
//!     target/release/examples/signature_work [sensor|flicker]
//! valgrind --tool=callgrind --toggle-collect='signature_work::run_spectrum' \
//!     target/release/examples/signature_work spectrum
//! ```
//!
//! `sensor`: the engine bench's 240×180 scenes at 1 % (eight 50 ms windows) through an estimator
//! over the whole sensor; `flicker`: a 32×32 box with a 12×12 patch flickering at 400 Hz over
//! noise, cleared, fed and read; `spectrum`: that box through the rate spectrum
//! (`uavsnn::signature::spectrum`), cleared, fed and read (the estimate's DFT included). Each
//! stream runs twice; the program prints the events fed, so
//! that callgrind's "Collected" divided by them is the instructions per event.

use uavsnn::events::{Event, SensorSize};
use uavsnn::signature::spectrum::{RotorSpectrum, Spectrum, SpectrumConfig};
use uavsnn::signature::{Region, RotorConfig, RotorSignature, Signature};

#[allow(dead_code)] // each example uses part of it
#[path = "../benches/common/mod.rs"]
mod common;
#[path = "../benches/common/rotor.rs"]
mod rotor;

/// The measured work (the name callgrind's `--toggle-collect` selects).
#[inline(never)]
fn run_all(sig: &mut RotorSignature, events: &[Event], passes: u64, span: u64) -> Signature {
    for pass in 0..passes {
        for e in events {
            sig.push(Event {
                t: e.t + pass * span,
                ..*e
            });
        }
    }
    sig.estimate()
}

/// The rate spectrum's measured work: per pass, clear, feed the box's events and read.
#[inline(never)]
fn run_spectrum(spec: &mut RotorSpectrum, events: &[Event], passes: u64) -> Spectrum {
    let mut est = Spectrum::default();
    for _ in 0..passes {
        spec.clear();
        for e in events {
            spec.push(*e);
        }
        est = spec.estimate();
    }
    est
}

fn main() {
    let which = std::env::args().nth(1).unwrap_or_else(|| "sensor".into());
    if which == "spectrum" {
        let region = Region::new(0, 0, 32, 32).expect("a region");
        let mut spec =
            RotorSpectrum::new(SpectrumConfig::default(), region).expect("defaults are valid");
        let events = rotor::flicker_box();
        let passes = 2;
        let est = run_spectrum(&mut spec, &events, passes);
        println!(
            "spectrum: {} events fed ({} per pass); {est:?}",
            events.len() as u64 * passes,
            events.len()
        );
        return;
    }
    let (mut sig, events) = match which.as_str() {
        "sensor" => {
            let sensor = SensorSize::new(240, 180).expect("a sensor");
            let region = Region::sensor(sensor).expect("a region");
            let events = rotor::as_events(&common::windows(240, 180, 0.01));
            (RotorSignature::new(RotorConfig::default(), region), events)
        }
        "flicker" => {
            let region = Region::new(0, 0, 32, 32).expect("a region");
            (
                RotorSignature::new(RotorConfig::default(), region),
                rotor::flicker_box(),
            )
        }
        other => panic!("usage: signature_work [sensor|flicker|spectrum], got {other}"),
    };
    let sig = sig.as_mut().expect("defaults are valid");
    let span = events.last().map_or(0, |e| e.t + 1);
    let passes = 2;
    let est = run_all(sig, &events, passes, span);
    println!(
        "{which}: {} events fed ({} per pass); {est:?}",
        events.len() as u64 * passes,
        events.len()
    );
}
