//! A fixed amount of engine work on the bench scenes, for counting instructions: on a shared
//! machine whose speed drifts, the instructions a change saves are a figure that does not.
//!
//! ```sh
//! cargo build --release --example engine_work
//! valgrind --tool=callgrind --toggle-collect='engine_work::run_all' \
//!     target/release/examples/engine_work 240 180 0.05 [network|recipe|conv1]
//! ```
//!
//! Runs the 8 windows of the Criterion scene (`benches/common`) twice through the network (the
//! first pass warms the state; callgrind counts both), then prints the last window's spikes per
//! layer. `network` is Table 1, `recipe` Table 1 with the recipe's conv2 threshold, `conv1`
//! Table 1 run only to conv1.

use uavsnn::network::{Layer, Network, Spikes, WindowState};

#[allow(dead_code)] // each example uses part of it
#[path = "../benches/common/mod.rs"]
mod common;
use common::{network, recipe_network, windows, Window};

/// The measured work (the name callgrind's `--toggle-collect` selects).
#[inline(never)]
fn run_all(net: &Network, state: &mut WindowState, ws: &[Window]) {
    for w in ws {
        let spikes = Spikes::new(&w.t, &w.x, &w.y).expect("equal columns");
        net.run_window(state, spikes, w.t0, None, false)
            .expect("valid window");
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: engine_work WIDTH HEIGHT DENSITY [network|recipe|conv1]";
    let number = |i: usize| {
        args.get(i)
            .and_then(|a| a.parse::<f64>().ok())
            .expect(usage)
    };
    let (width, height, density) = (number(0) as usize, number(1) as usize, number(2));
    let which = args.get(3).map_or("network", String::as_str);
    let net = match which {
        "recipe" => recipe_network(width, height),
        "network" | "conv1" => network(width, height),
        _ => panic!("{usage}"),
    };
    let ws = windows(width, height, density);
    let mut state = net.new_state();
    if which == "conv1" {
        state.set_depth(Layer::Conv1);
    }
    run_all(&net, &mut state, &ws);
    run_all(&net, &mut state, &ws);
    let events: usize = ws.iter().map(|w| w.t.len()).sum();
    println!(
        "{which} {width}x{height} {density}: {events} input events per pass; last window's spikes per layer {:?}",
        state.counts()
    );
}
