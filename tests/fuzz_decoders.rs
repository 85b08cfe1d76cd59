//! Byte fuzzing of the engine's decoders through the crate's public API (docs/robustness.md):
//! UDP packets in the three formats, packed 13-byte records, and model files. proptest
//! generates the inputs: arbitrary bytes, and mutations (bit flips, overwritten, inserted and
//! deleted bytes, cuts, splices) of the seed corpus in `tests/fuzz/corpus/`; model files are
//! also rebuilt as well-formed archives around mutated members (their CRC-32 recomputed), so
//! that the `.npy` and JSON parsers behind the zip checks are reached too.
//!
//! Every input must give `Ok` or a typed `Err` — never a panic or an abort — and the decoders
//! must keep their contracts: a packet is decoded whole or not at all, and what it yields is
//! inside the sensor and in time order.
//!
//! The number of cases per property is `UAVSNN_FUZZ_CASES` (default 256, a few seconds in
//! `cargo test`); a longer run:
//! `UAVSNN_FUZZ_CASES=100000 cargo test --release --test fuzz_decoders`.

use std::fs;
use std::path::PathBuf;

use proptest::prelude::*;
use uavsnn::events::decode_packed;
use uavsnn::network::Network;
use uavsnn::stream::{PacketDecoder, PacketFormat};
use uavsnn::{Error, Event, SensorSize};

fn cases() -> u32 {
    std::env::var("UAVSNN_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256)
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        // Shrinking a failure is worth seconds, not minutes.
        max_shrink_iters: 2_000,
        ..ProptestConfig::default()
    }
}

/// The seeds' sensor (`tests/fuzz/make_corpus.py`).
const SENSOR: (u16, u16) = (16, 12);

fn corpus(target: &str) -> Vec<Vec<u8>> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz/corpus")
        .join(target);
    let mut files: Vec<PathBuf> = fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let seeds: Vec<Vec<u8>> = files.iter().map(|p| fs::read(p).unwrap()).collect();
    assert!(!seeds.is_empty(), "no seeds in {}", dir.display());
    seeds
}

/// One edit of a byte string.
#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Set(usize, u8),
    Insert(usize, Vec<u8>),
    Delete(usize, usize),
    Truncate(usize),
    /// Copy `len` bytes from `from` over `to` (repeats a record, a header, a length field).
    Splice {
        from: usize,
        to: usize,
        len: usize,
    },
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(i, b)| Edit::Flip(i, 1 << b)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, v)| Edit::Set(i, v)),
        (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, v)| Edit::Insert(i, v)),
        (any::<usize>(), 1usize..32).prop_map(|(i, n)| Edit::Delete(i, n)),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), any::<usize>(), 1usize..64).prop_map(|(from, to, len)| Edit::Splice {
            from,
            to,
            len
        }),
    ]
}

fn apply(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let n = bytes.len();
        match e {
            Edit::Flip(i, m) if n > 0 => bytes[i % n] ^= m,
            Edit::Set(i, v) if n > 0 => bytes[i % n] = *v,
            Edit::Insert(i, v) => {
                let at = i % (n + 1);
                bytes.splice(at..at, v.iter().copied());
            }
            Edit::Delete(i, k) if n > 0 => {
                let at = i % n;
                bytes.drain(at..(at + k).min(n));
            }
            Edit::Truncate(i) => bytes.truncate(i % (n + 1)),
            Edit::Splice { from, to, len } if n > 0 => {
                let (from, to) = (from % n, to % n);
                let len = (*len).min(n - from).min(n - to);
                let piece = bytes[from..from + len].to_vec();
                bytes[to..to + len].copy_from_slice(&piece);
            }
            _ => {}
        }
    }
    bytes
}

/// Inputs for one target: arbitrary bytes, or a seed with a few edits.
fn inputs(target: &'static str) -> impl Strategy<Value = Vec<u8>> {
    let seeds = corpus(target);
    let n = seeds.len();
    prop_oneof![
        1 => prop::collection::vec(any::<u8>(), 0..512),
        4 => (0..n, prop::collection::vec(edit(), 0..6))
            .prop_map(move |(i, edits)| apply(seeds[i].clone(), &edits)),
    ]
}

