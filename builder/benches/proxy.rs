//! Proxy mesh bench (issue: light 3D proxy), one command for all figures:
//! `cargo bench -p exploremaps-builder --bench proxy --features proxy-bench`.
//!
//! Scenes: the built-in gallery, and from `../shared/scenes` (when present)
//! the Stanford bunny and the Crytek and Dabrovic Sponzas, each welded first.
//!
//! 1. Simplification at 50, 10, 2 and 1 % of the triangles, ours against
//!    meshoptimizer (`meshopt_simplify` with pruning, no error limit, on the
//!    same welded positions; it ignores materials, ours keeps their borders;
//!    so it runs a second time with each vertex split per material, which
//!    makes the borders attribute seams that it keeps, as ours does):
//!    time, triangles reached, and the geometric error against the input as
//!    symmetric Hausdorff and RMS distances in % of the box diagonal, from
//!    100 000 area-uniform points sampled on each mesh and projected on the
//!    other (parry3d's BVH). The Hausdorff figure is the largest sampled
//!    distance, so a lower bound of the true one. Also: triangles whose normal
//!    turned past 90° from the input's.
//! 2. Coding of each level sent whole (`meshcode`, 14-bit positions):
//!    connectivity bits a triangle, bytes all-in, bytes a triangle, against
//!    meshoptimizer's index and vertex codecs (16-bit quantized positions,
//!    the closest it has) followed by gzip -9, and against Google Draco (npm
//!    `draco3d` 1.5.7, installed into `target/bench-node` on first run;
//!    Edgebreaker, 14-bit positions, other settings default); decoding speed
//!    natively and in Node's WebAssembly (ours: the format crate's
//!    `wasm_decode` example, built by this bench; Draco: its npm module),
//!    each the median rate of 5 ms batches over half a second.
//! 3. The progressive stream as the bundle sends it (the scene simplified
//!    to 25 000 triangles, a 2 500-triangle base coded whole, then vertex
//!    splits in packets of 750 triangles, geometry only): bytes received
//!    against the error of the mesh the viewer then shows (as in 1, against
//!    the welded scene), the splits' bytes a triangle they bring back, the
//!    whole 25 000-triangle level coded at once for comparison, and how fast
//!    packets apply natively; drawn as curves (RMS error against kilobytes,
//!    one a scene, the whole level as a dot) in `target/proxy-stream.svg`.
//!
//! 1b. Colour-aware simplification, the bundle's setting (`COLOUR_WEIGHT=`
//!    a share of the diagonal to try another) against geometry alone, at 10 and 2 %: time, the distances of 1, and the RMS difference
//!    of the vertices' surface colours (as the simplifier sees them) between
//!    input points and the nearest points of the simplified mesh.
//!
//! Last, the issue's goals, each against this run's figures: met or not.
//!
//! `PROXY_BENCH=simplify` stops after sections 1 and 1b; `ONLY=dabrovic`
//! (a part of a shared scene's path) keeps the gallery and that scene;
//! `ONE_GROUP=1` simplifies without material borders, as meshoptimizer does.

use exploremaps_builder::proxy::progressive::Progressive;
use exploremaps_builder::proxy::simplify::{simplify, simplify_with_colours, Colours, Simplified, SimplifyParams};
use exploremaps_builder::proxy::weld::weld_scene;
use exploremaps_builder::proxy::{vertex_albedo, Mesh, COLOUR_WEIGHT};
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_format::{meshcode, splits};
use exploremaps_scenes::{BuiltIn, Scene};
use glam::Vec3;
use parry3d::math::{Isometry, Point};
use parry3d::query::PointQuery;
use parry3d::shape::TriMesh;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

/// Runs `f` three times: its last result and the median time (this machine's
/// speed drifts by ±10 % between runs).
fn median_of_3<T>(mut f: impl FnMut() -> T) -> (T, f64) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..3 {
        let t = Instant::now();
        out = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    (out.expect("three runs"), times[1])
}

const SAMPLES: usize = 100_000;

fn main() {
    let scenes = load_scenes();
    let mut goals = Goals::default();
    let (coding, streams) = compare_simplification(&scenes, &mut goals);
    compare_colour_simplification(&scenes);
    if std::env::var("PROXY_BENCH").as_deref() == Ok("simplify") {
        goals.print();
        return; // only section 1, for quick comparisons
    }
    compare_coding(&coding, &mut goals);
    let curves = measure_streams(&streams);
    let svg = stream_chart(&curves);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/proxy-stream.svg");
    match std::fs::write(&path, svg) {
        Ok(()) => println!("curves: {}", path.display()),
        Err(e) => println!("curves not written to {}: {e}", path.display()),
    }
    goals.print();
}

