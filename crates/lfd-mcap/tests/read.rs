//! `read_recording` and `read_summary` on written, shipped, truncated and crafted files.
#![allow(clippy::float_cmp)] // decoded values are compared exactly

mod common;

use common::{channel, chunk, fixture, head, message, record, shipped, string, TempFile, N, T0};
use lfd_mcap::{read_recording, read_summary, Options, Recording};

fn read(bytes: &[u8]) -> Result<Recording, lfd_mcap::ReadError> {
    let f = TempFile::new(bytes);
    read_recording(f.path(), &Options::default())
}

fn topic<'a, T>(items: &'a [(String, T)], name: &str) -> &'a T {
    &items.iter().find(|(t, _)| t == name).expect(name).1
}

#[test]
fn a_written_recording_is_decoded() {
    for compression in [
        Some(mcap::Compression::Zstd),
        Some(mcap::Compression::Lz4),
        None,
    ] {
        let bytes = fixture(compression, 4096);
        let f = TempFile::new(&bytes);
        let rec = read_recording(f.path(), &Options::default()).unwrap();
        assert!(rec.complete, "{compression:?}: {:?}", rec.error);
        assert_eq!(rec.error, None);
        assert_eq!(rec.library, "fixture");
        assert_eq!(rec.file_size, bytes.len() as u64);
        let topics: Vec<_> = rec.channels.iter().map(|c| c.topic.as_str()).collect();
        assert_eq!(
            topics,
            [
                "/hand/right/keypoints",
                "/hand/right/confidence",
                "/objects/a/pose",
                "/objects/b/pose",
                "/lfd/ground_truth",
                "/camera/color/image_raw"
            ]
        );
        let hand_ch = &rec.channels[0];
        assert_eq!(hand_ch.schema, "foxglove.PosesInFrame");
        assert_eq!(hand_ch.schema_encoding, "protobuf");
        assert_eq!(hand_ch.schema_data, b"poses");
        assert_eq!(hand_ch.encoding, "protobuf");
        assert_eq!(hand_ch.metadata, [("side".into(), "right".into())]);
        assert_eq!(hand_ch.count, N);
        assert_eq!(hand_ch.first_ns, Some(T0 as i64));
        assert_eq!(hand_ch.last_ns, Some((T0 + (N - 1) * 33_333_333) as i64));
        assert_eq!(rec.channels[4].schema, "");

        let hand = topic(&rec.hands, "/hand/right/keypoints");
        assert_eq!(hand.t_ns.len(), N as usize);
        assert_eq!(hand.keypoints.len(), N as usize * 63);
        assert!(hand.keypoints[7 * 63..8 * 63].iter().all(|v| v.is_nan()));
        assert_eq!(hand.keypoints[63 + 3 * 5 + 1], 5.0); // message 1, keypoint 5, y
        let t7 = T0 + 7 * 33_333_333;
        assert_eq!(
            hand.bad.as_deref(),
            Some(
                format!(
                    "{}: hand message at {t7} ns has 20 poses, not 21",
                    f.path().display()
                )
                .as_str()
            )
        );

        let conf = topic(&rec.confidence, "/hand/right/confidence");
        assert_eq!(conf.t_ns.len(), N as usize);
        assert_eq!(conf.bad, None);
        assert_eq!(conf.confidence[21 * 3 + 2], 0.05);
        assert_eq!(conf.has_visible[..4], [false, true, false, true]);
        assert_eq!(conf.visible[21..24], [false, true, true]);

        let a = topic(&rec.poses, "/objects/a/pose");
        assert_eq!(a.t_ns.len(), N as usize);
        assert_eq!(a.position[..2], [1.0, 2.0]);
        assert_eq!(a.quaternion[..4], [0.5, -0.5, 0.5, -0.5]);
        assert_eq!(a.bad, None);

        let events = topic(&rec.raw, "/lfd/ground_truth");
        assert_eq!(events.len(), 6);
        assert_eq!(
            events.get(1),
            ((T0 + 10 * 33_333_333) as i64, &b"event 10"[..])
        );
        assert_eq!(topic(&rec.raw, "/camera/color/image_raw").len(), N as usize);

        assert_eq!(
            rec.metadata,
            [(
                "demo".to_string(),
                vec![
                    ("objects".to_string(), "[1]".to_string()),
                    ("metadata".to_string(), "{}".to_string())
                ]
            )]
        );

        // the summary agrees with the full pass
        let wanted = ["/lfd/ground_truth".to_string(), "/nope".to_string()];
        let s = read_summary(f.path(), &wanted).unwrap().expect("a summary");
        assert_eq!(s.library, "fixture");
        assert_eq!(s.channels, rec.channels);
        assert_eq!(s.metadata, rec.metadata);
        assert_eq!(s.messages, rec.message_count());
        assert_eq!(s.attachments.len(), 1);
        assert_eq!(s.attachments[0].name, "notes.txt");
        assert_eq!(s.attachments[0].size, 5);
        assert_eq!(s.raw.len(), 1);
        assert_eq!(&s.raw[0].1, events);
    }
}

