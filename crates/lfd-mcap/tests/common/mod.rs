//! Shared by the tests: temporary files, hand-built records and a small lfd-like recording.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use lfd_mcap::proto::{Pose, PoseInFrame, PosesInFrame, Quaternion, Vector3};
use mcap::records::MessageHeader;
use prost::Message as _;

pub mod mutate;

/// A file in the temporary directory, removed when dropped.
pub struct TempFile(PathBuf);

impl TempFile {
    pub fn new(bytes: &[u8]) -> Self {
        static N: AtomicUsize = AtomicUsize::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let path =
            std::env::temp_dir().join(format!("lfd-mcap-test-{}-{n}.mcap", std::process::id()));
        std::fs::write(&path, bytes).expect("write a temporary file");
        Self(path)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A shipped recording.
pub fn shipped(name: &str) -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../recordings")
        .join(name);
    std::fs::read(path).expect("a shipped recording")
}

/// One record: opcode, little-endian length, body.
pub fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut out = vec![opcode];
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
    out
}

/// An MCAP string / bytes field with a u32 length prefix.
pub fn string(s: &[u8]) -> Vec<u8> {
    let mut out = (s.len() as u32).to_le_bytes().to_vec();
    out.extend_from_slice(s);
    out
}

/// A chunk record around `records` (already compressed as `compression`).
pub fn chunk(uncompressed_size: u64, crc: u32, compression: &str, records: &[u8]) -> Vec<u8> {
    let mut body = Vec::new();
    body.extend_from_slice(&0u64.to_le_bytes());
    body.extend_from_slice(&0u64.to_le_bytes());
    body.extend_from_slice(&uncompressed_size.to_le_bytes());
    body.extend_from_slice(&crc.to_le_bytes());
    body.extend_from_slice(&string(compression.as_bytes()));
    body.extend_from_slice(&(records.len() as u64).to_le_bytes());
    body.extend_from_slice(records);
    record(0x06, &body)
}

/// The magic and a header record.
pub fn head() -> Vec<u8> {
    let mut out = lfd_mcap::MAGIC.to_vec();
    let mut body = string(b"");
    body.extend_from_slice(&string(b"test"));
    out.extend_from_slice(&record(0x01, &body));
    out
}

/// A channel record (no schema).
pub fn channel(id: u16, topic: &str, encoding: &str) -> Vec<u8> {
    let mut body = id.to_le_bytes().to_vec();
    body.extend_from_slice(&0u16.to_le_bytes());
    body.extend_from_slice(&string(topic.as_bytes()));
    body.extend_from_slice(&string(encoding.as_bytes()));
    body.extend_from_slice(&0u32.to_le_bytes());
    record(0x04, &body)
}

/// A message record.
pub fn message(channel: u16, log_time: u64, data: &[u8]) -> Vec<u8> {
    let mut body = channel.to_le_bytes().to_vec();
    body.extend_from_slice(&0u32.to_le_bytes());
    body.extend_from_slice(&log_time.to_le_bytes());
    body.extend_from_slice(&log_time.to_le_bytes());
    body.extend_from_slice(data);
    record(0x05, &body)
}

pub fn hand_message(t: u64, n_poses: usize) -> Vec<u8> {
    PosesInFrame {
        timestamp: None,
        frame_id: "world".into(),
        poses: (0..n_poses)
            .map(|k| Pose {
                position: Some(Vector3 {
                    x: t as f64 * 1e-9,
                    y: k as f64,
                    z: -(k as f64),
                }),
                orientation: Some(Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                }),
            })
            .collect(),
    }
    .encode_to_vec()
}

pub fn pose_message(t: u64) -> Vec<u8> {
    PoseInFrame {
        timestamp: None,
        frame_id: "world".into(),
        pose: Some(Pose {
            position: Some(Vector3 {
                x: 1.0,
                y: 2.0,
                z: t as f64,
            }),
            orientation: Some(Quaternion {
                x: 0.5,
                y: -0.5,
                z: 0.5,
                w: -0.5,
            }),
        }),
    }
    .encode_to_vec()
}

pub fn confidence_message(k: usize) -> Vec<u8> {
    let values: Vec<f64> = (0..21).map(|i| (i + k) as f64 / 100.0).collect();
    let body = if k % 2 == 0 {
        serde_json::json!({ "confidence": values })
    } else {
        serde_json::json!({ "confidence": values, "visible": (0..21).map(|i| i % 3 != 0).collect::<Vec<_>>() })
    };
    body.to_string().into_bytes()
}