/// The gallery and the shared scenes (ONLY narrows them).
fn load_scenes() -> Vec<(String, Scene)> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let mut scenes: Vec<(String, Scene)> = vec![("gallery".into(), BuiltIn::Gallery.generate(1))];
    for file in ["stanford_bunny/bun_zipper.ply", "sponza_crytek/sponza_crytek.obj", "sponza_dabrovic/sponza.obj"] {
        let path = shared.join(file);
        if std::env::var("ONLY").is_ok_and(|o| !file.contains(&o)) {
            continue;
        }
        match load(&path, &LoadOptions::default()) {
            Ok(scene) => scenes.push((file.split('/').next().unwrap().to_string(), scene)),
            Err(e) => println!("skipped {}: {e}", path.display()),
        }
    }
    scenes
}

/// A welded mesh and what its errors are measured against.
struct Input {
    mesh: Mesh,
    diagonal: f32,
    tree: TriMesh,
    samples: Vec<Vec3>,
}

impl Input {
    fn new(mesh: Mesh, diagonal: f32) -> Input {
        Input { tree: tree(&mesh.positions, &mesh.triangles), samples: sample(&mesh.positions, &mesh.triangles), mesh, diagonal }
    }

    /// (Hausdorff, RMS) distances of a mesh from this one, in % of the diagonal.
    fn error(&self, positions: &[Vec3], triangles: &[[u32; 3]]) -> (f32, f32) {
        let (h, r) = distances(&self.tree, &self.samples, positions, triangles);
        (100.0 * h / self.diagonal, 100.0 * r / self.diagonal)
    }
}

/// A welded scene to stream: its name, mesh and box diagonal.
type Stream = (String, Mesh, f32);

/// Section 1: returns the meshes to code (section 2) and the welded scenes
/// to stream (section 3).
fn compare_simplification(scenes: &[(String, Scene)], goals: &mut Goals) -> (Vec<(String, Mesh)>, Vec<Stream>) {
    let (mut coding, mut streams) = (Vec::new(), Vec::new());
    println!("== simplification: ours | meshoptimizer (distances in % of the diagonal; Hausdorff = largest of {SAMPLES} samples each way; seconds: median of 3 runs)");
    #[rustfmt::skip]
    println!(
        "{:<16} {:>5} {:>8} | {:>8} {:>7} {:>9} {:>8} {:>4} | {:>8} {:>7} {:>9} {:>8} | {:>8} {:>9} {:>8}",
        "scene", "ratio", "input", "reached", "seconds", "Hausdorff", "RMS", "flip", "reached", "seconds", "Hausdorff", "RMS", "seams: reached", "Hausdorff", "RMS"
    );
    for (name, scene) in scenes {
        let t = Instant::now();
        let diagonal = scene.bounds().diagonal();
        let (mut mesh, stats) = weld_scene(scene, 1e-5 * diagonal);
        if std::env::var("ONE_GROUP").is_ok_and(|v| v == "1") {
            // As meshoptimizer sees it: no material borders to keep.
            mesh.groups.fill(0);
        }
        println!(
            "{name}: welded {} -> {} vertices, {} degenerate and {} repeated triangles dropped ({:.2} s)",
            stats.vertices_before,
            stats.vertices_after,
            stats.degenerate,
            stats.duplicates,
            t.elapsed().as_secs_f64()
        );
        coding.push((format!("{name} 100%"), mesh.clone()));
        streams.push((name.clone(), mesh.clone(), diagonal));
        let input = Input::new(mesh, diagonal);
        for ratio in [0.5, 0.1, 0.02, 0.01] {
            let ours = simplify_both(name, &input, ratio, goals);
            if ratio == 0.1 || ratio == 0.01 {
                coding.push((format!("{name} {:.0}%", ratio * 100.0), ours));
            }
        }
    }
    (coding, streams)
}

