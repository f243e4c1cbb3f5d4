//! Time `read_recording` on a file: `cargo run --release --example readtime -- FILE [images]`.
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(&args[1]);
    let options = lfd_mcap::Options {
        images: args.len() > 2,
        ..lfd_mcap::Options::default()
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
