//! Weld: a scene's triangles as one indexed mesh that simplification can walk.
//!
//! Scene files split vertices at every texture or normal seam and often store
//! each object, or each triangle, with its own copies, so neighbouring
//! triangles rarely share indices. Positions are merged when they fall in the
//! same cell of a grid `tolerance` wide, or in a neighbouring cell within
//! `tolerance` of the cell's first vertex (so two points a hair apart across a
//! cell wall still merge). Triangles left with a repeated corner, and repeats
//! of a triangle already kept (the same three vertices in any order, as
//! double-sided copies are), are dropped.

use super::Mesh;
use exploremaps_scenes::Scene;
use glam::Vec3;
use rustc_hash::FxHashMap;

/// What welding did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WeldStats {
    pub vertices_before: usize,
    pub vertices_after: usize,
    pub degenerate: usize,
    pub duplicates: usize,
    /// Per welded triangle: the input triangle it came from.
    pub sources: Vec<u32>,
}

/// The scene's triangles welded at `tolerance` (scene units), groups from materials.
pub fn weld_scene(scene: &Scene, tolerance: f32) -> (Mesh, WeldStats) {
    weld(&scene.positions, &scene.triangles, &scene.triangle_material, tolerance)
}

/// Welds an indexed soup; `groups` per triangle.
pub fn weld(positions: &[Vec3], triangles: &[[u32; 3]], groups: &[u32], tolerance: f32) -> (Mesh, WeldStats) {
    let tolerance = tolerance.max(f32::MIN_POSITIVE);
    let cell = |p: Vec3| (p / tolerance).floor().as_ivec3();
    let mut cells: FxHashMap<glam::IVec3, u32> = FxHashMap::default();
    let mut out = Mesh::default();
    let mut remap = vec![u32::MAX; positions.len()];
    for (i, &p) in positions.iter().enumerate() {
        if !p.is_finite() {
            continue;
        }
        let c = cell(p);
        let mut found = cells.get(&c).copied();
        if found.is_none() {
            'near: for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        if let Some(&j) = cells.get(&(c + glam::IVec3::new(dx, dy, dz))) {
                            if out.positions[j as usize].distance(p) <= tolerance {
                                found = Some(j);
                                break 'near;
                            }
                        }
                    }
                }
            }
        }
        remap[i] = found.unwrap_or_else(|| {
            let j = out.positions.len() as u32;
            out.positions.push(p);
            cells.insert(c, j);
            j
        });
    }
    let mut stats = WeldStats { vertices_before: positions.len(), vertices_after: out.positions.len(), ..Default::default() };
    let mut seen: FxHashMap<[u32; 3], ()> = FxHashMap::default();
    for (t, tri) in triangles.iter().enumerate() {
        let v = tri.map(|i| remap.get(i as usize).copied().unwrap_or(u32::MAX));
        if v.contains(&u32::MAX) || v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
            stats.degenerate += 1;
            continue;
        }
        let mut key = v;
        key.sort_unstable();
        if seen.insert(key, ()).is_some() {
            stats.duplicates += 1;
            continue;
        }
        out.triangles.push(v);
        out.groups.push(groups.get(t).copied().unwrap_or(0));
        stats.sources.push(t as u32);
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_seams_and_near_points_across_a_cell_wall_merge() {
        // Two triangles of a unit square, each with its own corners, one copy a hair off.
        let t = 1e-3;
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0 + 0.2 * t, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            // A point just across a cell wall from (1, 0, 0).
            Vec3::new(1.0 - 0.1 * t, 0.0, 0.0),
        ];
        let triangles = vec![[0, 1, 2], [3, 4, 5], [6, 2, 0], [2, 5, 4]];
        let (mesh, stats) = weld(&positions, &triangles, &[0, 0, 0, 0], t);
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!((stats.degenerate, stats.duplicates), (1, 1), "{stats:?}");
        assert_eq!(stats.sources, vec![0, 1]);
    }
}
