//! A conv layer's weights ([`ConvWeights`]).

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

use super::config::MAX_WEIGHTS;
use super::geometry::ConvGeom;
use crate::error::{Error, Result};

/// One conv layer's weights, in two layouts kept in step:
///
/// - the *canonical* `(maps, in_ch, k, k)` float32 array of docs/model.md §2 (what users, model
///   files and STDP see);
/// - the *engine* layout `[in_ch][dy][j][map]` in float64, with `j = k − 1 − dx`. An input spike
///   at `(c, iy, ix)` reaches, in output row `oy`, the consecutive columns `ox0 ..` with
///   `dx` falling as `ox` rises; with potentials stored `[row][col][map]`, its update for that
///   row is one contiguous run of `k × maps` potentials plus one contiguous run of weights.
///   The engine's running sums are float32 filters; exact potentials are gathered from the
///   canonical weights (see `conv`).
///
/// Each map also keeps the running sums of its weights sorted from the largest: no `n` inputs
/// of a neuron can give it more potential than the `n`-th of them, which tells the engine how
/// many inputs must have fired before a neuron can cross (see `conv`).
#[derive(Debug, Clone, PartialEq)]
pub struct ConvWeights {
    maps: usize,
    in_ch: usize,
    k: usize,
    canonical: Vec<f32>,
    engine: Vec<f32>,
    /// Per map, `kernel_len + 1` values: the float64 sum of its `n` largest weights, `n = 0 ..`.
    top: Vec<f64>,
}

impl ConvWeights {
    /// Weights from a canonical `(maps, in_ch, k, k)` array; every value must be finite and in
    /// `[0, 1]`.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] for a geometry of more than [`MAX_WEIGHTS`] weights, [`Error::Shape`]
    /// for `canonical` of another length, [`Error::InvalidParameter`] for a value outside `[0, 1]`.
    pub fn new(g: &ConvGeom, canonical: Vec<f32>) -> Result<Self> {
        weight_count(g)?;
        check_values(g, &canonical)?;
        let mut w = Self {
            maps: g.maps,
            in_ch: g.in_ch,
            k: g.k,
            canonical,
            engine: vec![0.0; g.maps * g.kernel_len()],
            top: vec![0.0; g.maps * (g.kernel_len() + 1)],
        };
        for m in 0..w.maps {
            w.sync_map(m);
        }
        Ok(w)
    }

