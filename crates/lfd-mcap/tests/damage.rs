//! Damaged files: a chunk whose contents are damaged or whose length field lies loses only
//! itself (the reader resynchronises on the next chunk and names the damage), a huge length in
//! any record kind is an error and never an allocation, a summary is believed only as far as
//! its chunk indexes and message indexes go.

mod common;

use std::collections::BTreeMap;

use common::{fixture, fixture_unindexed, record, shipped, string};
use lfd_mcap::records;
use lfd_mcap::{read_recording_bytes, read_summary_bytes, Options, Recording};
use proptest::prelude::*;

fn read(bytes: &[u8]) -> Recording {
    read_recording_bytes(bytes, "t.mcap", &Options::default()).expect("readable")
}

/// The chunks of a valid file (offset order) with their messages per topic.
fn chunks(bytes: &[u8]) -> Vec<(mcap::records::ChunkIndex, BTreeMap<String, u64>)> {
    let summary = mcap::Summary::read(bytes).unwrap().expect("a summary");
    let mut out: Vec<_> = summary
        .chunk_indexes
        .iter()
        .map(|ci| {
            let mut per_topic = BTreeMap::new();
            for (ch, entries) in summary.read_message_indexes(bytes, ci).unwrap() {
                *per_topic.entry(ch.topic.clone()).or_default() += entries.len() as u64;
            }
            (ci.clone(), per_topic)
        })
        .collect();
    out.sort_by_key(|(ci, _)| ci.chunk_start_offset);
    out
}

fn counts(rec: &Recording) -> BTreeMap<String, u64> {
    rec.channels
        .iter()
        .map(|c| (c.topic.clone(), c.count))
        .collect()
}

/// `full`'s counts less `lost`'s.
fn less(full: &BTreeMap<String, u64>, lost: &BTreeMap<String, u64>) -> BTreeMap<String, u64> {
    full.iter()
        .map(|(t, n)| (t.clone(), n - lost.get(t).copied().unwrap_or(0)))
        .collect()
}

#[test]
fn a_damaged_chunk_loses_only_its_messages() {
    let bytes = shipped("exp1.mcap");
    let full = read(&bytes);
    let index = chunks(&bytes);
    assert!(index.len() > 10);
    for k in [0, 1, 9, index.len() - 1] {
        let (ci, lost) = &index[k];
        let mut b = bytes.clone();
        let mid = (ci.chunk_start_offset + ci.chunk_length / 2) as usize;
        for x in &mut b[mid..mid + 32] {
            *x ^= 0x5A;
        }
        let rec = read(&b);
        let n: u64 = lost.values().sum();
        assert_eq!(counts(&rec), less(&counts(&full), lost), "chunk {k}");
        assert!(rec.complete && rec.error.is_none());
        assert_eq!(rec.damage.len(), 1, "{:?}", rec.damage);
        assert_eq!(rec.damage[0].chunks, Some(vec![k as u64 + 1]));
        assert_eq!(rec.damage[0].messages, Some(n));
        assert_eq!(rec.chunks, index.len() as u64);
        // the summary names it too, from the message indexes
        let s = read_summary_bytes(&b, "t.mcap", &[])
            .unwrap()
            .expect("a summary");
        assert_eq!(s.damage.len(), 1);
        assert_eq!(s.damage[0].chunks, Some(vec![k as u64 + 1]));
        assert_eq!(s.damage[0].messages, Some(n));
        assert_eq!(s.messages, full.message_count() - n);
        let by_topic: BTreeMap<String, u64> = s
            .channels
            .iter()
            .map(|c| (c.topic.clone(), c.count))
            .collect();
        assert_eq!(by_topic, less(&counts(&full), lost));
        assert!(!s.damage[0].why.contains('\n') && !s.damage[0].why.contains('\x1b'));
    }
}

#[test]
fn a_bad_chunk_length_loses_only_its_chunk() {
    let bytes = shipped("exp1.mcap");
    let full = read(&bytes);
    let index = chunks(&bytes);
    for k in [0, 1, 9] {
        let (ci, lost) = &index[k];
        let at = ci.chunk_start_offset as usize;
        for len in [
            u64::from(u32::MAX),
            u64::MAX,
            0,
            5,
            ci.chunk_length - 9 - 7,
            ci.chunk_length - 9 + 7,
        ] {
            let mut b = bytes.clone();
            b[at + 1..at + 9].copy_from_slice(&len.to_le_bytes());
            let rec = read(&b);
            assert_eq!(rec.damage.len(), 1, "{:?}", rec.damage);
            if len == ci.chunk_length - 9 + 7 {
                // a length a little long: the chunk's fields are whole, it is read; the
                // message index it runs into is the damage, no message lost
                assert_eq!(counts(&rec), counts(&full));
                assert_eq!(rec.damage[0].chunks, Some(vec![]));
                assert_eq!(rec.damage[0].messages, Some(0));
                continue;
            }
            assert_eq!(
                counts(&rec),
                less(&counts(&full), lost),
                "chunk {k} length {len}"
            );
            assert_eq!(rec.damage[0].chunks, Some(vec![k as u64 + 1]));
            assert_eq!(rec.damage[0].messages, Some(lost.values().sum()));
            // without a summary (cut after the data section) the messages lost are unknown,
            // and the channels the first chunk defined are lost with it
            let data_end = summary_start(&bytes) as usize - 13;
            let rec = read(&b[..data_end]);
            if k > 0 {
                assert_eq!(counts(&rec), less(&counts(&full), lost));
            }
            assert_eq!(rec.damage.len(), 1);
            assert_eq!(rec.damage[0].messages, None);
            assert_eq!(rec.damage[0].chunks, None);
        }
    }
}

