//! Progressive mesh: a base mesh and an ordered stream of vertex splits that
//! rebuilds every level of a simplification exactly (Hoppe, "Progressive
//! Meshes", SIGGRAPH 1996).
//!
//! Each split undoes one collapse: an existing vertex goes back to where it
//! was, a new vertex appears, some of the vertex's triangles switch corners to
//! the new vertex, and the triangles the collapse deleted come back. Parts that
//! simplification removed whole come back as one refinement each. Vertices and
//! triangles are numbered in stream order (the base's first, then each
//! refinement's new ones), so a viewer appends and never renumbers; the
//! orders back to the input's are kept for attributes and for checking.
//!
//! Unlike Hoppe's compact records (a split names two neighbours and the
//! triangles between them switch), a split here lists the triangles that
//! switch: that also holds around non-manifold vertices. The format crate
//! codes it compactly and applies it (`exploremaps_format::splits`), here
//! as in the viewer.

use super::simplify::{Simplified, Step};
use super::Mesh;
use exploremaps_format::meshcode::MeshData;
use exploremaps_format::splits::{Refinement, Refiner};
use glam::Vec3;

/// A base mesh and its refinements, coarse to fine (colours left black
/// until [`Progressive::colour`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Progressive {
    pub base: Mesh,
    pub refinements: Vec<Refinement>,
    /// Per stream vertex: its input index.
    pub vertex_order: Vec<u32>,
    /// Per stream triangle: its input index.
    pub triangle_order: Vec<u32>,
}

impl Progressive {
    /// The stream that rebuilds `input` from `simplified` (made from it).
    pub fn new(input: &Mesh, simplified: &Simplified) -> Progressive {
        let mut vertex_id = vec![u32::MAX; input.positions.len()];
        let mut triangle_id = vec![u32::MAX; input.triangles.len()];
        let mut vertex_order = Vec::new();
        let mut triangle_order = Vec::new();
        fn number_vertex(v: u32, ids: &mut [u32], order: &mut Vec<u32>) -> u32 {
            if ids[v as usize] == u32::MAX {
                ids[v as usize] = order.len() as u32;
                order.push(v);
            }
            ids[v as usize]
        }
        let mut base = Mesh::default();
        for (t, tri) in simplified.mesh.triangles.iter().enumerate() {
            if simplified.alive[t] {
                triangle_id[t] = triangle_order.len() as u32;
                triangle_order.push(t as u32);
                base.triangles.push(tri.map(|v| number_vertex(v, &mut vertex_id, &mut vertex_order)));
                base.groups.push(simplified.mesh.groups[t]);
            }
        }
        base.positions = vertex_order.iter().map(|&v| simplified.mesh.positions[v as usize]).collect();
        let group = |t: u32| simplified.mesh.groups[t as usize];
        let mut refinements = Vec::with_capacity(simplified.steps.len());
        // Positions of the kept vertices as the stream goes, in input numbering.
        let mut positions = simplified.mesh.positions.clone();
        for step in simplified.steps.iter().rev() {
            match step {
                Step::Collapse(c) => {
                    let vertex = vertex_id[c.kept as usize];
                    let new = number_vertex(c.removed, &mut vertex_id, &mut vertex_order);
                    debug_assert_eq!(new as usize, vertex_order.len() - 1);
                    positions[c.kept as usize] = c.kept_was;
                    let mut added = Vec::new();
                    for &(t, tri) in &c.deleted {
                        triangle_id[t as usize] = triangle_order.len() as u32;
                        triangle_order.push(t);
                        added.push(tri.map(|v| vertex_id[v as usize]));
                    }
                    refinements.push(Refinement::Split {
                        vertex,
                        position: c.kept_was.to_array(),
                        new_position: positions[c.removed as usize].to_array(),
                        colour: [0; 3],
                        new_colour: [0; 3],
                        moved: sorted(c.moved.iter().map(|&t| triangle_id[t as usize]).collect()),
                        added,
                        groups: c.deleted.iter().map(|&(t, _)| group(t)).collect(),
                    });
                }
                Step::Prune(tris) => {
                    let first = vertex_order.len();
                    let mut triangles = Vec::new();
                    for &(t, tri) in tris {
                        triangle_id[t as usize] = triangle_order.len() as u32;
                        triangle_order.push(t);
                        triangles.push(tri.map(|v| number_vertex(v, &mut vertex_id, &mut vertex_order)));
                    }
                    let positions = vertex_order[first..].iter().map(|&v| positions[v as usize].to_array()).collect();
                    let groups = tris.iter().map(|&(t, _)| group(t)).collect();
                    refinements.push(Refinement::Part { positions, colours: Vec::new(), triangles, groups });
                }
            }
        }
        Progressive { base, refinements, vertex_order, triangle_order }
    }

