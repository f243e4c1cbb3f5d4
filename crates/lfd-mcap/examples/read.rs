//! Time `read_recording` and `read_summary` on the files given: `cargo run --release
//! --example read -p lfd-mcap -- FILE...`.

use std::path::Path;
use std::time::Instant;

fn main() {
    for arg in std::env::args().skip(1) {
        let path = Path::new(&arg);
        let t0 = Instant::now();
        let rec = lfd_mcap::read_recording(path, &lfd_mcap::Options::default());
        let t1 = t0.elapsed().as_secs_f64();
        match rec {
            Ok(r) => println!(
                "{arg}: {} messages, complete={} error={:?} in {t1:.3} s",
                r.message_count(),
                r.complete,
                r.error
            ),
            Err(e) => println!("{arg}: error {e} in {t1:.3} s"),
        }
        let t0 = Instant::now();
        let topics = [
            "/lfd/ground_truth".to_string(),
            "/lfd/live/segments".to_string(),
        ];
        let s = lfd_mcap::read_summary(path, &topics);
        let t1 = t0.elapsed().as_secs_f64();
        match s {
            Ok(Some(s)) => println!(
                "  summary: {} messages, {} channels, raw {:?} in {t1:.4} s",
                s.messages,
                s.channels.len(),
                s.raw.iter().map(|(t, m)| (t, m.len())).collect::<Vec<_>>()
            ),
            Ok(None) => println!("  summary: none in {t1:.4} s"),
            Err(e) => println!("  summary: error {e} in {t1:.4} s"),
        }
    }
}