#[test]
fn a_bad_length_in_a_chunk_header_field_loses_only_its_chunk() {
    let bytes = shipped("exp1.mcap");
    let full = read(&bytes);
    let index = chunks(&bytes);
    let (ci, lost) = &index[3];
    // the compression string's and the records' lengths
    for (field, wide) in [(9 + 28, false), (9 + 36, true)] {
        for v in [u64::from(u32::MAX), u64::MAX] {
            let mut b = bytes.clone();
            let at = ci.chunk_start_offset as usize + field;
            if wide {
                b[at..at + 8].copy_from_slice(&v.to_le_bytes());
            } else {
                b[at..at + 4].copy_from_slice(&(v as u32).to_le_bytes());
            }
            let rec = read(&b);
            assert_eq!(counts(&rec), less(&counts(&full), lost));
            assert_eq!(rec.damage[0].chunks, Some(vec![4]));
        }
    }
}

fn summary_start(bytes: &[u8]) -> u64 {
    let f = bytes.len() - 8 - 29 + 9;
    u64::from_le_bytes(bytes[f..f + 8].try_into().unwrap())
}

/// `bytes` with its summary section's records replaced by `edit`'s (footer and CRC remade).
fn with_summary(bytes: &[u8], edit: impl Fn(u8, &[u8]) -> Vec<Vec<u8>>) -> Vec<u8> {
    let start = summary_start(bytes) as usize;
    let footer_at = bytes.len() - 8 - 29;
    let mut out = bytes[..start].to_vec();
    for (opcode, body) in records::split(&bytes[start..footer_at]).unwrap() {
        for body in edit(opcode, body) {
            out.extend_from_slice(&record(opcode, &body));
        }
    }
    let mut footer = vec![0x02];
    footer.extend_from_slice(&20u64.to_le_bytes());
    footer.extend_from_slice(&(start as u64).to_le_bytes());
    footer.extend_from_slice(&0u64.to_le_bytes());
    let mut h = crc32fast::Hasher::new();
    h.update(&out[start..]);
    h.update(&footer);
    footer.extend_from_slice(&h.finalize().to_le_bytes());
    out.extend_from_slice(&footer);
    out.extend_from_slice(lfd_mcap::MAGIC);
    out
}

#[test]
fn repeated_chunk_indexes_are_one_chunk_and_statistics_are_checked() {
    let bytes = shipped("exp1.mcap");
    let honest = read_summary_bytes(&bytes, "t.mcap", &["/lfd/ground_truth".into()])
        .unwrap()
        .unwrap();
    let repeated = with_summary(&bytes, |op, body| {
        let times = if op == records::op::CHUNK_INDEX {
            1000
        } else {
            1
        };
        vec![body.to_vec(); times]
    });
    let s = read_summary_bytes(&repeated, "t.mcap", &["/lfd/ground_truth".into()])
        .unwrap()
        .expect("still a usable summary");
    assert_eq!(s.messages, honest.messages);
    assert_eq!(s.channels, honest.channels);
    assert_eq!(s.chunks, honest.chunks);
    assert_eq!(s.raw, honest.raw);
    assert!(s.damage.is_empty());
    // statistics that count more than the message indexes are not believed
    let lying = with_summary(&bytes, |op, body| {
        let mut body = body.to_vec();
        if op == records::op::STATISTICS {
            let n = u64::from_le_bytes(body[..8].try_into().unwrap());
            body[..8].copy_from_slice(&(n * 20000).to_le_bytes());
        }
        vec![body]
    });
    assert!(read_summary_bytes(&lying, "t.mcap", &[]).unwrap().is_none());
    assert_eq!(read(&lying).message_count(), honest.messages);
    // a chunk index pointing elsewhere: not believed either
    let moved = with_summary(&bytes, |op, body| {
        let mut body = body.to_vec();
        if op == records::op::CHUNK_INDEX {
            let at = u64::from_le_bytes(body[16..24].try_into().unwrap());
            body[16..24].copy_from_slice(&(at + 1).to_le_bytes());
        }
        vec![body]
    });
    assert!(read_summary_bytes(&moved, "t.mcap", &[]).unwrap().is_none());
}