/// One row of section 1: ours and meshoptimizer's (plain and with seams) at
/// `ratio` of the triangles. Returns ours.
fn simplify_both(name: &str, input: &Input, ratio: f64, goals: &mut Goals) -> Mesh {
    let mesh = &input.mesh;
    let target = (mesh.triangles.len() as f64 * ratio) as usize;
    let (s, ours_seconds) = median_of_3(|| simplify(mesh, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY }));
    let normal = |p: [Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]);
    let flipped = (0..mesh.triangles.len())
        .filter(|&t| s.alive[t])
        .filter(|&t| {
            normal(mesh.triangles[t].map(|v| mesh.positions[v as usize])).dot(normal(s.mesh.triangles[t].map(|v| s.mesh.positions[v as usize]))) < 0.0
        })
        .count();
    let ours = s.compact();
    let (oh, or) = input.error(&ours.positions, &ours.triangles);

    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let meshopt = |indices: &[u32], positions: &[[f32; 3]]| -> Vec<[u32; 3]> {
        let simplified = meshopt::simplify_decoder(indices, positions, target * 3, f32::MAX, meshopt::SimplifyOptions::Prune, None);
        simplified.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
    };
    let (theirs, theirs_seconds) = median_of_3(|| meshopt(&indices, &positions));
    let (th, tr) = input.error(&mesh.positions, &theirs);
    let (seam_positions, seam_indices) = split_at_materials(mesh);
    let seamed = meshopt(&seam_indices, &seam_positions);
    let seam_points: Vec<Vec3> = seam_positions.iter().map(|&p| Vec3::from(p)).collect();
    let (sh, sr) = input.error(&seam_points, &seamed);
    println!(
        "{name:<16} {:>4.0}% {:>8} | {:>8} {ours_seconds:>7.3} {oh:>9.4} {or:>8.4} {flipped:>4} | {:>8} {theirs_seconds:>7.3} {th:>9.4} {tr:>8.4} | {:>14} {sh:>9.4} {sr:>8.4}",
        ratio * 100.0,
        mesh.triangles.len(),
        ours.triangles.len(),
        theirs.len(),
        seamed.len(),
    );
    goals.error.push((format!("{name} {:.0}%", ratio * 100.0), oh / th, or / tr));
    if name == "sponza_crytek" && ratio == 0.1 {
        goals.sponza_seconds = Some((ours.triangles.len(), mesh.triangles.len(), ours_seconds));
    }
    ours
}

/// The mesh with a vertex per (vertex, material) pair: material borders
/// become seams, which meshoptimizer keeps. (positions, indices)
fn split_at_materials(mesh: &Mesh) -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut at = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for &v in tri {
            indices.push(*at.entry((v, mesh.groups[t])).or_insert_with(|| {
                positions.push(mesh.positions[v as usize].to_array());
                positions.len() as u32 - 1
            }));
        }
    }
    (positions, indices)
}

/// Section 1b: colour-aware simplification against geometry alone.
fn compare_colour_simplification(scenes: &[(String, Scene)]) {
    let colour_weight = std::env::var("COLOUR_WEIGHT").ok().and_then(|w| w.parse().ok()).unwrap_or(COLOUR_WEIGHT);
    println!(
        "\n== colour-aware simplification (a full colour step counts as {} % of the diagonal): geometry only | with colour",
        100.0 * colour_weight
    );
    println!("   colours: each vertex's mean surface colour (display-encoded, 0-255), compared at {SAMPLES} input points with the simplified mesh's nearest point");
    println!(
        "{:<16} {:>5} | {:>7} {:>9} {:>8} {:>9} | {:>7} {:>9} {:>8} {:>9}",
        "scene", "ratio", "seconds", "Hausdorff", "RMS", "colour", "seconds", "Hausdorff", "RMS", "colour"
    );
    for (name, scene) in scenes {
        let diagonal = scene.bounds().diagonal();
        let (mesh, stats) = weld_scene(scene, 1e-5 * diagonal);
        let colours = vertex_albedo(scene, &mesh, &stats.sources);
        let used: Vec<Vec3> = mesh.triangles.iter().flatten().map(|&v| colours[v as usize]).collect();
        if used.iter().all(|c| c.abs_diff_eq(used[0], 1e-4)) {
            println!("{name:<16} one colour throughout: skipped");
            continue;
        }
        let input = Input::new(mesh, diagonal);
        for ratio in [0.1, 0.02] {
            let params = SimplifyParams { target_triangles: (input.mesh.triangles.len() as f64 * ratio) as usize, max_error: f32::INFINITY };
            let mut row = format!("{name:<16} {:>4.0}%", ratio * 100.0);
            for with in [false, true] {
                let (s, seconds) = median_of_3(|| {
                    simplify_with_colours(&input.mesh, with.then_some(Colours { values: &colours, weight: colour_weight * diagonal }), &params)
                });
                let (out, out_colours) = if with {
                    s.compact_with_colours()
                } else {
                    // Geometry only: the surviving vertices keep their colours.
                    let colourful = Simplified { colours: colours.clone(), ..s };
                    colourful.compact_with_colours()
                };
                let (h, r) = input.error(&out.positions, &out.triangles);
                let c = colour_rms(&input.mesh, &colours, &out, &out_colours);
                row += &format!(" | {seconds:>7.3} {h:>9.4} {r:>8.4} {:>9.2}", 255.0 * c);
            }
            println!("{row}");
        }
    }
}

