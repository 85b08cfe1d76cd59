//! The dense reference: docs/model.md written out layer by layer over whole maps, with no
//! events, no sparse state and no float32 filter — conv layers as first threshold crossings of
//! exact float64 potentials over the input's spike times (lateral inhibition and the training
//! winners by time, then potential, then position), pools as minima over their blocks, a
//! detection's box walked down its causes, and an STDP step applied to every winner's kernel.

use super::*;

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
pub(super) fn dense_window(
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
pub(super) fn dense_box(
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

/// Apply STDP densely for `winners` of `layer`, computing input spike times with the dense
/// model.
pub(super) fn dense_stdp(
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