fn sensor() -> SensorSize {
    SensorSize::new(SENSOR.0, SENSOR.1).unwrap()
}

/// Decode `packets` in turn with one decoder, checking the decoder's contract at each.
fn check_packets(format: PacketFormat, packets: &[Vec<u8>], arrival: u64) {
    let s = sensor();
    let mut decoder = PacketDecoder::new(format, s);
    let mut out: Vec<Event> = Vec::new();
    for p in packets {
        let before = (out.len(), decoder.last_t());
        let restarts = decoder.restarts();
        match decoder.decode(p, arrival, &mut out) {
            Ok(()) => {
                let new = &out[before.0..];
                // A restart starts a new time base, with the packets it took back before this.
                let restarted = decoder.restarts() != restarts;
                let mut last = if restarted { None } else { before.1 };
                for e in new {
                    assert!(s.contains(e.x, e.y), "{format}: {e:?} outside {s:?}");
                    assert!(last.is_none_or(|l| e.t >= l), "{format}: time goes back");
                    last = Some(e.t);
                }
                assert_eq!(decoder.last_t(), last, "{format}: last_t");
                if restarted {
                    // The packets taken back come first: no count of this packet alone.
                } else if format == PacketFormat::T64X16Y16On8 {
                    assert_eq!(new.len(), p.len() / 13);
                    // The stdin path's decoder agrees on the same bytes.
                    assert_eq!(decode_packed(p, s, before.1, 0).unwrap(), new);
                } else if format == PacketFormat::T32X16Y15On1 {
                    assert_eq!(new.len(), p.len() / 8);
                }
            }
            Err(e) => {
                // Whole or nothing: nothing appended, no state changed; a typed error.
                assert_eq!((out.len(), decoder.last_t()), before, "{format}: {e}");
                assert!(!e.to_string().is_empty());
                if format == PacketFormat::T64X16Y16On8 {
                    assert!(decode_packed(p, s, before.1, 0).is_err());
                }
            }
        }
    }
}

/// 9 to 15 packets of a target's seeds that hold whole events, a fifth of them edited.
fn restarting(target: &'static str) -> impl Strategy<Value = Vec<Vec<u8>>> {
    let seeds: Vec<Vec<u8>> = corpus(target)
        .into_iter()
        .filter(|s| !s.is_empty() && s.len() % 13 == 0)
        .collect();
    let n = seeds.len();
    let packet = (
        0..n,
        prop::option::weighted(0.2, prop::collection::vec(edit(), 1..3)),
    )
        .prop_map(move |(i, edits)| apply(seeds[i].clone(), &edits.unwrap_or_default()));
    prop::collection::vec(packet, 9..16)
}

