//! The in-memory scene every stage works on: indexed triangles with one material
//! and one object per triangle, materials with decoded textures, lights, bounds,
//! up axis and unit scale.
//!
//! Invariants (upheld by loaders and generators, checked by [`Scene::validate`]):
//! every index is in range, every position is finite, no triangle is degenerate,
//! `normals`/`uvs` are empty or as long as `positions`, and the up axis is +Y
//! (loaders rotate other up axes into +Y so no stage has to care).

use glam::{Vec2, Vec3};

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| Aabb { min: b.min.min(p), max: b.max.max(p) })
    }
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }
}

/// How a material's alpha is used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Cut-out: texels with alpha below the cutoff are holes (foliage, fences).
    Mask {
        cutoff: f32,
    },
    /// Partly transparent.
    Blend,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA; multiplies the texture when there is one.
    pub base_color: [f32; 4],
    /// Index into [`Scene::textures`].
    pub base_color_texture: Option<usize>,
    pub alpha_mode: AlphaMode,
    /// Linear emitted radiance (already multiplied by any strength factor).
    pub emissive: Vec3,
}

impl Material {
    pub fn diffuse(name: &str, rgb: [f32; 3]) -> Material {
        Material {
            name: name.to_string(),
            base_color: [rgb[0], rgb[1], rgb[2], 1.0],
            base_color_texture: None,
            alpha_mode: AlphaMode::Opaque,
            emissive: Vec3::ZERO,
        }
    }
}

/// A decoded texture in sRGB-encoded RGBA8, as stored in image files.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// File path it came from, or a generator name.
    pub name: String,
    pub image: image::RgbaImage,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light; `intensity` is linear RGB radiant intensity (W/sr).
    Point { position: Vec3, intensity: Vec3 },
    /// Distant light; `direction` points from the scene toward the sun.
    Sun { direction: Vec3, irradiance: Vec3 },
}

/// Where [`Scene::metres_per_unit`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScaleSource {
    /// The scene file or generator states it (glTF is metres by definition).
    File,
    /// The user gave it on the command line.
    User,
    /// Guessed from the scene's size; see [`guess_metres_per_unit`].
    Guessed,
    /// Measured from the scene's own heights (rooms, furniture, slabs) with
    /// confidence, by the planner's scale stage.
    Measured,
}

/// What loading dropped or repaired, reported to the user.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneStats {
    pub dropped_degenerate: usize,
    pub dropped_non_finite: usize,
    pub missing_textures: usize,
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals; empty when the source had none.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates; empty when the source had none.
    pub uvs: Vec<Vec2>,
    /// Per-vertex linear RGB colours (scans and photogrammetry carry them),
    /// multiplying the material's colour; empty when the source had none.
    pub colours: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: index into `materials`.
    pub triangle_material: Vec<u32>,
    /// Per triangle: index into `objects`.
    pub triangle_object: Vec<u32>,
    pub objects: Vec<String>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    pub metres_per_unit: f32,
    pub scale_source: ScaleSource,
    pub stats: SceneStats,
}

impl Scene {
    /// A scene with no geometry, metres as its unit (as stated by its maker).
    pub fn empty(name: &str) -> Scene {
        Scene {
            name: name.to_string(),
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: Vec::new(),
            colours: Vec::new(),
            triangles: Vec::new(),
            triangle_material: Vec::new(),
            triangle_object: Vec::new(),
            objects: Vec::new(),
            materials: Vec::new(),
            textures: Vec::new(),
            lights: Vec::new(),
            metres_per_unit: 1.0,
            scale_source: ScaleSource::File,
            stats: SceneStats::default(),
        }
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    pub fn triangle_area(&self, t: usize) -> f32 {
        let [a, b, c] = self.triangle(t);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Drops triangles with out-of-range indices, non-finite corners or zero area,
    /// counting them in `stats`. Loaders and generators call this last.
    pub fn drop_bad_triangles(&mut self) {
        let (mut triangles, mut materials, mut objects) = (Vec::new(), Vec::new(), Vec::new());
        for ((&tri, &m), &o) in self.triangles.iter().zip(&self.triangle_material).zip(&self.triangle_object) {
            let corners = tri.map(|i| self.positions.get(i as usize).copied().unwrap_or(Vec3::NAN));
            let [a, b, c] = corners;
            if !corners.iter().all(|p| p.is_finite()) {
                self.stats.dropped_non_finite += 1;
            } else if (b - a).cross(c - a).length_squared() <= f32::MIN_POSITIVE {
                self.stats.dropped_degenerate += 1;
            } else {
                triangles.push(tri);
                materials.push(m);
                objects.push(o);
            }
        }
        self.triangles = triangles;
        self.triangle_material = materials;
        self.triangle_object = objects;
    }

    /// Checks the invariants in the module header; returns the first violation.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.positions.len();
        let t = self.triangles.len();
        if self.triangle_material.len() != t || self.triangle_object.len() != t {
            return Err("per-triangle material/object lists differ in length from the triangles".into());
        }
        if [self.normals.len(), self.uvs.len(), self.colours.len()].iter().any(|&k| k != 0 && k != n) {
            return Err("normals, uvs or colours are not one per vertex".into());
        }
        if let Some(i) = self.triangles.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(format!("vertex index {i} out of range ({n} vertices)"));
        }
        if let Some(&m) = self.triangle_material.iter().find(|&&m| m as usize >= self.materials.len()) {
            return Err(format!("material index {m} out of range"));
        }
        if let Some(&o) = self.triangle_object.iter().find(|&&o| o as usize >= self.objects.len()) {
            return Err(format!("object index {o} out of range"));
        }
        if let Some(m) = self.materials.iter().find(|m| m.base_color_texture.is_some_and(|i| i >= self.textures.len())) {
            return Err(format!("material {} names a missing texture", m.name));
        }
        Ok(())
    }

    pub fn total_area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| self.triangle_area(t) as f64).sum()
    }
}

/// A guess of metres per unit from the scene's size alone, for files that do not say.
/// Scenes over 2 km across are taken to be in centimetres or millimetres, everything
/// else in metres. The guess is always reported so the user can override it.
pub fn guess_metres_per_unit(bounds: &Aabb) -> f32 {
    let longest = bounds.extent().max_element();
    if longest > 20_000.0 {
        0.001
    } else if longest > 2_000.0 {
        0.01
    } else {
        1.0
    }
}
