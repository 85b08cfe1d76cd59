//! Layer geometry (docs/model.md §2): output sizes, which outputs an input position reaches
//! (the event-driven direction) and which inputs an output reads (receptive fields, STDP).
//!
//! Everything is per axis; a layer's 2-D geometry is the same rule applied to rows and columns.

use std::ops::Range;

use super::config::{NetworkConfig, Padding, MAX_WINDOW_STATE_BYTES};
use crate::error::{Error, Result};

/// One convolution layer's geometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConvGeom {
    pub in_h: usize,
    pub in_w: usize,
    pub in_ch: usize,
    pub k: usize,
    pub maps: usize,
    pub out_h: usize,
    pub out_w: usize,
    /// Offset of the kernel's first row/column before the output position: `(k − 1) / 2` for
    /// `same`, 0 for `valid`.
    pub p_lo: usize,
}

/// One max-pool layer's geometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PoolGeom {
    pub in_h: usize,
    pub in_w: usize,
    pub maps: usize,
    pub k: usize,
    pub stride: usize,
    pub out_h: usize,
    pub out_w: usize,
}

/// The geometry of the whole network: conv1, pool1, conv2, pool2, conv3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Geometry {
    pub conv: [ConvGeom; 3],
    pub pool: [PoolGeom; 2],
}

impl NetworkConfig {
    /// Check every field's range and that the layers' sizes compose (docs/model.md §2).
    pub fn validate(&self) -> Result<()> {
        self.check_fields()?;
        // The layer sizes must compose: this fails on kernels larger than their input under
        // `valid` padding.
        let geom = Geometry::new(self)?;
        let bytes = geom.state_bytes();
        if bytes > MAX_WINDOW_STATE_BYTES as u128 {
            let maps = geom.conv.map(|g| g.maps);
            return Err(Error::param(
                "config",
                format!(
                    "one window's state of a {}x{} network (conv maps {}/{}/{}) needs {bytes} \
                     bytes, above the cap of {MAX_WINDOW_STATE_BYTES} (MAX_WINDOW_STATE_BYTES); \
                     use a smaller width and height, or fewer maps",
                    self.width, self.height, maps[0], maps[1], maps[2]
                ),
            ));
        }
        Ok(())
    }
}

impl Geometry {
    /// Bytes of one window's state, counted from its largest arrays (exact, in 128 bits: no
    /// size the fields allow overflows): per pixel its firing stamp and time (12); per conv
    /// neuron its float32 potential (4) and per position a 16-bit count (2); per pool neuron
    /// its stamp, time and cause box (28) and its cause words (8 per 64 conv neurons of its
    /// block).
    pub fn state_bytes(&self) -> u128 {
        let c1 = &self.conv[0];
        let pixels = c1.in_h as u128 * c1.in_w as u128 * 12;
        let conv: u128 = self
            .conv
            .iter()
            .map(|g| {
                let positions = g.out_h as u128 * g.out_w as u128;
                positions * g.maps as u128 * 4 + positions * 2
            })
            .sum();
        let pool: u128 = self
            .pool
            .iter()
            .map(|g| {
                let neurons = g.out_h as u128 * g.out_w as u128 * g.maps as u128;
                let words = (g.k as u128 * g.k as u128).div_ceil(64);
                neurons * (28 + 8 * words)
            })
            .sum();
        pixels + conv + pool
    }
}

impl ConvGeom {
    fn new(
        layer: &'static str,
        in_h: usize,
        in_w: usize,
        in_ch: usize,
        k: usize,
        maps: usize,
        padding: Padding,
    ) -> Result<Self> {
        let out = |n: usize| match padding {
            Padding::Same => Ok(n),
            Padding::Valid if k <= n => Ok(n - k + 1),
            Padding::Valid => Err(Error::Shape {
                name: layer,
                expected: format!(
                    "a kernel no larger than its {in_w}x{in_h} input (valid padding)"
                ),
                got: format!("kernel {k}"),
            }),
        };
        Ok(Self {
            in_h,
            in_w,
            in_ch,
            k,
            maps,
            out_h: out(in_h)?,
            out_w: out(in_w)?,
            p_lo: match padding {
                Padding::Same => (k - 1) / 2,
                Padding::Valid => 0,
            },
        })
    }

