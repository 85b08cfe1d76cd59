//! The emulated sensor's parameters ([`DvsParams`]), their defaults and their bounds.

use crate::error::{Error, Result};

/// Lowest threshold a mismatched pixel may get (v2e's clamp).
pub const MIN_THRESHOLD: f32 = 0.01;

/// Highest noise rate accepted, per pixel: one event per microsecond.
pub const MAX_RATE_HZ: f64 = 1e6;

/// Parameters of the emulated sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DvsParams {
    /// Mean ON threshold on the change of the response (log units).
    pub threshold_on: f32,
    /// Mean OFF threshold (log units, positive).
    pub threshold_off: f32,
    /// Standard deviation of the per-pixel thresholds.
    pub threshold_sigma: f32,
    /// Refractory period after each event, in microseconds.
    pub refractory_us: f64,
    /// Leak (background activity) ON events per pixel per second in a static scene.
    pub leak_rate_hz: f64,
    /// Log-normal spread of the per-pixel leak rates, in decades.
    pub leak_spread_decades: f64,
    /// Shot-noise events per pixel per second in the dark.
    pub shot_noise_rate_hz: f64,
    /// Shot-noise rate at white relative to the dark rate.
    pub shot_noise_bright_factor: f64,
    /// Fraction of pixels that are hot.
    pub hot_pixel_fraction: f64,
    /// ON events per second of a hot pixel.
    pub hot_pixel_rate_hz: f64,
    /// Photoreceptor cutoff at white, in Hz; 0 disables the low-pass.
    pub cutoff_hz: f64,
    /// Luma added before the cutoff scales with intensity: the cutoff at luma `Y` is
    /// `cutoff_hz · (Y + cutoff_dark_luma) / (255 + cutoff_dark_luma)`. v2e's 20 keeps a dark
    /// pixel at 7 % of the bright bandwidth; a small value makes the cutoff proportional to
    /// the light, as a photoreceptor's is.
    pub cutoff_dark_luma: f32,
    /// Luma below which the response is linear rather than logarithmic.
    pub linlog_threshold: f32,
}

impl Default for DvsParams {
    fn default() -> Self {
        Self {
            threshold_on: 0.2,
            threshold_off: 0.2,
            threshold_sigma: 0.03,
            refractory_us: 100.0,
            leak_rate_hz: 0.1,
            leak_spread_decades: 0.1,
            shot_noise_rate_hz: 1.0,
            shot_noise_bright_factor: 0.25,
            hot_pixel_fraction: 1e-4,
            hot_pixel_rate_hz: 20.0,
            cutoff_hz: 300.0,
            cutoff_dark_luma: 20.0,
            linlog_threshold: 20.0,
        }
    }
}

impl DvsParams {
    /// An ideal sensor: uniform thresholds, no refractory period, no noise, unlimited bandwidth.
    pub fn ideal() -> Self {
        Self {
            threshold_sigma: 0.0,
            refractory_us: 0.0,
            leak_rate_hz: 0.0,
            shot_noise_rate_hz: 0.0,
            hot_pixel_fraction: 0.0,
            cutoff_hz: 0.0,
            ..Self::default()
        }
    }

    /// Reject values that cannot make sense, naming the parameter and the value.
    pub fn validate(&self) -> Result<()> {
        // `v` finite and meeting its bound (`ok`, written `bound` in the error).
        let finite = |name: &'static str, v: f64, ok: bool, bound: &str| {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(Error::param(
                    name,
                    format!("must be finite and {bound}, got {v}"),
                ))
            }
        };
        let positive = |name: &'static str, v: f64| finite(name, v, v > 0.0, "> 0");
        let non_negative = |name: &'static str, v: f64| finite(name, v, v >= 0.0, ">= 0");
        let rate = |name: &'static str, v: f64| {
            non_negative(name, v)?;
            if v > MAX_RATE_HZ {
                return Err(Error::param(
                    name,
                    format!("must be <= {MAX_RATE_HZ} Hz (one event per microsecond), got {v}"),
                ));
            }
            Ok(())
        };
        positive("threshold_on", f64::from(self.threshold_on))?;
        positive("threshold_off", f64::from(self.threshold_off))?;
        non_negative("threshold_sigma", f64::from(self.threshold_sigma))?;
        non_negative("refractory_us", self.refractory_us)?;
        rate("leak_rate_hz", self.leak_rate_hz)?;
        non_negative("leak_spread_decades", self.leak_spread_decades)?;
        if self.leak_spread_decades > 3.0 {
            return Err(Error::param(
                "leak_spread_decades",
                format!("must be <= 3, got {}", self.leak_spread_decades),
            ));
        }
        rate("shot_noise_rate_hz", self.shot_noise_rate_hz)?;
        non_negative("shot_noise_bright_factor", self.shot_noise_bright_factor)?;
        rate(
            "shot_noise_rate_hz * shot_noise_bright_factor",
            self.shot_noise_rate_hz * self.shot_noise_bright_factor,
        )?;
        if !(0.0..=1.0).contains(&self.hot_pixel_fraction) {
            return Err(Error::param(
                "hot_pixel_fraction",
                format!("must be in [0, 1], got {}", self.hot_pixel_fraction),
            ));
        }
        rate("hot_pixel_rate_hz", self.hot_pixel_rate_hz)?;
        non_negative("cutoff_hz", self.cutoff_hz)?;
        positive("cutoff_dark_luma", f64::from(self.cutoff_dark_luma))?;
        positive("linlog_threshold", f64::from(self.linlog_threshold))?;
        Ok(())
    }
}
