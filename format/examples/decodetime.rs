// Scratch: native decoding speed of coded meshes given on the command line.
use std::time::Instant;
fn main() {
    let secs: f64 = std::env::var("SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(0.7);
    let fixed: Option<usize> = std::env::var("RUNS").ok().and_then(|s| s.parse().ok());
    for path in std::env::args().skip(1) {
        let bytes = std::fs::read(&path).unwrap();
        let n = exploremaps_format::meshcode::decode(&bytes).unwrap().triangles.len() as f64;
        let t = Instant::now();
        let mut runs = 0;
        while fixed.map_or(runs < 3 || t.elapsed().as_secs_f64() < secs, |f| runs < f) {
            std::hint::black_box(exploremaps_format::meshcode::decode(&bytes).unwrap());
            runs += 1;
        }
        println!("{path}: {:.1} M tri/s", n * runs as f64 / t.elapsed().as_secs_f64() / 1e6);
    }
}
