//! Proxy simplification (issue: light 3D proxy): for the Stanford bunny, the
//! Crytek Sponza and the Dabrovic Sponza (when `../shared/scenes` has them)
//! and the built-in gallery, weld then simplify to 50 %, 10 %, 2 % and 1 % of
//! the triangles; print the time, the triangles reached, the largest collapse
//! error (in % of the bounding-box diagonal), the triangles whose normal turned
//! more than 90° from the input's, and the progressive stream's size.
//! Not yet here: Hausdorff/RMS distances and meshoptimizer side by side.
//! `cargo bench -p exploremaps-builder --bench proxy`.

use exploremaps_builder::load::{load, LoadOptions};
use exploremaps_builder::proxy::progressive::Progressive;
use exploremaps_builder::proxy::simplify::{simplify, SimplifyParams};
use exploremaps_builder::proxy::weld::weld_scene;
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

fn main() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let mut scenes: Vec<(String, Scene)> = vec![("gallery".into(), BuiltIn::Gallery.generate(1))];
    for file in ["stanford_bunny/bun_zipper.ply", "sponza_crytek/sponza_crytek.obj", "sponza_dabrovic/sponza.obj"] {
        let path = shared.join(file);
        match load(&path, &LoadOptions::default()) {
            Ok(scene) => scenes.push((file.split('/').next().unwrap().to_string(), scene)),
            Err(e) => println!("skipped {}: {e}", path.display()),
        }
    }
    println!("{:<16} {:>8} {:>8} {:>8} {:>9} {:>9} {:>7} {:>8}", "scene", "input", "ratio", "reached", "seconds", "error %", "flipped", "splits");
    for (name, scene) in &scenes {
        let t = Instant::now();
        let diagonal = scene.bounds().diagonal();
        let (mesh, stats) = weld_scene(scene, 1e-5 * diagonal);
        println!("{name}: welded {} -> {} vertices, {} degenerate and {} repeated triangles dropped ({:.2} s)", stats.vertices_before, stats.vertices_after, stats.degenerate, stats.duplicates, t.elapsed().as_secs_f64());
        for ratio in [0.5, 0.1, 0.02, 0.01] {
            let target = (mesh.triangles.len() as f64 * ratio) as usize;
            let t = Instant::now();
            let s = simplify(&mesh, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY });
            let seconds = t.elapsed().as_secs_f64();
            let normal = |p: [Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]);
            let flipped = (0..mesh.triangles.len())
                .filter(|&t| s.alive[t])
                .filter(|&t| normal(mesh.triangles[t].map(|v| mesh.positions[v as usize])).dot(normal(s.mesh.triangles[t].map(|v| s.mesh.positions[v as usize]))) < 0.0)
                .count();
            let pm = Progressive::new(&mesh, &s);
            println!("{name:<16} {:>8} {:>7.0}% {:>8} {seconds:>9.3} {:>9.4} {flipped:>7} {:>8}", mesh.triangles.len(), ratio * 100.0, s.triangles().len(), 100.0 * s.error / diagonal, pm.refinements.len());
        }
    }
}
