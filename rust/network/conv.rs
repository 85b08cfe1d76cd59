//! A conv layer's per-window state: potentials, latching, candidates and lateral inhibition
//! (docs/model.md §3).
//!
//! - Potentials are stored `[row][col][map]` in float64. The weights are float32 values in
//!   `[0, 1]`; their sums are exact in float64 (below 2⁻²¹ a weight could lose bits, far under
//!   any meaningful difference), so a potential does not depend on the order in which its input
//!   spikes were added: the event-driven engine and a dense reference agree bit for bit.
//! - Nothing is swept per window: each position carries the generation (window number) in which
//!   its potentials were last zeroed, and stale positions are zeroed when a spike first reaches
//!   them. Lateral-inhibition locks are generation stamps too.
//! - A neuron *crosses* when a spike takes its potential from below its threshold to at or above
//!   it. Potentials never decrease, so this happens at most once per window: latching needs no
//!   flag.

use super::geometry::ConvGeom;

/// A neuron that crossed its threshold in the current timestamp group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Crossing {
    /// Position index `row * out_w + col`.
    pub pos: u32,
    pub map: u32,
    /// Potential after every spike of the group.
    pub v: f64,
}

/// Per-window state of one conv layer.
#[derive(Debug, Clone)]
pub(crate) struct ConvState {
    pub geom: ConvGeom,
    /// Potentials `[row][col][map]`.
    pot: Vec<f64>,
    /// Generation in which a position's potentials were last zeroed.
    fresh: Vec<u32>,
    /// Generation in which a map fired at a position (lateral inhibition).
    lock: Vec<u32>,
    /// Group in which `best` was last written, per position.
    best_group: Vec<u32>,
    /// Best crossing at a position in the current group: (map, potential).
    best: Vec<(u32, f64)>,
    /// Thresholds per map, tiled `k` times to match one row's run of potentials.
    thr: Vec<f64>,
    /// Neurons `(pos, map)` that crossed in the current group.
    crossed: Vec<(u32, u32)>,
    /// Positions holding a best crossing in the current group.
    touched: Vec<u32>,
}

impl ConvState {
    pub fn new(geom: ConvGeom) -> Self {
        let positions = geom.out_h * geom.out_w;
        Self {
            geom,
            pot: vec![0.0; positions * geom.maps],
            fresh: vec![0; positions],
            lock: vec![0; positions],
            best_group: vec![0; positions],
            best: vec![(0, 0.0); positions],
            thr: vec![f64::INFINITY; geom.k * geom.maps],
            crossed: Vec::new(),
            touched: Vec::new(),
        }
    }

    /// Forget the window stamps (after the window generation counter wrapped).
    pub fn clear_window_stamps(&mut self) {
        self.fresh.fill(0);
        self.lock.fill(0);
    }

    /// Forget the group stamps (after the group counter wrapped).
    pub fn clear_group_stamps(&mut self) {
        self.best_group.fill(0);
    }

    /// Set the per-map thresholds for the coming window.
    pub fn set_thresholds(&mut self, thresholds: impl Fn(usize) -> f32) {
        let maps = self.geom.maps;
        for (i, t) in self.thr.iter_mut().enumerate() {
            *t = f64::from(thresholds(i % maps));
        }
    }

    /// Add input spike `(c, iy, ix)` to every neuron whose kernel covers it (`w` in the engine
    /// layout of `weights`), recording the neurons that cross.
    #[inline]
    pub fn add(&mut self, w: &[f64], generation: u32, c: usize, iy: usize, ix: usize) {
        let g = self.geom;
        let maps = g.maps;
        let rows = g.outputs_of(iy, g.out_h);
        let cols = g.outputs_of(ix, g.out_w);
        if cols.is_empty() {
            return;
        }
        let n = cols.len();
        let run = n * maps;
        // Kernel column index j = k − 1 − dx of the first output column.
        let j0 = g.k - 1 - (ix + g.p_lo - cols.start);
        let thr = &self.thr[..run];
        for oy in rows {
            let dy = iy + g.p_lo - oy;
            let wstart = ((c * g.k + dy) * g.k + j0) * maps;
            let weights = &w[wstart..wstart + run];
            let pos0 = oy * g.out_w + cols.start;
            for (p, fresh) in self.fresh[pos0..pos0 + n].iter_mut().enumerate() {
                if *fresh != generation {
                    *fresh = generation;
                    self.pot[(pos0 + p) * maps..(pos0 + p + 1) * maps].fill(0.0);
                }
            }
            let pot = &mut self.pot[pos0 * maps..pos0 * maps + run];
            if crosses(pot, weights, thr) {
                for (i, (v, &dw)) in pot.iter_mut().zip(weights).enumerate() {
                    let old = *v;
                    *v = old + dw;
                    if old < thr[i] && *v >= thr[i] {
                        self.crossed
                            .push(((pos0 + i / maps) as u32, (i % maps) as u32));
                    }
                }
            } else {
                for (v, &dw) in pot.iter_mut().zip(weights) {
                    *v += dw;
                }
            }
        }
    }

