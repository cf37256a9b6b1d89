//! Proxy: a light 3D stand-in of the scene for the viewer's overview and
//! point-to-go, built with the classic methods for putting heavy meshes on
//! phones.
//!
//! - `weld`: a scene's triangle soup as one indexed mesh (positions within a
//!   tolerance merged, degenerate and repeated triangles dropped).
//! - `simplify`: quadric error metric edge collapses (Garland and Heckbert 1997),
//!   recording every collapse; the surface's colour (albedo) counts too.
//! - `progressive`: the collapses as vertex splits (Hoppe 1996), so a base
//!   mesh and an ordered stream of splits rebuild every level exactly.
//! - `bake`: colour per vertex from the render's lighting, so the proxy looks
//!   like the panoramas.
//! - `seen`: per triangle, the probe that sees it best (point-to-go).
//! - Coding (Edgebreaker connectivity, predicted positions) lives in the format
//!   crate (`exploremaps_format::meshcode`), so the viewer decodes it in wasm.
//!
//! The stage ([`levels`], then [`bake::bake`] per level): the welded scene
//! simplified to a detail level (25 k triangles by default) and from that to
//! a base level (2.5 k); `render` writes both into the bundle, coded, and the
//! detail level as a GLB too.

pub mod bake;
pub mod progressive;
pub mod seen;
pub mod simplify;
pub mod weld;

use exploremaps_scenes::Scene;
use glam::Vec3;
use simplify::{simplify_with_colours, Colours, SimplifyParams};

/// The distance, as a share of the scene's diagonal, that a full step of
/// colour (black to white) counts as when simplifying. The proxy bench's
/// sweep: at 0.25 % the Crytek Sponza at 10 % of its triangles has 41 % less
/// colour error for 10 % more RMS distance; at 1 %, 70 % more distance.
pub const COLOUR_WEIGHT: f32 = 0.0025;

/// How the bundle's proxy is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProxyParams {
    pub detail_triangles: usize,
    pub base_triangles: usize,
    /// Quantization of coded positions, bits per axis of the proxy's box.
    pub bits: u32,
    /// Lighting samples per vertex when baking colour.
    pub bake_samples: u32,
}

impl Default for ProxyParams {
    fn default() -> Self {
        ProxyParams { detail_triangles: 25_000, base_triangles: 2_500, bits: 14, bake_samples: 16 }
    }
}

/// One level of the proxy: its mesh, and the largest distance from the scene
/// its simplification allowed (scene units, summed over the levels above it).
pub struct Level {
    pub mesh: Mesh,
    pub error: f32,
    /// For a level simplified from the one before it: the vertex splits
    /// that rebuild that one from this (whose base is `mesh`).
    pub refines: Option<progressive::Progressive>,
}

/// The proxy's levels, finest first: the welded scene simplified to
/// `detail_triangles` (or kept whole when smaller), then to `base_triangles`
/// (left out when the detail level is that small already).
pub fn levels(scene: &Scene, params: &ProxyParams) -> Vec<Level> {
    let (welded, stats) = weld::weld_scene(scene, 1e-5 * scene.bounds().diagonal());
    let mut colours = vertex_albedo(scene, &welded, &stats.sources);
    let weight = COLOUR_WEIGHT * scene.bounds().diagonal();
    let whole = Level { mesh: welded, error: 0.0, refines: None };
    let detail = if whole.mesh.triangles.len() > params.detail_triangles {
        let s = simplify_with_colours(
            &whole.mesh,
            Some(Colours { values: &colours, weight }),
            &SimplifyParams { target_triangles: params.detail_triangles, max_error: f32::INFINITY },
        );
        let (mesh, detail_colours) = s.compact_with_colours();
        colours = detail_colours;
        Level { mesh, error: s.error, refines: None }
    } else {
        whole
    };
    let mut out = Vec::new();
    if detail.mesh.triangles.len() > 2 * params.base_triangles {
        let s = simplify_with_colours(
            &detail.mesh,
            Some(Colours { values: &colours, weight }),
            &SimplifyParams { target_triangles: params.base_triangles, max_error: f32::INFINITY },
        );
        let stream = progressive::Progressive::new(&detail.mesh, &s);
        let base = Level { mesh: stream.base.clone(), error: detail.error + s.error, refines: Some(stream) };
        out.push(detail);
        out.push(base);
    } else {
        out.push(detail);
    }
    out
}

