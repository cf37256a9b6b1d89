//! A small mesh builder for the procedural scenes: boxes, walls with door
//! openings, cylinders and displaced spheres, each tagged with a material and an
//! object. Boxes get planar texture coordinates in metres / `tile_m`, so textures
//! keep their size whatever the box.

use crate::scene::{Light, Material, Scene, Texture};
use glam::{Vec2, Vec3};
use std::ops::Range;

/// Where a wall stands: on the line z = `line` from x = `from` to `to`
/// (along x), or on x = `line` from z = `from` to `to` (along z).
#[derive(Clone, Copy, Debug)]
pub struct Wall {
    pub along_x: bool,
    pub line: f32,
    pub from: f32,
    pub to: f32,
}

impl Wall {
    pub fn new(along_x: bool, line: f32, from: f32, to: f32) -> Wall {
        Wall { along_x, line, from, to }
    }

    pub fn along_x(z: f32, from: f32, to: f32) -> Wall {
        Wall::new(true, z, from, to)
    }

    pub fn along_z(x: f32, from: f32, to: f32) -> Wall {
        Wall::new(false, x, from, to)
    }
}

/// An opening in a wall: centre and width along it, sill and head heights above its floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Opening {
    pub centre: f32,
    pub width: f32,
    pub sill: f32,
    pub head: f32,
}

pub struct MeshBuilder {
    scene: Scene,
    material: u32,
    object: u32,
    /// Size in metres of one texture repeat.
    pub tile_m: f32,
}

impl MeshBuilder {
    pub fn new(name: &str) -> MeshBuilder {
        MeshBuilder { scene: Scene::empty(name), material: 0, object: 0, tile_m: 2.0 }
    }

    pub fn add_texture(&mut self, texture: Texture) -> usize {
        self.scene.textures.push(texture);
        self.scene.textures.len() - 1
    }

    pub fn add_material(&mut self, material: Material) -> u32 {
        self.scene.materials.push(material);
        (self.scene.materials.len() - 1) as u32
    }

    pub fn add_light(&mut self, light: Light) {
        self.scene.lights.push(light);
    }

    pub fn set_material(&mut self, material: u32) {
        self.material = material;
    }

    /// Starts a new named object; later triangles belong to it.
    pub fn begin_object(&mut self, name: &str) {
        self.scene.objects.push(name.to_string());
        self.object = (self.scene.objects.len() - 1) as u32;
    }

    fn vertex(&mut self, p: Vec3, n: Vec3, uv: Vec2) -> u32 {
        self.scene.positions.push(p);
        self.scene.normals.push(n);
        self.scene.uvs.push(uv);
        (self.scene.positions.len() - 1) as u32
    }

    fn triangle(&mut self, tri: [u32; 3]) {
        if self.scene.objects.is_empty() {
            self.begin_object("default");
        }
        self.scene.triangles.push(tri);
        self.scene.triangle_material.push(self.material);
        self.scene.triangle_object.push(self.object);
    }

    /// A planar quad a, b, c, d (counter-clockwise seen from the side `normal` points to).
    pub fn quad(&mut self, corners: [Vec3; 4]) {
        let [a, b, c, d] = corners;
        let normal = (b - a).cross(c - a).normalize_or_zero();
        // Planar mapping on the two axes the normal is least aligned with.
        let (u_axis, v_axis) = if normal.y.abs() > 0.5 {
            (Vec3::X, Vec3::Z)
        } else if normal.x.abs() > 0.5 {
            (Vec3::Z, Vec3::Y)
        } else {
            (Vec3::X, Vec3::Y)
        };
        let uv = |p: Vec3| Vec2::new(p.dot(u_axis), p.dot(v_axis)) / self.tile_m;
        let (ua, ub, uc, ud) = (uv(a), uv(b), uv(c), uv(d));
        let i = [self.vertex(a, normal, ua), self.vertex(b, normal, ub), self.vertex(c, normal, uc), self.vertex(d, normal, ud)];
        self.triangle([i[0], i[1], i[2]]);
        self.triangle([i[0], i[2], i[3]]);
    }

    /// A closed axis-aligned box with outward faces.
    pub fn cuboid(&mut self, min: Vec3, max: Vec3) {
        let p = |x: bool, y: bool, z: bool| Vec3::new(if x { max.x } else { min.x }, if y { max.y } else { min.y }, if z { max.z } else { min.z });
        let (f, t) = (false, true);
        self.quad([p(f, f, t), p(t, f, t), p(t, t, t), p(f, t, t)]); // +z
        self.quad([p(t, f, f), p(f, f, f), p(f, t, f), p(t, t, f)]); // -z
        self.quad([p(t, f, t), p(t, f, f), p(t, t, f), p(t, t, t)]); // +x
        self.quad([p(f, f, f), p(f, f, t), p(f, t, t), p(f, t, f)]); // -x
        self.quad([p(f, t, t), p(t, t, t), p(t, t, f), p(f, t, f)]); // +y
        self.quad([p(f, f, f), p(t, f, f), p(t, f, t), p(f, f, t)]); // -y
    }

