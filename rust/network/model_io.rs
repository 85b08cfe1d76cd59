//! Model files ([`MODEL_FORMAT`]): writing, reading and checking them.

use std::fs;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::config::{NetworkConfig, CONFIG_VERSION};
use super::layer::ConvLayer;
use super::npz::{npy_bytes, parse_npy, unzip, zip_stored};
use super::window::Network;
use crate::error::{Error, Result};

/// The format marker stored in every model file.
///
/// A model file is an uncompressed `.npz` archive (readable by `numpy.load(path,
/// allow_pickle=False)`) holding
///
/// - `format`: the bytes of [`MODEL_FORMAT`] as a `uint8` array,
/// - `config`: the config as UTF-8 JSON bytes, a `uint8` array (its `version` is checked, and
///   every field must be there: [`NetworkConfig::missing_fields`]),
/// - `conv1`, `conv2`, `conv3`: the weights, `float32` `(maps, in_ch, k, k)`.
///
/// Writing is atomic (a temporary file in the same folder, synced, then renamed over the
/// target); loading checks the format, version, shapes and that every weight is finite and in
/// `[0, 1]`, and reports any problem as [`Error::Model`]. No pickled code, ever.
pub const MODEL_FORMAT: &str = "uavsnn-model";

/// The largest model file [`Network::load`] reads: four times the bytes of the most weights a
/// network may hold ([`MAX_WEIGHTS`](super::config::MAX_WEIGHTS) float32s), room for its config
/// and identification part (at most tens of MB).
pub const MAX_MODEL_FILE_BYTES: u64 = 1 << 30;

impl Network {
    /// The model file's bytes (the format: [`MODEL_FORMAT`]).
    pub fn to_npz_bytes(&self) -> Result<Vec<u8>> {
        let json = self.config().to_json();
        let mut entries = vec![
            (
                "format.npy".to_string(),
                npy_bytes("|u1", &[MODEL_FORMAT.len()], MODEL_FORMAT.as_bytes()),
            ),
            (
                "config.npy".to_string(),
                npy_bytes("|u1", &[json.len()], json.as_bytes()),
            ),
        ];
        for layer in ConvLayer::ALL {
            let w = self.conv_weights(layer);
            let data: Vec<u8> = w.canonical().iter().flat_map(|v| v.to_le_bytes()).collect();
            entries.push((
                format!("{}.npy", layer.name()),
                npy_bytes("<f4", &w.shape(), &data),
            ));
        }
        zip_stored(&entries)
    }