/// Per vertex of `mesh` (welded from `scene`, `sources` its triangles'
/// input triangles): the mean surface colour (base colour with textures,
/// sRGB-encoded so differences count as the eye sees them) of its
/// triangles, each sampled at three points and weighted by area. What the
/// simplifier keeps; the proxy's shown colours are baked later, with light.
pub fn vertex_albedo(scene: &Scene, mesh: &Mesh, sources: &[u32]) -> Vec<Vec3> {
    let materials = crate::tracer::Materials::new(scene);
    let (mut sum, mut weight) = (vec![Vec3::ZERO; mesh.positions.len()], vec![0.0f32; mesh.positions.len()]);
    for (tri, &source) in mesh.triangles.iter().zip(sources) {
        let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
        let area = 0.5 * (b - a).cross(c - a).length();
        let (near, far) = (2.0 / 3.0, 1.0 / 6.0);
        let mean = [(far, far), (near, far), (far, near)].iter().map(|&(u, v)| materials.albedo(source, u, v)).sum::<Vec3>() / 3.0;
        for &v in tri {
            sum[v as usize] += area * mean;
            weight[v as usize] += area;
        }
    }
    let display = |c: Vec3| Vec3::from(c.to_array().map(|x| crate::colour::linear_to_srgb(x) as f32 / 255.0));
    sum.iter().zip(&weight).map(|(s, &w)| if w > 0.0 { display(*s / w) } else { Vec3::ZERO }).collect()
}

/// Splits `mesh`'s triangles into spatial chunks of at most `max` triangles
/// each (the longest side of their centres' box halved at the median, again
/// and again), so a viewer decodes one small chunk between two frames.
/// Returns each chunk's triangle indices.
pub fn chunks(mesh: &Mesh, max: usize) -> Vec<Vec<usize>> {
    let centre = |t: usize| mesh.triangles[t].iter().map(|&v| mesh.positions[v as usize]).sum::<Vec3>() / 3.0;
    let mut out = Vec::new();
    let mut todo = vec![(0..mesh.triangles.len()).collect::<Vec<usize>>()];
    while let Some(mut part) = todo.pop() {
        if part.len() <= max.max(1) {
            out.push(part);
            continue;
        }
        let (lo, hi) = part.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &t| (lo.min(centre(t)), hi.max(centre(t))));
        let axis = (hi - lo).max_position();
        part.sort_by(|&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b)));
        let second = part.split_off(part.len() / 2);
        // Second half pushed first, so chunks come out in sorted order.
        todo.push(second);
        todo.push(part);
    }
    out
}

/// An indexed triangle mesh with a group (material) per triangle.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle; edges between groups are kept like boundaries.
    pub groups: Vec<u32>,
}

impl Mesh {
    /// Diagonal of the bounding box (0 for an empty mesh).
    /// The mesh as the coder takes it.
    pub fn to_coded(&self) -> exploremaps_format::meshcode::MeshData {
        exploremaps_format::meshcode::MeshData {
            positions: self.positions.iter().map(|p| p.to_array()).collect(),
            triangles: self.triangles.clone(),
            groups: self.groups.clone(),
            colours: Vec::new(),
        }
    }

