//! End-to-end checks of the event-driven engine against a plain dense, layer-by-layer
//! implementation of docs/model.md written here for clarity (test-only), on random small
//! networks and windows, with one engine state reused across windows (sparse resets).

#![allow(clippy::float_cmp, clippy::needless_range_loop)] // exact equality; dense loops by index

use proptest::prelude::*;

use super::*;
use crate::error::Error;

/// Spike times of a layer's neurons, `[map][row][col]`, `None` = silent.
type Times = Vec<Vec<Vec<Option<u64>>>>;

/// A dense layer's output: spike times and potentials at the firing time.
struct DenseConv {
    times: Times,
    v: Vec<Vec<Vec<f64>>>,
    /// Every neuron that crossed (time, potential) — before inhibition.
    crossed: Vec<(u64, f64, usize, usize, usize)>,
}

fn dense_conv(
    g: &ConvGeom,
    w: &ConvWeights,
    input: &Times,
    thresholds: &[f64],
    inhibit: bool,
) -> DenseConv {
    let mut taus: Vec<u64> = input
        .iter()
        .flatten()
        .flatten()
        .flatten()
        .copied()
        .collect();
    taus.sort_unstable();
    taus.dedup();
    let mut cross = vec![vec![vec![None::<(u64, f64)>; g.out_w]; g.out_h]; g.maps];
    for m in 0..g.maps {
        for oy in 0..g.out_h {
            for ox in 0..g.out_w {
                for &tau in &taus {
                    let mut v = 0.0f64;
                    for c in 0..g.in_ch {
                        for dy in 0..g.k {
                            for dx in 0..g.k {
                                let (iy, ix) = (oy + dy, ox + dx);
                                if iy < g.p_lo || ix < g.p_lo {
                                    continue;
                                }
                                let (iy, ix) = (iy - g.p_lo, ix - g.p_lo);
                                if iy >= g.in_h || ix >= g.in_w {
                                    continue;
                                }
                                if input[c][iy][ix].is_some_and(|t| t <= tau) {
                                    v += f64::from(w.kernel(m)[(c * g.k + dy) * g.k + dx]);
                                }
                            }
                        }
                    }
                    if v >= thresholds[m] {
                        cross[m][oy][ox] = Some((tau, v));
                        break;
                    }
                }
            }
        }
    }
    let mut out = DenseConv {
        times: vec![vec![vec![None; g.out_w]; g.out_h]; g.maps],
        v: vec![vec![vec![0.0; g.out_w]; g.out_h]; g.maps],
        crossed: Vec::new(),
    };
    for oy in 0..g.out_h {
        for ox in 0..g.out_w {
            let mut best: Option<(u64, f64, usize)> = None;
            for (m, map) in cross.iter().enumerate() {
                if let Some((t, v)) = map[oy][ox] {
                    out.crossed.push((t, v, m, oy, ox));
                    if !inhibit {
                        out.times[m][oy][ox] = Some(t);
                        out.v[m][oy][ox] = v;
                    }
                    let better = match best {
                        None => true,
                        Some((bt, bv, _)) => t < bt || (t == bt && v > bv),
                    };
                    if better {
                        best = Some((t, v, m));
                    }
                }
            }
            if inhibit {
                if let Some((t, v, m)) = best {
                    out.times[m][oy][ox] = Some(t);
                    out.v[m][oy][ox] = v;
                }
            }
        }
    }
    out
}

fn dense_pool(g: &PoolGeom, input: &Times) -> Times {
    let mut out = vec![vec![vec![None; g.out_w]; g.out_h]; g.maps];
    for (m, map) in out.iter_mut().enumerate() {
        for (qy, row) in map.iter_mut().enumerate() {
            for (qx, cell) in row.iter_mut().enumerate() {
                for iy in g.inputs_of(qy, g.in_h) {
                    for ix in g.inputs_of(qx, g.in_w) {
                        if let Some(t) = input[m][iy][ix] {
                            *cell = Some(cell.map_or(t, |c: u64| c.min(t)));
                        }
                    }
                }
            }
        }
    }
    out
}

fn spikes_of(times: &Times, v: Option<&Vec<Vec<Vec<f64>>>>) -> Vec<LayerSpike> {
    let mut out = Vec::new();
    for (m, map) in times.iter().enumerate() {
        for (r, row) in map.iter().enumerate() {
            for (c, t) in row.iter().enumerate() {
                if let Some(t) = t {
                    out.push(LayerSpike {
                        t: *t,
                        map: m as u16,
                        row: r as u16,
                        col: c as u16,
                        v: v.map_or(0.0, |v| v[m][r][c] as f32),
                    });
                }
            }
        }
    }
    out.sort_unstable_by_key(|s| (s.t, s.map, s.row, s.col));
    out
}

