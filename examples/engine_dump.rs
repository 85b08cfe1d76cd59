//! Everything the engine outputs on the bench scenes, as text, for checking that a change to
//! the per-event path leaves every result bit for bit as it was:
//!
//! ```sh
//! cargo run --release --example engine_dump > before.txt   # on the old build
//! cargo run --release --example engine_dump > after.txt    # on the new one
//! cmp before.txt after.txt
//! ```
//!
//! For the 8 windows of the Criterion scenes (`benches/common`) at 64×48, 240×180 and 1280×720
//! (0.1, 1 and 5 % active; 1280×720 at 5 % is left out, as slow), through Table 1's network and
//! the recipe's, with recording on and off, and each window run twice in a row on one state: per
//! window, the layer counts, conv1's thresholds, every recorded spike of every layer (time, map,
//! position, potential as its bits) and every detection (time, map, position, box). Floats are
//! printed as their bits, so that a difference in the last bit shows.

use std::io::{self, BufWriter, Write};

use uavsnn::network::{Layer, Network, Spikes};

#[allow(dead_code)] // each example uses part of it
#[path = "../benches/common/mod.rs"]
mod common;
use common::{network, recipe_network, windows};

const LAYERS: [Layer; 5] = [
    Layer::Conv1,
    Layer::Pool1,
    Layer::Conv2,
    Layer::Pool2,
    Layer::Conv3,
];

fn dump(
    out: &mut impl Write,
    name: &str,
    net: &Network,
    width: usize,
    height: usize,
    density: f64,
) -> io::Result<()> {
    let ws = windows(width, height, density);
    for record in [false, true] {
        let mut state = net.new_state();
        for pass in 0..2 {
            for (i, w) in ws.iter().enumerate() {
                let spikes = Spikes::new(&w.t, &w.x, &w.y).expect("equal columns");
                net.run_window(&mut state, spikes, w.t0, None, record)
                    .expect("valid window");
                writeln!(
                    out,
                    "{name} {width}x{height} {density} record={record} pass={pass} window={i} counts={:?} thresholds={:?}",
                    state.counts(),
                    state.thresholds().iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                )?;
                if record {
                    for layer in LAYERS {
                        for s in state.spikes(layer) {
                            writeln!(
                                out,
                                "  {layer:?} t={} map={} row={} col={} v={:#x}",
                                s.t,
                                s.map,
                                s.row,
                                s.col,
                                s.v.to_bits()
                            )?;
                        }
                    }
                }
                for d in state.detections() {
                    writeln!(
                        out,
                        "  detection t={} map={} row={} col={} x={:#x} y={:#x} box=({}, {}, {}, {})",
                        d.t,
                        d.map,
                        d.row,
                        d.col,
                        d.x.to_bits(),
                        d.y.to_bits(),
                        d.x0,
                        d.y0,
                        d.x1,
                        d.y1
                    )?;
                }
            }
        }
    }
    Ok(())
}

fn main() -> io::Result<()> {
    let mut out = BufWriter::new(io::stdout().lock());
    for (width, height) in [(64, 48), (240, 180), (1280, 720)] {
        for density in [0.001, 0.01, 0.05] {
            if width == 1280 && density > 0.01 {
                continue;
            }
            dump(
                &mut out,
                "network",
                &network(width, height),
                width,
                height,
                density,
            )?;
            dump(
                &mut out,
                "recipe",
                &recipe_network(width, height),
                width,
                height,
                density,
            )?;
        }
    }
    out.flush()
}
