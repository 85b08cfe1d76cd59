//! conv1's fixed Gabor kernels (docs/model.md §4).

use super::config::GaborConfig;
use crate::error::{check_alloc, Error, Result};

/// `maps` Gabor kernels of side `k`, orientations `m · 180° / maps` (0°, 45°, 90°, 135° for the
/// default 4 maps), each min–max scaled into `[0, 1]`; returned in the layout `(maps, 1, k, k)`.
///
/// `g(x, y) = exp(−(x'² + γ²y'²) / (2σ²)) · cos(2πx'/λ)` with `x' = x cos θ + y sin θ`,
/// `y' = −x sin θ + y cos θ`, `x` to the right and `y` down, both centred on the kernel (from
/// `−(k−1)/2` to `(k−1)/2`). Computed in float64 and rounded to float32 at the end. A constant
/// kernel (possible only for degenerate parameters) scales to all ones.
///
/// # Errors
///
/// [`Error::InvalidParameter`]: `k` when a kernel's `k²` float64 terms, `maps` when the
/// `maps · k²` weights are above [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES) (or their
/// count overflows); `gabor` when the parameters give a term that is not finite (NaN
/// `sigma`, a subnormal `wavelength`...; [`NetworkConfig::validate`](super::NetworkConfig::validate)
/// refuses those first).
pub fn gabor_kernels(k: usize, maps: usize, p: &GaborConfig) -> Result<Vec<f32>> {
    let area = k.saturating_mul(k);
    check_alloc("k", || format!("a {k}x{k} Gabor kernel"), area, 8)?;
    check_alloc(
        "maps",
        || format!("{maps} Gabor kernels of {k}x{k}"),
        maps.saturating_mul(area),
        4,
    )?;
    let mut out = Vec::with_capacity(maps * area);
    let centre = (k as f64 - 1.0) / 2.0;
    for m in 0..maps {
        let theta = m as f64 * std::f64::consts::PI / maps as f64;
        let (sin, cos) = theta.sin_cos();
        let raw: Vec<f64> = (0..area)
            .map(|i| {
                let y = (i / k) as f64 - centre;
                let x = (i % k) as f64 - centre;
                let xr = x * cos + y * sin;
                let yr = -x * sin + y * cos;
                let envelope =
                    (-(xr * xr + p.gamma * p.gamma * yr * yr) / (2.0 * p.sigma * p.sigma)).exp();
                envelope * (2.0 * std::f64::consts::PI * xr / p.wavelength).cos()
            })
            .collect();
        if let Some(i) = raw.iter().position(|g| !g.is_finite()) {
            return Err(Error::param(
                "gabor",
                format!(
                    "sigma {}, wavelength {} and gamma {} give a term that is not finite \
                     (kernel {m}, index {i})",
                    p.sigma, p.wavelength, p.gamma
                ),
            ));
        }
        let lo = raw.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = raw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let span = hi - lo;
        out.extend(raw.iter().map(|&g| {
            if span > 0.0 {
                // Round-off of a cosine that should be 0 leaves values far below 2^-21; flush
                // them so that potentials stay exact float64 sums (docs/model.md §3-4).
                let w = ((g - lo) / span) as f32;
                if w < GABOR_FLUSH {
                    0.0
                } else {
                    w
                }
            } else {
                1.0
            }
        }));
    }
    Ok(out)
}

/// Scaled Gabor weights below this are set to 0 (see [`gabor_kernels`]).
const GABOR_FLUSH: f32 = 1.0 / (1u32 << 21) as f32;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::config::NetworkConfig;

    #[test]
    fn kernels_are_scaled_and_oriented() {
        let p = NetworkConfig::default().gabor;
        let w = gabor_kernels(5, 4, &p).unwrap();
        assert_eq!(w.len(), 100);
        for m in 0..4 {
            let kernel = &w[m * 25..(m + 1) * 25];
            let lo = kernel.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = kernel.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            assert_eq!((lo, hi), (0.0, 1.0));
        }
        // 0°: the wave runs along x, so the kernel responds to vertical edges: its centre
        // column is its strongest, and every row is the same up to the envelope.
        let k0 = &w[..25];
        let col = |c: usize| (0..5).map(|r| k0[r * 5 + c]).sum::<f32>();
        assert!(col(2) > col(1) && col(2) > col(0));
        // 90° is 0° transposed.
        let k90 = &w[50..75];
        for r in 0..5 {
            for c in 0..5 {
                assert!((k0[r * 5 + c] - k90[c * 5 + r]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn sizes_above_the_cap_and_bad_parameters_are_refused() {
        let p = NetworkConfig::default().gabor;
        // 65535² float64 terms (34 GB), then 2^64 weights (an overflow), used to abort or panic.
        crate::error::assert_over_cap(&gabor_kernels(65_535, 65_535, &p).unwrap_err(), "k");
        crate::error::assert_over_cap(&gabor_kernels(1 << 32, 1 << 32, &p).unwrap_err(), "k");
        crate::error::assert_over_cap(&gabor_kernels(5, 1 << 60, &p).unwrap_err(), "maps");
        crate::error::assert_over_cap(&gabor_kernels(1 << 14, 1 << 10, &p).unwrap_err(), "maps");
        assert!(gabor_kernels(0, 4, &p).unwrap().is_empty());
        assert!(gabor_kernels(5, 0, &p).unwrap().is_empty());
        for bad in [
            GaborConfig {
                sigma: f64::NAN,
                ..p
            },
            GaborConfig {
                wavelength: 1e-320,
                ..p
            },
        ] {
            let err = gabor_kernels(5, 4, &bad).unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name: "gabor", .. }),
                "{bad:?}: {err}"
            );
        }
    }
}