/// Section 2: each level coded whole, ours against meshoptimizer's codecs and Draco.
fn compare_coding(coding: &[(String, Mesh)], goals: &mut Goals) {
    let wasm = wasm_module().map_err(|e| println!("wasm decode skipped: {e}")).ok();
    println!("\n== coding each level whole: meshcode (Edgebreaker, 14-bit parallelogram) | meshoptimizer codecs (16-bit) + gzip -9");
    println!(
        "{:<22} {:>8} {:>10} {:>9} {:>9} {:>8} {:>10} {:>9} | {:>9} {:>8} | {:>9} {:>8} {:>10}",
        "mesh", "tris", "conn b/t", "conn B", "bytes", "B/tri", "decode M/s", "wasm M/s", "meshopt B", "B/tri", "Draco B", "B/tri", "wasm M/s"
    );
    for (name, mesh) in coding {
        let encoded = meshcode::encode(&mesh.to_coded(), 14).expect("codes");
        let n = mesh.triangles.len() as f64;
        let decode_rate = n * median_rate(|| {
            std::hint::black_box(meshcode::decode(&encoded.bytes).expect("decodes"));
        }) / 1e6;
        let wasm_rate = wasm.as_ref().map_or(0.0, |module| {
            wasm_decode(module, &encoded.bytes).unwrap_or_else(|e| {
                println!("wasm decode skipped: {e}");
                0.0
            })
        });
        goals.decode.push((name.clone(), decode_rate));
        goals.connectivity.push((name.clone(), encoded.sizes.connectivity as f64 * 8.0 / n));
        let theirs = meshopt_coded(mesh);
        let (draco_bytes, draco_rate) = draco(mesh).unwrap_or_else(|e| {
            println!("Draco skipped: {e}");
            (0, 0.0)
        });
        println!(
            "{name:<22} {:>8} {:>10.3} {:>9} {:>9} {:>8.2} {decode_rate:>10.1} {wasm_rate:>9.1} | {:>9} {:>8.2} | {draco_bytes:>9} {:>8.2} {draco_rate:>10.2}",
            mesh.triangles.len(),
            encoded.sizes.connectivity as f64 * 8.0 / n,
            encoded.sizes.connectivity,
            encoded.bytes.len(),
            encoded.bytes.len() as f64 / n,
            theirs,
            theirs as f64 / n,
            draco_bytes as f64 / n
        );
    }
}

/// Section 3: the progressive stream of each scene; returns its curve.
fn measure_streams(streams: &[Stream]) -> Vec<Curve> {
    println!("\n== progressive stream: base 2 500 + vertex splits to 25 000 (14-bit, geometry only; error as in 1, in % of the diagonal)");
    println!("{:<16} {:>7} {:>9} {:>10} {:>9} {:>8}", "scene", "packet", "triangles", "bytes sum", "Hausdorff", "RMS");
    let mut curves = Vec::new();
    for (name, mesh, diagonal) in streams {
        let detail = if mesh.triangles.len() > 25_000 {
            simplify(mesh, &SimplifyParams { target_triangles: 25_000, max_error: f32::INFINITY }).compact()
        } else {
            mesh.clone()
        };
        if detail.triangles.len() <= 5_000 {
            println!("{name:<16} skipped: {} triangles, no stream", detail.triangles.len());
            continue;
        }
        curves.push(measure_stream(name, &Input::new(mesh.clone(), *diagonal), &detail));
    }
    curves
}