    /// Boxes from `y0` to `y1` covering the union of the rectangles
    /// `[x0, x1] × [z0, z1]` once. Overlapping boxes would leave coincident,
    /// same-facing faces where they overlap; these meet only side to side.
    pub fn slabs(&mut self, rects: &[[f32; 4]], y0: f32, y1: f32) {
        let cuts = |lo: usize, hi: usize| {
            let mut v: Vec<f32> = rects.iter().flat_map(|r| [r[lo], r[hi]]).collect();
            v.sort_by(f32::total_cmp);
            v.dedup();
            v
        };
        let (xs, zs) = (cuts(0, 2), cuts(1, 3));
        let covered = |x: f32, z: f32| rects.iter().any(|r| (r[0]..=r[2]).contains(&x) && (r[1]..=r[3]).contains(&z));
        // A band between consecutive z cuts at a time, its covered cells merged into runs.
        for z in zs.windows(2) {
            let zc = 0.5 * (z[0] + z[1]);
            let mut run: Option<f32> = None;
            for x in xs.windows(2) {
                match (covered(0.5 * (x[0] + x[1]), zc), run) {
                    (true, None) => run = Some(x[0]),
                    (false, Some(x0)) => {
                        self.cuboid(Vec3::new(x0, y0, z[0]), Vec3::new(x[0], y1, z[1]));
                        run = None;
                    }
                    _ => {}
                }
            }
            if let Some(x0) = run {
                self.cuboid(Vec3::new(x0, y0, z[0]), Vec3::new(xs[xs.len() - 1], y1, z[1]));
            }
        }
    }

    /// A closed prism: a convex polygon in the x-y plane (counter-clockwise seen
    /// from +z) extruded from `z0` to `z1`, with outward faces.
    pub fn prism_z(&mut self, profile: &[Vec2], z0: f32, z1: f32) {
        self.prism(profile, |p, z| Vec3::new(p.x, p.y, z), Vec3::Z, z0, z1);
    }

    /// [`MeshBuilder::prism_z`] along x: a convex polygon of (y, z) points
    /// (counter-clockwise seen from +x) extruded from `x0` to `x1`.
    pub fn prism_x(&mut self, profile: &[Vec2], x0: f32, x1: f32) {
        self.prism(profile, |p, x| Vec3::new(x, p.x, p.y), Vec3::X, x0, x1);
    }

    /// A prism along `axis`; `at(p, t)` places profile point `p` at `t` along it,
    /// the profile's two axes and `axis` making a right-handed frame.
    fn prism(&mut self, profile: &[Vec2], at: impl Fn(Vec2, f32) -> Vec3, axis: Vec3, t0: f32, t1: f32) {
        for k in 0..profile.len() {
            let (a, b) = (profile[k], profile[(k + 1) % profile.len()]);
            self.quad([at(a, t0), at(b, t0), at(b, t1), at(a, t1)]);
        }
        for (t, n) in [(t1, axis), (t0, -axis)] {
            let first = self.scene.positions.len() as u32;
            for &p in profile {
                self.vertex(at(p, t), n, p / self.tile_m);
            }
            for k in 1..profile.len() as u32 - 1 {
                // Counter-clockwise seen from +axis for that cap, reversed for the other.
                if t == t1 {
                    self.triangle([first, first + k, first + k + 1])
                } else {
                    self.triangle([first, first + k + 1, first + k])
                }
            }
        }
    }

    /// A wall of `thickness` centred on `wall`'s line, over `height` (from
    /// the floor to its top), with door openings given as (centre, width,
    /// height) along the wall.
    pub fn wall(&mut self, wall: Wall, height: Range<f32>, thickness: f32, doors: &[(f32, f32, f32)]) {
        let openings: Vec<Opening> = doors.iter().map(|&(centre, width, height)| Opening { centre, width, sill: 0.0, head: height }).collect();
        self.wall_with_openings(wall, height, thickness, &openings);
    }