#[test]
fn a_file_without_message_indexes_or_statistics_is_read_whole() {
    for compression in [Some(mcap::Compression::Zstd), None] {
        let indexed = read(&fixture(compression, 4096));
        let bytes = fixture_unindexed(compression, 4096);
        // no summary to count with: None, and the full read has every message
        assert!(read_summary_bytes(&bytes, "t.mcap", &[]).unwrap().is_none());
        let rec = read(&bytes);
        assert!(rec.complete && rec.damage.is_empty());
        assert_eq!(rec.channels, indexed.channels);
        assert_eq!(rec.message_count(), indexed.message_count());
    }
}

/// A body of record kind `opcode` in which a length field holds `len`.
fn with_length(opcode: u8, len: u64) -> Vec<u8> {
    let l32 = (len as u32).to_le_bytes();
    let mut b = Vec::new();
    match opcode {
        records::op::HEADER | records::op::METADATA => {
            b.extend_from_slice(&l32);
            b.extend_from_slice(b"abc");
        }
        records::op::SCHEMA => {
            b.extend_from_slice(&1u16.to_le_bytes());
            b.extend_from_slice(&string(b"name"));
            b.extend_from_slice(&string(b"protobuf"));
            b.extend_from_slice(&l32);
        }
        records::op::CHANNEL => {
            b.extend_from_slice(&[1, 0, 0, 0]);
            b.extend_from_slice(&string(b"/t"));
            b.extend_from_slice(&string(b"json"));
            b.extend_from_slice(&l32); // metadata map
        }
        records::op::CHUNK => {
            b.extend_from_slice(&[0; 28]);
            b.extend_from_slice(&string(b"zstd"));
            b.extend_from_slice(&len.to_le_bytes());
        }
        records::op::MESSAGE_INDEX => {
            b.extend_from_slice(&[1, 0]);
            b.extend_from_slice(&l32);
        }
        records::op::CHUNK_INDEX => {
            b.extend_from_slice(&[0; 32]);
            b.extend_from_slice(&l32); // message index offsets
        }
        records::op::ATTACHMENT_INDEX => {
            b.extend_from_slice(&[0; 40]);
            b.extend_from_slice(&l32);
        }
        records::op::STATISTICS => {
            b.extend_from_slice(&[0; 42]);
            b.extend_from_slice(&l32); // channel message counts
        }
        _ => b.extend_from_slice(&len.to_le_bytes()),
    }
    b
}

#[test]
fn a_huge_length_in_any_record_kind_is_an_error_not_an_allocation() {
    for len in [
        u64::from(u32::MAX),
        u64::MAX,
        1 << 31,
        (1 << 63) | (1 << 31),
    ] {
        let results = [
            records::header(&with_length(0x01, len)).err(),
            records::metadata(&with_length(0x0C, len)).err(),
            records::schema(&with_length(0x03, len)).err(),
            records::channel(&with_length(0x04, len)).err(),
            records::chunk(&with_length(0x06, len)).err(),
            records::message_index(&with_length(0x07, len)).err(),
            records::chunk_index(&with_length(0x08, len)).err(),
            records::attachment_index(&with_length(0x0A, len)).err(),
            records::statistics(&with_length(0x0B, len)).err(),
        ];
        for (i, r) in results.iter().enumerate() {
            let why = r
                .as_ref()
                .unwrap_or_else(|| panic!("kind {i}: {len} accepted"));
            assert!(why.contains("are left in it"), "{why}");
        }
        // and as records of a file, and as a record's own length, top level: damage
        for opcode in [0x01, 0x03, 0x04, 0x05, 0x06, 0x07, 0x0C, 0x0F] {
            let mut b = common::head();
            b.extend_from_slice(&record(opcode, &with_length(opcode, len)));
            let mut huge = vec![opcode];
            huge.extend_from_slice(&len.to_le_bytes());
            b.extend_from_slice(&huge);
            let rec = read(&b);
            if opcode == 0x0F {
                assert!(rec.complete); // a data-end record may be longer than its CRC
            } else {
                assert!(!rec.complete && rec.error.is_some(), "{opcode}: {rec:?}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Any length written over any 4 or 8 bytes of a record's first 64: the reader returns.
    #[test]
    fn any_length_anywhere_in_a_record(pick in 0usize..1000, off in 0usize..64, wide: bool,
                                       shift in 0u32..64) {
        let bytes = fixture(None, 2048);
        let starts = common::mutate::record_starts(&bytes);
        let at = starts[pick % starts.len()] + 1 + off;
        let v = u64::MAX >> shift;
        let mut b = bytes.clone();
        let w = if wide { 8 } else { 4 };
        if at + w <= b.len() {
            b[at..at + w].copy_from_slice(&v.to_le_bytes()[..w]);
        }
        let rec = read_recording_bytes(&b, "t.mcap", &Options::default());
        if let Ok(rec) = rec {
            prop_assert!(rec.message_count() <= read(&bytes).message_count() + 1);
        }
        let _ = read_summary_bytes(&b, "t.mcap", &[]);
    }
}