    /// The mesh after the first `count` refinements.
    pub fn level(&self, count: usize) -> Mesh {
        let mut r = Refiner::new(self.base.to_coded()).expect("a simplified mesh is a valid base");
        for x in &self.refinements[..count.min(self.refinements.len())] {
            r.apply(x).expect("the stream fits its base");
        }
        let MeshData { positions, triangles, groups, .. } = r.mesh;
        Mesh { positions: positions.into_iter().map(Vec3::from).collect(), triangles, groups }
    }

    /// Renumbers the base as a decoder of it numbers it: its decoded vertex
    /// `k` is base vertex `vertices[k]`, its decoded triangle `k` base
    /// triangle `triangles[k]` (both permutations). Refinements follow.
    pub fn renumber_base(&mut self, vertices: &[u32], triangles: &[u32]) {
        let (nv, nt) = (self.base.positions.len(), self.base.triangles.len());
        assert!(vertices.len() == nv && triangles.len() == nt, "a permutation of the base");
        let invert = |order: &[u32]| {
            let mut inverse = vec![0u32; order.len()];
            for (k, &x) in order.iter().enumerate() {
                inverse[x as usize] = k as u32;
            }
            inverse
        };
        let (to_v, to_t) = (invert(vertices), invert(triangles));
        let v = |x: u32| if (x as usize) < nv { to_v[x as usize] } else { x };
        let t = |x: u32| if (x as usize) < nt { to_t[x as usize] } else { x };
        let base = &self.base;
        self.base = Mesh {
            positions: vertices.iter().map(|&x| base.positions[x as usize]).collect(),
            triangles: triangles.iter().map(|&x| base.triangles[x as usize].map(v)).collect(),
            groups: triangles.iter().map(|&x| base.groups[x as usize]).collect(),
        };
        let (old_v, old_t) = (self.vertex_order.clone(), self.triangle_order.clone());
        for (k, &x) in vertices.iter().enumerate() {
            self.vertex_order[k] = old_v[x as usize];
        }
        for (k, &x) in triangles.iter().enumerate() {
            self.triangle_order[k] = old_t[x as usize];
        }
        for r in &mut self.refinements {
            match r {
                Refinement::Split { vertex, moved, added, .. } => {
                    *vertex = v(*vertex);
                    *moved = sorted(moved.iter().map(|&x| t(x)).collect());
                    added.iter_mut().for_each(|tri| *tri = tri.map(v));
                }
                Refinement::Part { triangles, .. } => triangles.iter_mut().for_each(|tri| *tri = tri.map(v)),
            }
        }
    }

    /// Gives the returning triangles new groups: `groups` per input triangle.
    pub fn regroup(&mut self, groups: &[u32]) {
        let mut next = self.base.triangles.len();
        for r in &mut self.refinements {
            let (Refinement::Split { groups: g, .. } | Refinement::Part { groups: g, .. }) = r;
            for x in g.iter_mut() {
                *x = groups[self.triangle_order[next] as usize];
                next += 1;
            }
        }
    }

    /// Gives the refinements colours: `colours` per input vertex.
    pub fn colour(&mut self, colours: &[[u8; 3]]) {
        let of = |stream: usize| colours[self.vertex_order[stream] as usize];
        let mut next = self.base.positions.len();
        for r in &mut self.refinements {
            match r {
                Refinement::Split { vertex, colour, new_colour, .. } => {
                    (*colour, *new_colour) = (of(*vertex as usize), of(next));
                    next += 1;
                }
                Refinement::Part { positions, colours, .. } => {
                    *colours = (next..next + positions.len()).map(of).collect();
                    next += positions.len();
                }
            }
        }
    }
}

fn sorted(mut v: Vec<u32>) -> Vec<u32> {
    v.sort_unstable();
    v
}

#[cfg(test)]
mod tests {
    use super::super::simplify::{simplify, SimplifyParams};
    use super::*;

