//! The small subset of NumPy's `.npz` format that model files need, so that Rust users need no
//! Python and the build needs no archive crate: an uncompressed ("stored") zip archive of `.npy`
//! files, with CRC-32 checks. Files written here open with `numpy.load(path,
//! allow_pickle=False)`; files written by `numpy.savez` (zip64 extras included) read back.
//!
//! **Why not a crate.** `zip` (without default features: stored entries only) with `npyz`
//! would replace this file's ~250 lines of parsing. Built clean on their own in a scratch crate
//! (`cargo build --release -j2` of a crate depending on `zip = { default-features = false }`
//! and `npyz`), they are 38 crates, about 45 s of CPU on the project's 2-core machine: `npyz`
//! parses `.npy` headers with a parser generator (`pest` and its derive macros, `py_literal`,
//! `num-bigint`), and `zip` brings `typed-path`, `zeroize` and more, for the one stored entry
//! layout and the one header form that model files use. `ndarray-npy` sits on the same `zip`.
//! So the reader stays, as small as the format needs: it reads lengths and offsets through
//! checked slices (a short or inconsistent file is an error, not a panic) and refuses what
//! model files never hold (compressed entries). It parses files that users hand over, so it
//! is meant to be fuzzed through the public API (`Network::load`), not trusted on review.

use crate::error::{Error, Result};

/// One `.npy` array: dtype descriptor (`"<f4"`, `"|u1"`...), C-order shape and raw bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct NpyArray {
    pub descr: String,
    pub shape: Vec<usize>,
    pub data: Vec<u8>,
}

const NPY_MAGIC: &[u8] = b"\x93NUMPY";

/// Serialise an array as `.npy` version 1.0 (header padded to a multiple of 64 bytes).
pub(crate) fn npy_bytes(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(ToString::to_string).collect();
    let shape_text = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut header =
        format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape_text}, }}");
    let unpadded = NPY_MAGIC.len() + 4 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut out = Vec::with_capacity(NPY_MAGIC.len() + 4 + header.len() + data.len());
    out.extend_from_slice(NPY_MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    out
}

/// Parse a `.npy` file (versions 1 to 3) whose header holds `descr`, `fortran_order` and
/// `shape`; the data length must match the shape and item size.
pub(crate) fn parse_npy(name: &str, bytes: &[u8]) -> Result<NpyArray> {
    let bad = |why: &str| Error::Model(format!("array {name}: {why}"));
    if bytes.len() < 10 || &bytes[..6] != NPY_MAGIC {
        return Err(bad("not a .npy array (bad magic)"));
    }
    let (header_len, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(bad(&format!("unsupported .npy version {v}"))),
    };
    let header = bytes
        .get(start..start + header_len)
        .ok_or_else(|| bad("truncated header"))?;
    let header = std::str::from_utf8(header).map_err(|_| bad("header is not text"))?;
    let descr = quoted_value(header, "descr").ok_or_else(|| bad("no 'descr' in header"))?;
    if value_after(header, "fortran_order").is_some_and(|v| v.starts_with("True")) {
        return Err(bad("Fortran-order arrays are not supported"));
    }
    let shape_text = value_after(header, "shape").ok_or_else(|| bad("no 'shape' in header"))?;
    let shape = parse_shape(shape_text).ok_or_else(|| bad("unreadable shape"))?;
    let item = match descr.as_str() {
        "<f4" => 4,
        "|u1" | "<u1" => 1,
        "<f8" | "<i8" | "<u8" => 8,
        other => return Err(bad(&format!("unsupported dtype {other}"))),
    };
    let data = &bytes[start + header_len..];
    let expected = shape
        .iter()
        .try_fold(item, |acc: usize, &d| acc.checked_mul(d));
    if expected != Some(data.len()) {
        return Err(bad(&format!(
            "data holds {} bytes, shape {shape:?} of {descr} needs {}",
            data.len(),
            expected.map_or_else(|| "too many".to_string(), |e| e.to_string())
        )));
    }
    Ok(NpyArray {
        descr,
        shape,
        data: data.to_vec(),
    })
}

/// The text after `'key':` in a header dict, trimmed at the left.
fn value_after<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let pattern = format!("'{key}':");
    let at = header.find(&pattern)? + pattern.len();
    Some(header[at..].trim_start())
}