/// One scene's stream: (bytes received, RMS %) after the base and each
/// packet, and the level sent whole.
fn measure_stream(name: &str, input: &Input, detail: &Mesh) -> Curve {
    let s = simplify(detail, &SimplifyParams { target_triangles: 2_500, max_error: f32::INFINITY });
    let mut pm = Progressive::new(detail, &s);
    let base = meshcode::encode(&pm.base.to_coded(), 14).expect("codes");
    let decoded = meshcode::decode(&base.bytes).expect("decodes");
    pm.renumber_base(&base.order.vertices, &base.order.triangles);
    let packets = splits::encode(&decoded, &pm.refinements, 14, 750).expect("codes");
    let mut refiner = splits::Refiner::new(decoded.clone()).expect("a valid base");
    let mut bytes = base.bytes.len();
    let mut curve = Vec::new();
    for k in 0..=packets.len() {
        if k > 0 {
            refiner.apply_packet(&packets[k - 1].bytes).expect("applies");
            bytes += packets[k - 1].bytes.len();
        }
        let positions: Vec<Vec3> = refiner.mesh.positions.iter().map(|&p| Vec3::from(p)).collect();
        let (h, r) = input.error(&positions, &refiner.mesh.triangles);
        let label = if k == 0 { "base".to_string() } else { k.to_string() };
        println!("{name:<16} {label:>7} {:>9} {bytes:>10} {h:>9.4} {r:>8.4}", refiner.mesh.triangles.len());
        curve.push((bytes as f64, r as f64));
    }
    let split_bytes: usize = packets.iter().map(|p| p.bytes.len()).sum();
    let added = detail.triangles.len() - decoded.triangles.len();
    let whole = meshcode::encode(&detail.to_coded(), 14).expect("codes").bytes.len();
    let last_error = curve.last().map_or(0.0, |p| p.1);
    let rate = added as f64
        * median_rate(|| {
            let mut r = splits::Refiner::new(decoded.clone()).expect("a valid base");
            for p in &packets {
                r.apply_packet(&p.bytes).expect("applies");
            }
            std::hint::black_box(r);
        })
        / 1e6;
    println!(
        "{name:<16} splits {split_bytes} B for {added} triangles ({:.2} B/tri, {} packets); base + splits {} B vs the level whole {whole} B ({:.2}x); apply {rate:.1} M tri/s",
        split_bytes as f64 / added as f64,
        packets.len(),
        base.bytes.len() + split_bytes,
        (base.bytes.len() + split_bytes) as f64 / whole as f64
    );
    (name.to_string(), curve, (whole as f64, last_error))
}

/// The issue's figures with a goal, as this run measured them.
#[derive(Default)]
struct Goals {
    /// Per scene and ratio: our Hausdorff and RMS distances over meshoptimizer's.
    error: Vec<(String, f32, f32)>,
    /// The Crytek Sponza at 10 %: triangles reached, of, in seconds.
    sponza_seconds: Option<(usize, usize, f64)>,
    /// Per level coded whole: connectivity bits a triangle.
    connectivity: Vec<(String, f64)>,
    /// Per level coded whole: native decoding, M triangles a second.
    decode: Vec<(String, f64)>,
}

impl Goals {
    fn print(&self) {
        let verdict = |met: bool| if met { "met" } else { "NOT MET" };
        println!("\n== goals, against this run's figures");
        let worst = self.error.iter().flat_map(|(level, h, r)| [(level, "Hausdorff", *h), (level, "RMS", *r)]).max_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((level, what, ratio)) = worst {
            println!(
                "error within 10 % of meshoptimizer's at every ratio: the farthest is {level}'s {what}, {ratio:.3} times theirs: {}",
                verdict(ratio <= 1.1)
            );
        }
        match self.sponza_seconds {
            Some((reached, of, seconds)) => println!(
                "the Crytek Sponza to 25 k triangles in 0.5 s: {reached} of its {of} welded triangles (10 %) in {seconds:.3} s: {}",
                verdict(seconds <= 0.5)
            ),
            None => println!("the Crytek Sponza to 25 k triangles in 0.5 s: not measured (scene absent)"),
        }
        // (The Crytek Sponza's 1 % level is its base: 2.3 k triangles.)
        let judged: Vec<_> =
            self.connectivity.iter().filter(|(level, _)| level.starts_with("stanford_bunny") || level == "sponza_crytek 1%").collect();
        if let Some((level, bits)) = judged.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            println!("connectivity at most 2.0 bits a triangle on the bunny and the Crytek Sponza's base (its 1 % level): the most is {bits:.3} ({level}): {}", verdict(*bits <= 2.0));
        }
        if let Some((level, rate)) = self.decode.iter().min_by(|a, b| a.1.total_cmp(&b.1)) {
            println!(
                "decoding at least 20 M triangles a second natively, every level: the slowest is {level} at {rate:.1}: {}",
                verdict(*rate >= 20.0)
            );
        }
        println!(
            "(the sizes with baked colour, 150 KB at 25 k triangles and 25 KB for the base, are the bundle's: `render` logs them on its proxy line)"
        );
    }
}

