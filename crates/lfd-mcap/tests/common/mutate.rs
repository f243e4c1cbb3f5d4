//! The mutation fuzzer of the reader: valid recordings damaged at random (bytes flipped, huge
//! lengths written over length fields and record fields, cut, slices repeated or removed) and
//! read from memory with `read_recording_bytes` and `read_summary_bytes`. Used by the CI smoke
//! (`tests/fuzz.rs`, a few thousand calls) and the long run (`examples/fuzz.rs`, millions of
//! calls under `ulimit -v`): any panic fails, an allocation beyond the limit aborts.

use lfd_mcap::{read_recording_bytes, read_summary_bytes, Options};

/// splitmix64: a small, seedable generator (no dependency).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Offsets of the records of `bytes` (top level, and inside uncompressed chunks), found by
/// following the lengths of a valid file: where a damaged length or field does the most harm.
pub fn record_starts(bytes: &[u8]) -> Vec<usize> {
    fn walk(bytes: &[u8], mut at: usize, end: usize, out: &mut Vec<usize>) {
        while at + 9 <= end {
            out.push(at);
            let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
            let Some(next) = usize::try_from(len)
                .ok()
                .and_then(|l| (at + 9).checked_add(l))
                .filter(|&n| n <= end)
            else {
                return;
            };
            // an uncompressed chunk: its records too
            if bytes[at] == 0x06 && next - at > 9 + 36 {
                let b = at + 9;
                let clen = u32::from_le_bytes(bytes[b + 28..b + 32].try_into().unwrap()) as usize;
                if clen == 0 && b + 32 + 8 <= next {
                    walk(bytes, b + 40, next, out);
                }
            }
            at = next;
        }
    }
    let mut out = Vec::new();
    walk(bytes, 8, bytes.len(), &mut out);
    out
}

/// Lengths that broke readers: all ones in 32 and 64 bits, the sign bits, just past the file.
fn huge(rng: &mut Rng, file_len: usize) -> u64 {
    match rng.below(7) {
        0 => u64::from(u32::MAX),
        1 => u64::MAX,
        2 => 1 << 31,
        3 => 1 << 63,
        4 => file_len as u64 + rng.below(64) as u64,
        5 => rng.next() >> rng.below(64),
        _ => u64::from(u32::MAX) - rng.below(16) as u64,
    }
}

/// `seed` with 1-4 random mutations (`starts`: its record offsets).
pub fn mutate(seed: &[u8], starts: &[usize], rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    if starts.is_empty() {
        return b;
    }
    for _ in 0..=rng.below(4) {
        if b.len() < 16 {
            break;
        }
        match rng.below(8) {
            0 | 1 => {
                // flip up to 32 bytes
                let at = rng.below(b.len());
                let n = (1 + rng.below(32)).min(b.len() - at);
                for x in &mut b[at..at + n] {
                    *x ^= 1 + rng.below(255) as u8;
                }
            }
            2 | 3 => {
                // a huge value over a record's length or one of its first fields
                let start = starts[rng.below(starts.len())];
                let at = start
                    + if rng.below(3) == 0 {
                        1
                    } else {
                        9 + rng.below(64)
                    };
                let v = huge(rng, b.len());
                let wide = rng.below(2) == 0;
                let bytes = if wide {
                    v.to_le_bytes().to_vec()
                } else {
                    (v as u32).to_le_bytes().to_vec()
                };
                if at + bytes.len() <= b.len() {
                    b[at..at + bytes.len()].copy_from_slice(&bytes);
                }
            }
            4 => b.truncate(8 + rng.below(b.len() - 8)),
            5 => {
                // repeat a slice
                let at = rng.below(b.len());
                let n = rng.below((b.len() - at).min(4096)) + 1;
                let slice = b[at..at + n].to_vec();
                let to = rng.below(b.len());
                b.splice(to..to, slice);
            }
            6 => {
                // remove a slice
                let at = rng.below(b.len());
                let n = rng.below((b.len() - at).min(4096)) + 1;
                b.drain(at..at + n);
            }
            _ => {
                // a random byte as an opcode at a record start
                let start = starts[rng.below(starts.len())];
                if start < b.len() {
                    b[start] = rng.below(256) as u8;
                }
            }
        }
    }
    b
}

/// Read `bytes` with both readers (any result but a panic), checking the shapes of what comes
/// back.
pub fn read_both(bytes: &[u8], rng: &mut Rng) {
    let options = Options::images(rng.below(2) == 0);
    if let Ok(rec) = read_recording_bytes(bytes, "fuzz.mcap", &options) {
        for (_, h) in &rec.hands {
            assert_eq!(h.keypoints.len(), h.t_ns.len() * 63);
        }
        for (_, p) in &rec.poses {
            assert_eq!(p.position.len(), p.t_ns.len() * 3);
        }
        for d in &rec.damage {
            assert!(d.offset <= d.end && !d.why.contains('\n'), "{d:?}");
        }
    }
    let topics = ["/lfd/ground_truth".to_string()];
    let _ = read_summary_bytes(bytes, "fuzz.mcap", &topics);
}

/// `n` mutated reads of the seeds, from `seed`; returns the calls made (two per read).
pub fn run(seeds: &[Vec<u8>], n: u64, seed: u64) -> u64 {
    let starts: Vec<Vec<usize>> = seeds.iter().map(|s| record_starts(s)).collect();
    let mut rng = Rng(seed);
    for _ in 0..n {
        let i = rng.below(seeds.len());
        let b = mutate(&seeds[i], &starts[i], &mut rng);
        read_both(&b, &mut rng);
    }
    2 * n
}