fn packets(target: &'static str) -> impl Strategy<Value = Vec<Vec<u8>>> {
    prop::collection::vec(inputs(target), 1..5)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn udp_t64_packets(p in packets("udp_t64")) {
        check_packets(PacketFormat::T64X16Y16On8, &p, 0);
    }

    /// A packet stamped far ahead, then enough packets of the stream to restart it (more than
    /// `RESTART_AFTER` in a row going back: the seeds with events, a fifth of them edited, so
    /// that most runs restart): the contract holds through the restart.
    #[test]
    fn udp_t64_packets_through_a_restart(p in restarting("udp_t64")) {
        let mut ahead = Vec::with_capacity(13);
        ahead.extend_from_slice(&(1u64 << 40).to_le_bytes());
        ahead.extend_from_slice(&[0, 0, 0, 0, 1]);
        let mut packets = vec![ahead];
        packets.extend(p);
        check_packets(PacketFormat::T64X16Y16On8, &packets, 0);
    }

    #[test]
    fn udp_t32_packets(p in packets("udp_t32")) {
        check_packets(PacketFormat::T32X16Y15On1, &p, 0);
    }

    #[test]
    fn udp_spif_packets(p in packets("udp_spif"), arrival in any::<u64>()) {
        check_packets(PacketFormat::Spif, &p, arrival);
    }

    #[test]
    fn stdin_packed_records(bytes in inputs("stdin_packed"), previous in any::<Option<u64>>()) {
        let s = sensor();
        if let Ok(events) = decode_packed(&bytes, s, previous, 0) {
            prop_assert_eq!(events.len() * 13, bytes.len());
            prop_assert!(events.iter().all(|e| s.contains(e.x, e.y)));
            prop_assert!(events.windows(2).all(|w| w[0].t <= w[1].t));
        }
    }

    #[test]
    fn model_file_bytes(bytes in inputs("model")) {
        check_model(&bytes);
    }

    /// Well-formed archives around mutated members: reaches the `.npy` header parser, the
    /// config's JSON and its validation, and the weight checks.
    #[test]
    fn model_file_members(
        member in 0usize..5,
        edits in prop::collection::vec(edit(), 1..6),
        drop_member in any::<bool>(),
    ) {
        let seed = &corpus("model")[0];
        let mut members = members_of(seed);
        let i = member % members.len();
        if drop_member && member == 4 {
            members.remove(i);
        } else {
            members[i].1 = apply(members[i].1.clone(), &edits);
        }
        check_model(&zip_stored(&members));
    }

    /// The config's JSON, rewritten field by field: sizes, kernels and maps up to absurd
    /// values must be refused or loaded, never abort on an allocation.
    #[test]
    fn model_config_values(
        field in prop::sample::select(vec![
            "\"width\": 16", "\"height\": 12", "\"maps\": 2", "\"kernel\": 3", "\"kernel\": 5",
            "\"stride\": 5", "\"version\": 1", "\"threshold\": 4.0", "\"min_detections\": 1",
        ]),
        value in prop_oneof![
            Just("0".to_string()), Just("-1".to_string()), Just("1e308".to_string()),
            Just("65535".to_string()), Just("4294967297".to_string()), Just("null".to_string()),
            Just("NaN".to_string()), Just("\"x\"".to_string()), (0u64..100_000).prop_map(|v| v.to_string()),
        ],
        nth in 0usize..3,
    ) {
        let seed = &corpus("model")[0];
        let mut members = members_of(seed);
        let config = members.iter_mut().find(|(n, _)| n == "config.npy").unwrap();
        let (header, json) = split_npy(&config.1);
        let json = String::from_utf8(json.to_vec()).unwrap();
        let key = field.split(':').next().unwrap();
        let hits: Vec<usize> = json.match_indices(field).map(|(i, _)| i).collect();
        prop_assume!(!hits.is_empty());
        let at = hits[nth % hits.len()];
        let replaced = format!("{}{key}: {value}{}", &json[..at], &json[at + field.len()..]);
        config.1 = npy_u8(&header, replaced.as_bytes());
        check_model(&zip_stored(&members));
    }
}

fn check_model(bytes: &[u8]) {
    match Network::from_npz_bytes(bytes) {
        // A file that loads writes back and loads again the same.
        Ok(net) => {
            let again = net.to_npz_bytes().expect("a loaded model writes back");
            let back = Network::from_npz_bytes(&again).expect("and reads back");
            assert_eq!(back.to_npz_bytes().unwrap(), again);
        }
        Err(e) => assert!(matches!(e, Error::Model(_)), "not a model error: {e:?}"),
    }
}

// -------------------------------------------------- a minimal stored zip, for the member fuzz

fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn le16(b: &[u8], at: usize) -> usize {
    usize::from(u16::from_le_bytes([b[at], b[at + 1]]))
}

fn le32(b: &[u8], at: usize) -> usize {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]) as usize
}

/// The members of a stored zip written by the engine (local headers in order, no extras).
fn members_of(zip: &[u8]) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut at = 0;
    while le32(zip, at) == 0x0403_4b50 {
        let size = le32(zip, at + 18);
        let (name_len, extra_len) = (le16(zip, at + 26), le16(zip, at + 28));
        let name = String::from_utf8(zip[at + 30..at + 30 + name_len].to_vec()).unwrap();
        let data_at = at + 30 + name_len + extra_len;
        out.push((name, zip[data_at..data_at + size].to_vec()));
        at = data_at + size;
    }
    assert_eq!(out.len(), 5, "the seed model has five members");
    out
}