    /// Output rows (or columns) whose kernel covers input row `i`.
    #[inline]
    pub fn outputs_of(&self, i: usize, out: usize) -> Range<usize> {
        let hi = (i + self.p_lo + 1).min(out);
        let lo = (i + self.p_lo + 1).saturating_sub(self.k);
        lo..hi.max(lo)
    }

    /// Input rows (or columns) whose `k` output rows (columns) all exist: those for which
    /// `outputs_of` is not clipped.
    pub fn whole_footprints(&self, out: usize) -> Range<usize> {
        let lo = self.k - 1 - self.p_lo;
        lo..out.saturating_sub(self.p_lo).max(lo)
    }

    /// Input rows (or columns) read by output row `o`, clipped to the input.
    #[inline]
    pub fn inputs_of(&self, o: usize, input: usize) -> Range<usize> {
        let lo = o.saturating_sub(self.p_lo);
        let hi = (o + self.k).saturating_sub(self.p_lo).min(input);
        lo..hi.max(lo)
    }

    /// Number of weights of one map's kernel.
    pub fn kernel_len(&self) -> usize {
        self.in_ch * self.k * self.k
    }

    /// Number of neurons.
    pub fn neurons(&self) -> usize {
        self.out_h * self.out_w * self.maps
    }
}

impl PoolGeom {
    fn new(
        layer: &'static str,
        in_h: usize,
        in_w: usize,
        maps: usize,
        k: usize,
        stride: usize,
        padding: Padding,
    ) -> Result<Self> {
        let out = |n: usize| match padding {
            Padding::Same => Ok(n.div_ceil(stride)),
            Padding::Valid if k <= n => Ok((n - k) / stride + 1),
            Padding::Valid => Err(Error::Shape {
                name: layer,
                expected: format!("a block no larger than its {in_w}x{in_h} input (valid padding)"),
                got: format!("kernel {k}"),
            }),
        };
        Ok(Self {
            in_h,
            in_w,
            maps,
            k,
            stride,
            out_h: out(in_h)?,
            out_w: out(in_w)?,
        })
    }

    /// Pool rows (or columns) whose block holds input row `i`.
    #[inline]
    pub fn outputs_of(&self, i: usize, out: usize) -> Range<usize> {
        let lo = (i + 1).saturating_sub(self.k).div_ceil(self.stride);
        let hi = (i / self.stride + 1).min(out);
        lo..hi.max(lo)
    }

    /// Input rows (or columns) read by pool row `q`, clipped to the input.
    #[inline]
    pub fn inputs_of(&self, q: usize, input: usize) -> Range<usize> {
        let lo = q * self.stride;
        let hi = (lo + self.k).min(input);
        lo..hi.max(lo)
    }

    /// Number of neurons.
    pub fn neurons(&self) -> usize {
        self.out_h * self.out_w * self.maps
    }
}

/// Division by a fixed divisor `1 ≤ d ≤ 2³¹` with one multiplication (Lemire, Kaser & Kurz
/// 2019, with a 63-bit shift so that the magic fits 64 bits for every such `d`, `d = 1`
/// included: `⌊n / d⌋ = ⌊n · M / 2⁶³⌋` with `M = ⌊2⁶³ / d⌋ + 1`, exact for every 32-bit `n`:
/// `M = 2⁶³ / d + e` with `0 < e ≤ 1` adds `n · e / 2⁶³ < 1 / d` (as `n · d < 2⁶³`) to
/// `n / d`, whose fraction is at most `1 − 1 / d`). The product's high word is taken of
/// `2n · M`, no shift. The engine splits positions into rows and columns per spike, where a
/// hardware division would cost more than the rest of the work; the geometry's divisors
/// (sides, strides, maps) are at most `u16::MAX`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Divider {
    d: u32,
    magic: u64,
}

impl Divider {
    pub fn new(d: usize) -> Self {
        let d = u32::try_from(d).expect("divisor fits 32 bits");
        assert!(d > 0 && d <= 1 << 31, "divisor in 1..=2^31");
        Self {
            d,
            magic: (1u64 << 63) / u64::from(d) + 1,
        }
    }