/// The dense model on one window: every layer's spikes, and for `train`, the winners.
fn dense_window(
    net: &Network,
    t: &[u64],
    x: &[u16],
    y: &[u16],
    train: Option<usize>,
) -> ([Vec<LayerSpike>; 5], Vec<Winner>) {
    let c = net.config();
    let g = net.geometry();
    let mut frame: Times = vec![vec![vec![None; c.width]; c.height]];
    for i in 0..t.len() {
        let cell = &mut frame[0][y[i] as usize][x[i] as usize];
        if cell.is_none() {
            *cell = Some(t[i]);
        }
    }
    let th1: Vec<f64> = net
        .conv1_thresholds(t.len() as u64)
        .iter()
        .map(|&v| f64::from(v))
        .collect();
    let mut traces: [Vec<LayerSpike>; 5] = Default::default();
    let mut input = frame;
    for layer in 0..3 {
        let lc = c.conv(layer);
        let th = if layer == 0 {
            th1.clone()
        } else {
            vec![f64::from(lc.threshold); lc.maps]
        };
        let training = train == Some(layer);
        let conv = dense_conv(
            &g.conv[layer],
            net.conv_weights(ConvLayer::ALL[layer]),
            &input,
            &th,
            lc.lateral_inhibition && !training,
        );
        traces[2 * layer] = spikes_of(&conv.times, Some(&conv.v));
        if training {
            let mut all = conv.crossed.clone();
            all.sort_by(|a, b| {
                a.0.cmp(&b.0)
                    .then(b.1.total_cmp(&a.1))
                    .then((a.2, a.3, a.4).cmp(&(b.2, b.3, b.4)))
            });
            let mut winners: Vec<Winner> = Vec::new();
            for (t, v, m, r, col) in all {
                if winners.len() >= lc.wta_k {
                    break;
                }
                let taken = winners.iter().any(|w| w.map as usize == m);
                let near = winners.iter().any(|w| {
                    (w.row as usize).abs_diff(r) <= lc.wta_radius
                        && (w.col as usize).abs_diff(col) <= lc.wta_radius
                });
                if !taken && !near {
                    winners.push(Winner {
                        t,
                        map: m as u16,
                        row: r as u16,
                        col: col as u16,
                        v,
                    });
                }
            }
            return (traces, winners);
        }
        if layer == 2 {
            break;
        }
        let pooled = dense_pool(&g.pool[layer], &conv.times);
        traces[2 * layer + 1] = spikes_of(&pooled, None);
        input = pooled;
    }
    (traces, Vec::new())
}

/// `dense_box`'s walk down the causes, widening `b`.
struct Walk<'a> {
    g: &'a Geometry,
    pixels: &'a [Vec<Option<u64>>],
    times: &'a [std::collections::HashMap<(usize, usize, usize), u64>],
    b: Option<(u16, u16, u16, u16)>,
}

impl Walk<'_> {
    fn conv(&mut self, layer: usize, row: usize, col: usize, t: u64) {
        let cg = self.g.conv[layer];
        for ch in 0..cg.in_ch {
            for iy in cg.inputs_of(row, cg.in_h) {
                for ix in cg.inputs_of(col, cg.in_w) {
                    if layer == 0 {
                        if self.pixels[iy][ix].is_some_and(|ti| ti <= t) {
                            let (x, y) = (ix as u16, iy as u16);
                            let b = self.b.get_or_insert((x, y, x + 1, y + 1));
                            *b = (b.0.min(x), b.1.min(y), b.2.max(x + 1), b.3.max(y + 1));
                        }
                    } else if let Some(&ti) = self.times[2 * layer - 1].get(&(ch, iy, ix)) {
                        if ti <= t {
                            self.pool(layer - 1, ch, iy, ix, ti);
                        }
                    }
                }
            }
        }
    }

    fn pool(&mut self, layer: usize, map: usize, qy: usize, qx: usize, tq: u64) {
        let pg = self.g.pool[layer];
        for row in pg.inputs_of(qy, pg.in_h) {
            for col in pg.inputs_of(qx, pg.in_w) {
                if self.times[2 * layer].get(&(map, row, col)) == Some(&tq) {
                    self.conv(layer, row, col, tq);
                }
            }
        }
    }
}

/// A detection's box by docs/model.md §5 from the dense model's spikes, followed down without
/// shortcuts: a conv spike at `t` is caused by the inputs of its field that fired at or before
/// `t`, a pool spike by the spikes of its map in its block at its time, a pixel by itself.
fn dense_box(
    net: &Network,
    t: &[u64],
    x: &[u16],
    y: &[u16],
    spikes: &[Vec<LayerSpike>; 5],
    d: &Detection,
) -> (u16, u16, u16, u16) {
    let g = net.geometry();
    let mut pixels: Vec<Vec<Option<u64>>> = vec![vec![None; g.conv[0].in_w]; g.conv[0].in_h];
    for i in 0..t.len() {
        pixels[y[i] as usize][x[i] as usize].get_or_insert(t[i]);
    }
    // Per layer, `(map, row, col) → time`.
    let times: Vec<std::collections::HashMap<(usize, usize, usize), u64>> = spikes
        .iter()
        .map(|l| {
            l.iter()
                .map(|s| ((s.map as usize, s.row as usize, s.col as usize), s.t))
                .collect()
        })
        .collect();
    let mut walk = Walk {
        g,
        pixels: &pixels,
        times: &times,
        b: None,
    };
    walk.conv(2, d.row as usize, d.col as usize, d.t);
    walk.b.unwrap_or_else(|| {
        let (rows, cols) = g.conv3_receptive_field(d.row as usize, d.col as usize);
        (
            cols.start as u16,
            rows.start as u16,
            cols.end as u16,
            rows.end as u16,
        )
    })
}