#[test]
fn images_false_drops_the_image_payloads_but_counts_them() {
    let f = TempFile::new(&fixture(Some(mcap::Compression::Zstd), 4096));
    let rec = read_recording(f.path(), &Options::images(false)).unwrap();
    assert!(rec.raw.iter().all(|(t, _)| t != "/camera/color/image_raw"));
    assert_eq!(rec.channels[5].count, N);
}

#[test]
fn raw_topics_keeps_those_payloads_only_and_counts_every_topic() {
    let f = TempFile::new(&fixture(Some(mcap::Compression::Zstd), 4096));
    let all = read_recording(f.path(), &Options::default()).unwrap();
    let options = Options {
        images: true,
        raw_topics: Some(vec!["/lfd/ground_truth".to_string()]),
        raw_limit: None,
    };
    let some = read_recording(f.path(), &options).unwrap();
    assert_eq!(some.channels, all.channels);
    assert_eq!(some.metadata, all.metadata);
    // (NaN in the tracks: compared as printed)
    assert!(format!("{:?}", some.hands) == format!("{:?}", all.hands));
    assert!(format!("{:?}", some.confidence) == format!("{:?}", all.confidence));
    assert!(format!("{:?}", some.poses) == format!("{:?}", all.poses));
    let kept: Vec<_> = all
        .raw
        .iter()
        .filter(|(t, _)| t == "/lfd/ground_truth")
        .cloned()
        .collect();
    assert_eq!(kept.len(), 1);
    assert_eq!(some.raw, kept);
}

#[test]
fn the_shipped_recordings_read_and_truncations_never_panic() {
    let bytes = shipped("exp1.mcap");
    let full = read(&bytes).unwrap();
    assert!(full.complete);
    let total = full.message_count();
    assert!(total > 1000);
    let mut last = 0;
    let step = (bytes.len() / 120).max(1);
    let mut cuts: Vec<usize> = (8..bytes.len()).step_by(step).collect();
    cuts.extend(8..120);
    cuts.extend(bytes.len() - 40..=bytes.len());
    cuts.sort_unstable();
    cuts.dedup();
    for cut in cuts {
        let f = TempFile::new(&bytes[..cut]);
        let rec = read_recording(f.path(), &Options::default())
            .unwrap_or_else(|e| panic!("cut at {cut}: {e}"));
        let n = rec.message_count();
        assert!(n >= last, "cut at {cut}: {n} messages, fewer than {last}");
        assert!(n <= total);
        last = n;
        if rec.complete {
            assert_eq!(n, total);
        } else {
            let err = rec.error.expect("an incomplete file says why");
            assert!(
                err.starts_with("incomplete or damaged record: ")
                    || err.starts_with("file ends without a data-end record"),
                "{err}"
            );
            assert!(!err.contains('\n') && !err.contains('\x1b'), "{err}");
        }
        // no summary in a cut file (or the full one's)
        let s = read_summary(f.path(), &["/lfd/ground_truth".into()]).unwrap();
        assert!(
            s.is_none() || cut == bytes.len(),
            "cut at {cut} has a summary"
        );
    }
    assert_eq!(last, total);
}

#[test]
fn magic_errors_are_worded_as_scan() {
    let f = TempFile::new(b"");
    let p = f.path().display().to_string();
    let err = |r: Result<Recording, lfd_mcap::ReadError>| r.unwrap_err().to_string();
    assert_eq!(
        err(read_recording(f.path(), &Options::default())),
        format!("{p} is empty, not an MCAP recording")
    );
    let f = TempFile::new(b"PK\x03\x04 not mcap");
    let p = f.path().display().to_string();
    assert_eq!(
        err(read_recording(f.path(), &Options::default())),
        format!("{p} is not an MCAP file (bad magic bytes b'PK\\x03\\x04 not')")
    );
    let f = TempFile::new(b"\x89MCA");
    let p = f.path().display().to_string();
    assert_eq!(
        err(read_recording(f.path(), &Options::default())),
        format!("{p} is cut inside the MCAP magic (4 bytes)")
    );
    assert!(read_summary(f.path(), &[]).is_err());
    let missing = std::path::Path::new("/nonexistent/lfd/x.mcap");
    assert_eq!(
        err(read_recording(missing, &Options::default())),
        "cannot open recording /nonexistent/lfd/x.mcap: [Errno 2] No such file or directory: \
         '/nonexistent/lfd/x.mcap'"
    );
}