fn zip_stored(members: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut central = Vec::new();
    for (name, data) in members {
        let offset = out.len() as u32;
        let crc = crc32(data);
        let size = data.len() as u32;
        let common = |v: &mut Vec<u8>| {
            v.extend_from_slice(&20u16.to_le_bytes()); // version needed
            v.extend_from_slice(&0u16.to_le_bytes()); // flags
            v.extend_from_slice(&0u16.to_le_bytes()); // stored
            v.extend_from_slice(&[0; 4]); // time, date
            v.extend_from_slice(&crc.to_le_bytes());
            v.extend_from_slice(&size.to_le_bytes());
            v.extend_from_slice(&size.to_le_bytes());
            v.extend_from_slice(&(name.len() as u16).to_le_bytes());
            v.extend_from_slice(&0u16.to_le_bytes()); // extra
        };
        out.extend_from_slice(&0x0403_4b50u32.to_le_bytes());
        common(&mut out);
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(data);
        central.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
        central.extend_from_slice(&20u16.to_le_bytes()); // version made by
        common(&mut central);
        central.extend_from_slice(&[0; 6]); // comment length, disk, internal attributes
        central.extend_from_slice(&[0; 4]); // external attributes
        central.extend_from_slice(&offset.to_le_bytes());
        central.extend_from_slice(name.as_bytes());
    }
    let cd_offset = out.len() as u32;
    let n = members.len() as u16;
    out.extend_from_slice(&central);
    out.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(&(central.len() as u32).to_le_bytes());
    out.extend_from_slice(&cd_offset.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out
}

/// A `.npy` member's header (magic to newline) and data.
fn split_npy(npy: &[u8]) -> (String, &[u8]) {
    let len = le16(npy, 8);
    let header = String::from_utf8(npy[10..10 + len].to_vec()).unwrap();
    (header, &npy[10 + len..])
}

/// A version 1.0 `.npy` of `|u1` bytes whose header is `header` with the shape replaced.
fn npy_u8(header: &str, data: &[u8]) -> Vec<u8> {
    let start = header.find("'shape': (").unwrap() + "'shape': (".len();
    let end = start + header[start..].find(')').unwrap();
    let mut h = format!("{}{},{}", &header[..start], data.len(), &header[end..]);
    h = h.trim_end().to_string();
    let unpadded = 10 + h.len() + 1;
    h.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    h.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(h.as_bytes());
    out.extend_from_slice(data);
    out
}

/// The helpers above build what the engine reads: an unedited rebuild loads, and an edited
/// config value comes through.
#[test]
fn member_rebuild_round_trips() {
    let seed = &corpus("model")[0];
    let members = members_of(seed);
    let net = Network::from_npz_bytes(&zip_stored(&members)).unwrap();
    assert_eq!(
        net.to_npz_bytes().unwrap(),
        Network::from_npz_bytes(seed)
            .unwrap()
            .to_npz_bytes()
            .unwrap()
    );
    let mut edited = members.clone();
    let config = edited.iter_mut().find(|(n, _)| n == "config.npy").unwrap();
    let (header, json) = split_npy(&config.1);
    let json = String::from_utf8(json.to_vec()).unwrap().replacen(
        "\"threshold\": 4.0",
        "\"threshold\": 7.5",
        1,
    );
    config.1 = npy_u8(&header, json.as_bytes());
    let net = Network::from_npz_bytes(&zip_stored(&edited)).unwrap();
    assert!((net.config().conv1.threshold - 7.5).abs() < 1e-6);
}

/// Every seed decodes (the corpus is valid input, not only noise).
#[test]
fn seeds_are_valid() {
    let s = sensor();
    for p in corpus("udp_t64").iter().filter(|p| p.len() % 13 == 0) {
        PacketDecoder::new(PacketFormat::T64X16Y16On8, s)
            .decode(p, 0, &mut Vec::new())
            .unwrap();
    }
    for (target, format) in [
        ("udp_t32", PacketFormat::T32X16Y15On1),
        ("udp_spif", PacketFormat::Spif),
    ] {
        for p in corpus(target) {
            let mut out = Vec::new();
            PacketDecoder::new(format, s)
                .decode(&p, 7, &mut out)
                .unwrap();
            assert!(!out.is_empty());
        }
    }
    Network::from_npz_bytes(&corpus("model")[0]).unwrap();
}