fn quoted_value(header: &str, key: &str) -> Option<String> {
    let rest = value_after(header, key)?;
    let quote = rest.chars().next().filter(|c| *c == '\'' || *c == '"')?;
    let end = rest[1..].find(quote)?;
    Some(rest[1..=end].to_string())
}

fn parse_shape(text: &str) -> Option<Vec<usize>> {
    let inner = text.strip_prefix('(')?;
    let inner = &inner[..inner.find(')')?];
    inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse().ok())
        .collect()
}

/// CRC-32 (IEEE, as zip uses), table driven.
pub(crate) fn crc32(data: &[u8]) -> u32 {
    static TABLE: std::sync::OnceLock<[u32; 256]> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        let mut t = [0u32; 256];
        for (i, entry) in t.iter_mut().enumerate() {
            let mut c = i as u32;
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
            *entry = c;
        }
        t
    });
    !data.iter().fold(!0u32, |c, &b| {
        table[((c ^ u32::from(b)) & 0xFF) as usize] ^ (c >> 8)
    })
}

const LOCAL: u32 = 0x0403_4b50;
const CENTRAL: u32 = 0x0201_4b50;
const END: u32 = 0x0605_4b50;
/// 1980-01-01 00:00, the zip epoch: files are byte-for-byte reproducible.
const DOS_DATE: u16 = (1 << 5) | 1;

/// A stored (uncompressed) zip archive of `entries` (name, bytes).
pub(crate) fn zip_stored(entries: &[(String, Vec<u8>)]) -> Result<Vec<u8>> {
    let too_big = || Error::Model("model too large for a zip archive without zip64".into());
    let mut out = Vec::new();
    let mut central = Vec::new();
    for (name, data) in entries {
        let offset = u32::try_from(out.len()).map_err(|_| too_big())?;
        let size = u32::try_from(data.len()).map_err(|_| too_big())?;
        let crc = crc32(data);
        let name_len = u16::try_from(name.len()).map_err(|_| too_big())?;
        let common = |v: &mut Vec<u8>| {
            put16(v, 20); // version needed: 2.0
            put16(v, 0); // flags
            put16(v, 0); // method: stored
            put16(v, 0); // time
            put16(v, DOS_DATE);
            put32(v, crc);
            put32(v, size);
            put32(v, size);
            put16(v, name_len);
            put16(v, 0); // extra length
        };
        put32(&mut out, LOCAL);
        common(&mut out);
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(data);
        put32(&mut central, CENTRAL);
        put16(&mut central, 20); // made by
        common(&mut central);
        put16(&mut central, 0); // comment length
        put16(&mut central, 0); // disk
        put16(&mut central, 0); // internal attributes
        put32(&mut central, 0); // external attributes
        put32(&mut central, offset);
        central.extend_from_slice(name.as_bytes());
    }
    let cd_offset = u32::try_from(out.len()).map_err(|_| too_big())?;
    let cd_size = u32::try_from(central.len()).map_err(|_| too_big())?;
    let count = u16::try_from(entries.len()).map_err(|_| too_big())?;
    out.extend_from_slice(&central);
    put32(&mut out, END);
    put16(&mut out, 0);
    put16(&mut out, 0);
    put16(&mut out, count);
    put16(&mut out, count);
    put32(&mut out, cd_size);
    put32(&mut out, cd_offset);
    put16(&mut out, 0);
    Ok(out)
}

fn put16(v: &mut Vec<u8>, x: u16) {
    v.extend_from_slice(&x.to_le_bytes());
}

fn put32(v: &mut Vec<u8>, x: u32) {
    v.extend_from_slice(&x.to_le_bytes());
}

/// `len` bytes of `b` from `at`, or a corrupt-file error (never a panic, whatever the offsets a
/// damaged record gives).
fn span(b: &[u8], at: usize, len: usize) -> Result<&[u8]> {
    at.checked_add(len)
        .and_then(|end| b.get(at..end))
        .ok_or_else(truncated)
}

/// Little-endian reads that fail (as a corrupt file) instead of panicking.
fn get16(b: &[u8], at: usize) -> Result<u16> {
    span(b, at, 2).map(|s| u16::from_le_bytes([s[0], s[1]]))
}

