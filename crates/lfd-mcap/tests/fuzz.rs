//! Fuzzing the reader with proptest: on random bytes, and on valid recordings truncated at a
//! random offset with random bytes flipped, `read_recording` and `read_summary` return `Ok` or
//! a `ReadError`; no panic, no abort, no hang.
//!
//! `cargo test -p lfd-mcap --test fuzz` runs a short smoke (CI). A long run sets the number of
//! cases per target: `LFD_MCAP_FUZZ_CASES=100000 cargo test --release -p lfd-mcap --test fuzz --
//! --nocapture` (each target prints its executions).

mod common;

use common::{fixture, shipped, TempFile};
use lfd_mcap::{read_recording, read_summary, Options};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::sync::OnceLock;

const SMOKE_CASES: u32 = 64;

fn cases() -> u32 {
    std::env::var("LFD_MCAP_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(SMOKE_CASES)
}

fn runner() -> TestRunner {
    TestRunner::new(Config {
        cases: cases(),
        failure_persistence: None,
        max_shrink_iters: 200,
        ..Config::default()
    })
}

fn report(target: &str, n: u32) {
    eprintln!("fuzz {target}: {n} cases passed");
}

/// Valid recordings to damage: zstd, lz4 and uncompressed chunks, and a shipped recording.
fn seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        vec![
            fixture(Some(mcap::Compression::Zstd), 2048),
            fixture(Some(mcap::Compression::Lz4), 2048),
            fixture(None, 2048),
            shipped("exp1.mcap"),
        ]
    })
}

/// Both readers on `bytes`: any result but a panic; a complete pass keeps at least as many
/// messages as a summary announces for its requested topics.
fn read_both(bytes: &[u8], images: bool) -> Result<(), TestCaseError> {
    let f = TempFile::new(bytes);
    if let Ok(rec) = read_recording(f.path(), &Options::images(images)) {
        prop_assert!(rec.complete || rec.error.is_some());
        for (_, h) in &rec.hands {
            prop_assert_eq!(h.keypoints.len(), h.t_ns.len() * 63);
        }
        for (_, c) in &rec.confidence {
            prop_assert_eq!(c.confidence.len(), c.t_ns.len() * 21);
            prop_assert_eq!(c.visible.len(), c.t_ns.len() * 21);
            prop_assert_eq!(c.has_visible.len(), c.t_ns.len());
        }
        for (_, p) in &rec.poses {
            prop_assert_eq!(p.position.len(), p.t_ns.len() * 3);
            prop_assert_eq!(p.quaternion.len(), p.t_ns.len() * 4);
        }
    }
    let topics = ["/lfd/ground_truth".to_string(), "/tf".to_string()];
    let _ = read_summary(f.path(), &topics);
    Ok(())
}

#[test]
fn fuzz_random_bytes() {
    let bytes = prop::collection::vec(any::<u8>(), 0..600);
    let with_magic = prop::collection::vec(any::<u8>(), 0..600).prop_map(|tail| {
        let mut b = lfd_mcap::MAGIC.to_vec();
        b.extend(tail);
        b
    });
    runner()
        .run(&prop_oneof![bytes, with_magic], |b| read_both(&b, true))
        .unwrap();
    report("random_bytes", cases());
}

#[test]
fn fuzz_truncated_and_flipped() {
    let damage = (
        0..seeds().len(),
        0.0..=1.0f64,
        prop::collection::vec((0.0..1.0f64, 0u8..8), 0..4),
        any::<bool>(),
    );
    runner()
        .run(&damage, |(seed, keep, flips, images)| {
            let src = &seeds()[seed];
            let mut b = src[..(src.len() as f64 * keep) as usize].to_vec();
            for (at, bit) in flips {
                if !b.is_empty() {
                    let i = ((b.len() as f64 * at) as usize).min(b.len() - 1);
                    b[i] ^= 1 << bit;
                }
            }
            read_both(&b, images)
        })
        .unwrap();
    report("truncated_and_flipped", cases());
}

#[test]
fn fuzz_mutations() {
    // the long run's mutations (examples/fuzz.rs), briefly: LFD_MCAP_FUZZ_CASES reads
    let n = u64::from(cases()) * 4;
    let calls = common::mutate::run(&common::fuzz_seeds(), n, 7);
    eprintln!("fuzz mutations: {calls} calls passed");
}

#[test]
fn fuzz_summary_fields() {
    // flips confined to the summary section and footer of a complete file
    let src = &seeds()[0];
    let tail = 2000.min(src.len());
    runner()
        .run(&prop::collection::vec((0..tail, 0u8..8), 1..4), |flips| {
            let mut b = src.clone();
            let n = b.len();
            for (at, bit) in flips {
                b[n - 1 - at] ^= 1 << bit;
            }
            read_both(&b, true)
        })
        .unwrap();
    report("summary_fields", cases());
}
