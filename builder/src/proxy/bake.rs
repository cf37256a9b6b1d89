//! Appearance: a colour per proxy vertex, baked from the same lighting as the
//! panoramas (the renderer's lights, shadow rays and radiance cache, its
//! exposure and tone curve), so the overview looks like the places it joins.
//!
//! Each vertex takes the mean radiance of the scene's surface under it (rays
//! back along its normal, reaching the level's error plus the disc's radius
//! either side, as the disc leaves a curved or cornered surface) over a disc
//! of half its mean edge length: a coarse level's vertex stands for a wider
//! patch, so it averages one. Vertices that find no surface take the colour of
//! the nearest ones that did, spreading over the mesh's edges.
//! Colours are display sRGB, as the panoramas' pixels.

use super::Mesh;
use crate::tracer::Renderer;
use glam::Vec3;
use rayon::prelude::*;

/// Area-weighted vertex normals (zero for a vertex no triangle uses).
pub fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; mesh.positions.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        let face = (b - a).cross(c - a);
        for &v in t {
            n[v as usize] += face;
        }
    }
    n.into_iter().map(Vec3::normalize_or_zero).collect()
}

/// sRGB colour per vertex of `mesh`, whose surface lies within `error` of the
/// scene's. `level` separates the random streams of different levels.
pub fn bake(renderer: &Renderer, mesh: &Mesh, error: f32, samples: u32, level: u64) -> Vec<[u8; 3]> {
    let normals = vertex_normals(mesh);
    let (mut edge_sum, mut edge_count) = (vec![0.0f32; mesh.positions.len()], vec![0u32; mesh.positions.len()]);
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let length = mesh.positions[a].distance(mesh.positions[b]);
            for (x, y) in [(a, b), (b, a)] {
                edge_sum[x] += length;
                edge_count[x] += 1;
                neighbours[x].push(y as u32);
            }
        }
    }
    let margin = 2.0 * error + 1e-3 * mesh.diagonal();
    let radiance: Vec<Option<Vec3>> = (0..mesh.positions.len())
        .into_par_iter()
        .map(|v| {
            if edge_count[v] == 0 || normals[v] == Vec3::ZERO {
                return None;
            }
            let radius = 0.5 * edge_sum[v] / edge_count[v] as f32;
            renderer.surface_radiance(
                mesh.positions[v],
                normals[v],
                radius,
                margin + radius,
                samples,
                crate::seeds::image::bake(level as u32, v as u32),
            )
        })
        .collect();
    let filled = fill(&radiance, &neighbours);
    let image = renderer.to_image(filled.len() as u32, 1, &filled);
    image.pixels().map(|p| p.0).collect()
}

/// Gives every missing value the mean of its neighbours known one round
/// earlier, round after round (so it spreads from the nearest known ones);
/// parts with no value at all take the mean of every known one.
fn fill(values: &[Option<Vec3>], neighbours: &[Vec<u32>]) -> Vec<Vec3> {
    let mut known = values.to_vec();
    loop {
        let next: Vec<Option<Vec3>> = (0..known.len())
            .map(|v| {
                known[v].or_else(|| {
                    let around: Vec<Vec3> = neighbours[v].iter().filter_map(|&u| known[u as usize]).collect();
                    (!around.is_empty()).then(|| around.iter().sum::<Vec3>() / around.len() as f32)
                })
            })
            .collect();
        if next == known {
            break;
        }
        known = next;
    }
    let found: Vec<Vec3> = values.iter().flatten().copied().collect();
    let mean = found.iter().sum::<Vec3>() / found.len().max(1) as f32;
    known.into_iter().map(|k| k.unwrap_or(mean)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raycast::{Ray, RayScene};
    use crate::tracer::{Quality, Settings};

    #[test]
    fn baked_colours_match_the_panorama_where_both_see_the_floor() {
        // The sunroom's floor: a sunlit patch under the window, shade elsewhere.
        let scene = exploremaps_scenes::BuiltIn::Sunroom.generate(1);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let eye = Vec3::new(3.0, 1.6, 2.5);
        let renderer = Renderer::new(&scene, &rays, &[eye, Vec3::new(1.5, 1.6, 1.5), Vec3::new(4.5, 1.6, 3.5)], Settings::new(Quality::Preview, 1));
        // A stand-in 1 mm above the floor, a vertex every 0.2 m.
        let (nx, nz) = (29u32, 24u32);
        let mut mesh = Mesh::default();
        for j in 0..=nz {
            for i in 0..=nx {
                mesh.positions.push(Vec3::new(0.1 + 5.8 * i as f32 / nx as f32, 0.001, 0.1 + 4.8 * j as f32 / nz as f32));
            }
        }
        let at = |i: u32, j: u32| j * (nx + 1) + i;
        for j in 0..nz {
            for i in 0..nx {
                mesh.triangles.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
                mesh.triangles.push([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
            }
        }
        mesh.groups = vec![0; mesh.triangles.len()];
        assert!(vertex_normals(&mesh).iter().all(|n| n.y > 0.99), "the stand-in faces up");
        let colours = bake(&renderer, &mesh, 0.0, 16, 0);
        // The panorama from the eye, as `preview` renders it.
        let width = 1024;
        let pano = renderer.to_image(width, width / 2, &renderer.equirect(&renderer.settings.panorama, eye, width, 0).color);
        let luma = |c: [u8; 3]| (0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32) / 255.0;
        let mut differences = Vec::new();
        let mut baked = Vec::new();
        for (v, &p) in mesh.positions.iter().enumerate() {
            if !renderer.tracer.visible(&Ray::segment(eye, p + Vec3::Y * 0.01)) {
                continue; // behind the block
            }
            let (yaw, pitch) = exploremaps_format::yaw_pitch((p - eye).normalize().to_array());
            let x = ((yaw.rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU) * width as f32) as u32 % width;
            let y = (((std::f32::consts::FRAC_PI_2 - pitch) / std::f32::consts::PI) * (width / 2) as f32).min((width / 2 - 1) as f32) as u32;
            differences.push((luma(colours[v]) - luma(pano.get_pixel(x, y).0)).abs());
            baked.push(luma(colours[v]));
        }
        assert!(differences.len() > 500, "{} floor vertices seen", differences.len());
        differences.sort_by(f32::total_cmp);
        let median = differences[differences.len() / 2];
        let p90 = differences[differences.len() * 9 / 10];
        let (lo, hi) = baked.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &l| (lo.min(l), hi.max(l)));
        println!("floor: baked luma {lo:.2}..{hi:.2}; |baked - panorama| median {median:.3}, 90th percentile {p90:.3}");
        assert!(hi - lo > 0.3, "the sun patch and the shade differ: {lo:.2}..{hi:.2}");
        assert!(median < 0.03 && p90 < 0.1, "median {median:.3}, 90th percentile {p90:.3}");
    }

    #[test]
    fn missing_colours_spread_from_the_nearest_known_ones() {
        // A chain 0-1-2-3-4 known at both ends, and a lone vertex 5.
        let (a, b) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0));
        let values = [Some(a), None, None, None, Some(b), None];
        let neighbours = vec![vec![1], vec![0, 2], vec![1, 3], vec![2, 4], vec![3], vec![]];
        let filled = fill(&values, &neighbours);
        assert_eq!(filled[1], a, "next to a known end");
        assert_eq!(filled[3], b);
        assert_eq!(filled[2], (a + b) / 2.0, "halfway: both sides at once");
        assert_eq!(filled[5], (a + b) / 2.0, "a part with nothing known: the mean of all");
        assert_eq!((filled[0], filled[4]), (a, b), "known values stay");
    }
}
