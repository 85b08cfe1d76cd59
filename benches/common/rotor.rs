//! The event streams of the rotor-signature bench (`benches/signature.rs`) and its instruction
//! counter (`examples/signature_work.rs`).

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use uavsnn::events::Event;

use super::common::Window;

/// The scenes' spikes as events with seeded polarities, one window after the other.
pub fn as_events(ws: &[Window]) -> Vec<Event> {
    let mut rng = Pcg64::seed_from_u64(7);
    ws.iter()
        .flat_map(|w| {
            (0..w.t.len())
                .map(|i| Event {
                    t: w.t[i],
                    x: w.x[i],
                    y: w.y[i],
                    p: rng.random(),
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// A 12×12 patch flickering at 400 Hz in a 32×32 box of uniform noise at 10^4 events/s.
pub fn flicker_box() -> Vec<Event> {
    let mut rng = Pcg64::seed_from_u64(11);
    let duration = 100_000.0;
    let period = 1e6 / 400.0;
    let mut out = Vec::new();
    for y in 10..22u16 {
        for x in 10..22u16 {
            let phase = rng.random::<f64>() * period;
            let mut start = phase;
            while start < duration {
                for (half, p) in [(0.0, true), (0.5, false)] {
                    let edge = start + half * period + (rng.random::<f64>() - 0.5) * 0.04 * period;
                    for r in 0..3 {
                        let t = edge + f64::from(r) * 0.02 * period;
                        if t < duration {
                            out.push(Event {
                                t: t as u64,
                                x,
                                y,
                                p,
                            });
                        }
                    }
                }
                start += period;
            }
        }
    }
    for _ in 0..1000 {
        out.push(Event {
            t: rng.random_range(0..duration as u64),
            x: rng.random_range(0..32),
            y: rng.random_range(0..32),
            p: rng.random(),
        });
    }
    out.sort_by_key(|e| e.t);
    out
}
