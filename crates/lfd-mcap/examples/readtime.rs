//! Time `read_recording` on a file, keeping the raw topics `lfd.load` keeps:
//! `cargo run --release --example readtime -- FILE [all]` (`all`: every raw topic).
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(&args[1]);
    let raw_topics = (args.len() < 3).then(|| {
        [
            "/lfd/ground_truth",
            "/lfd/live/segments",
            "/camera/color/camera_info",
        ]
        .map(String::from)
        .to_vec()
    });
    let options = lfd_mcap::Options {
        images: false,
        raw_topics,
        raw_limit: None,
    };
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let rec = lfd_mcap::read_recording(path, &options).expect("readable");
        println!(
            "{:.3} s, {} messages",
            t.elapsed().as_secs_f64(),
            rec.message_count()
        );
    }
}