#[test]
fn a_zstd_bomb_is_refused_before_inflating() {
    let zeros = vec![0u8; 16 << 20];
    let packed = zstd::bulk::compress(&zeros, 3).unwrap();
    let mut bytes = head();
    bytes.extend_from_slice(&chunk(zeros.len() as u64, 0, "zstd", &packed));
    let f = TempFile::new(&bytes);
    let e = read_recording(f.path(), &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.ends_with("refusing a possible decompression bomb"), "{e}");
    assert!(
        e.contains(&format!("declares {} uncompressed bytes", zeros.len())),
        "{e}"
    );
    // a header that lies low: decompression stops one byte beyond it, the chunk is damage
    let mut bytes = head();
    bytes.extend_from_slice(&chunk(1000, 0, "zstd", &packed));
    let rec = read(&bytes).unwrap();
    assert!(!rec.complete);
    assert_eq!(rec.damage.len(), 1);
    assert_eq!(rec.damage[0].chunks, Some(vec![1]));
    assert_eq!(
        rec.damage[0].why,
        format!(
            "chunk at offset {}: it inflates to more than 1000 bytes, its header says 1000",
            head().len()
        )
    );
}

#[test]
fn crafted_records_are_handled_as_scan() {
    // a message before its channel is skipped; a second channel of a topic merges into it
    let mut body = channel(1, "/x", "json");
    body.extend_from_slice(&message(9, T0, b"lost"));
    body.extend_from_slice(&channel(2, "/x", "json"));
    body.extend_from_slice(&message(1, T0 + 5, b"a"));
    body.extend_from_slice(&message(2, T0 + 1, b"b"));
    let mut bytes = head();
    bytes.extend_from_slice(&chunk(body.len() as u64, crc32fast::hash(&body), "", &body));
    bytes.extend_from_slice(&record(0x0F, &0u32.to_le_bytes()));
    let rec = read(&bytes).unwrap();
    assert!(rec.complete);
    assert_eq!(rec.channels.len(), 1);
    assert_eq!(rec.channels[0].count, 2);
    assert_eq!(rec.channels[0].first_ns, Some(T0 as i64 + 1));
    assert_eq!(rec.channels[0].last_ns, Some(T0 as i64 + 5));
    let raw: Vec<_> = rec.raw[0].1.iter().map(|(t, d)| (t, d.to_vec())).collect();
    assert_eq!(
        raw,
        [
            (T0 as i64 + 5, b"a".to_vec()),
            (T0 as i64 + 1, b"b".to_vec())
        ]
    );

    // a bad chunk CRC loses that chunk only
    let mut bytes = head();
    bytes.extend_from_slice(&channel(1, "/x", "json"));
    bytes.extend_from_slice(&message(1, T0, b"kept"));
    let m = message(1, T0 + 1, b"dropped");
    bytes.extend_from_slice(&chunk(m.len() as u64, 12345, "", &m));
    let m = message(1, T0 + 2, b"kept too");
    bytes.extend_from_slice(&chunk(m.len() as u64, crc32fast::hash(&m), "", &m));
    let rec = read(&bytes).unwrap();
    assert!(!rec.complete);
    assert_eq!(rec.message_count(), 2);
    assert_eq!(rec.damage.len(), 1);
    assert!(rec.damage[0].why.contains("its header says 12345"));

    // no data end: not complete
    let mut bytes = head();
    bytes.extend_from_slice(&channel(1, "/x", "json"));
    let rec = read(&bytes).unwrap();
    assert!(!rec.complete);
    assert_eq!(
        rec.error.as_deref(),
        Some("file ends without a data-end record (writer not closed)")
    );

    // a log time beyond i64::MAX is an error
    let mut bytes = head();
    bytes.extend_from_slice(&channel(1, "/x", "json"));
    bytes.extend_from_slice(&message(1, u64::MAX, b"late"));
    let f = TempFile::new(&bytes);
    let e = read_recording(f.path(), &Options::default())
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}: a message on /x has log_time {} ns, beyond the largest time lfd reads (2**63 - 1 ns)",
            f.path().display(),
            u64::MAX
        )
    );

    // an unknown compression is an error
    let mut bytes = head();
    bytes.extend_from_slice(&chunk(3, 0, "brotli", b"abc"));
    let f = TempFile::new(&bytes);
    let e = read_recording(f.path(), &Options::default())
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!("{}: unknown chunk compression 'brotli'", f.path().display())
    );

    // a bad protobuf / confidence message is reported, not raised
    let mut bytes = head();
    bytes.extend_from_slice(&channel(1, "/hand/left/keypoints", "protobuf"));
    bytes.extend_from_slice(&channel(2, "/hand/left/confidence", "json"));
    bytes.extend_from_slice(&channel(3, "/objects/o/pose", "protobuf"));
    bytes.extend_from_slice(&message(1, T0, b"\xff\xff"));
    bytes.extend_from_slice(&message(2, T0, br#"{"confidence": [2]}"#));
    bytes.extend_from_slice(&message(2, T0 + 1, b"[]"));
    bytes.extend_from_slice(&message(3, T0, b"\x1a\x05"));
    let f = TempFile::new(&bytes);
    let rec = read_recording(f.path(), &Options::default()).unwrap();
    let p = f.path().display().to_string();
    let bad = topic(&rec.hands, "/hand/left/keypoints")
        .bad
        .clone()
        .unwrap();
    assert!(
        bad.starts_with(&format!(
            "{p}: cannot decode a foxglove.PosesInFrame on /hand/left/keypoints at {T0} ns: "
        )),
        "{bad}"
    );
    assert_eq!(
        topic(&rec.confidence, "/hand/left/confidence").bad.as_deref(),
        Some(
            format!(
                "{p}: /hand/left/confidence at {T0} ns: confidence must be 21 numbers in [0, 1], got [2]"
            )
            .as_str()
        )
    );
    assert!(topic(&rec.poses, "/objects/o/pose")
        .bad
        .clone()
        .unwrap()
        .contains("cannot decode a foxglove.PoseInFrame on /objects/o/pose"));
    let _ = string(b"");
}

#[test]
fn many_batches_read_as_one_sequential_pass() {
    // small chunks: hundreds of them, several parallel batches; every cut keeps a prefix
    let bytes = fixture(Some(mcap::Compression::Zstd), 256);
    let full = read(&bytes).unwrap();
    assert!(full.complete);
    let hand = topic(&full.hands, "/hand/right/keypoints");
    let conf = topic(&full.confidence, "/hand/right/confidence");
    let pose = topic(&full.poses, "/objects/b/pose");
    assert_eq!(hand.t_ns.len(), N as usize);
    let mut last = 0;
    for cut in (0..bytes.len()).step_by(bytes.len() / 97).skip(1) {
        let rec = read(&bytes[..cut]).unwrap();
        assert!(rec.message_count() >= last);
        last = rec.message_count();
        for (name, h) in &rec.hands {
            let f = topic(&full.hands, name);
            assert_eq!(h.t_ns[..], f.t_ns[..h.t_ns.len()]);
            let k = h.keypoints.len();
            assert!(h
                .keypoints
                .iter()
                .zip(&f.keypoints[..k])
                .all(|(a, b)| a == b || (a.is_nan() && b.is_nan())));
            assert_eq!(h.bad.is_some(), h.t_ns.len() > 7);
        }
        for (name, c) in &rec.confidence {
            let f = topic(&full.confidence, name);
            assert_eq!(c.confidence[..], conf.confidence[..c.confidence.len()]);
            assert_eq!(c.visible[..], f.visible[..c.visible.len()]);
        }
        for (name, p) in &rec.poses {
            let f = topic(&full.poses, name);
            assert_eq!(p.position[..], f.position[..p.position.len()]);
            assert_eq!(p.quaternion[..], f.quaternion[..p.quaternion.len()]);
        }
        for (name, r) in &rec.raw {
            let f = topic(&full.raw, name);
            assert!(r.iter().zip(f.iter()).all(|(a, b)| a == b));
        }
    }
    assert!(pose.bad.is_none());
}

#[test]
fn confidence_messages_are_validated_as_python() {
    let v = [0.5f64; 21];
    let ok = serde_json::json!({ "confidence": v }).to_string();
    let cases: [(&str, bool); 7] = [
        (&ok, true),
        (&format!("[{}]", serde_json::json!(v)), false), // an array, not an object
        (&format!("[{ok}]"), false),
        (r#"{"confidence": [0.5], "visible": null}"#, false),
        (r#"{"confidence": null}"#, false),
        ("3", false),
        ("{", false),
    ];
    let mut bytes = head();
    bytes.extend_from_slice(&channel(1, "/hand/right/confidence", "json"));
    for (i, (text, _)) in cases.iter().enumerate() {
        bytes.extend_from_slice(&message(1, T0 + i as u64, text.as_bytes()));
    }
    let rec = read(&bytes).unwrap();
    let c = topic(&rec.confidence, "/hand/right/confidence");
    for (i, (text, valid)) in cases.iter().enumerate() {
        let row = &c.confidence[i * 21..(i + 1) * 21];
        assert_eq!(row.iter().all(|x| !x.is_nan()), *valid, "{text}");
    }
    assert!(c.bad.as_deref().unwrap().contains(&format!(
        "at {} ns: not a JSON object {{\"confidence\": [21 numbers]}} (TypeError('list indices",
        T0 + 1
    )));
}