/// Messages per topic in [`fixture`].
pub const N: u64 = 60;
pub const T0: u64 = 1_700_000_000_000_000_000;

/// A small lfd-like recording written by the `mcap` crate: hand keypoints (message 7 has 20
/// poses), confidences, two object poses, events, colour images, metadata and an attachment.
pub fn fixture(compression: Option<mcap::Compression>, chunk_size: u64) -> Vec<u8> {
    fixture_with(
        mcap::WriteOptions::new()
            .compression(compression)
            .chunk_size(Some(chunk_size)),
    )
}

/// [`fixture`] without message indexes and statistics (both optional in MCAP).
pub fn fixture_unindexed(compression: Option<mcap::Compression>, chunk_size: u64) -> Vec<u8> {
    fixture_with(
        mcap::WriteOptions::new()
            .compression(compression)
            .chunk_size(Some(chunk_size))
            .emit_message_indexes(false)
            .emit_statistics(false),
    )
}

/// The seeds of the mutation fuzzer: the fixture in every compression, without indexes, and
/// the shipped exp1.
pub fn fuzz_seeds() -> Vec<Vec<u8>> {
    vec![
        fixture(None, 2048),
        fixture(Some(mcap::Compression::Zstd), 4096),
        fixture(Some(mcap::Compression::Lz4), 4096),
        fixture_unindexed(Some(mcap::Compression::Zstd), 4096),
        shipped("exp1.mcap"),
    ]
}

/// The fixture's messages written with `options`.
pub fn fixture_with(options: mcap::WriteOptions) -> Vec<u8> {
    let mut w = options
        .library("fixture")
        .create(Cursor::new(Vec::new()))
        .expect("a writer");
    let poses = w
        .add_schema("foxglove.PosesInFrame", "protobuf", b"poses")
        .unwrap();
    let pose = w
        .add_schema("foxglove.PoseInFrame", "protobuf", b"pose")
        .unwrap();
    let json = w.add_schema("Confidence", "jsonschema", b"{}").unwrap();
    let meta: BTreeMap<String, String> = [("side".to_string(), "right".to_string())].into();
    let none = BTreeMap::new();
    let hand = w
        .add_channel(poses, "/hand/right/keypoints", "protobuf", &meta)
        .unwrap();
    let conf = w
        .add_channel(json, "/hand/right/confidence", "json", &none)
        .unwrap();
    let a = w
        .add_channel(pose, "/objects/a/pose", "protobuf", &none)
        .unwrap();
    let b = w
        .add_channel(pose, "/objects/b/pose", "protobuf", &none)
        .unwrap();
    let events = w
        .add_channel(0, "/lfd/ground_truth", "protobuf", &none)
        .unwrap();
    let image = w
        .add_channel(0, "/camera/color/image_raw", "protobuf", &none)
        .unwrap();
    let md = |name: &str, k: &str, v: &str| mcap::records::Metadata {
        name: name.into(),
        metadata: [(k.to_string(), v.to_string())].into(),
    };
    w.write_metadata(&md("demo", "objects", "[]")).unwrap();
    let put = |w: &mut mcap::Writer<_>, ch: u16, t: u64, data: &[u8]| {
        w.write_to_known_channel(
            &MessageHeader {
                channel_id: ch,
                sequence: 0,
                log_time: t,
                publish_time: t,
            },
            data,
        )
        .unwrap();
    };
    for i in 0..N {
        let t = T0 + i * 33_333_333;
        put(
            &mut w,
            hand,
            t,
            &hand_message(t, if i == 7 { 20 } else { 21 }),
        );
        put(&mut w, conf, t, &confidence_message(i as usize));
        put(&mut w, a, t, &pose_message(t));
        put(&mut w, b, t + 1, &pose_message(t + 1));
        if i % 10 == 0 {
            put(&mut w, events, t, format!("event {i}").as_bytes());
        }
        put(&mut w, image, t, &vec![i as u8; 3000]);
    }
    w.write_metadata(&md("demo", "metadata", "{}")).unwrap();
    w.write_metadata(&md("demo", "objects", "[1]")).unwrap();
    w.attach(&mcap::Attachment {
        log_time: T0,
        create_time: T0,
        name: "notes.txt".into(),
        media_type: "text/plain".into(),
        data: std::borrow::Cow::Borrowed(b"hello"),
    })
    .unwrap();
    w.finish().unwrap();
    w.into_inner().into_inner()
}
