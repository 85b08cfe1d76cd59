//! The network's configuration (docs/api.md, docs/model.md §2): every number of the paper's
//! Table 1 is a field, with the table as the default. The struct is (de)serialised with serde as
//! the JSON dict of `uavsnn.network.default_config()`; missing fields take their defaults and
//! unknown fields are rejected, so a typo never passes silently.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The only configuration format version this engine reads and writes.
pub const CONFIG_VERSION: u32 = 1;

/// How conv and pool layers treat their borders (docs/model.md §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Padding {
    /// Output size = input size (conv) or `ceil(in / stride)` (pool); reads past the border see
    /// padding, which never spikes.
    Same,
    /// Only positions whose whole kernel lies inside the input.
    Valid,
}

/// One convolution layer (conv1, conv2 or conv3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConvConfig {
    /// Kernel side `k` (kernels are `k × k`).
    pub kernel: usize,
    /// Number of feature maps.
    pub maps: usize,
    /// Firing threshold (for conv1: the static threshold, used when `pent.mode == "static"`).
    pub threshold: f32,
    /// Inter-map lateral inhibition in inference: one map per position per window.
    pub lateral_inhibition: bool,
    /// Winner-take-all: at most this many winners per training window.
    pub wta_k: usize,
    /// Winner-take-all: Chebyshev radius of inter-map inhibition around a winner.
    pub wta_radius: usize,
}

/// One max-pooling layer (pool1 or pool2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoolConfig {
    /// Block side.
    pub kernel: usize,
    /// Step between blocks.
    pub stride: usize,
}

/// How conv1's threshold is set (docs/model.md §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThresholdMode {
    /// Pre-emptive neuron thresholding, from the window's number of input spikes.
    Pent,
    /// `conv1.threshold` for every map (the paper's comparison).
    Static,
}

/// Where PENT's `N_in` comes from (docs/model.md §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PentEstimate {
    /// The window's own number of input spikes (offline).
    Window,
    /// The number of distinct active pixels in `[t0 − L, t0)` (what a live stream knows).
    Preceding,
}

/// PENT parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PentConfig {
    /// `"pent"` or `"static"`.
    pub mode: ThresholdMode,
    /// β: how many times denser than the window's average a neuron's input must be.
    pub beta: f64,
    /// `θ_min`: the threshold floor.
    pub theta_min: f64,
    /// `ρ_max`, optional: the most local density PENT asks for, `θ1 ≤ max(θ_min, ρ_max · K1)`.
    /// Without it (SPEC §3's formula as written) a window busier than `1/β` of the sensor asks
    /// for more than a whole kernel of input, which no neuron can reach, so heavy noise silences
    /// layer 1 instead of raising its bar. Absent from older model files: none.
    #[serde(default)]
    pub max_density: Option<f64>,
    /// Source of `N_in`.
    pub estimate: PentEstimate,
}

/// STDP learning rates and their schedule (docs/model.md §6).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StdpConfig {
    /// Initial potentiation rate a⁺ (> 0).
    pub a_plus: f64,
    /// Initial depression rate a⁻ (≤ 0).
    pub a_minus: f64,
    /// Cap of the doubling schedule of a⁺.
    pub a_plus_max: f64,
    /// Double a⁺ every this many training windows.
    pub lr_every: u64,
}

/// The detection rule (docs/model.md §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectionConfig {
    /// A window contains a UAV when at least this many conv3 neurons fire.
    pub min_detections: usize,
}

/// Initial weights of conv2 and conv3: `N(mean, std)` clipped to `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitConfig {
    pub mean: f64,
    pub std: f64,
}

/// conv1's Gabor kernels (docs/model.md §4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaborConfig {
    pub sigma: f64,
    pub wavelength: f64,
    pub gamma: f64,
}

/// The whole network configuration (docs/api.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkConfig {
    /// Format version; always [`CONFIG_VERSION`].
    pub version: u32,
    /// Input (sensor) width in pixels.
    pub width: usize,
    /// Input (sensor) height in pixels.
    pub height: usize,
    pub padding: Padding,
    pub conv1: ConvConfig,
    pub pool1: PoolConfig,
    pub conv2: ConvConfig,
    pub pool2: PoolConfig,
    pub conv3: ConvConfig,
    pub pent: PentConfig,
    pub stdp: StdpConfig,
    pub detection: DetectionConfig,
    pub init: InitConfig,
    pub gabor: GaborConfig,
}