fn tree(positions: &[Vec3], triangles: &[[u32; 3]]) -> TriMesh {
    TriMesh::new(positions.iter().map(|p| Point::new(p.x, p.y, p.z)).collect(), triangles.to_vec()).expect("a mesh with triangles")
}

/// Points spread uniformly over the surface (a fixed sequence: same points
/// every run).
fn sample(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    sample_places(positions, triangles)
        .into_iter()
        .map(|(k, u, v)| {
            let [a, b, c] = triangles[k].map(|i| positions[i as usize]);
            a + u * (b - a) + v * (c - a)
        })
        .collect()
}

/// [`sample`]'s points as (triangle, barycentric u, v).
fn sample_places(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<(usize, f32, f32)> {
    let areas: Vec<f64> = triangles
        .iter()
        .map(|t| {
            0.5 * (positions[t[1] as usize] - positions[t[0] as usize]).cross(positions[t[2] as usize] - positions[t[0] as usize]).length() as f64
        })
        .collect();
    let mut cumulative = Vec::with_capacity(areas.len());
    let mut total = 0.0;
    for a in &areas {
        total += a;
        cumulative.push(total);
    }
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..SAMPLES)
        .map(|_| {
            let k = cumulative.partition_point(|&c| c < uniform() * total).min(triangles.len() - 1);
            let (mut u, mut v) = (uniform() as f32, uniform() as f32);
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            (k, u, v)
        })
        .collect()
}

/// RMS difference between the colour interpolated over the input's
/// triangles at its sample points and the colour interpolated over the
/// simplified mesh at the nearest point on it.
fn colour_rms(input: &Mesh, input_colours: &[Vec3], out: &Mesh, out_colours: &[Vec3]) -> f32 {
    let other = tree(&out.positions, &out.triangles);
    let lerp = |c: &[Vec3], t: [u32; 3], u: f32, v: f32| c[t[0] as usize] * (1.0 - u - v) + c[t[1] as usize] * u + c[t[2] as usize] * v;
    let mut sum = 0.0f64;
    for (k, u, v) in sample_places(&input.positions, &input.triangles) {
        let t = input.triangles[k];
        let [a, b, c] = t.map(|i| input.positions[i as usize]);
        let p = a + u * (b - a) + v * (c - a);
        let (projection, feature) = other.project_local_point_and_get_feature(&Point::new(p.x, p.y, p.z));
        let parry3d::shape::FeatureId::Face(f) = feature else { continue };
        let o = out.triangles[f as usize % out.triangles.len()];
        let q = Vec3::new(projection.point.x, projection.point.y, projection.point.z);
        let [oa, ob, oc] = o.map(|i| out.positions[i as usize]);
        let (e1, e2, d) = (ob - oa, oc - oa, q - oa);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = (d11 * d22 - d12 * d12).max(1e-30);
        let (ou, ov) = ((d22 * d.dot(e1) - d12 * d.dot(e2)) / det, (d11 * d.dot(e2) - d12 * d.dot(e1)) / det);
        let difference = lerp(input_colours, t, u, v) - lerp(out_colours, o, ou.clamp(0.0, 1.0), ov.clamp(0.0, 1.0 - ou.clamp(0.0, 1.0)));
        sum += difference.length_squared() as f64 / 3.0;
    }
    (sum / SAMPLES as f64).sqrt() as f32
}

/// Symmetric (Hausdorff, RMS) distance between the input (its tree and
/// samples) and a simplified mesh over the positions given.
fn distances(input_tree: &TriMesh, input_samples: &[Vec3], positions: &[Vec3], triangles: &[[u32; 3]]) -> (f32, f32) {
    if triangles.is_empty() {
        return (f32::NAN, f32::NAN);
    }
    let other = tree(positions, triangles);
    let other_samples = sample(positions, triangles);
    let identity = Isometry::identity();
    let mut max = 0f32;
    let mut sum = 0f64;
    for (from, to) in [(input_samples, &other), (&other_samples[..], input_tree)] {
        for p in from {
            let d = to.distance_to_point(&identity, &Point::new(p.x, p.y, p.z), false);
            max = max.max(d);
            sum += (d as f64).powi(2);
        }
    }
    (max, (sum / (2 * SAMPLES) as f64).sqrt() as f32)
}