fn get32(b: &[u8], at: usize) -> Result<u32> {
    span(b, at, 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

fn get64(b: &[u8], at: usize) -> Result<u64> {
    span(b, at, 8).map(|s| {
        let mut a = [0u8; 8];
        a.copy_from_slice(s);
        u64::from_le_bytes(a)
    })
}

fn truncated() -> Error {
    Error::Model("the file is truncated or corrupt (a zip record runs past its end)".into())
}

/// Read every entry of a zip archive of stored entries, checking their CRC-32.
pub(crate) fn unzip(bytes: &[u8]) -> Result<Vec<(String, Vec<u8>)>> {
    // The end record is in the last 22 + 65535 bytes (it may be followed by a comment).
    let floor = bytes.len().saturating_sub(22 + 0xFFFF);
    let end = (floor..bytes.len().saturating_sub(21))
        .rev()
        .find(|&i| get32(bytes, i).is_ok_and(|s| s == END))
        .ok_or_else(|| {
            Error::Model("not a model file: no zip archive found (is it a .npz file?)".into())
        })?;
    let count = usize::from(get16(bytes, end + 10)?);
    let cd_offset = get32(bytes, end + 16)? as usize;
    let mut entries: Vec<(String, Vec<u8>)> = Vec::with_capacity(count);
    let mut names = std::collections::BTreeSet::new();
    // The entries' data lie apart in a sound archive: together they fit in the file. A
    // directory listing one entry many times (65535 names of one 10 MB entry) would otherwise
    // copy it each time.
    let mut total = 0usize;
    let mut at = cd_offset;
    for _ in 0..count {
        if get32(bytes, at)? != CENTRAL {
            return Err(Error::Model("corrupt zip central directory".into()));
        }
        let method = get16(bytes, at + 10)?;
        let crc = get32(bytes, at + 16)?;
        let mut size = u64::from(get32(bytes, at + 20)?);
        let name_len = usize::from(get16(bytes, at + 28)?);
        let extra_len = usize::from(get16(bytes, at + 30)?);
        let comment_len = usize::from(get16(bytes, at + 32)?);
        let mut local = u64::from(get32(bytes, at + 42)?);
        let name = String::from_utf8_lossy(span(bytes, at + 46, name_len)?).into_owned();
        let extra = span(bytes, at + 46 + name_len, extra_len)?;
        // zip64: sizes and offset that overflow 32 bits live in extra field 0x0001, in the
        // order uncompressed size, compressed size, offset (only those that overflowed).
        let compressed32 = get32(bytes, at + 20)?;
        if size == 0xFFFF_FFFF || compressed32 == 0xFFFF_FFFF || local == 0xFFFF_FFFF {
            let mut e = 0;
            while e + 4 <= extra.len() {
                let (id, len) = (get16(extra, e)?, usize::from(get16(extra, e + 2)?));
                if id == 1 {
                    let mut f = e + 4;
                    if size == 0xFFFF_FFFF {
                        size = get64(extra, f)?;
                        f += 8;
                    }
                    if compressed32 == 0xFFFF_FFFF {
                        f += 8;
                    }
                    if local == 0xFFFF_FFFF {
                        local = get64(extra, f)?;
                    }
                }
                e += 4 + len;
            }
        }
        if method != 0 {
            return Err(Error::Model(format!(
                "entry {name} is compressed (method {method}); model files are stored \
                 uncompressed (numpy.savez, not savez_compressed)"
            )));
        }
        // Both within the file, so the sums below stay far from overflowing (zip64 gives them
        // as any u64).
        let local = usize::try_from(local)
            .ok()
            .filter(|&l| l < bytes.len())
            .ok_or_else(truncated)?;
        let size = usize::try_from(size)
            .ok()
            .filter(|&s| s <= bytes.len())
            .ok_or_else(truncated)?;
        if !names.insert(name.clone()) {
            return Err(Error::Model(format!("entry {name} appears twice")));
        }
        total = total.saturating_add(size);
        if total > bytes.len() {
            return Err(Error::Model(
                "corrupt zip directory: its entries hold more data than the file".into(),
            ));
        }
        check_local_header(bytes, local, &name, method, crc, size)?;
        let data_at = local
            + 30
            + usize::from(get16(bytes, local + 26)?)
            + usize::from(get16(bytes, local + 28)?);
        let data = span(bytes, data_at, size)?;
        if crc32(data) != crc {
            return Err(Error::Model(format!(
                "entry {name} is corrupt (CRC-32 mismatch)"
            )));
        }
        entries.push((name, data.to_vec()));
        at += 46 + name_len + extra_len + comment_len;
    }
    Ok(entries)
}

/// The local header of an entry must agree with its central-directory record (name, method,
/// and CRC and size unless they are deferred to a data descriptor or to zip64).
fn check_local_header(
    bytes: &[u8],
    at: usize,
    name: &str,
    method: u16,
    crc: u32,
    size: usize,
) -> Result<()> {
    let corrupt = |what: &str| Error::Model(format!("corrupt zip entry {name}: {what}"));
    if get32(bytes, at)? != LOCAL {
        return Err(corrupt("no local header"));
    }
    let flags = get16(bytes, at + 6)?;
    let name_len = usize::from(get16(bytes, at + 26)?);
    if get16(bytes, at + 8)? != method {
        return Err(corrupt("method differs from the directory"));
    }
    if span(bytes, at + 30, name_len)? != name.as_bytes() {
        return Err(corrupt("name differs from the directory"));
    }
    if flags & 0x08 == 0 {
        let local_crc = get32(bytes, at + 14)?;
        let sizes = [get32(bytes, at + 18)?, get32(bytes, at + 22)?];
        let size_ok = |s: u32| s == 0xFFFF_FFFF || s as usize == size;
        if local_crc != crc || !sizes.into_iter().all(size_ok) {
            return Err(corrupt("CRC or size differs from the directory"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_of_known_strings() {
        assert_eq!(crc32(b""), 0);
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn npy_round_trip() {
        let data: Vec<u8> = (0..24).collect();
        let bytes = npy_bytes("<f4", &[2, 3], &data);
        assert_eq!(bytes.len() % 64, 24);
        let a = parse_npy("a", &bytes).unwrap();
        assert_eq!(
            (a.descr.as_str(), a.shape.as_slice()),
            ("<f4", &[2usize, 3][..])
        );
        assert_eq!(a.data, data);
        let one = parse_npy("b", &npy_bytes("|u1", &[5], &[1, 2, 3, 4, 5])).unwrap();
        assert_eq!(one.shape, vec![5]);
        assert!(parse_npy("c", &bytes[..bytes.len() - 1]).is_err());
        assert!(parse_npy("d", b"not an array at all").is_err());
    }

    #[test]
    fn zip_round_trip_and_corruption() {
        let entries = vec![
            ("a.npy".to_string(), vec![1u8, 2, 3]),
            ("b.npy".to_string(), b"hello".to_vec()),
        ];
        let bytes = zip_stored(&entries).unwrap();
        assert_eq!(unzip(&bytes).unwrap(), entries);
        let mut bad = bytes.clone();
        bad[35] ^= 0xFF; // the first byte of a.npy's data
        assert!(unzip(&bad).is_err());
        for cut in [0, 10, bytes.len() / 2, bytes.len() - 1] {
            assert!(unzip(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }

    /// One stored entry `a.npy` of 3 bytes whose central record gives its sizes and offset in
    /// a zip64 extra field.
    fn zip64_archive(size: u64, local: u64) -> Vec<u8> {
        let plain = zip_stored(&[("a.npy".to_string(), vec![1u8, 2, 3])]).unwrap();
        let mut out = plain[..30 + 5 + 3].to_vec(); // the local header, name and data
        let cd_offset = out.len() as u32;
        let mut cd = Vec::new();
        put32(&mut cd, CENTRAL);
        for v in [45, 45, 0, 0, 0, DOS_DATE] {
            put16(&mut cd, v); // made by, needed, flags, method, time, date
        }
        put32(&mut cd, crc32(&[1, 2, 3]));
        put32(&mut cd, 0xFFFF_FFFF); // compressed size: in zip64
        put32(&mut cd, 0xFFFF_FFFF); // uncompressed size: in zip64
        for v in [5, 4 + 24, 0, 0, 0] {
            put16(&mut cd, v); // name, extra and comment lengths, disk, internal attributes
        }
        put32(&mut cd, 0); // external attributes
        put32(&mut cd, 0xFFFF_FFFF); // offset: in zip64
        cd.extend_from_slice(b"a.npy");
        put16(&mut cd, 1);
        put16(&mut cd, 24);
        for v in [size, size, local] {
            cd.extend_from_slice(&v.to_le_bytes());
        }
        let cd_size = cd.len() as u32;
        out.extend_from_slice(&cd);
        put32(&mut out, END);
        for v in [0, 0, 1, 1] {
            put16(&mut out, v);
        }
        put32(&mut out, cd_size);
        put32(&mut out, cd_offset);
        put16(&mut out, 0);
        out
    }

    /// `entries` archived, with the central record of the first entry listed `times` times.
    fn listed_again(entries: &[(String, Vec<u8>)], times: u16) -> Vec<u8> {
        let plain = zip_stored(entries).unwrap();
        let end = plain.len() - 22;
        let cd_offset = get32(&plain, end + 16).unwrap() as usize;
        let first = 46 + entries[0].0.len();
        let mut out = plain[..end].to_vec();
        for _ in 0..times {
            out.extend_from_slice(&plain[cd_offset..cd_offset + first]);
        }
        let count = entries.len() as u16 + times;
        put32(&mut out, END);
        for v in [0, 0, count, count] {
            put16(&mut out, v);
        }
        let cd_size = (out.len() - 12 - cd_offset) as u32;
        put32(&mut out, cd_size);
        put32(&mut out, cd_offset as u32);
        put16(&mut out, 0);
        out
    }

    #[test]
    fn an_entry_listed_twice_is_refused_before_it_is_copied_again() {
        let entries = vec![
            ("a.npy".to_string(), vec![7u8; 1000]),
            ("b.npy".to_string(), vec![1u8, 2]),
        ];
        assert_eq!(unzip(&listed_again(&entries, 0)).unwrap(), entries);
        for times in [1, 100, u16::MAX - 2] {
            let err = unzip(&listed_again(&entries, times)).unwrap_err();
            assert!(err.to_string().contains("a.npy appears twice"), "{err}");
        }
    }

    #[test]
    fn entries_holding_more_data_than_the_file_are_refused() {
        // b.npy's local header lies inside a.npy's data, so their data overlap: each entry is
        // sound alone, but together they claim more bytes than the file has.
        let inner = zip_stored(&[("b.npy".to_string(), vec![5u8; 600])]).unwrap();
        let b_local = 30 + 5; // within a.npy's data, which starts after its header and name
        let mut a_data = inner[..30 + 5 + 600].to_vec();
        a_data.extend_from_slice(&[0u8; 100]);
        let archive = zip_stored(&[("a.npy".to_string(), a_data)]).unwrap();
        let end = archive.len() - 22;
        let cd_offset = get32(&archive, end + 16).unwrap() as usize;
        let mut out = archive[..end].to_vec();
        // A second central record: b.npy at b_local.
        put32(&mut out, CENTRAL);
        put16(&mut out, 20);
        for v in [20, 0, 0, 0, DOS_DATE] {
            put16(&mut out, v);
        }
        put32(&mut out, crc32(&[5u8; 600]));
        put32(&mut out, 600);
        put32(&mut out, 600);
        for v in [5, 0, 0, 0, 0] {
            put16(&mut out, v);
        }
        put32(&mut out, 0);
        put32(&mut out, b_local as u32);
        out.extend_from_slice(b"b.npy");
        put32(&mut out, END);
        for v in [0, 0, 2, 2] {
            put16(&mut out, v);
        }
        let cd_size = (out.len() - 12 - cd_offset) as u32;
        put32(&mut out, cd_size);
        put32(&mut out, cd_offset as u32);
        put16(&mut out, 0);
        let err = unzip(&out).unwrap_err();
        assert!(err.to_string().contains("more data than the file"), "{err}");
    }

    #[test]
    fn zip64_sizes_and_offsets_past_the_file_are_corrupt_not_a_panic() {
        // Sums with these overflowed (a panic in debug builds).
        assert_eq!(
            unzip(&zip64_archive(3, 0)).unwrap(),
            vec![("a.npy".to_string(), vec![1, 2, 3])]
        );
        for (size, local) in [
            (3, u64::MAX),
            (u64::MAX, 0),
            (u64::MAX - 20, 0),
            (3, 1 << 40),
        ] {
            let err = unzip(&zip64_archive(size, local)).unwrap_err();
            assert!(matches!(err, Error::Model(_)), "{size} {local}: {err}");
        }
    }
}