impl Default for NetworkConfig {
    /// The paper's Table 1 on a 240 × 180 sensor, with `same` padding.
    fn default() -> Self {
        Self {
            version: CONFIG_VERSION,
            width: 240,
            height: 180,
            padding: Padding::Same,
            conv1: ConvConfig {
                kernel: 5,
                maps: 4,
                threshold: 4.0,
                lateral_inhibition: true,
                wta_k: 4,
                wta_radius: 5,
            },
            pool1: PoolConfig {
                kernel: 5,
                stride: 5,
            },
            conv2: ConvConfig {
                kernel: 10,
                maps: 20,
                threshold: 45.0,
                lateral_inhibition: true,
                wta_k: 5,
                wta_radius: 10,
            },
            pool2: PoolConfig {
                kernel: 5,
                stride: 5,
            },
            conv3: ConvConfig {
                kernel: 5,
                maps: 10,
                threshold: 3.0,
                lateral_inhibition: true,
                wta_k: 8,
                wta_radius: 5,
            },
            pent: PentConfig {
                mode: ThresholdMode::Pent,
                beta: 8.0,
                theta_min: 3.0,
                max_density: None,
                estimate: PentEstimate::Window,
            },
            stdp: StdpConfig {
                a_plus: 0.004,
                a_minus: -0.003,
                a_plus_max: 0.15,
                lr_every: 500,
            },
            detection: DetectionConfig { min_detections: 1 },
            init: InitConfig {
                mean: 0.8,
                std: 0.08,
            },
            gabor: GaborConfig {
                sigma: 1.5,
                wavelength: 4.0,
                gamma: 0.5,
            },
        }
    }
}

/// Sizes above this (per axis, and for kernels and maps) are rejected as absurd: they would not
/// fit the engine's 16-bit coordinates.
const MAX_SIDE: usize = u16::MAX as usize;

/// Most weights a network may hold, its three conv layers together (`maps · in_channels · k²`
/// each; conv1 has one input channel, conv2 and conv3 the maps of the layer below). Each takes
/// 16 bytes (float32 canonical and engine copies, float64 sorted sums), so 2^26 weights are
/// 1 GiB; Table 1's layers hold 13,100.
pub const MAX_WEIGHTS: usize = 1 << 26;

/// Most bytes one window's state may take (per-pixel tables, every layer's potentials, pool
/// stamps and cause words, as `Geometry::state_bytes` counts them), the engine's
/// [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES): 4 GiB (less on 32-bit targets).
/// Table 1's layers need about 30 MB on a 1280 × 720 sensor and 150 MB on 2048 × 2048.
pub const MAX_WINDOW_STATE_BYTES: usize = crate::error::MAX_ALLOC_BYTES;

impl NetworkConfig {
    /// Parse a JSON config and validate it. Missing fields, at any depth, take the defaults
    /// (`{"conv2": {"threshold": 30}}` changes one number); unknown fields are refused.
    pub fn from_json(text: &str) -> Result<Self> {
        let bad =
            |e: serde_json::Error| Error::param("config", format!("cannot read the config: {e}"));
        let given: serde_json::Value = serde_json::from_str(text).map_err(bad)?;
        if !given.is_object() {
            return Err(Error::param(
                "config",
                format!("must be a JSON object, got {given}"),
            ));
        }
        let mut merged = serde_json::to_value(Self::default()).map_err(bad)?;
        merge(&mut merged, given);
        let config: Self = serde_json::from_value(merged).map_err(bad)?;
        config.validate()?;
        Ok(config)
    }