/// Bytes of meshoptimizer's index and vertex codecs (positions as 16-bit
/// integers in the box, padded to 8 bytes a vertex) after gzip -9.
fn meshopt_coded(mesh: &Mesh) -> usize {
    let (lo, hi) = mesh.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &p| (l.min(p), h.max(p)));
    let scale = (hi - lo).max(Vec3::splat(1e-20));
    let vertices: Vec<[u16; 4]> = mesh
        .positions
        .iter()
        .map(|&p| {
            let q = ((p - lo) / scale * 65535.0).round();
            [q.x as u16, q.y as u16, q.z as u16, 0]
        })
        .collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let index_bytes = meshopt::encode_index_buffer(&indices, vertices.len()).expect("index codec");
    let vertex_bytes = meshopt::encode_vertex_buffer(&vertices).expect("vertex codec");
    gzip(&index_bytes) + gzip(&vertex_bytes)
}

fn gzip(bytes: &[u8]) -> usize {
    let mut child = Command::new("gzip").arg("-9").stdin(Stdio::piped()).stdout(Stdio::piped()).spawn().expect("gzip runs");
    let mut stdin = child.stdin.take().unwrap();
    let data = bytes.to_vec();
    let writer = std::thread::spawn(move || stdin.write_all(&data));
    let out = child.wait_with_output().expect("gzip output");
    writer.join().unwrap().expect("gzip input");
    out.stdout.len()
}

/// Draco's size and decoding speed (M triangles a second) for `mesh`.
fn draco(mesh: &Mesh) -> Result<(usize, f64), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let prefix = root.join("../target/bench-node");
    let module = prefix.join("node_modules/draco3d");
    if !module.exists() {
        let status = Command::new("npm")
            .args(["install", "--silent", "--prefix"])
            .arg(&prefix)
            .arg("draco3d@1.5.7")
            .status()
            .map_err(|e| format!("npm: {e}"))?;
        if !status.success() {
            return Err("npm install draco3d failed".into());
        }
    }
    let mut data = Vec::new();
    data.extend_from_slice(&(mesh.positions.len() as u32).to_le_bytes());
    data.extend_from_slice(&(mesh.triangles.len() as u32).to_le_bytes());
    for p in &mesh.positions {
        for x in p.to_array() {
            data.extend_from_slice(&x.to_le_bytes());
        }
    }
    for v in mesh.triangles.iter().flatten() {
        data.extend_from_slice(&v.to_le_bytes());
    }
    let file = prefix.join("mesh.bin");
    std::fs::write(&file, data).map_err(|e| format!("{}: {e}", file.display()))?;
    let out =
        Command::new("node").arg(root.join("benches/draco.js")).arg(&file).env("DRACO3D", &module).output().map_err(|e| format!("node: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let field = |key: &str| text.lines().find_map(|l| l.strip_prefix(key)).map(str::trim).map(str::to_string);
    match (field("bytes "), field("decode ")) {
        (Some(b), Some(r)) => Ok((b.parse().map_err(|_| "bytes")?, r.parse().map_err(|_| "rate")?)),
        _ => Err(format!("node said: {} {}", text, String::from_utf8_lossy(&out.stderr))),
    }
}

/// Builds the decoder as a bare wasm module (see format/examples/wasm_decode.rs).
fn wasm_module() -> Result<std::path::PathBuf, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let status = Command::new(env!("CARGO"))
        .current_dir(&root)
        .args(["build", "--quiet", "--release", "-p", "exploremaps-format", "--example", "wasm_decode", "--target", "wasm32-unknown-unknown"])
        .status()
        .map_err(|e| format!("cargo: {e}"))?;
    if !status.success() {
        return Err("building the wasm decoder failed (is the wasm32 target installed?)".into());
    }
    Ok(root.join("target/wasm32-unknown-unknown/release/examples/wasm_decode.wasm"))
}

