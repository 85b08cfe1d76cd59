//! Winner-take-all over the trained layer's crossings (docs/model.md §6).
//!
//! Crossings arrive one timestamp group at a time, in time order, so sorting each group by
//! (potential descending, map, row, col) and walking it gives exactly the order of the model's
//! global sort; once `k` winners (or one per map) are found the window's remaining spikes cannot
//! change anything and training stops reading it.

use std::cmp::Ordering;

/// A winning neuron of a training window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Winner {
    /// Firing time (µs, absolute).
    pub t: u64,
    pub map: u16,
    pub row: u16,
    pub col: u16,
    /// Potential at its firing time (float64, exact; see `conv`).
    pub v: f64,
}

/// The winner-take-all competition of one window.
#[derive(Debug, Clone, Default)]
pub(crate) struct Wta {
    k: usize,
    radius: usize,
    map_taken: Vec<bool>,
    winners: Vec<Winner>,
    group: Vec<Winner>,
}

impl Wta {
    /// Start a new window for a layer of `maps` maps.
    pub fn reset(&mut self, maps: usize, k: usize, radius: usize) {
        self.k = k.min(maps);
        self.radius = radius;
        self.map_taken.clear();
        self.map_taken.resize(maps, false);
        self.winners.clear();
        self.group.clear();
    }

    /// Whether no further crossing can win.
    pub fn done(&self) -> bool {
        self.winners.len() >= self.k
    }

    /// The winners so far, in acceptance order.
    pub fn winners(&self) -> &[Winner] {
        &self.winners
    }

    /// Queue a crossing of the current group.
    pub fn offer(&mut self, c: Winner) {
        self.group.push(c);
    }

    /// Close the current group: walk its crossings in the model's order and accept winners.
    pub fn close_group(&mut self) {
        self.group.sort_unstable_by(order);
        for c in &self.group {
            if self.winners.len() >= self.k {
                break;
            }
            if self.map_taken[c.map as usize] {
                continue;
            }
            let r = self.radius;
            let near = self.winners.iter().any(|w| {
                w.row.abs_diff(c.row) as usize <= r && w.col.abs_diff(c.col) as usize <= r
            });
            if near {
                continue;
            }
            self.map_taken[c.map as usize] = true;
            self.winners.push(*c);
        }
        self.group.clear();
    }
}

/// Time ascending, potential descending, then map, row, col ascending.
fn order(a: &Winner, b: &Winner) -> Ordering {
    a.t.cmp(&b.t)
        .then(b.v.total_cmp(&a.v))
        .then(a.map.cmp(&b.map))
        .then(a.row.cmp(&b.row))
        .then(a.col.cmp(&b.col))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(t: u64, v: f64, map: u16, row: u16, col: u16) -> Winner {
        Winner {
            t,
            map,
            row,
            col,
            v,
        }
    }

    #[test]
    fn order_map_and_radius_rules() {
        let mut wta = Wta::default();
        wta.reset(4, 3, 2);
        // Group 1: map 1 wins on potential; map 0 at (0, 2) is within radius 2 of it.
        wta.offer(w(5, 1.0, 0, 0, 2));
        wta.offer(w(5, 2.0, 1, 0, 0));
        wta.close_group();
        // Group 2: map 1 is taken; map 2 is far enough; map 3 ties map 2 on potential but is
        // near it.
        wta.offer(w(6, 9.0, 1, 10, 10));
        wta.offer(w(6, 1.0, 3, 10, 11));
        wta.offer(w(6, 1.0, 2, 10, 10));
        wta.close_group();
        let got: Vec<(u16, u64)> = wta.winners().iter().map(|w| (w.map, w.t)).collect();
        assert_eq!(got, vec![(1, 5), (2, 6)]);
        assert!(!wta.done());
        wta.offer(w(7, 1.0, 3, 20, 20));
        wta.offer(w(7, 1.0, 0, 30, 30));
        wta.close_group();
        assert_eq!(wta.winners().len(), 3);
        assert!(wta.done());
    }
}