    /// The config as pretty JSON (the dict of `default_config()`).
    pub fn to_json(&self) -> String {
        // Serialising plain structs of numbers, bools and enums cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// The conv layers' configs in order: `conv(0)` is conv1, `conv(1)` conv2 and `conv(2)`
    /// conv3 (a [`ConvLayer`](super::ConvLayer)'s [`index`](super::ConvLayer::index)).
    ///
    /// # Panics
    ///
    /// If `index` is 3 or more, as indexing a slice of the three does.
    pub fn conv(&self, index: usize) -> &ConvConfig {
        match index {
            0 => &self.conv1,
            1 => &self.conv2,
            2 => &self.conv3,
            _ => panic!("conv layer index {index} is out of range: there are 3 conv layers"),
        }
    }

    /// The pool layers' configs in order: `pool(0)` is pool1 and `pool(1)` pool2.
    ///
    /// # Panics
    ///
    /// If `index` is 2 or more, as indexing a slice of the two does.
    pub fn pool(&self, index: usize) -> &PoolConfig {
        match index {
            0 => &self.pool1,
            1 => &self.pool2,
            _ => panic!("pool layer index {index} is out of range: there are 2 pool layers"),
        }
    }

    /// Check every field's range ([`NetworkConfig::validate`] also checks that the layers'
    /// sizes compose, in `geometry`, which this module does not import).
    pub(super) fn check_fields(&self) -> Result<()> {
        if self.version != CONFIG_VERSION {
            return Err(Error::param(
                "version",
                format!(
                    "this engine reads config version {CONFIG_VERSION}, got {}",
                    self.version
                ),
            ));
        }
        for (name, side) in [("width", self.width), ("height", self.height)] {
            if side == 0 || side > MAX_SIDE {
                return Err(Error::param(
                    name,
                    format!("must be in 1..={MAX_SIDE}, got {side}"),
                ));
            }
        }
        for index in 0..3 {
            check_conv(index, self.conv(index))?;
        }
        self.check_weights()?;
        for (name, p) in [("pool1", &self.pool1), ("pool2", &self.pool2)] {
            if p.kernel == 0 || p.kernel > MAX_SIDE || p.stride == 0 || p.stride > MAX_SIDE {
                return Err(Error::param(
                    name,
                    format!(
                        "kernel and stride must be in 1..={MAX_SIDE}, got kernel {} stride {}",
                        p.kernel, p.stride
                    ),
                ));
            }
        }
        self.check_pent()?;
        self.check_stdp()?;
        if self.detection.min_detections == 0 {
            return Err(Error::param(
                "detection.min_detections",
                "must be at least 1, got 0",
            ));
        }
        if !(self.init.mean.is_finite() && self.init.std.is_finite() && self.init.std >= 0.0) {
            return Err(Error::param(
                "init",
                format!(
                    "mean must be finite and std finite and >= 0, got mean {} std {}",
                    self.init.mean, self.init.std
                ),
            ));
        }
        let g = &self.gabor;
        if !(g.sigma.is_finite()
            && g.sigma > 0.0
            && g.wavelength.is_finite()
            && g.wavelength > 0.0
            && g.gamma.is_finite()
            && g.gamma > 0.0)
        {
            return Err(Error::param(
                "gabor",
                format!(
                    "sigma, wavelength and gamma must be finite and > 0, got sigma {} \
                     wavelength {} gamma {}",
                    g.sigma, g.wavelength, g.gamma
                ),
            ));
        }
        // The kernel's terms (gabor.rs) must stay finite over the kernel: a subnormal sigma or
        // wavelength, or a gamma whose square overflows, made NaN weights (refused later as
        // the weights' fault).
        let reach = 2.0 * std::f64::consts::PI * self.conv1.kernel as f64 / g.wavelength;
        let spread = 2.0 * g.sigma * g.sigma;
        let finite = spread > 0.0
            && spread.is_finite()
            && (g.gamma * g.gamma).is_finite()
            && reach.is_finite();
        if !finite {
            return Err(Error::param(
                "gabor",
                format!(
                    "sigma {}, wavelength {} and gamma {} make a kernel that is not finite: \
                     2·sigma² must be a positive float, gamma² and 2π·kernel/wavelength finite",
                    g.sigma, g.wavelength, g.gamma
                ),
            ));
        }
        Ok(())
    }

    /// The three layers' weights together at most [`MAX_WEIGHTS`] (fields already in range).
    fn check_weights(&self) -> Result<()> {
        let in_channels = [1, self.conv1.maps, self.conv2.maps];
        let per_layer: Vec<u128> = (0..3)
            .map(|i| {
                let c = self.conv(i);
                c.maps as u128 * in_channels[i] as u128 * c.kernel as u128 * c.kernel as u128
            })
            .collect();
        let total: u128 = per_layer.iter().sum();
        if total > MAX_WEIGHTS as u128 {
            return Err(Error::param(
                "config",
                format!(
                    "the conv layers hold {total} weights (maps x in_channels x kernel^2: conv1 \
                     {}, conv2 {}, conv3 {}), above the cap of {MAX_WEIGHTS} (MAX_WEIGHTS); \
                     use smaller kernels or fewer maps",
                    per_layer[0], per_layer[1], per_layer[2]
                ),
            ));
        }
        Ok(())
    }

    fn check_pent(&self) -> Result<()> {
        let p = &self.pent;
        if !(p.beta.is_finite() && p.beta >= 0.0) {
            return Err(Error::param(
                "pent.beta",
                format!("must be finite and >= 0, got {}", p.beta),
            ));
        }
        if !(p.theta_min.is_finite() && p.theta_min > 0.0) || p.theta_min > f64::from(f32::MAX) {
            return Err(Error::param(
                "pent.theta_min",
                format!("must be finite and > 0, got {}", p.theta_min),
            ));
        }
        if let Some(r) = p.max_density {
            if !(r > 0.0 && r <= 1.0) {
                return Err(Error::param(
                    "pent.max_density",
                    format!("must be in (0, 1] or null, got {r}"),
                ));
            }
        }
        Ok(())
    }

    fn check_stdp(&self) -> Result<()> {
        let s = &self.stdp;
        if !(s.a_plus.is_finite() && s.a_plus > 0.0) {
            return Err(Error::param(
                "stdp.a_plus",
                format!("must be finite and > 0, got {}", s.a_plus),
            ));
        }
        if !(s.a_minus.is_finite() && s.a_minus <= 0.0) {
            return Err(Error::param(
                "stdp.a_minus",
                format!("must be finite and <= 0, got {}", s.a_minus),
            ));
        }
        if !(s.a_plus_max.is_finite() && s.a_plus_max > 0.0) {
            return Err(Error::param(
                "stdp.a_plus_max",
                format!("must be finite and > 0, got {}", s.a_plus_max),
            ));
        }
        if s.lr_every == 0 {
            return Err(Error::param("stdp.lr_every", "must be at least 1, got 0"));
        }
        // The rates are applied in float32: the largest each reaches must be one (a rate past
        // it became infinite, and the weights it touched NaN).
        let f32_max = f64::from(f32::MAX);
        let reached = [
            ("stdp.a_plus", s.a_plus),
            ("stdp.a_plus_max", s.a_plus.max(s.a_plus_max)),
            (
                "stdp.a_minus",
                s.a_minus.abs() * (s.a_plus.max(s.a_plus_max) / s.a_plus),
            ),
        ];
        for (name, rate) in reached {
            // NaN cannot come here: the rates were checked finite and a_plus > 0 above.
            if rate > f32_max {
                return Err(Error::param(
                    name,
                    format!(
                        "makes a rate of {rate:e} (a_minus grows with a_plus up to \
                         a_plus_max), beyond float32's largest ({f32_max:e})"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Fields a complete config may lack: those added after the first model files were written,
/// whose default is what those files meant.
const ADDED_LATER: [&str; 1] = ["pent.max_density"];

impl NetworkConfig {
    /// The fields (dotted paths, `pent.beta`) that the JSON object `given` lacks, which
    /// [`NetworkConfig::from_json`] would fill with their defaults. A model file's config is
    /// written whole, so a field missing there is damage, not a wish for the default.
    pub fn missing_fields(given: &serde_json::Value) -> Vec<String> {
        let mut missing = Vec::new();
        if let Ok(full) = serde_json::to_value(Self::default()) {
            missing_under(&full, given, "", &mut missing);
        }
        missing.retain(|path| !ADDED_LATER.contains(&path.as_str()));
        missing
    }
}

fn missing_under(
    full: &serde_json::Value,
    given: &serde_json::Value,
    prefix: &str,
    out: &mut Vec<String>,
) {
    let serde_json::Value::Object(full) = full else {
        return;
    };
    for (key, value) in full {
        let path = format!("{prefix}{key}");
        match given.get(key) {
            Some(slot) => missing_under(value, slot, &format!("{path}."), out),
            None => out.push(path),
        }
    }
}

/// Overlay `given` onto `base`, recursing into objects present in both.
fn merge(base: &mut serde_json::Value, given: serde_json::Value) {
    match (base, given) {
        (serde_json::Value::Object(b), serde_json::Value::Object(g)) => {
            for (key, value) in g {
                match b.get_mut(&key) {
                    Some(slot) => merge(slot, value),
                    None => {
                        b.insert(key, value);
                    }
                }
            }
        }
        (slot, value) => *slot = value,
    }
}

/// Field names per conv layer, for error messages (`Error` names are static strings).
const CONV_FIELDS: [[&str; 4]; 3] = [
    [
        "conv1.kernel",
        "conv1.maps",
        "conv1.threshold",
        "conv1.wta_k",
    ],
    [
        "conv2.kernel",
        "conv2.maps",
        "conv2.threshold",
        "conv2.wta_k",
    ],
    [
        "conv3.kernel",
        "conv3.maps",
        "conv3.threshold",
        "conv3.wta_k",
    ],
];

fn check_conv(index: usize, c: &ConvConfig) -> Result<()> {
    let [kernel, maps, threshold, wta_k] = CONV_FIELDS[index];
    if c.kernel == 0 || c.kernel > MAX_SIDE {
        return Err(Error::param(
            kernel,
            format!("must be in 1..={MAX_SIDE}, got {}", c.kernel),
        ));
    }
    if c.maps == 0 || c.maps > MAX_SIDE {
        return Err(Error::param(
            maps,
            format!("must be in 1..={MAX_SIDE}, got {}", c.maps),
        ));
    }
    if !(c.threshold.is_finite() && c.threshold > 0.0) {
        return Err(Error::param(
            threshold,
            format!("must be finite and > 0, got {}", c.threshold),
        ));
    }
    if c.wta_k == 0 {
        return Err(Error::param(wta_k, "must be at least 1, got 0"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::ConvLayer;

    #[test]
    fn layers_by_index() {
        let mut c = NetworkConfig::default();
        (c.conv1.maps, c.conv2.maps, c.conv3.maps) = (1, 2, 3);
        for layer in ConvLayer::ALL {
            assert_eq!(c.conv(layer.index()).maps, 1 + layer.index());
        }
        c.pool2.kernel = 3;
        assert_eq!(c.pool(0), &c.pool1);
        assert_eq!(c.pool(1), &c.pool2);
        assert_ne!(c.pool(0), c.pool(1));
    }

    #[test]
    #[should_panic(expected = "conv layer index 7 is out of range")]
    fn no_conv_layer_beyond_conv3() {
        let _ = NetworkConfig::default().conv(7);
    }

    #[test]
    #[should_panic(expected = "pool layer index 2 is out of range")]
    fn no_pool_layer_beyond_pool2() {
        let _ = NetworkConfig::default().pool(2);
    }

    #[test]
    fn default_is_valid_and_round_trips_through_json() {
        let c = NetworkConfig::default();
        c.validate().unwrap();
        let back = NetworkConfig::from_json(&c.to_json()).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn missing_fields_take_defaults() {
        let c = NetworkConfig::from_json(r#"{"width": 64, "height": 48}"#).unwrap();
        assert_eq!(c.width, 64);
        assert_eq!(c.conv2, NetworkConfig::default().conv2);
        let c = NetworkConfig::from_json(r#"{"conv3": {"maps": 3}}"#).unwrap();
        assert_eq!(c.conv3.maps, 3);
        assert_eq!(c.conv3.kernel, NetworkConfig::default().conv3.kernel);
        assert!(NetworkConfig::from_json(r#"{"conv3": {"mpas": 3}}"#).is_err());
        // Model files written before `pent.max_density` existed read as without the cap.
        let c = NetworkConfig::from_json(
            r#"{"pent": {"mode": "pent", "beta": 8.0, "theta_min": 3.0, "estimate": "window"}}"#,
        )
        .unwrap();
        assert_eq!(c.pent, NetworkConfig::default().pent);
        assert!(NetworkConfig::from_json("[1]").is_err());
    }

    #[test]
    fn caps_weights_and_window_state_but_accepts_large_sensors() {
        for text in [
            r#"{"width": 1280, "height": 720}"#,
            r#"{"width": 2048, "height": 2048}"#,
            r#"{"conv2": {"kernel": 50}}"#,
        ] {
            NetworkConfig::from_json(text).unwrap();
        }
        let refused = |text: &str, what: &str| {
            let err = NetworkConfig::from_json(text).unwrap_err();
            let message = err.to_string();
            assert!(
                matches!(err, Error::InvalidParameter { name: "config", .. }),
                "{text}: {message}"
            );
            assert!(message.contains(what), "{text}: {message}");
        };
        // Each field within 65535, the product far beyond memory.
        refused(r#"{"conv2": {"kernel": 65535}}"#, "MAX_WEIGHTS");
        refused(
            r#"{"conv1": {"maps": 65535}, "conv2": {"maps": 65535}}"#,
            "MAX_WEIGHTS",
        );
        refused(
            r#"{"width": 65535, "height": 65535}"#,
            "MAX_WINDOW_STATE_BYTES",
        );
        // A pool block of 65535² conv neurons needs 2^26 cause words per pool neuron.
        refused(
            r#"{"pool1": {"kernel": 65535, "stride": 65535}, "conv1": {"maps": 200}}"#,
            "MAX_WINDOW_STATE_BYTES",
        );
    }

    #[test]
    fn rejects_bad_values() {
        let cases = [
            r#"{"version": 2}"#,
            r#"{"width": 0}"#,
            r#"{"conv2": {"kernel": 0, "maps": 20, "threshold": 45.0,
                "lateral_inhibition": true, "wta_k": 5, "wta_radius": 10}}"#,
            r#"{"conv2": {"kernel": 10, "maps": 20, "threshold": -1.0,
                "lateral_inhibition": true, "wta_k": 5, "wta_radius": 10}}"#,
            r#"{"pent": {"mode": "pent", "beta": -1.0, "theta_min": 3.0,
                "estimate": "window"}}"#,
            r#"{"pent": {"mode": "pent", "beta": 8.0, "theta_min": 0.0,
                "estimate": "window"}}"#,
            r#"{"pent": {"mode": "pent", "beta": 8.0, "theta_min": 3.0,
                "max_density": 0.0, "estimate": "window"}}"#,
            r#"{"pent": {"mode": "pent", "beta": 8.0, "theta_min": 3.0,
                "max_density": 1.01, "estimate": "window"}}"#,
            r#"{"padding": "valid", "width": 8, "height": 8}"#,
            r#"{"widht": 240}"#,
            r#"{"stdp": {"a_plus": 0.004, "a_minus": 0.003, "a_plus_max": 0.15,
                "lr_every": 500}}"#,
            // Rates past float32's range: they became infinite and the weights NaN.
            r#"{"stdp": {"a_plus": 1e39, "a_minus": -0.003, "a_plus_max": 0.15,
                "lr_every": 500}}"#,
            r#"{"stdp": {"a_plus": 0.004, "a_minus": -0.003, "a_plus_max": 1e300,
                "lr_every": 1}}"#,
            // Subnormal Gabor parameters and a gamma whose square overflows: NaN kernels.
            r#"{"gabor": {"sigma": 1.0, "wavelength": 1e-320, "gamma": 0.5}}"#,
            r#"{"gabor": {"sigma": 1e-200, "wavelength": 3.0, "gamma": 0.5}}"#,
            r#"{"gabor": {"sigma": 1.0, "wavelength": 3.0, "gamma": 1e200}}"#,
            // a⁻ grows with a⁺: 3e35 · (3e38 / 0.004) is past it too.
            r#"{"stdp": {"a_plus": 0.004, "a_minus": -3e35, "a_plus_max": 3e38,
                "lr_every": 1}}"#,
        ];
        for text in cases {
            let err = NetworkConfig::from_json(text).unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { .. } | Error::Shape { .. }),
                "{text}: {err:?}"
            );
        }
    }
}