    /// A wall as [`MeshBuilder::wall`], with openings from `sill` to `head` above
    /// the floor (a door has sill 0; a window's sill is above the floor).
    pub fn wall_with_openings(&mut self, wall: Wall, height: Range<f32>, thickness: f32, openings: &[Opening]) {
        let Wall { along_x, line, from: a, to: b } = wall;
        let Range { start: floor_y, end: top_y } = height;
        let h = 0.5 * thickness;
        let block = |s0: f32, s1: f32, y0: f32, y1: f32| {
            if along_x {
                (Vec3::new(s0, y0, line - h), Vec3::new(s1, y1, line + h))
            } else {
                (Vec3::new(line - h, y0, s0), Vec3::new(line + h, y1, s1))
            }
        };
        // Ends reach almost, not quite, to the far side of a wall they meet: an
        // end flush with it would be a coincident, same-facing face, which
        // renderers resolve differently (Cycles shades such strips black).
        let reach = 0.99 * h;
        let mut start = a.min(b) - reach;
        let end = a.max(b) + reach;
        let mut openings = openings.to_vec();
        openings.sort_by(|x, y| x.centre.total_cmp(&y.centre));
        for o in openings {
            let (d0, d1) = (o.centre - 0.5 * o.width, o.centre + 0.5 * o.width);
            if d0 > start {
                let (lo, hi) = block(start, d0, floor_y, top_y);
                self.cuboid(lo, hi);
            }
            if o.sill > 0.0 {
                let (lo, hi) = block(d0, d1, floor_y, floor_y + o.sill);
                self.cuboid(lo, hi);
            }
            if floor_y + o.head < top_y {
                let (lo, hi) = block(d0, d1, floor_y + o.head, top_y);
                self.cuboid(lo, hi);
            }
            start = d1;
        }
        if end > start {
            let (lo, hi) = block(start, end, floor_y, top_y);
            self.cuboid(lo, hi);
        }
    }

    /// A height field over [x0, x1] × [z0, z1], `cells` quads a side, facing up.
    pub fn terrain(&mut self, x0: f32, z0: f32, x1: f32, z1: f32, cells: usize, height: impl Fn(f32, f32) -> f32) {
        let at = |i: usize, j: usize| {
            let (x, z) = (x0 + (x1 - x0) * i as f32 / cells as f32, z0 + (z1 - z0) * j as f32 / cells as f32);
            Vec3::new(x, height(x, z), z)
        };
        for j in 0..cells {
            for i in 0..cells {
                self.quad([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j), at(i, j)]);
            }
        }
    }

    /// A closed vertical cylinder (capped), `segments` around.
    pub fn cylinder(&mut self, base: Vec3, radius: f32, height: f32, segments: u32) {
        let ring = |k: u32| {
            let a = std::f32::consts::TAU * k as f32 / segments as f32;
            Vec3::new(a.cos(), 0.0, -a.sin())
        };
        let top = base + Vec3::Y * height;
        for k in 0..segments {
            let (d0, d1) = (ring(k), ring(k + 1));
            self.quad([base + d0 * radius, base + d1 * radius, top + d1 * radius, top + d0 * radius]);
            // Caps as thin triangles fanned from the axis (emitted as degenerate-free quads' halves).
            let n_up = Vec3::Y;
            let c = self.vertex(top, n_up, Vec2::ZERO);
            let p0 = self.vertex(top + d0 * radius, n_up, Vec2::ZERO);
            let p1 = self.vertex(top + d1 * radius, n_up, Vec2::ZERO);
            self.triangle([c, p0, p1]);
            let c = self.vertex(base, -n_up, Vec2::ZERO);
            let p0 = self.vertex(base + d0 * radius, -n_up, Vec2::ZERO);
            let p1 = self.vertex(base + d1 * radius, -n_up, Vec2::ZERO);
            self.triangle([c, p1, p0]);
        }
    }

    /// A closed, smooth-shaded sphere subdivided `levels` times from an octahedron
    /// (8·4^levels triangles), with its radius modulated by `displace(direction)`.
    pub fn blob(&mut self, centre: Vec3, radii: Vec3, levels: u32, displace: impl Fn(Vec3) -> f32) {
        let mut verts: Vec<Vec3> = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let mut faces: Vec<[u32; 3]> = vec![[0, 2, 4], [4, 2, 1], [1, 2, 5], [5, 2, 0], [4, 3, 0], [1, 3, 4], [5, 3, 1], [0, 3, 5]];
        for _ in 0..levels {
            let mut midpoint = std::collections::HashMap::new();
            let mut mid = |a: u32, b: u32, verts: &mut Vec<Vec3>| -> u32 {
                *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    verts.push((verts[a as usize] + verts[b as usize]).normalize());
                    (verts.len() - 1) as u32
                })
            };
            let mut next = Vec::with_capacity(faces.len() * 4);
            for [a, b, c] in faces {
                let (ab, bc, ca) = (mid(a, b, &mut verts), mid(b, c, &mut verts), mid(c, a, &mut verts));
                next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            faces = next;
        }
        let base = self.scene.positions.len() as u32;
        for d in &verts {
            let p = centre + *d * radii * displace(*d);
            let uv = Vec2::new(0.5 + d.z.atan2(d.x) / std::f32::consts::TAU, 0.5 - d.y.asin() / std::f32::consts::PI);
            // Normal from the undisplaced ellipsoid: smooth enough for shading.
            self.vertex(p, (*d / radii).normalize(), uv);
        }
        for [a, b, c] in faces {
            self.triangle([base + a, base + b, base + c]);
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.scene.triangles.len()
    }

    pub fn finish(mut self) -> Scene {
        self.scene.drop_bad_triangles();
        self.scene
    }
}