    /// The triangles `triangles` as a mesh of their own, and per new vertex
    /// the index of the vertex it was (for per-vertex attributes).
    pub fn subset(&self, triangles: &[usize]) -> (Mesh, Vec<u32>) {
        let mut remap = vec![u32::MAX; self.positions.len()];
        let (mut out, mut was) = (Mesh::default(), Vec::new());
        for &t in triangles {
            out.triangles.push(self.triangles[t].map(|v| {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = out.positions.len() as u32;
                    out.positions.push(self.positions[v as usize]);
                    was.push(v);
                }
                remap[v as usize]
            }));
            out.groups.push(self.groups[t]);
        }
        (out, was)
    }

    pub fn diagonal(&self) -> f32 {
        let (lo, hi) = self.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        if lo.x > hi.x {
            0.0
        } else {
            (hi - lo).length()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::simplify::{simplify, SimplifyParams};
    use super::weld::weld_scene;
    use exploremaps_format::meshcode::{decode, encode};
    use exploremaps_scenes::BuiltIn;

    /// Codes `mesh` and checks every triangle comes back, over the same
    /// (quantized) positions and in the same group. Returns connectivity bits
    /// a triangle.
    pub(crate) fn coded_round_trip(name: &str, mesh: &super::Mesh) -> f64 {
        let data = mesh.to_coded();
        let encoded = encode(&data, 14).unwrap_or_else(|e| panic!("{name}: {e}"));
        let back = decode(&encoded.bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(back.triangles.len(), mesh.triangles.len(), "{name}");
        let tolerance = mesh.diagonal() / (1 << 14) as f32;
        for (k, t) in back.triangles.iter().enumerate() {
            let input = encoded.order.triangles[k] as usize;
            assert_eq!(back.groups[k], mesh.groups[input], "{name}: triangle {input}");
            let want = mesh.triangles[input].map(|v| mesh.positions[v as usize]);
            let got = t.map(|v| glam::Vec3::from(back.positions[v as usize]));
            // Same corners in the same cyclic order.
            let r = (0..3).find(|&r| (0..3).all(|i| got[(i + r) % 3].distance(want[i]) <= tolerance));
            assert!(r.is_some(), "{name}: triangle {input} is {got:?}, was {want:?}");
        }
        encoded.sizes.connectivity as f64 * 8.0 / mesh.triangles.len().max(1) as f64
    }

    #[test]
    fn chunks_cover_every_triangle_once_within_their_size_and_keep_attributes() {
        let scene = BuiltIn::parse("gallery").unwrap().generate(1);
        let (mesh, _) = weld_scene(&scene, 1e-5 * scene.bounds().diagonal());
        let chunks = super::chunks(&mesh, 7_000);
        assert!(chunks.len() >= mesh.triangles.len() / 7_000 && chunks.iter().all(|c| c.len() <= 7_000 && !c.is_empty()));
        let mut seen = vec![0u8; mesh.triangles.len()];
        for c in &chunks {
            for &t in c {
                seen[t] += 1;
            }
            // A chunk is a mesh of its own whose triangles are the originals.
            let (part, was) = mesh.subset(c);
            for (k, &t) in c.iter().enumerate() {
                assert_eq!(part.triangles[k].map(|v| was[v as usize]), mesh.triangles[t]);
                assert_eq!(part.groups[k], mesh.groups[t]);
            }
        }
        assert!(seen.iter().all(|&n| n == 1), "each triangle in exactly one chunk");
        // Without a limit, one chunk.
        assert_eq!(super::chunks(&mesh, usize::MAX).len(), 1);
    }

    #[test]
    fn every_built_in_scene_codes_and_decodes() {
        for spec in ["gallery", "maze:4", "pillars", "island", "house", "cathedral", "sunroom"] {
            let scene = BuiltIn::parse(spec).unwrap().generate(1);
            let (mesh, _) = weld_scene(&scene, 1e-5 * scene.bounds().diagonal());
            coded_round_trip(spec, &mesh);
            let level = simplify(&mesh, &SimplifyParams { target_triangles: mesh.triangles.len() / 10, max_error: f32::INFINITY });
            coded_round_trip(&format!("{spec} at 10 %"), &level.compact());
        }
    }

    #[test]
    #[ignore]
    fn every_shared_scene_codes_and_decodes() {
        // Slow: the shared third-party scenes (`cargo test -- --ignored`).
        for file in [
            "stanford_bunny/bun_zipper.ply",
            "sponza_crytek/sponza_crytek.obj",
            "sponza_dabrovic/sponza.obj",
            "grey_white_room/grey_white_room.obj",
            "cornell_box/CornellBox-Original.obj",
            "wooden_staircase/wooden_staircase.obj",
            "dream_apartment/dream_apartment.glb",
        ] {
            let Some(path) = crate::testing::shared_scene(file) else { continue };
            let scene = crate::scene_io::load(&path, &crate::scene_io::LoadOptions::default()).unwrap();
            let (mesh, _) = weld_scene(&scene, 1e-5 * scene.bounds().diagonal());
            let bits = coded_round_trip(file, &mesh);
            eprintln!("{file}: {} triangles, {bits:.2} connectivity bits a triangle", mesh.triangles.len());
        }
    }
}