    /// Decide which of this group's crossings fire and append them to `out`.
    ///
    /// With lateral inhibition, a position that already fired this window fires nothing; among
    /// a position's crossings in the group the highest potential fires, ties going to the
    /// lowest map, and the position is locked. Without it, every crossing fires.
    pub fn resolve(&mut self, generation: u32, group: u32, inhibit: bool, out: &mut Vec<Crossing>) {
        let maps = self.geom.maps;
        if !inhibit {
            out.extend(self.crossed.iter().map(|&(pos, map)| Crossing {
                pos,
                map,
                v: self.pot[pos as usize * maps + map as usize],
            }));
            self.crossed.clear();
            return;
        }
        for &(pos, map) in &self.crossed {
            let p = pos as usize;
            if self.lock[p] == generation {
                continue;
            }
            let v = self.pot[p * maps + map as usize];
            if self.best_group[p] == group {
                let (bm, bv) = self.best[p];
                let better = match v.total_cmp(&bv) {
                    std::cmp::Ordering::Greater => true,
                    std::cmp::Ordering::Equal => map < bm,
                    std::cmp::Ordering::Less => false,
                };
                if better {
                    self.best[p] = (map, v);
                }
            } else {
                self.best_group[p] = group;
                self.best[p] = (map, v);
                self.touched.push(pos);
            }
        }
        for &pos in &self.touched {
            let p = pos as usize;
            self.lock[p] = generation;
            let (map, v) = self.best[p];
            out.push(Crossing { pos, map, v });
        }
        self.touched.clear();
        self.crossed.clear();
    }
}

/// Whether adding `w` to `pot` takes any potential from below to at or above its threshold.
/// Written as a branch-free reduction so that it vectorises.
#[inline]
#[allow(clippy::needless_bitwise_bool)] // `&` keeps the loop branch-free
fn crosses(pot: &[f64], w: &[f64], thr: &[f64]) -> bool {
    let mut any = false;
    for ((&v, &dw), &t) in pot.iter().zip(w).zip(thr) {
        any |= (v < t) & (v + dw >= t);
    }
    any
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact equality is the property under test
mod tests {
    use super::*;
    use crate::network::config::{NetworkConfig, Padding};
    use crate::network::geometry::Geometry;
    use crate::network::weights::ConvWeights;

    fn small(padding: Padding) -> (ConvGeom, ConvWeights) {
        let c = NetworkConfig {
            width: 12,
            height: 10,
            padding,
            ..NetworkConfig::default()
        };
        let mut c = c;
        c.conv2.kernel = 3;
        c.pool1.kernel = 1;
        c.pool1.stride = 1;
        c.pool2.kernel = 1;
        c.pool2.stride = 1;
        c.conv3.kernel = 1;
        let g = Geometry::new(&c).unwrap().conv[0];
        let w = ConvWeights::random(&g, 0.5, 0.3, 3, 0).unwrap();
        (g, w)
    }

    /// Event-driven potentials equal a direct cross-correlation of the spikes.
    #[test]
    fn potentials_equal_direct_correlation() {
        for padding in [Padding::Same, Padding::Valid] {
            let (g, w) = small(padding);
            let mut s = ConvState::new(g);
            s.set_thresholds(|_| 1e9);
            let spikes = [(0, 0), (3, 4), (9, 11), (5, 5), (9, 0)];
            for &(y, x) in &spikes {
                s.add(w.engine(), 1, 0, y, x);
            }
            for oy in 0..g.out_h {
                for ox in 0..g.out_w {
                    for m in 0..g.maps {
                        let mut expected = 0.0f64;
                        for &(y, x) in &spikes {
                            let (dy, dx) = (
                                y as isize - oy as isize + g.p_lo as isize,
                                x as isize - ox as isize + g.p_lo as isize,
                            );
                            if (0..g.k as isize).contains(&dy) && (0..g.k as isize).contains(&dx) {
                                expected += f64::from(w.kernel(m)[dy as usize * g.k + dx as usize]);
                            }
                        }
                        let pos = oy * g.out_w + ox;
                        let got = if s.fresh[pos] == 1 {
                            s.pot[pos * g.maps + m]
                        } else {
                            0.0
                        };
                        assert_eq!(got, expected, "{padding:?} ({oy},{ox},{m})");
                    }
                }
            }
        }
    }

    #[test]
    fn inhibition_picks_highest_potential_then_lowest_map() {
        let (g, _) = small(Padding::Same);
        let mut s = ConvState::new(g);
        s.pot[..4].copy_from_slice(&[2.0, 3.0, 3.0, 1.0]);
        s.fresh[0] = 1;
        s.crossed.extend([(0, 0), (0, 2), (0, 1)]);
        let mut out = Vec::new();
        s.resolve(1, 1, true, &mut out);
        assert_eq!(
            out,
            vec![Crossing {
                pos: 0,
                map: 1,
                v: 3.0
            }]
        );
        // Locked for the rest of the window.
        s.crossed.push((0, 3));
        s.resolve(1, 2, true, &mut out);
        assert_eq!(out.len(), 1);
        // Without inhibition every crossing fires.
        s.crossed.extend([(0, 0), (0, 3)]);
        s.resolve(2, 3, false, &mut out);
        assert_eq!(out.len(), 3);
    }
}