    /// A network from a model file's bytes (checked).
    pub fn from_npz_bytes(bytes: &[u8]) -> Result<Self> {
        let entries = unzip(bytes)?;
        let entry = |name: &str| {
            entries
                .iter()
                .find(|(n, _)| n == &format!("{name}.npy"))
                .map(|(_, b)| b.as_slice())
                .ok_or_else(|| {
                    Error::Model(format!(
                        "not a uavsnn model: the archive has no `{name}` array (it holds {})",
                        entries
                            .iter()
                            .map(|(n, _)| n.trim_end_matches(".npy"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })
        };
        let format = parse_npy("format", entry("format")?)?;
        if format.data != MODEL_FORMAT.as_bytes() {
            return Err(Error::Model(format!(
                "not a uavsnn model: format marker is {:?}",
                String::from_utf8_lossy(&format.data)
            )));
        }
        let config = read_config(&parse_npy("config", entry("config")?)?.data)?;
        let geom = super::geometry::Geometry::new(&config)
            .map_err(|e| Error::Model(format!("its config is invalid: {e}")))?;
        let mut weights: [Vec<f32>; 3] = Default::default();
        for layer in ConvLayer::ALL {
            let name = layer.name();
            let a = parse_npy(name, entry(name)?)?;
            let g = &geom.conv[layer.index()];
            let expected = [g.maps, g.in_ch, g.k, g.k];
            if a.descr != "<f4" || a.shape != expected {
                return Err(Error::Model(format!(
                    "array {name}: expected float32 {expected:?} from the config, got {} {:?}",
                    a.descr, a.shape
                )));
            }
            weights[layer.index()] = a
                .data
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
        }
        Network::from_weights(config, weights).map_err(|e| match e {
            Error::Model(m) => Error::Model(m),
            other => Error::Model(format!("inconsistent model: {other}")),
        })
    }

    /// Save to `path` atomically (a temporary file beside it, then a rename).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let bytes = self.to_npz_bytes()?;
        write_atomic(path, &bytes)
            .map_err(|e| Error::Model(format!("cannot write {}: {e}", path.display())))
    }

    /// Load from `path` (checked: [`MODEL_FORMAT`]). A file larger than
    /// [`MAX_MODEL_FILE_BYTES`] is refused before more than that is read.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes = read_at_most(path, MAX_MODEL_FILE_BYTES)?;
        Self::from_npz_bytes(&bytes)
            .map_err(|e| Error::Model(format!("{}: {}", path.display(), strip(&e))))
    }
}

/// The bytes of the file at `path`, refused (before more than `limit + 1` bytes are read) when
/// it holds more than `limit`: a device or a huge file named by mistake.
fn read_at_most(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let cannot = |e: std::io::Error| Error::Model(format!("cannot read {}: {e}", path.display()));
    let file = fs::File::open(path).map_err(cannot)?;
    let hint = file.metadata().map_or(0, |m| m.len()).min(limit);
    let mut bytes = Vec::with_capacity(usize::try_from(hint).unwrap_or(0));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > limit {
        return Err(Error::Model(format!(
            "{}: larger than {limit} bytes (MAX_MODEL_FILE_BYTES), more than any network's \
             weights and identification take; not a model file",
            path.display()
        )));
    }
    Ok(bytes)
}

/// An error's message without the `model file:` prefix (it is added again by the caller).
fn strip(e: &Error) -> String {
    match e {
        Error::Model(m) => m.clone(),
        other => other.to_string(),
    }
}

fn read_config(bytes: &[u8]) -> Result<NetworkConfig> {
    let text = std::str::from_utf8(bytes)
        .map_err(|_| Error::Model("its config is not UTF-8 text".into()))?;
    let value: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| Error::Model(format!("its config is not JSON: {e}")))?;
    match value.get("version").and_then(serde_json::Value::as_u64) {
        Some(v) if v == u64::from(CONFIG_VERSION) => {}
        Some(v) => {
            return Err(Error::Model(format!(
                "model version {v} is not supported (this engine reads version {CONFIG_VERSION})"
            )))
        }
        None => return Err(Error::Model("its config has no version".into())),
    }
    let missing = NetworkConfig::missing_fields(&value);
    if !missing.is_empty() {
        return Err(Error::Model(format!(
            "its config lacks {} (a model file's config is written whole; this one is damaged)",
            missing.join(", ")
        )));
    }
    NetworkConfig::from_json(text).map_err(|e| Error::Model(format!("its config is invalid: {e}")))
}

/// Write `bytes` to a temporary file beside `path`, sync it, and rename it over `path`.
fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::other("the path has no file name"))?;
    let tmp: PathBuf = dir.join(format!(
        ".{}.tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_above_the_limit_is_refused_after_reading_one_byte_more() {
        let dir = std::env::temp_dir().join(format!("uavsnn-read-at-most-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("big.npz");
        fs::write(&path, vec![1u8; 101]).unwrap();
        assert_eq!(read_at_most(&path, 101).unwrap().len(), 101);
        let err = read_at_most(&path, 100).unwrap_err();
        assert!(err.to_string().contains("larger than 100 bytes"), "{err}");
        fs::remove_dir_all(&dir).unwrap();
        #[cfg(unix)] // endless: read only up to the limit
        {
            let err = read_at_most(Path::new("/dev/zero"), 1000).unwrap_err();
            assert!(err.to_string().contains("larger than 1000 bytes"), "{err}");
        }
    }

    fn small() -> Network {
        let c = NetworkConfig {
            width: 40,
            height: 30,
            ..NetworkConfig::default()
        };
        Network::new(c, 5).unwrap()
    }

    #[test]
    fn save_load_round_trip_is_exact() {
        let net = small();
        let dir = std::env::temp_dir().join(format!("uavsnn-model-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.npz");
        net.save(&path).unwrap();
        let back = Network::load(&path).unwrap();
        assert_eq!(back, net);
        // No temporary file is left behind.
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rejects_foreign_truncated_and_corrupt_files() {
        let bytes = small().to_npz_bytes().unwrap();
        for bad in [
            &b"hello"[..],
            &bytes[..bytes.len() / 2],
            &bytes[..bytes.len() - 3],
        ] {
            assert!(matches!(Network::from_npz_bytes(bad), Err(Error::Model(_))));
        }
        // Another archive without our arrays.
        let other = zip_stored(&[("x.npy".into(), npy_bytes("|u1", &[1], &[0]))]).unwrap();
        let err = Network::from_npz_bytes(&other).unwrap_err();
        assert!(err.to_string().contains("no `format`"), "{err}");
    }

    #[test]
    fn rejects_other_versions_and_bad_weights() {
        let net = small();
        let json = net
            .config()
            .to_json()
            .replace("\"version\": 1", "\"version\": 2");
        let mut entries = vec![
            (
                "format.npy".to_string(),
                npy_bytes("|u1", &[MODEL_FORMAT.len()], MODEL_FORMAT.as_bytes()),
            ),
            (
                "config.npy".to_string(),
                npy_bytes("|u1", &[json.len()], json.as_bytes()),
            ),
        ];
        for layer in ConvLayer::ALL {
            let w = net.conv_weights(layer);
            let mut values = w.canonical().to_vec();
            if layer == ConvLayer::Conv3 {
                values[0] = 1.5;
            }
            let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            entries.push((format!("{layer}.npy"), npy_bytes("<f4", &w.shape(), &data)));
        }
        let err = Network::from_npz_bytes(&zip_stored(&entries).unwrap()).unwrap_err();
        assert!(err.to_string().contains("version 2"), "{err}");
        // A field left out is damage, not the default: a top-level one and a nested one.
        let mut partial: serde_json::Value = serde_json::from_str(&net.config().to_json()).unwrap();
        let config = partial.as_object_mut().unwrap();
        config.remove("width");
        config["pent"].as_object_mut().unwrap().remove("beta");
        let partial = partial.to_string();
        entries[1].1 = npy_bytes("|u1", &[partial.len()], partial.as_bytes());
        let err = Network::from_npz_bytes(&zip_stored(&entries).unwrap()).unwrap_err();
        assert!(
            matches!(err, Error::Model(_)) && err.to_string().contains("lacks pent.beta, width"),
            "{err}"
        );
        // ... except a field older files were written without.
        let mut older: serde_json::Value = serde_json::from_str(&net.config().to_json()).unwrap();
        older["pent"].as_object_mut().unwrap().remove("max_density");
        assert!(NetworkConfig::missing_fields(&older).is_empty());
        entries[1].1 = npy_bytes(
            "|u1",
            &[net.config().to_json().len()],
            net.config().to_json().as_bytes(),
        );
        let err = Network::from_npz_bytes(&zip_stored(&entries).unwrap()).unwrap_err();
        assert!(
            matches!(err, Error::Model(_)) && err.to_string().contains("[0, 1]"),
            "{err}"
        );
    }
}