    /// `N(mean, std)` clipped to `[0, 1]`, drawn in canonical order from a PCG64 stream seeded
    /// by `seed` and the layer's index (so conv2 and conv3 draw independent streams).
    ///
    /// # Errors
    ///
    /// As [`Self::new`], and [`Error::InvalidParameter`] for a `std` that is negative or not finite.
    pub fn random(g: &ConvGeom, mean: f64, std: f64, seed: u64, layer: usize) -> Result<Self> {
        let count = weight_count(g)?;
        let normal = Normal::new(mean, std)
            .map_err(|e| Error::param("init", format!("mean {mean} std {std}: {e}")))?;
        let mut rng =
            Pcg64::seed_from_u64(seed ^ (layer as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let canonical = (0..count)
            .map(|_| normal.sample(&mut rng).clamp(0.0, 1.0) as f32)
            .collect();
        Self::new(g, canonical)
    }

    /// The canonical `(maps, in_ch, k, k)` weights, C order.
    pub fn canonical(&self) -> &[f32] {
        &self.canonical
    }

    /// The engine layout (see [`ConvWeights`]).
    #[inline]
    pub fn engine(&self) -> &[f32] {
        &self.engine
    }

    /// `(maps, in_ch, k, k)`.
    pub fn shape(&self) -> [usize; 4] {
        [self.maps, self.in_ch, self.k, self.k]
    }

    /// Map `m`'s canonical kernel `(in_ch, k, k)`.
    ///
    /// # Panics
    ///
    /// If `m` is not below the layer's maps (`shape()[0]`).
    pub fn kernel(&self, m: usize) -> &[f32] {
        let n = self.in_ch * self.k * self.k;
        &self.canonical[m * n..(m + 1) * n]
    }

    /// Map `m`'s canonical kernel, mutable; call [`Self::sync_map`] after writing it.
    pub(crate) fn kernel_mut(&mut self, m: usize) -> &mut [f32] {
        let n = self.in_ch * self.k * self.k;
        &mut self.canonical[m * n..(m + 1) * n]
    }

    /// Copy map `m`'s canonical kernel into the engine layout and its sorted sums.
    pub(crate) fn sync_map(&mut self, m: usize) {
        let (k, maps) = (self.k, self.maps);
        let n = self.in_ch * k * k;
        let kernel = &self.canonical[m * n..(m + 1) * n];
        for c in 0..self.in_ch {
            for dy in 0..k {
                for dx in 0..k {
                    let j = k - 1 - dx;
                    self.engine[((c * k + dy) * k + j) * maps + m] = kernel[(c * k + dy) * k + dx];
                }
            }
        }
        let top = &mut self.top[m * (n + 1)..(m + 1) * (n + 1)];
        for (t, &w) in top[1..].iter_mut().zip(kernel) {
            *t = f64::from(w);
        }
        top[1..].sort_unstable_by(|a, b| b.total_cmp(a));
        top[0] = 0.0;
        for i in 1..=n {
            top[i] += top[i - 1];
        }
    }

    /// The fewest inputs that can give a neuron of map `m` a potential of at least `target`:
    /// the smallest `n` whose `n` largest weights sum to `target` or more (`kernel_len + 1` if
    /// even all of them fall short).
    pub(crate) fn inputs_to_reach(&self, m: usize, target: f64) -> usize {
        let n = self.in_ch * self.k * self.k;
        self.top[m * (n + 1)..(m + 1) * (n + 1)].partition_point(|&s| s < target)
    }

    /// Whether `n ≤ kernel_len` inputs may be enough: `inputs_to_reach(m, target) ≤ n`, from
    /// one sum instead of a search.
    #[inline]
    pub(crate) fn reaches(&self, m: usize, n: usize, target: f64) -> bool {
        let len = self.in_ch * self.k * self.k + 1;
        let s = self.top[m * len..(m + 1) * len][n];
        // The complement of `inputs_to_reach`'s `s < target`.
        s >= target || target.is_nan()
    }

    /// Sum of map `m`'s weights in float64 (PENT's `K1[m]`), summed in canonical order.
    pub fn kernel_sum(&self, m: usize) -> f64 {
        self.kernel(m).iter().map(|&w| f64::from(w)).sum()
    }
}

/// The weights of a layer of geometry `g`, `maps · in_ch · k²`, if at most [`MAX_WEIGHTS`]
/// (a geometry's fields are public: a caller may give any).
fn weight_count(g: &ConvGeom) -> Result<usize> {
    g.maps
        .checked_mul(g.in_ch)
        .and_then(|n| n.checked_mul(g.k))
        .and_then(|n| n.checked_mul(g.k))
        .filter(|&n| n <= MAX_WEIGHTS)
        .ok_or_else(|| {
            Error::param(
                "weights",
                format!(
                    "a layer of {} maps, {} input channels and {}x{} kernels holds more than \
                     MAX_WEIGHTS ({MAX_WEIGHTS}) weights",
                    g.maps, g.in_ch, g.k, g.k
                ),
            )
        })
}

fn check_values(g: &ConvGeom, w: &[f32]) -> Result<()> {
    let expected = g.maps * g.kernel_len();
    if w.len() != expected {
        return Err(Error::Shape {
            name: "weights",
            expected: format!("({}, {}, {}, {})", g.maps, g.in_ch, g.k, g.k),
            got: format!("{} values", w.len()),
        });
    }
    if let Some((i, v)) = w
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && (0.0..=1.0).contains(*v)))
    {
        return Err(Error::param(
            "weights",
            format!("every weight must be finite and in [0, 1]; value {i} is {v}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact equality is the property under test
mod tests {
    use super::*;
    use crate::network::config::NetworkConfig;
    use crate::network::geometry::Geometry;

    #[test]
    fn a_geometry_of_too_many_weights_is_refused_before_any_allocation() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap().conv[1];
        // 2^31 weights (8 GiB), and a count that overflows usize.
        for (maps, in_ch, k) in [
            (1 << 15, 1 << 16, 1),
            (usize::MAX, 2, 3),
            (2, 2, usize::MAX),
        ] {
            let big = ConvGeom {
                in_ch,
                k,
                maps,
                ..g
            };
            for err in [
                ConvWeights::random(&big, 0.8, 0.05, 0, 1).unwrap_err(),
                ConvWeights::new(&big, vec![0.5; 4]).unwrap_err(),
            ] {
                assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
                assert!(err.to_string().contains("MAX_WEIGHTS"), "{err}");
            }
        }
        assert!(ConvWeights::random(&g, 0.8, 0.05, 0, 1).is_ok());
    }

    #[test]
    fn random_weights_are_seeded_and_clipped() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap().conv[1];
        let a = ConvWeights::random(&g, 0.8, 0.08, 7, 1).unwrap();
        let b = ConvWeights::random(&g, 0.8, 0.08, 7, 1).unwrap();
        let c = ConvWeights::random(&g, 0.8, 0.08, 8, 1).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
        let mean = a.canonical().iter().map(|&w| f64::from(w)).sum::<f64>() / 8000.0;
        assert!((mean - 0.8).abs() < 0.01, "{mean}");
        let wide = ConvWeights::random(&g, 0.8, 2.0, 7, 1).unwrap();
        assert!(wide.canonical().iter().all(|w| (0.0..=1.0).contains(w)));
    }

    #[test]
    fn engine_layout_matches_canonical() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap().conv[1];
        let w = ConvWeights::random(&g, 0.5, 0.2, 1, 1).unwrap();
        let (k, maps) = (g.k, g.maps);
        for m in 0..maps {
            for c in 0..g.in_ch {
                for dy in 0..k {
                    for dx in 0..k {
                        let a = w.kernel(m)[(c * k + dy) * k + dx];
                        let b = w.engine()[((c * k + dy) * k + (k - 1 - dx)) * maps + m];
                        assert_eq!(a, b);
                    }
                }
            }
        }
    }

    #[test]
    fn inputs_to_reach_counts_the_largest_weights() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap().conv[0];
        let mut v = vec![0.0f32; 100];
        v[..25].copy_from_slice(&[0.5; 25]);
        v[3] = 1.0;
        v[7] = 0.75;
        let w = ConvWeights::new(&g, v).unwrap();
        assert_eq!(w.inputs_to_reach(0, 1.0), 1);
        assert_eq!(w.inputs_to_reach(0, 1.75), 2);
        assert_eq!(w.inputs_to_reach(0, 1.76), 3);
        assert_eq!(w.inputs_to_reach(0, 13.25), 25);
        assert_eq!(w.inputs_to_reach(0, 13.3), 26);
        assert_eq!(w.inputs_to_reach(1, 0.1), 26); // all zeros
        for target in [0.0, 1.0, 1.75, 1.76, 13.25, 13.3, f64::NAN] {
            for m in 0..2 {
                for n in 0..=25 {
                    assert_eq!(w.reaches(m, n, target), w.inputs_to_reach(m, target) <= n);
                }
            }
        }
    }

    #[test]
    fn rejects_out_of_range_values() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap().conv[0];
        for bad in [f32::NAN, -0.1, 1.5, f32::INFINITY] {
            let mut v = vec![0.5; 100];
            v[3] = bad;
            assert!(matches!(
                ConvWeights::new(&g, v),
                Err(Error::InvalidParameter { .. })
            ));
        }
        assert!(matches!(
            ConvWeights::new(&g, vec![0.5; 99]),
            Err(Error::Shape { .. })
        ));
    }
}