    /// The full stream rebuilds the input triangle for triangle, and every
    /// level in between has as many triangles as the simplification had there.
    fn check_round_trip(input: &Mesh, target: usize) {
        check_round_trip_of(input, &simplify(input, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY }));
    }

    fn check_round_trip_of(input: &Mesh, s: &Simplified) {
        let pm = Progressive::new(input, s);
        assert_eq!(pm.base.triangles.len(), s.triangles().len());
        let full = pm.level(usize::MAX);
        assert_eq!(full.triangles.len(), input.triangles.len());
        for (stream, &t) in pm.triangle_order.iter().enumerate() {
            let rebuilt = full.triangles[stream].map(|v| pm.vertex_order[v as usize]);
            assert_eq!(rebuilt, input.triangles[t as usize], "triangle {t}");
        }
        for (stream, &v) in pm.vertex_order.iter().enumerate() {
            assert_eq!(full.positions[stream], input.positions[v as usize], "vertex {v}");
        }
        let mut count = pm.base.triangles.len();
        for (k, r) in pm.refinements.iter().enumerate() {
            count += match r {
                Refinement::Split { added, .. } => added.len(),
                Refinement::Part { triangles, .. } => triangles.len(),
            };
            assert_eq!(pm.level(k + 1).triangles.len(), count);
        }
    }

    #[test]
    fn base_and_all_splits_rebuild_the_input_exactly() {
        let plane = super::super::simplify::tests::plane(6);
        check_round_trip(&plane, 2);
        let mut bumpy = super::super::simplify::tests::subdivide(&plane);
        for (i, p) in bumpy.positions.iter_mut().enumerate() {
            p.z = 0.2 * ((i * 7919) % 11) as f32 / 11.0;
        }
        // A loose triangle, pruned and restored as a part.
        let b = bumpy.positions.len() as u32;
        bumpy.positions.extend([Vec3::new(9.0, 0.0, 0.0), Vec3::new(9.01, 0.0, 0.0), Vec3::new(9.0, 0.01, 0.0)]);
        bumpy.triangles.push([b, b + 1, b + 2]);
        bumpy.groups.push(0);
        check_round_trip(&bumpy, 20);
        // Simplified in two halves at once (as large meshes are).
        let large = super::super::simplify::tests::bumpy();
        check_round_trip_of(&large, &super::super::simplify::tests::in_halves(&large, 300));
        // Collapses that delete three triangles (along a non-manifold edge).
        check_round_trip(&super::super::simplify::tests::fin(), 6);
    }

    /// A stream coded as the bundle codes it: the base through Edgebreaker
    /// and back, the splits in packets of about `packet` triangles. Returns
    /// the decoded base, the renumbered stream, its packets and per input
    /// vertex a colour.
    fn coded(input: &Mesh, target: usize, packet: usize) -> (MeshData, Progressive, Vec<exploremaps_format::splits::Packet>, Vec<[u8; 3]>) {
        use exploremaps_format::meshcode;
        let s = simplify(input, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY });
        let mut pm = Progressive::new(input, &s);
        let colours: Vec<[u8; 3]> = (0..input.positions.len()).map(|i| [(i * 37) as u8, (i * 11) as u8, 200]).collect();
        let mut base = pm.base.to_coded();
        base.colours = pm.vertex_order[..base.positions.len()].iter().map(|&v| colours[v as usize]).collect();
        let encoded = meshcode::encode(&base, 14).unwrap();
        let decoded = meshcode::decode(&encoded.bytes).unwrap();
        pm.renumber_base(&encoded.order.vertices, &encoded.order.triangles);
        pm.colour(&colours);
        let packets = exploremaps_format::splits::encode(&decoded, &pm.refinements, 14, packet).unwrap();
        (decoded, pm, packets, colours)
    }

    fn bumpy() -> Mesh {
        let plane = super::super::simplify::tests::plane(12);
        let mut bumpy = super::super::simplify::tests::subdivide(&plane);
        for (i, p) in bumpy.positions.iter_mut().enumerate() {
            p.z = 0.2 * ((i * 7919) % 11) as f32 / 11.0;
        }
        for (t, g) in bumpy.groups.iter_mut().enumerate() {
            *g = (t / 100) as u32 % 3;
        }
        let b = bumpy.positions.len() as u32;
        bumpy.positions.extend([Vec3::new(9.0, 0.0, 0.0), Vec3::new(9.01, 0.0, 0.0), Vec3::new(9.0, 0.01, 0.0)]);
        bumpy.triangles.push([b, b + 1, b + 2]);
        bumpy.groups.push(2);
        bumpy
    }

    /// Base + every packet, decoded as the viewer decodes them, is the input:
    /// each triangle the same corners in the same turn (positions within the
    /// grid's step), its group, and each vertex its colour.
    #[test]
    fn coded_packets_rebuild_the_input() {
        // (The fin's splits along its shared edge bring back three triangles.)
        for (input, target, packet) in [(bumpy(), 40, 150), (super::super::simplify::tests::fin(), 6, 30)] {
            packets_rebuild(&input, target, packet);
        }
    }

    fn packets_rebuild(input: &Mesh, target: usize, packet: usize) {
        let (decoded, pm, packets, colours) = coded(input, target, packet);
        assert!(packets.len() >= 3, "{} packets", packets.len());
        // Packets in one file come apart again; a damaged one is named.
        let file: Vec<u8> = packets.iter().flat_map(|p| p.bytes.iter().copied()).collect();
        let parts = exploremaps_format::splits::packets(&file).unwrap();
        assert!(parts.iter().zip(&packets).all(|(a, b)| *a == b.bytes.as_slice()) && parts.len() == packets.len());
        let mut bad = file.clone();
        bad[packets[0].bytes.len() + 7] ^= 4;
        assert!(exploremaps_format::splits::packets(&bad).is_err());
        let mut refiner = exploremaps_format::splits::Refiner::new(decoded).unwrap();
        for p in &packets {
            refiner.apply_packet(&p.bytes).unwrap();
            assert_eq!(refiner.mesh.triangles.len() as u64, p.triangles);
        }
        let m = &refiner.mesh;
        assert_eq!(m.triangles.len(), input.triangles.len());
        let step = input.diagonal() / (1 << 14) as f32;
        for (k, &v) in pm.vertex_order.iter().enumerate() {
            assert!(Vec3::from(m.positions[k]).distance(input.positions[v as usize]) <= step, "vertex {v}");
            assert_eq!(m.colours[k], colours[v as usize], "vertex {v}");
        }
        for (k, &t) in pm.triangle_order.iter().enumerate() {
            let got = m.triangles[k].map(|v| pm.vertex_order[v as usize]);
            let want = input.triangles[t as usize];
            assert!((0..3).any(|r| (0..3).all(|i| got[(i + r) % 3] == want[i])), "triangle {t}: {got:?} for {want:?}");
            assert_eq!(m.groups[k], input.groups[t as usize], "triangle {t}");
        }
    }

    /// Packets out of order, truncated, damaged or lying (checksum redone)
    /// are errors or a valid mesh, never a panic.
    #[test]
    fn bad_packets_are_errors() {
        let (decoded, _, packets, _) = coded(&bumpy(), 40, 150);
        let fresh = || exploremaps_format::splits::Refiner::new(decoded.clone()).unwrap();
        let err = fresh().apply_packet(&packets[1].bytes).unwrap_err().to_string();
        assert!(err.contains("out of order"), "{err}");
        let bytes = &packets[0].bytes;
        for n in 0..bytes.len() {
            assert!(fresh().apply_packet(&bytes[..n]).is_err(), "truncated to {n}");
        }
        let body = bytes.len() - 4;
        let mut state = 99u64;
        for trial in 0..4000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let mut bad = bytes[..body].to_vec();
            let i = (state >> 33) as usize % body;
            bad[i] = (state >> 20) as u8;
            if trial % 2 == 0 && bad[i] != bytes[i] {
                assert!(fresh().apply_packet(&[bad.as_slice(), &bytes[body..]].concat()).is_err(), "byte {i} changed, checksum kept");
            }
            let crc = crc32fast::hash(&bad);
            bad.extend_from_slice(&crc.to_le_bytes());
            let mut r = fresh();
            let _ = r.apply_packet(&bad);
            let m = &r.mesh;
            assert!(m.triangles.iter().flatten().all(|&v| (v as usize) < m.positions.len()));
            assert!(m.groups.len() == m.triangles.len() && m.colours.len() == m.positions.len());
        }
    }
}