    /// `⌊n / d⌋`.
    #[inline]
    pub fn div(self, n: usize) -> usize {
        debug_assert!(u32::try_from(n).is_ok(), "dividend fits 32 bits");
        // `2n` fits 64 bits (`n < 2³²`).
        ((u128::from(2 * n as u64) * u128::from(self.magic)) >> 64) as usize
    }

    /// `(⌊n / d⌋, n mod d)`.
    #[inline]
    pub fn div_rem(self, n: usize) -> (usize, usize) {
        let q = self.div(n);
        (q, n - q * self.d as usize)
    }
}

impl Geometry {
    /// Compose the layers of a config; fails when a layer comes out empty.
    pub fn new(c: &NetworkConfig) -> Result<Self> {
        let p = c.padding;
        let conv1 = ConvGeom::new(
            "conv1",
            c.height,
            c.width,
            1,
            c.conv1.kernel,
            c.conv1.maps,
            p,
        )?;
        let pool1 = PoolGeom::new(
            "pool1",
            conv1.out_h,
            conv1.out_w,
            conv1.maps,
            c.pool1.kernel,
            c.pool1.stride,
            p,
        )?;
        let conv2 = ConvGeom::new(
            "conv2",
            pool1.out_h,
            pool1.out_w,
            pool1.maps,
            c.conv2.kernel,
            c.conv2.maps,
            p,
        )?;
        let pool2 = PoolGeom::new(
            "pool2",
            conv2.out_h,
            conv2.out_w,
            conv2.maps,
            c.pool2.kernel,
            c.pool2.stride,
            p,
        )?;
        let conv3 = ConvGeom::new(
            "conv3",
            pool2.out_h,
            pool2.out_w,
            pool2.maps,
            c.conv3.kernel,
            c.conv3.maps,
            p,
        )?;
        Ok(Self {
            conv: [conv1, conv2, conv3],
            pool: [pool1, pool2],
        })
    }

    /// The sensor pixels a conv3 neuron at `(row, col)` can see: rows `y0..y1`, columns `x0..x1`
    /// (half-open), composed back through every layer and clipped to each layer's extent.
    /// A position outside conv3's output sees nothing (two empty ranges).
    pub fn conv3_receptive_field(&self, row: usize, col: usize) -> (Range<usize>, Range<usize>) {
        let [c1, c2, c3] = &self.conv;
        let [p1, p2] = &self.pool;
        if row >= c3.out_h || col >= c3.out_w {
            return (0..0, 0..0);
        }
        let axis = |o: usize, vertical: bool| {
            let pick = |h: usize, w: usize| if vertical { h } else { w };
            let r = conv_back(c3, o..o + 1, pick(c3.in_h, c3.in_w));
            let r = pool_back(p2, r, pick(p2.in_h, p2.in_w));
            let r = conv_back(c2, r, pick(c2.in_h, c2.in_w));
            let r = pool_back(p1, r, pick(p1.in_h, p1.in_w));
            conv_back(c1, r, pick(c1.in_h, c1.in_w))
        };
        (axis(row, true), axis(col, false))
    }
}

/// Inputs read by a range of conv outputs.
fn conv_back(g: &ConvGeom, r: Range<usize>, input: usize) -> Range<usize> {
    if r.is_empty() {
        return r;
    }
    let first = g.inputs_of(r.start, input);
    let last = g.inputs_of(r.end - 1, input);
    first.start..last.end.max(first.start)
}