/// A random small network config.
fn config_strategy() -> impl Strategy<Value = NetworkConfig> {
    (
        (6usize..20, 6usize..20, any::<bool>()),
        (1usize..6, 1usize..5, 0.5f32..4.0, any::<bool>()),
        (1usize..4, 1usize..4),
        (1usize..5, 1usize..5, 0.3f32..3.0, any::<bool>()),
        (1usize..3, 1usize..3),
        (1usize..4, 1usize..4, 0.3f32..2.0, any::<bool>()),
        (any::<bool>(), 0.0f64..20.0, 0.5f64..3.0),
        (1usize..5, 0usize..4),
    )
        .prop_map(|(sensor, c1, p1, c2, p2, c3, pent, wta)| {
            let mut c = NetworkConfig {
                width: sensor.0,
                height: sensor.1,
                padding: if sensor.2 {
                    Padding::Same
                } else {
                    Padding::Valid
                },
                ..NetworkConfig::default()
            };
            // Thresholds on a grid of 1/4, to meet potentials exactly.
            let conv = |(kernel, maps, threshold, li): (usize, usize, f32, bool)| ConvConfig {
                kernel,
                maps,
                threshold: (threshold * 4.0).round().max(1.0) / 4.0,
                lateral_inhibition: li,
                wta_k: wta.0,
                wta_radius: wta.1,
            };
            c.conv1 = conv(c1);
            c.conv2 = conv(c2);
            c.conv3 = conv(c3);
            c.pool1 = PoolConfig {
                kernel: p1.0,
                stride: p1.1,
            };
            c.pool2 = PoolConfig {
                kernel: p2.0,
                stride: p2.1,
            };
            c.pent.mode = if pent.0 {
                ThresholdMode::Pent
            } else {
                ThresholdMode::Static
            };
            c.pent.beta = pent.1;
            c.pent.theta_min = (pent.2 * 4.0).round().max(1.0) / 4.0;
            c
        })
        .prop_filter("layers must fit", |c| c.validate().is_ok())
}

/// Weights on a grid of 1/8 (equal potentials and potentials exactly at a threshold are
/// common), of 2⁻¹², or of 2⁻²⁴ (float32 running sums round), by seed.
fn random_weights(net: &mut Network, seed: u64) {
    let steps = [8, 1 << 12, 1 << 24][(seed % 3) as usize];
    let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    for layer in ConvLayer::ALL {
        let n = net.conv_weights(layer).canonical().len();
        let w = (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                ((s >> 40) % (steps + 1)) as f32 / steps as f32
            })
            .collect();
        net.set_weights(layer, w).unwrap();
    }
}

