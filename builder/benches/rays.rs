//! Ray throughput on Embree, single rays against 8-wide packets, side by side.
//!
//! `cargo bench -p exploremaps-builder --bench rays [-- TRIANGLES]` (default 1,000,000).
//! Scene: the built-in `big` museum of gallery wings. Three kinds of rays:
//! coherent (a 6×512² cube map from a probe at eye height, the exploration
//! stage's workload, in 4×2 pixel tiles, and a 1024² view down a corridor), incoherent (cosine-weighted bounce rays from the primary hits), shadow
//! (from the hits to a point light). Output buffers are reused, as in the hot loops.
//! Packets are traced both plainly and flagged COHERENT (one frustum per packet).
//! Reference limits measured on these 2-core machines when the project began:
//! coherent 18-20 (single) / 42-50 (packets), incoherent ≈ 11, shadow 31 / 65 Mrays/s.

use exploremaps_builder::plan::visibility::CubeView;
use exploremaps_builder::raycast::{Packing, Ray, RayScene};
use exploremaps_builder::seeds::cosine_direction;
use exploremaps_scenes::BuiltIn;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use std::time::Instant;

fn main() {
    let triangles: usize = std::env::args().skip(1).find_map(|a| a.replace('_', "").parse().ok()).unwrap_or(1_000_000);
    let t = Instant::now();
    let scene = BuiltIn::Big(triangles).generate(1);
    let gen_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let rays = RayScene::new(&scene.positions, &scene.triangles, 0).expect("Embree scene");
    let build_s = t.elapsed().as_secs_f64();
    println!(
        "scene: big, {} triangles (generated in {gen_s:.2} s), Embree {}, BVH build {build_s:.2} s, {} rayon threads",
        scene.triangles.len(),
        rays.embree_version(),
        rayon::current_num_threads()
    );

    let _bounds = scene.bounds();
    // A probe at eye height in the pillared hall of the first wing.
    let eye = Vec3::new(28.0, 1.6, 10.0);
    let (primary, _) = CubeView::tiled_rays(eye, 512);
    // A 1024² view down the 40 m corridor: large walls and floor, the most coherent case.
    // (The +X face of a cube map comes first in its rays.)
    let corridor = CubeView::tiled_rays(Vec3::new(0.8, 1.6, 2.0), 1024).0[..1024 * 1024].to_vec();
    let hits = rays.intersect_batch(&primary, Packing::Coherent8);
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
    let light = Vec3::new(30.0, 3.5, 12.0);
    let (mut bounce, mut shadow) = (Vec::new(), Vec::new());
    for (r, h) in primary.iter().zip(&hits) {
        let Some(h) = h else { continue };
        let n = if h.normal.dot(r.dir) < 0.0 { h.normal } else { -h.normal };
        let p = r.at(h.t) + n * 1e-3;
        bounce.push(Ray::new(p, cosine_direction(n, glam::Vec2::new(rng.random(), rng.random()))));
        shadow.push(Ray::segment(p, light));
    }
    println!("{:<22} {:>8} {:>8} {:>10} {:>7}   reference measured here (single / 8-wide)", "Mrays/s", "single", "8-wide", "8 coherent", "best/1");
    let row = |name: &str, rays: &[Ray], reference: &str, trace: &dyn Fn(&[Ray], Packing)| {
        let per_s = |packing| rays.len() as f64 / time(|| trace(rays, packing)) / 1e6;
        let (s, p, c) = (per_s(Packing::Single), per_s(Packing::Packets8), per_s(Packing::Coherent8));
        println!("{name:<22} {s:>8.1} {p:>8.1} {c:>10.1} {:>6.2}x   {reference}", p.max(c) / s);
    };
    let mut hit_buf = vec![None; primary.len().max(corridor.len())];
    let mut bool_buf = vec![false; shadow.len()];
    let hit_buf = std::sync::Mutex::new(&mut hit_buf);
    let bool_buf = std::sync::Mutex::new(&mut bool_buf);
    let intersect = |r: &[Ray], p| rays.intersect_into(r, &mut hit_buf.lock().unwrap()[..r.len()], p);
    let occluded = |r: &[Ray], p| rays.occluded_into(r, &mut bool_buf.lock().unwrap()[..r.len()], p);
    row("coherent (cube map)", &primary, "18-20 / 42-50", &intersect);
    row("coherent (corridor)", &corridor, "18-20 / 42-50", &intersect);
    row("incoherent (bounce)", &bounce, "≈11 / ≈11", &intersect);
    row("shadow (occlusion)", &shadow, "31 / 65", &occluded);
}

/// Best-of-5 seconds per run of `f`, after one warm-up run.
fn time(f: impl Fn()) -> f64 {
    f();
    (0..5)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}