/// Inputs read by a range of pool outputs.
fn pool_back(g: &PoolGeom, r: Range<usize>, input: usize) -> Range<usize> {
    if r.is_empty() {
        return r;
    }
    let first = g.inputs_of(r.start, input);
    let last = g.inputs_of(r.end - 1, input);
    first.start..last.end.max(first.start)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_receptive_field_outside_conv3_is_empty() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap();
        let c3 = g.conv[2];
        assert!(!g
            .conv3_receptive_field(c3.out_h - 1, c3.out_w - 1)
            .0
            .is_empty());
        for (row, col) in [(c3.out_h, 0), (0, c3.out_w), (usize::MAX, usize::MAX)] {
            assert_eq!(g.conv3_receptive_field(row, col), (0..0, 0..0));
        }
    }

    fn conv(k: usize, padding: Padding, n: usize) -> ConvGeom {
        ConvGeom::new("t", n, n, 1, k, 1, padding).unwrap()
    }

    fn pool(k: usize, s: usize, padding: Padding, n: usize) -> PoolGeom {
        PoolGeom::new("t", n, n, 1, k, s, padding).unwrap()
    }

    /// The multiplicative division equals the hardware one, for divisors of every size and
    /// dividends near every multiple and at the ends of the 32-bit range.
    #[test]
    fn divider_is_exact() {
        let mut divisors: Vec<usize> = (1..=2000).collect();
        divisors.extend([4095, 4096, 65_535, 65_536, 1 << 20, (1 << 31) - 1, 1 << 31]);
        for d in divisors {
            let div = Divider::new(d);
            let mut ns: Vec<usize> = (0..3 * d.min(1000)).collect();
            for q in [1usize, 7, 1000, 65_535, 1 << 20] {
                let m = q.saturating_mul(d);
                if u32::try_from(m).is_ok() {
                    ns.extend([m.saturating_sub(1), m, m + 1]);
                }
            }
            ns.extend([u32::MAX as usize - 1, u32::MAX as usize]);
            for n in ns.into_iter().filter(|&n| u32::try_from(n).is_ok()) {
                assert_eq!(div.div_rem(n), (n / d, n % d), "{n} / {d}");
            }
        }
    }

    /// `outputs_of` is exactly the inverse of `inputs_of`, by brute force.
    #[test]
    fn conv_directions_agree() {
        for padding in [Padding::Same, Padding::Valid] {
            for k in 1..7 {
                for n in k..12 {
                    let g = conv(k, padding, n);
                    for i in 0..n {
                        let direct: Vec<usize> = (0..g.out_h)
                            .filter(|&o| g.inputs_of(o, n).contains(&i))
                            .collect();
                        let inverse: Vec<usize> = g.outputs_of(i, g.out_h).collect();
                        assert_eq!(direct, inverse, "k={k} n={n} i={i} {padding:?}");
                        assert_eq!(
                            g.whole_footprints(g.out_h).contains(&i),
                            inverse.len() == k,
                            "k={k} n={n} i={i} {padding:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn pool_directions_agree() {
        for padding in [Padding::Same, Padding::Valid] {
            for k in 1..7 {
                for s in 1..7 {
                    for n in k..14 {
                        let g = pool(k, s, padding, n);
                        for i in 0..n {
                            let direct: Vec<usize> = (0..g.out_h)
                                .filter(|&q| g.inputs_of(q, n).contains(&i))
                                .collect();
                            let inverse: Vec<usize> = g.outputs_of(i, g.out_h).collect();
                            assert_eq!(direct, inverse, "k={k} s={s} n={n} i={i}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn table1_sizes() {
        let g = Geometry::new(&NetworkConfig::default()).unwrap();
        assert_eq!((g.conv[0].out_h, g.conv[0].out_w), (180, 240));
        assert_eq!((g.pool[0].out_h, g.pool[0].out_w), (36, 48));
        assert_eq!(
            (g.conv[1].out_h, g.conv[1].out_w, g.conv[1].p_lo),
            (36, 48, 4)
        );
        assert_eq!((g.pool[1].out_h, g.pool[1].out_w), (8, 10));
        assert_eq!((g.conv[2].out_h, g.conv[2].out_w), (8, 10));
        let (rows, cols) = g.conv3_receptive_field(0, 0);
        assert_eq!(rows.start, 0);
        assert_eq!(cols.start, 0);
        let (rows, cols) = g.conv3_receptive_field(7, 9);
        assert_eq!((rows.end, cols.end), (180, 240));
    }

    #[test]
    fn valid_padding_rejects_large_kernels() {
        let c = NetworkConfig {
            padding: Padding::Valid,
            width: 20,
            height: 20,
            ..NetworkConfig::default()
        };
        assert!(matches!(Geometry::new(&c), Err(Error::Shape { .. })));
    }
}
