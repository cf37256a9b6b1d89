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
//! switch: that also holds around non-manifold vertices. The coder makes it
//! compact.

use super::simplify::{Simplified, Step};
use super::Mesh;
use glam::Vec3;

/// One refinement of the stream.
#[derive(Clone, Debug, PartialEq)]
pub enum Refinement {
    /// `vertex` moves back to `position`, a vertex appears at `new_position`,
    /// the triangles `moved` have their `vertex` corner changed to the new
    /// vertex, and `added` triangles appear (corners in stream numbering).
    Split { vertex: u32, position: Vec3, new_position: Vec3, moved: Vec<u32>, added: Vec<[u32; 3]> },
    /// A separate part: vertices and triangles appended.
    Part { positions: Vec<Vec3>, triangles: Vec<[u32; 3]> },
}

/// A base mesh and its refinements, coarse to fine.
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
                        position: c.kept_was,
                        new_position: positions[c.removed as usize],
                        moved: c.moved.iter().map(|&t| triangle_id[t as usize]).collect(),
                        added,
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
                    let positions = vertex_order[first..].iter().map(|&v| positions[v as usize]).collect();
                    refinements.push(Refinement::Part { positions, triangles });
                }
            }
        }
        Progressive { base, refinements, vertex_order, triangle_order }
    }

    /// The mesh after the first `count` refinements (groups are the base's,
    /// then the input's through `triangle_order` when `groups` is given).
    pub fn level(&self, count: usize) -> Mesh {
        let mut m = self.base.clone();
        for r in &self.refinements[..count.min(self.refinements.len())] {
            match r {
                Refinement::Split { vertex, position, new_position, moved, added } => {
                    m.positions[*vertex as usize] = *position;
                    let new = m.positions.len() as u32;
                    m.positions.push(*new_position);
                    for &t in moved {
                        for c in &mut m.triangles[t as usize] {
                            if *c == *vertex {
                                *c = new;
                            }
                        }
                    }
                    m.triangles.extend(added);
                }
                Refinement::Part { positions, triangles } => {
                    m.positions.extend(positions);
                    m.triangles.extend(triangles);
                }
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::super::simplify::{simplify, SimplifyParams};
    use super::*;

    /// The full stream rebuilds the input triangle for triangle, and every
    /// level in between has as many triangles as the simplification had there.
    fn check_round_trip(input: &Mesh, target: usize) {
        let s = simplify(input, &SimplifyParams { target_triangles: target, max_error: f32::INFINITY });
        let pm = Progressive::new(input, &s);
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
    }
}
