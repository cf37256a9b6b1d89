//! Proxy: a light 3D stand-in of the scene for the viewer's overview and
//! point-to-go, built with the classic methods for putting heavy meshes on
//! phones.
//!
//! - `weld`: a scene's triangle soup as one indexed mesh (positions within a
//!   tolerance merged, degenerate and repeated triangles dropped).
//! - `simplify`: quadric error metric edge collapses (Garland and Heckbert 1997),
//!   recording every collapse.
//! - `progressive`: the collapses as vertex splits (Hoppe 1996), so a base
//!   mesh and an ordered stream of splits rebuild every level exactly.

pub mod progressive;
pub mod simplify;
pub mod weld;

use glam::Vec3;

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
    pub fn diagonal(&self) -> f32 {
        let (lo, hi) = self.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        if lo.x > hi.x {
            0.0
        } else {
            (hi - lo).length()
        }
    }
}