/// Our decoder's speed in Node's WebAssembly, M triangles a second.
fn wasm_decode(module: &Path, bytes: &[u8]) -> Result<f64, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = root.join("../target/bench-node/mesh.emmc");
    std::fs::create_dir_all(file.parent().unwrap()).map_err(|e| e.to_string())?;
    std::fs::write(&file, bytes).map_err(|e| format!("{}: {e}", file.display()))?;
    let out = Command::new("node").arg(root.join("benches/wasm_decode.js")).arg(module).arg(&file).output().map_err(|e| format!("node: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|l| l.strip_prefix("decode "))
        .and_then(|r| r.trim().parse().ok())
        .ok_or_else(|| format!("node said: {text} {}", String::from_utf8_lossy(&out.stderr)))
}

/// A scene's stream: its name, (bytes received, RMS error in % of the diagonal) per
/// packet, and the whole level's (bytes, error).
type Curve = (String, Vec<(f64, f64)>, (f64, f64));

/// Runs of `f` a second: the median over batches of at least 5 ms each,
/// for half a second of batches in all. The machine's speed drifts and
/// other work takes the core now and then; a mean over the whole half
/// second counts those pauses, the median of batches does not (the same
/// estimator as `median_rate.js` gives the Node scripts, so rates compare).
fn median_rate(mut f: impl FnMut()) -> f64 {
    let start = Instant::now();
    let mut rates = Vec::new();
    while rates.len() < 3 || start.elapsed().as_secs_f64() < 0.5 {
        let t = Instant::now();
        let mut runs = 0;
        while runs == 0 || t.elapsed().as_secs_f64() < 0.005 {
            f();
            runs += 1;
        }
        rates.push(runs as f64 / t.elapsed().as_secs_f64());
    }
    rates.sort_by(f64::total_cmp);
    rates[rates.len() / 2]
}

/// Bytes received against RMS error (log scale), a polyline a scene and a
/// dot for its level sent whole, as SVG with axes and a legend.
fn stream_chart(curves: &[Curve]) -> String {
    let (w, h, m) = (720.0, 440.0, 60.0);
    let points = curves.iter().flat_map(|c| c.1.iter().chain(std::iter::once(&c.2)));
    let max_x = points.clone().map(|p| p.0).fold(1.0, f64::max) / 1024.0;
    let (lo, hi) = points.map(|p| p.1.max(1e-4).log10()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| (a.min(y), b.max(y)));
    let (lo, hi) = (lo.floor(), hi.ceil().max(lo.floor() + 1.0));
    let px = |kb: f64| m + kb / max_x * (w - 2.0 * m);
    let py = |e: f64| h - m - (e.max(1e-4).log10() - lo) / (hi - lo) * (h - 1.5 * m);
    let mut svg = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12"><rect width="100%" height="100%" fill="white"/>"##
    );
    let mut decade = lo;
    while decade <= hi {
        let y = py(10f64.powf(decade));
        svg += &format!(
            r##"<line x1="{m}" x2="{}" y1="{y}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">{}</text>"##,
            w - m / 2.0,
            m - 6.0,
            y + 4.0,
            10f64.powf(decade)
        );
        decade += 1.0;
    }
    let step = [10.0, 20.0, 50.0, 100.0].into_iter().find(|s| max_x / s <= 8.0).unwrap_or(200.0);
    let mut kb = 0.0;
    while kb <= max_x {
        svg += &format!(
            r##"<line x1="{0}" x2="{0}" y1="{1}" y2="{2}" stroke="#ddd"/><text x="{0}" y="{3}" text-anchor="middle">{kb}</text>"##,
            px(kb),
            m / 2.0,
            h - m,
            h - m + 16.0
        );
        kb += step;
    }
    svg += &format!(
        r##"<text x="{}" y="{}" text-anchor="middle">kilobytes received (base, then each packet of splits)</text><text x="14" y="{}" transform="rotate(-90 14 {})" text-anchor="middle">RMS error, % of the diagonal</text>"##,
        w / 2.0,
        h - 12.0,
        h / 2.0,
        h / 2.0
    );
    let colours = ["#1b7837", "#c51b7d", "#2166ac", "#e08214", "#542788"];
    for (k, (name, curve, whole)) in curves.iter().enumerate() {
        let c = colours[k % colours.len()];
        let line: Vec<String> = curve.iter().map(|&(b, e)| format!("{:.1},{:.1}", px(b / 1024.0), py(e))).collect();
        svg += &format!(
            r##"<polyline fill="none" stroke="{c}" stroke-width="2" points="{}"/><circle cx="{:.1}" cy="{:.1}" r="5" fill="{c}"/>"##,
            line.join(" "),
            px(whole.0 / 1024.0),
            py(whole.1)
        );
        svg += &format!(r##"<text x="{}" y="{}" fill="{c}">{name}</text>"##, w - 260.0, m + 16.0 * k as f64);
    }
    svg += &format!(r##"<text x="{}" y="{}">dots: the 25,000-triangle level sent whole</text>"##, w - 260.0, m + 16.0 * curves.len() as f64);
    svg + "</svg>\n"
}