/// Random windows: pixels with times in a small range (many equal times).
fn window(c: &NetworkConfig, seed: u64, n: usize, t0: u64) -> (Vec<u64>, Vec<u16>, Vec<u16>) {
    let mut rng = crate::network::xorshift(seed | 1);
    let mut next = |m: u64| {
        let s = rng();
        s % m
    };
    let mut v: Vec<(u64, u16, u16)> = (0..n)
        .map(|_| {
            (
                t0 + next(12),
                next(c.width as u64) as u16,
                next(c.height as u64) as u16,
            )
        })
        .collect();
    v.sort_by_key(|e| e.0);
    (
        v.iter().map(|e| e.0).collect(),
        v.iter().map(|e| e.1).collect(),
        v.iter().map(|e| e.2).collect(),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn engine_equals_dense_reference(c in config_strategy(), seed in any::<u64>()) {
        let mut net = Network::new(c.clone(), seed).unwrap();
        random_weights(&mut net, seed);
        let mut state = net.new_state();
        for w in 0..3u64 {
            let n = (seed.wrapping_add(w) % (c.width as u64 * c.height as u64)) as usize;
            let (t, x, y) = window(&c, seed.wrapping_add(w * 7919), n, 100 * w);
            net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, true)
                .unwrap();
            let (dense, _) = dense_window(&net, &t, &x, &y, None);
            for layer in Layer::ALL {
                prop_assert_eq!(state.spikes(layer), &dense[layer.index()][..], "{}", layer);
                prop_assert_eq!(state.counts()[layer.index()], dense[layer.index()].len() as u64);
            }
            // Without recording, potentials are gathered exactly only where decisions need
            // them: the same spikes must come out.
            let mut quiet = net.new_state();
            net.run_window(&mut quiet, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, false)
                .unwrap();
            prop_assert_eq!(quiet.counts(), state.counts());
            prop_assert_eq!(quiet.detections(), state.detections());
            let det: Vec<_> = state.detections().iter().map(|d| (d.t, d.map, d.row, d.col)).collect();
            let mut want: Vec<_> = dense[4].iter().map(|s| (s.t, s.map, s.row, s.col)).collect();
            let mut got = det.clone();
            got.sort_unstable();
            want.sort_unstable();
            prop_assert_eq!(got, want);
            for d in state.detections() {
                let want = dense_box(&net, &t, &x, &y, &dense, d);
                prop_assert_eq!((d.x0, d.y0, d.x1, d.y1), want, "{:?}", d);
            }
        }
    }

    #[test]
    fn stdp_step_equals_dense_reference(
        c in config_strategy(),
        seed in any::<u64>(),
        layer in 0usize..3,
    ) {
        let mut net = Network::new(c.clone(), seed).unwrap();
        random_weights(&mut net, seed);
        let mut state = net.new_state();
        let conv = ConvLayer::ALL[layer];
        for w in 0..3u64 {
            let n = (seed.wrapping_add(w) % (c.width as u64 * c.height as u64)) as usize;
            let (t, x, y) = window(&c, seed.wrapping_add(w * 31), n, 50 * w);
            let (_, want) = dense_window(&net, &t, &x, &y, Some(layer));
            let mut expected = net.clone();
            let rates = Rates { a_plus: 0.25, a_minus: -0.125 };
            // The dense update: inputs' first spikes from the dense run of the layers below.
            dense_stdp(&mut expected, &t, &x, &y, layer, &want, rates);
            let got = net
                .stdp_step(&mut state, conv, Spikes::new(&t, &x, &y).unwrap(), 50 * w, None, rates)
                .unwrap();
            prop_assert_eq!(&got, &want);
            prop_assert_eq!(net.conv_weights(conv), expected.conv_weights(conv));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Waking positions by count (the default only for layers with many maps) changes no
    /// spike, potential, detection or STDP update, on any layer.
    #[test]
    fn waking_by_count_equals_dense_reference(
        c in config_strategy(),
        seed in any::<u64>(),
        layer in 0usize..3,
    ) {
        let mut net = Network::new(c.clone(), seed).unwrap();
        random_weights(&mut net, seed);
        let mut state = net.new_state();
        for w in 0..3u64 {
            // Denser windows than above, so that many positions wake.
            let n = (seed.wrapping_add(w) % (2 * c.width as u64 * c.height as u64)) as usize;
            let (t, x, y) = window(&c, seed.wrapping_add(w * 104_729), n, 100 * w);
            let (dense, _) = dense_window(&net, &t, &x, &y, None);
            for (gated, record) in [(true, true), (true, false), (false, false)] {
                state.set_gated(gated);
                net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, record)
                    .unwrap();
                for l in Layer::ALL {
                    prop_assert_eq!(state.counts()[l.index()], dense[l.index()].len() as u64);
                    if record {
                        prop_assert_eq!(state.spikes(l), &dense[l.index()][..], "{}", l);
                    }
                }
            }
            state.set_gated(true);
            let (_, want) = dense_window(&net, &t, &x, &y, Some(layer));
            let mut expected = net.clone();
            let rates = Rates { a_plus: 0.25, a_minus: -0.125 };
            dense_stdp(&mut expected, &t, &x, &y, layer, &want, rates);
            let conv = ConvLayer::ALL[layer];
            let got = net
                .stdp_step(&mut state, conv, Spikes::new(&t, &x, &y).unwrap(), 100 * w, None, rates)
                .unwrap();
            prop_assert_eq!(&got, &want);
            prop_assert_eq!(net.conv_weights(conv), expected.conv_weights(conv));
        }
    }
}

/// Apply STDP densely for `winners` of `layer`, computing input spike times with the dense
/// model.
fn dense_stdp(
    net: &mut Network,
    t: &[u64],
    x: &[u16],
    y: &[u16],
    layer: usize,
    winners: &[Winner],
    rates: Rates,
) {
    let c = net.config().clone();
    let g = net.geometry().conv[layer];
    // The input of `layer`: pixels, pool1 or pool2 spike times.
    let input: Times = if layer == 0 {
        let mut f = vec![vec![vec![None; c.width]; c.height]];
        for i in 0..t.len() {
            let cell = &mut f[0][y[i] as usize][x[i] as usize];
            if cell.is_none() {
                *cell = Some(t[i]);
            }
        }
        f
    } else {
        let (traces, _) = dense_window(net, t, x, y, None);
        let pool = &traces[2 * layer - 1];
        let pg = net.geometry().pool[layer - 1];
        let mut f = vec![vec![vec![None; pg.out_w]; pg.out_h]; pg.maps];
        for s in pool {
            f[s.map as usize][s.row as usize][s.col as usize] = Some(s.t);
        }
        f
    };
    let conv = ConvLayer::ALL[layer];
    let mut w = net.conv_weights(conv).canonical().to_vec();
    let n = g.kernel_len();
    for win in winners {
        for ch in 0..g.in_ch {
            for dy in 0..g.k {
                for dx in 0..g.k {
                    let iy = (win.row as usize + dy).checked_sub(g.p_lo);
                    let ix = (win.col as usize + dx).checked_sub(g.p_lo);
                    let fired = match (iy, ix) {
                        (Some(iy), Some(ix)) if iy < g.in_h && ix < g.in_w => {
                            input[ch][iy][ix].is_some_and(|ti| ti <= win.t)
                        }
                        _ => false,
                    };
                    let a = if fired { rates.a_plus } else { rates.a_minus };
                    let i = win.map as usize * n + (ch * g.k + dy) * g.k + dx;
                    w[i] = stdp::updated(w[i], a);
                }
            }
        }
    }
    net.set_weights(conv, w).unwrap();
}

#[test]
fn generation_wrap_keeps_results() {
    let c = NetworkConfig {
        width: 30,
        height: 20,
        ..NetworkConfig::default()
    };
    let mut net = Network::new(c.clone(), 1).unwrap();
    random_weights(&mut net, 3);
    let (t, x, y) = window(&c, 11, 200, 0);
    let mut a = net.new_state();
    net.run_window(&mut a, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    let mut b = net.new_state();
    b.set_generation(u32::MAX - 1);
    for _ in 0..3 {
        net.run_window(&mut b, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
            .unwrap();
        for layer in Layer::ALL {
            assert_eq!(a.spikes(layer), b.spikes(layer));
        }
    }
}

#[test]
fn a_line_makes_the_matching_gabor_fire_at_its_last_pixel() {
    // A vertical line of 5 pixels, one pixel per microsecond: the 0° kernel (vertical edges)
    // centred on the line reaches its threshold at exactly the pixel that brings the sum of its
    // centre column over it.
    let mut c = NetworkConfig {
        width: 20,
        height: 20,
        ..NetworkConfig::default()
    };
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 4.0;
    let net = Network::new(c, 0).unwrap();
    let w = net.conv_weights(ConvLayer::Conv1).kernel(0).to_vec();
    let column: Vec<f64> = (0..5).map(|r| f64::from(w[r * 5 + 2])).collect();
    let mut sum = 0.0;
    let crossing = column
        .iter()
        .position(|&v| {
            sum += v;
            sum >= 4.0
        })
        .unwrap() as u64;
    let t: Vec<u64> = (0..5).collect();
    let x = vec![10u16; 5];
    let y: Vec<u16> = (8..13).collect();
    let mut state = net.new_state();
    net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    let centre = state
        .spikes(Layer::Conv1)
        .iter()
        .find(|s| (s.row, s.col) == (10, 10))
        .copied()
        .unwrap();
    assert_eq!((centre.map, centre.t), (0, crossing));
    assert_eq!(
        centre.v,
        column[..=crossing as usize].iter().sum::<f64>() as f32
    );
    // Raising the threshold past the whole column silences the centre neuron.
    let mut c = net.config().clone();
    c.conv1.threshold = (column.iter().sum::<f64>() + 0.01) as f32;
    let net = Network::new(c, 0).unwrap();
    let mut state = net.new_state();
    net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    assert!(state
        .spikes(Layer::Conv1)
        .iter()
        .all(|s| (s.row, s.col) != (10, 10) || s.map != 0));
}

/// `run_window` checks a window's spikes together before taking them without per-spike checks:
/// a bad spike anywhere gives the error, with its index, that pushing the groups one by one
/// gives, after the same earlier spikes.
#[test]
fn run_window_refuses_bad_spikes_like_push_group() {
    let c = NetworkConfig {
        width: 24,
        height: 18,
        ..NetworkConfig::default()
    };
    let net = Network::new(c.clone(), 3).unwrap();
    let (t, x, y) = window(&c, 11, 300, 1_000);
    let k = 150;
    let mut cases = Vec::new();
    for bad in 0..4 {
        let (mut t, mut x, mut y) = (t.clone(), x.clone(), y.clone());
        match bad {
            0 => x[k] = c.width as u16,
            1 => y[k] = c.height as u16,
            2 => t[k] = t[k - 1] - 1,
            _ => t[0] = 999, // before t0
        }
        cases.push((t, x, y));
    }
    for (t, x, y) in &cases {
        let mut a = net.new_state();
        let spikes = Spikes::new(t, x, y).unwrap();
        let err_a = net
            .run_window(&mut a, spikes, 1_000, None, false)
            .unwrap_err();
        let mut b = net.new_state();
        b.begin(&net, 1_000, &net.conv1_thresholds(t.len() as u64))
            .unwrap();
        let mut start = 0;
        let err_b = loop {
            let end = start + t[start..].iter().take_while(|&&ti| ti == t[start]).count();
            if let Err(e) = b.push_group(&net, t[start], &x[start..end], &y[start..end]) {
                break e;
            }
            start = end;
        };
        assert_eq!(err_a.to_string(), err_b.to_string());
        assert_eq!(a.counts(), b.counts());
        assert_eq!(a.input_count(), b.input_count());
    }
}

#[test]
fn push_api_matches_run_window_and_reports_detections_early() {
    let c = NetworkConfig {
        width: 40,
        height: 30,
        ..NetworkConfig::default()
    };
    let mut c = c;
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 1.5;
    c.conv2.threshold = 2.0;
    c.conv3.threshold = 1.0;
    let mut net = Network::new(c.clone(), 2).unwrap();
    random_weights(&mut net, 9);
    let (t, x, y) = window(&c, 5, 400, 0);
    let mut a = net.new_state();
    net.run_window(&mut a, Spikes::new(&t, &x, &y).unwrap(), 0, None, false)
        .unwrap();
    assert!(!a.detections().is_empty(), "the test needs detections");
    let mut b = net.new_state();
    b.begin(&net, 0, &net.conv1_thresholds(t.len() as u64))
        .unwrap();
    let mut seen = Vec::new();
    for i in 0..t.len() {
        for d in b.push(&net, t[i], x[i], y[i]).unwrap() {
            // A group's detections come back as soon as a later spike arrives.
            assert!(d.t < t[i]);
            seen.push(*d);
        }
    }
    b.finish(&net).unwrap();
    seen.extend_from_slice(&b.detections()[seen.len()..]);
    assert_eq!(seen, a.detections());
    assert_eq!(b.counts(), a.counts());
    // Bad input is refused with the event's index, and the window goes on.
    b.begin(&net, 100, &net.conv1_thresholds(0)).unwrap();
    assert!(matches!(
        b.push(&net, 99, 0, 0),
        Err(Error::InvalidEvent { index: 0, .. })
    ));
    assert!(matches!(
        b.push(&net, 100, 40, 0),
        Err(Error::InvalidEvent { index: 0, .. })
    ));
    b.push(&net, 105, 1, 1).unwrap();
    assert!(matches!(
        b.push(&net, 104, 1, 2),
        Err(Error::InvalidEvent { index: 1, .. })
    ));
    // A state made for another network is refused.
    let other = Network::new(c, 2).unwrap();
    assert!(b.push(&other, 106, 0, 0).is_err());
}

#[test]
fn duplicate_pixels_keep_their_first_spike() {
    let c = NetworkConfig {
        width: 20,
        height: 20,
        ..NetworkConfig::default()
    };
    let net = Network::new(c, 0).unwrap();
    let mut state = net.new_state();
    state.begin(&net, 0, &net.conv1_thresholds(0)).unwrap();
    for t in 0..5 {
        state.push(&net, t, 3, 3).unwrap();
    }
    state.finish(&net).unwrap();
    assert_eq!(state.input_count(), 1);
}

#[test]
fn depth_stops_the_network_early_without_changing_the_layers_below() {
    let c = NetworkConfig {
        width: 40,
        height: 30,
        ..NetworkConfig::default()
    };
    let mut c = c;
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 1.5;
    c.conv2.threshold = 2.0;
    c.conv3.threshold = 1.0;
    let mut net = Network::new(c.clone(), 2).unwrap();
    random_weights(&mut net, 9);
    let (t, x, y) = window(&c, 5, 400, 0);
    let mut full = net.new_state();
    net.run_window(&mut full, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    assert!(full.counts().iter().all(|&n| n > 0));
    for last in Layer::ALL {
        let mut s = net.new_state();
        s.set_depth(last);
        net.run_window(&mut s, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
            .unwrap();
        for layer in Layer::ALL {
            if layer.index() <= last.index() {
                assert_eq!(s.spikes(layer), full.spikes(layer));
            } else {
                assert_eq!(s.counts()[layer.index()], 0);
            }
        }
    }
}

/// A neuron whose float32 running sum rounds below its threshold while its exact potential
/// reaches it must fire: the float32 sum is only a filter.
#[test]
fn exact_potential_decides_where_float32_rounds_below() {
    // Find three weights whose sequential float32 sum rounds below the float32 threshold that
    // their exact sum reaches.
    let mut rng = crate::network::xorshift(0x2545_f491_4f6c_dd1du64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 24) as f32 + (s & 0xFF) as f32 * 1e-10
    };
    let (w, theta) = loop {
        let w = [next(), next(), next()];
        let exact: f64 = w.iter().map(|&v| f64::from(v)).sum();
        let running = w[0] + w[1] + w[2];
        let theta = exact as f32;
        let theta = if f64::from(theta) > exact {
            f32::from_bits(theta.to_bits() - 1)
        } else {
            theta
        };
        if running < theta && w.iter().all(|v| (0.0..=1.0).contains(v)) {
            break (w, theta);
        }
    };
    let mut c = NetworkConfig {
        width: 3,
        height: 1,
        ..NetworkConfig::default()
    };
    c.conv1.kernel = 3;
    c.conv1.maps = 1;
    c.conv1.threshold = theta;
    c.pent.mode = ThresholdMode::Static;
    c.pool1 = PoolConfig {
        kernel: 1,
        stride: 1,
    };
    c.conv2.kernel = 1;
    c.pool2 = c.pool1;
    c.conv3.kernel = 1;
    let mut net = Network::new(c, 0).unwrap();
    // Only the middle row of the kernel: the neuron at column 1 reads the 3 pixels.
    let mut kernel = vec![0.0f32; 9];
    kernel[3..6].copy_from_slice(&w);
    net.set_weights(ConvLayer::Conv1, kernel).unwrap();
    let (t, x, y) = (vec![1u64, 2, 3], vec![0u16, 1, 2], vec![0u16; 3]);
    let mut state = net.new_state();
    net.run_window(&mut state, Spikes::new(&t, &x, &y).unwrap(), 0, None, true)
        .unwrap();
    let exact: f64 = w.iter().map(|&v| f64::from(v)).sum();
    assert_eq!(
        state.spikes(Layer::Conv1),
        &[LayerSpike {
            t: 3,
            map: 0,
            row: 0,
            col: 1,
            v: exact as f32
        }]
    );
}

/// Two maps whose exact potentials tie while their float32 running sums differ (the same
/// weights added in another order): the tie goes to the lower map, as the exact values say.
#[test]
fn inhibition_ties_are_decided_exactly() {
    let mut rng = crate::network::xorshift(0x9E37_79B9_7F4A_7C15u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let w = loop {
        let w = [next(), next(), next()];
        if (w[2] + w[1]) + w[0] > (w[0] + w[1]) + w[2] {
            break w;
        }
    };
    let mut c = NetworkConfig {
        width: 3,
        height: 1,
        ..NetworkConfig::default()
    };
    c.conv1.kernel = 3;
    c.conv1.maps = 2;
    c.conv1.threshold = 0.01;
    c.pent.mode = ThresholdMode::Static;
    c.pool1 = PoolConfig {
        kernel: 1,
        stride: 1,
    };
    c.conv2.kernel = 1;
    c.conv2.maps = 1;
    c.conv2.threshold = 0.5;
    c.pool2 = c.pool1;
    c.conv3.kernel = 1;
    let mut net = Network::new(c, 0).unwrap();
    // Middle rows: map 0 reads the pixels with (w0, w1, w2), map 1 with (w2, w1, w0).
    let mut kernels = vec![0.0f32; 18];
    kernels[3..6].copy_from_slice(&w);
    kernels[12..15].copy_from_slice(&[w[2], w[1], w[0]]);
    net.set_weights(ConvLayer::Conv1, kernels).unwrap();
    // conv2 (1x1) listens to map 0 only, so its count tells which map won, even unrecorded.
    net.set_weights(ConvLayer::Conv2, vec![1.0, 0.0]).unwrap();
    // All three pixels at once: both maps cross at (0, 1) in the same group with equal exact
    // potentials.
    let (t, x, y) = (vec![5u64; 3], vec![0u16, 1, 2], vec![0u16; 3]);
    let mut recorded = net.new_state();
    net.run_window(
        &mut recorded,
        Spikes::new(&t, &x, &y).unwrap(),
        0,
        None,
        true,
    )
    .unwrap();
    let winner: Vec<u16> = recorded
        .spikes(Layer::Conv1)
        .iter()
        .filter(|s| s.col == 1)
        .map(|s| s.map)
        .collect();
    assert_eq!(winner, vec![0]);
    assert!(recorded.spikes(Layer::Conv2).iter().any(|s| s.col == 1));
    let mut quiet = net.new_state();
    net.run_window(&mut quiet, Spikes::new(&t, &x, &y).unwrap(), 0, None, false)
        .unwrap();
    assert_eq!(quiet.counts(), recorded.counts());
}

/// The mirror case: a float32 running sum that rounds up to the threshold while the exact
/// potential stays below it must not fire.
#[test]
fn exact_potential_decides_where_float32_rounds_above() {
    let mut rng = crate::network::xorshift(0x1234_5678_9abc_def1u64);
    let mut next = || {
        let s = rng();
        (s >> 40) as f32 / (1u64 << 24) as f32 + (s & 0xFF) as f32 * 1e-10
    };
    let (w, theta) = loop {
        let w = [next(), next(), next()];
        let exact: f64 = w.iter().map(|&v| f64::from(v)).sum();
        let running = w[0] + w[1] + w[2];
        if f64::from(running) > exact && w.iter().all(|v| (0.0..=1.0).contains(v)) {
            // The running sum itself as threshold: reached by float32, not by the exact sum.
            break (w, running);
        }
    };
    let mut c = NetworkConfig {
        width: 3,
        height: 1,
        ..NetworkConfig::default()
    };
    c.conv1.kernel = 3;
    c.conv1.maps = 1;
    c.conv1.threshold = theta;
    c.pent.mode = ThresholdMode::Static;
    c.pool1 = PoolConfig {
        kernel: 1,
        stride: 1,
    };
    c.conv2.kernel = 1;
    c.pool2 = c.pool1;
    c.conv3.kernel = 1;
    let mut net = Network::new(c, 0).unwrap();
    let mut kernel = vec![0.0f32; 9];
    kernel[3..6].copy_from_slice(&w);
    net.set_weights(ConvLayer::Conv1, kernel).unwrap();
    let (t, x, y) = (vec![1u64, 2, 3], vec![0u16, 1, 2], vec![0u16; 3]);
    for record in [false, true] {
        let mut state = net.new_state();
        net.run_window(
            &mut state,
            Spikes::new(&t, &x, &y).unwrap(),
            0,
            None,
            record,
        )
        .unwrap();
        assert_eq!(state.counts()[0], 0);
    }
}

/// Table 1's layers on a `side` × `side` sensor with static thresholds low enough for random
/// weights to fire every layer, and those weights.
fn table1_static(side: usize) -> (NetworkConfig, Network) {
    let mut c = NetworkConfig {
        width: side,
        height: side,
        padding: Padding::Same,
        ..NetworkConfig::default()
    };
    c.pent.mode = ThresholdMode::Static;
    c.conv1.threshold = 1.5;
    c.conv2.threshold = 2.0;
    c.conv3.threshold = 1.0;
    let mut net = Network::new(c.clone(), 3).unwrap();
    random_weights(&mut net, 11);
    (c, net)
}

/// Table 1's layers (conv2 10 × 10 over 4 maps into 20, conv3 into 10: the shapes the engine
/// has fixed fast paths for, outside `config_strategy`'s sizes) against the dense reference,
/// recorded and not, through every layer and stopped early.
#[test]
fn table1_layers_equal_dense_reference() {
    let (c, net) = table1_static(125);
    let (t, x, y) = window(&c, 7, 6000, 0);
    let (dense, _) = dense_window(&net, &t, &x, &y, None);
    assert!(dense.iter().all(|l| !l.is_empty()), "every layer fires");
    for record in [true, false] {
        for last in Layer::ALL {
            let mut s = net.new_state();
            s.set_gated(true);
            s.set_depth(last);
            net.run_window(&mut s, Spikes::new(&t, &x, &y).unwrap(), 0, None, record)
                .unwrap();
            for layer in Layer::ALL {
                let want = if layer.index() <= last.index() {
                    dense[layer.index()].len() as u64
                } else {
                    0
                };
                assert_eq!(
                    s.counts()[layer.index()],
                    want,
                    "{layer} (to {last}, {record})"
                );
                if record && layer.index() <= last.index() {
                    assert_eq!(s.spikes(layer), &dense[layer.index()][..], "{layer}");
                }
            }
        }
    }
}

/// A CPU without AVX2 runs the scalar references of `simd` end to end: the same spikes, counts
/// and detections as the AVX2 kernels (where the CPU has them) and the dense reference, window
/// after window in one state (so that each way's reset between windows runs too), adding
/// densely and waking by count.
#[test]
fn scalar_kernels_give_the_spikes_of_the_avx2_ones() {
    let (c, net) = table1_static(48);
    for gated in [false, true] {
        let (mut fast, mut scalar) = (net.new_state(), net.new_state());
        scalar.set_scalar();
        for w in 0..3u64 {
            let (t, x, y) = window(&c, 7 + w, 1500, 1_000 * w);
            let (dense, _) = dense_window(&net, &t, &x, &y, None);
            assert!(dense.iter().all(|l| !l.is_empty()), "every layer fires");
            for s in [&mut fast, &mut scalar] {
                s.set_gated(gated);
                net.run_window(s, Spikes::new(&t, &x, &y).unwrap(), 1_000 * w, None, true)
                    .unwrap();
            }
            assert_eq!(scalar.counts(), fast.counts(), "window {w}, gated {gated}");
            assert_eq!(
                scalar.detections(),
                fast.detections(),
                "window {w}, gated {gated}"
            );
            for layer in Layer::ALL {
                assert_eq!(
                    scalar.spikes(layer),
                    fast.spikes(layer),
                    "{layer}, window {w}"
                );
                assert_eq!(scalar.spikes(layer), &dense[layer.index()][..], "{layer}");
            }
        }
    }
}

#[test]
fn stdp_step_refuses_rates_of_the_wrong_sign_or_not_finite() {
    // A NaN rate wrote NaN weights, which the model file then refused to read back.
    let c = NetworkConfig {
        width: 16,
        height: 12,
        ..NetworkConfig::default()
    };
    let mut net = Network::new(c, 1).unwrap();
    let before = net.clone();
    let mut state = net.new_state();
    let (t, x, y) = (vec![0u64, 1, 2], vec![3u16, 4, 5], vec![3u16, 4, 5]);
    for (a_plus, a_minus) in [
        (f32::NAN, -0.003),
        (0.004, f32::NEG_INFINITY),
        (f32::INFINITY, -0.003),
        (-0.5, -0.003),
        (0.004, 0.5),
    ] {
        let rates = Rates { a_plus, a_minus };
        let spikes = Spikes::new(&t, &x, &y).unwrap();
        let err = net
            .stdp_step(&mut state, ConvLayer::Conv1, spikes, 0, None, rates)
            .unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "rates", .. }),
            "{err}"
        );
    }
    assert_eq!(
        net.conv_weights(ConvLayer::Conv1),
        before.conv_weights(ConvLayer::Conv1)
    );
}
