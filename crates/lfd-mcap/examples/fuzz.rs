//! The long fuzz run of the reader: `cargo run --release -p lfd-mcap --example fuzz -- CALLS
//! [SEED]` reads mutated recordings (`tests/common/mutate.rs`) until CALLS calls of
//! `read_recording_bytes` and `read_summary_bytes` are made, printing the count every million.
//! Run it under an address-space limit (`ulimit -v 2097152`): a length trusted enough to
//! allocate beyond it aborts the process.

#[path = "../tests/common/mod.rs"]
mod common;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let calls: u64 = args
        .get(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let seed: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(0);
    let mut seeds = common::fuzz_seeds();
    if let Some(i) = args.get(3).and_then(|a| a.parse::<usize>().ok()) {
        seeds = vec![seeds.swap_remove(i)]; // one seed only
    }
    for s in &seeds {
        eprintln!("seed of {} bytes", s.len());
    }
    let t = std::time::Instant::now();
    let mut done = 0u64;
    let step = 500_000u64;
    while done < calls {
        let n = (calls - done).min(step);
        done += common::mutate::run(&seeds, n.div_ceil(2), seed.wrapping_mul(1_000_003) ^ done);
        println!(
            "{done} calls, {:.0} s, seed {seed}",
            t.elapsed().as_secs_f64()
        );
    }
}
