//! What a ray sees where it hits: materials (base colour with textures,
//! cut-outs, emission) and the lights (sun, sky, point lights, and the
//! defaults for scenes that have none).

use crate::colour::{linear_to_srgb, srgb_table};
use crate::raycast::{Hit, Ray, RayScene};
use exploremaps_scenes::{AlphaMode, Light, Material, Scene};
use glam::{Vec2, Vec3};

/// The sun used when an open scene has no lights: south-east and high
/// (65° up, so it reaches into courtyards).
pub const DEFAULT_SUN: Light = Light::Sun { direction: Vec3::new(0.2988, 0.9063, 0.2988), irradiance: Vec3::new(3.4, 3.2, 2.9) };

/// Angular radius of the sun (the real one's), for soft shadow edges.
pub const SUN_RADIUS: f32 = 0.0047;

/// A shading point: where a ray hit, oriented toward the ray.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    pub position: Vec3,
    /// Shading normal, on the side the ray came from.
    pub normal: Vec3,
    /// Geometric normal, on the side the ray came from (offsets new rays).
    pub geometric: Vec3,
    /// Linear diffuse albedo.
    pub albedo: Vec3,
    /// Linear emitted radiance.
    pub emission: Vec3,
}

impl Surface {
    /// A point just off the surface on the visible side, to start new rays from.
    pub fn lifted(&self) -> Vec3 {
        self.position + self.geometric * offset(self.position)
    }
}

/// Self-intersection offset, growing with the coordinates' magnitude.
pub fn offset(p: Vec3) -> f32 {
    1e-4 * (1.0 + p.abs().max_element())
}

/// Bilinear filtering of a tiled sRGB texture: linear RGB and alpha.
fn bilinear(img: &image::RgbaImage, uv: Vec2) -> (Vec3, f32) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let table = srgb_table();
    // The texel grid's coordinates, shifted to be positive: uv tiles, and
    // truncation floors a positive number without a libm call.
    // (Casts saturate, so huge or infinite coordinates give some texel, not a panic.)
    let tiled = |t: f32, size: usize| {
        let t = (t - (t as i64) as f32 + 2.0) * size as f32 - 0.5;
        let whole = t as usize;
        // A mask where it can (a division is a tenth of a lookup).
        let i = if size.is_power_of_two() { whole & (size - 1) } else { whole % size };
        (i, if i + 1 == size { 0 } else { i + 1 }, (t - whole as f32).clamp(0.0, 1.0))
    };
    let (x0, x1, fx) = tiled(uv.x, w);
    let (y0, y1, fy) = tiled(uv.y, h);
    let raw = img.as_raw();
    let texel = |x: usize, y: usize| {
        let p = &raw[4 * (y * w + x)..][..4];
        (Vec3::new(table[p[0] as usize], table[p[1] as usize], table[p[2] as usize]), p[3] as f32 / 255.0)
    };
    let mix = |a: (Vec3, f32), b: (Vec3, f32), f: f32| (a.0 * (1.0 - f) + b.0 * f, a.1 * (1.0 - f) + b.1 * f);
    let top = mix(texel(x0, y0), texel(x1, y0), fx);
    let bottom = mix(texel(x0, y1), texel(x1, y1), fx);
    mix(top, bottom, fy)
}

/// The next level of a texture's mip pyramid: each texel the mean of 2 × 2,
/// in linear light (averaging sRGB bytes would darken every mix of light
/// and dark), for a cut-out's texture weighted by alpha (its holes show no
/// colour, and often hold black; an opaque material's alpha may mean
/// anything), wrapping at the edges as the texture tiles. (The `image`
/// crate's resize filters do none of these.)
fn half(img: &image::RgbaImage, cutout: bool) -> image::RgbaImage {
    let (w, h) = (img.width(), img.height());
    let table = srgb_table();
    image::RgbaImage::from_fn((w / 2).max(1), (h / 2).max(1), |x, y| {
        let (mut weighted, mut plain, mut weights, mut alpha) = (Vec3::ZERO, Vec3::ZERO, 0.0, 0u32);
        for (sx, sy) in [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1), (2 * x + 1, 2 * y + 1)] {
            let p = img.get_pixel(sx % w, sy % h);
            let c = Vec3::new(table[p[0] as usize], table[p[1] as usize], table[p[2] as usize]);
            let weight = if cutout { p[3] as f32 } else { 1.0 };
            weighted += c * weight;
            plain += c;
            weights += weight;
            alpha += p[3] as u32;
        }
        let c = if weights > 0.0 { weighted / weights } else { plain * 0.25 };
        image::Rgba([linear_to_srgb(c.x), linear_to_srgb(c.y), linear_to_srgb(c.z), ((alpha + 2) / 4) as u8])
    })
}

/// log2 of a positive, normal float within 0.01 (the exponent, and a
/// parabola through the mantissa's ends and middle): enough to choose a mip
/// level, at a fraction of libm's cost, once a pixel.
fn log2_approx(x: f32) -> f32 {
    let bits = x.to_bits();
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000) - 1.0;
    ((bits >> 23) & 0xff) as f32 - 127.0 + m * (1.3466 - 0.3466 * m)
}

/// The scene's materials as the renderer sees them.
pub struct Materials<'a> {
    scene: &'a Scene,
    /// Whether any material can be see-through (then visibility tests look at alpha).
    pub has_cutouts: bool,
    /// Per texture, its mip levels below the full one, made when first read.
    mips: Vec<std::sync::OnceLock<Vec<image::RgbaImage>>>,
    /// Per triangle (empty for a scene without textures): half the log2 of
    /// its area in texels of its texture's full level over its area in the
    /// scene, so a footprint's size in texels follows from its size in space.
    texel_density: Vec<f32>,
}

/// What triangles without a material look like.
static DEFAULT_MATERIAL: Material =
    Material { name: String::new(), base_color: [0.7, 0.7, 0.7, 1.0], base_color_texture: None, alpha_mode: AlphaMode::Opaque, emissive: Vec3::ZERO };

impl<'a> Materials<'a> {
    fn of(&self, triangle: u32) -> &Material {
        let s = self.scene;
        s.triangle_material.get(triangle as usize).and_then(|&m| s.materials.get(m as usize)).unwrap_or(&DEFAULT_MATERIAL)
    }

    pub fn new(scene: &'a Scene) -> Materials<'a> {
        let has_cutouts = scene.materials.iter().any(|m| m.alpha_mode != AlphaMode::Opaque);
        let textured = !scene.uvs.is_empty() && !scene.textures.is_empty();
        let mips = scene.textures.iter().map(|_| std::sync::OnceLock::new()).collect();
        let mut materials = Materials { scene, has_cutouts, mips, texel_density: Vec::new() };
        if textured {
            materials.texel_density = (0..scene.triangles.len() as u32)
                .map(|t| {
                    let Some(texture) = materials.of(t).base_color_texture.and_then(|i| scene.textures.get(i)) else { return f32::NEG_INFINITY };
                    let texels = texture.image.width() as f32 * texture.image.height() as f32;
                    let [a, b, c] = scene.triangles[t as usize].map(|i| scene.positions[i as usize]);
                    let [p, q, r] = scene.triangles[t as usize].map(|i| scene.uvs[i as usize]);
                    let uv_area = (q - p).perp_dot(r - p).abs();
                    let area = (b - a).cross(c - a).length();
                    // Degenerate either way: the full level.
                    if uv_area > 0.0 && area > 0.0 {
                        0.5 * (texels * uv_area / area).log2()
                    } else {
                        f32::NEG_INFINITY
                    }
                })
                .collect();
        }
        materials
    }

    /// Whether any triangle is textured (else footprints change nothing).
    /// The scene the materials are of.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    pub fn has_textures(&self) -> bool {
        !self.texel_density.is_empty()
    }

    /// A texture's mip levels below the full one, down to 1 × 1.
    fn levels(&self, texture: usize) -> &[image::RgbaImage] {
        self.mips[texture].get_or_init(|| {
            let mut levels: Vec<image::RgbaImage> = Vec::new();
            let cutout = self.scene.materials.iter().any(|m| m.base_color_texture == Some(texture) && m.alpha_mode != AlphaMode::Opaque);
            let mut last = &self.scene.textures[texture].image;
            while last.width() > 1 || last.height() > 1 {
                levels.push(half(last, cutout));
                last = levels.last().expect("just pushed");
            }
            levels
        })
    }

    fn uv(&self, triangle: u32, u: f32, v: f32) -> Option<Vec2> {
        let s = self.scene;
        if s.uvs.is_empty() {
            return None;
        }
        let [a, b, c] = s.triangles[triangle as usize].map(|i| s.uvs[i as usize]);
        Some(a * (1.0 - u - v) + b * u + c * v)
    }

    /// Linear base colour (texture times factor) at barycentric (u, v) of a triangle.
    pub fn albedo(&self, triangle: u32, u: f32, v: f32) -> Vec3 {
        self.colour_at(self.of(triangle), triangle, u, v, f32::NEG_INFINITY)
    }

    /// Alpha at a hit (texture times factor), read at the full level: cut-outs
    /// keep their exact outline whatever the distance.
    fn alpha(&self, m: &Material, hit: &Hit) -> f32 {
        match (m.base_color_texture, self.uv(hit.triangle, hit.u, hit.v)) {
            (Some(t), Some(uv)) => m.base_color[3] * bilinear(&self.scene.textures[t].image, uv).1,
            _ => m.base_color[3],
        }
    }

    /// Linear base colour of material `m` at barycentric (u, v) of a triangle
    /// (times the vertex colours, where the scene has them), its texture read at mip
    /// `level` (fractional: trilinear; 0 or less: the full level, as
    /// [`Materials::albedo`]).
    fn colour_at(&self, m: &Material, triangle: u32, u: f32, v: f32, level: f32) -> Vec3 {
        let [r, g, b, _] = m.base_color;
        let mut factor = Vec3::new(r, g, b);
        let s = self.scene;
        if !s.colours.is_empty() {
            let [a, b, c] = s.triangles[triangle as usize].map(|i| s.colours[i as usize]);
            factor *= a * (1.0 - u - v) + b * u + c * v;
        }
        let (Some(t), Some(uv)) = (m.base_color_texture, self.uv(triangle, u, v)) else {
            return factor;
        };
        let full = &self.scene.textures[t].image;
        // (A NaN level, from a hit with NaN in it, reads the full level too.)
        if level.is_nan() || level <= 0.0 {
            return factor * bilinear(full, uv).0;
        }
        let levels = self.levels(t);
        let at = |k: usize| if k == 0 { bilinear(full, uv).0 } else { bilinear(&levels[(k - 1).min(levels.len() - 1)], uv).0 };
        // Trilinear, but one level alone within a tenth of a level of it
        // (half the lookups there, for a blend no one could see).
        let k = (level as usize).min(levels.len());
        let f = (level - k as f32).min(1.0);
        factor
            * if f <= 0.1 || k == levels.len() {
                at(k)
            } else if f >= 0.9 {
                at(k + 1)
            } else {
                at(k) * (1.0 - f) + at(k + 1) * f
            }
    }

    /// Whether a hit is a hole in a cut-out (blended materials count as
    /// cut-outs at alpha 0.5, which keeps rendering deterministic).
    pub fn is_hole(&self, hit: &Hit) -> bool {
        if !self.has_cutouts {
            return false;
        }
        let m = self.of(hit.triangle);
        let cutoff = match m.alpha_mode {
            AlphaMode::Opaque => return false,
            AlphaMode::Mask { cutoff } => cutoff,
            AlphaMode::Blend => 0.5,
        };
        self.alpha(m, hit) < cutoff
    }

    /// The radiance a triangle emits (either side).
    pub fn emission(&self, triangle: u32) -> Vec3 {
        self.of(triangle).emissive
    }

    /// The shading point of a hit seen along `ray`.
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> Surface {
        self.surface_seen(ray, hit, 0.0)
    }

    /// [`Materials::surface`] for a ray that stands for a cone `spread`
    /// radians wide (a pixel's, where one sample through its centre stands
    /// for the whole pixel): its texture is averaged over the cone's
    /// footprint (Amanatides 1984's ray cones; the level as in
    /// Akenine-Möller et al. 2019, "Texture level of detail strategies for
    /// real-time ray tracing"), so detail finer than a pixel does not alias
    /// (glitter in still images, shimmer in videos).
    pub fn surface_seen(&self, ray: &Ray, hit: &Hit, spread: f32) -> Surface {
        let s = self.scene;
        let mut surface = self.flat(ray, hit, spread);
        if !s.normals.is_empty() {
            let geometric = surface.geometric;
            let [a, b, c] = s.triangles[hit.triangle as usize].map(|i| s.normals[i as usize]);
            let n = (a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v).normalize_or_zero();
            // Interpolated normals may point away on the wrong side; then the flat one is better.
            let n = if n.dot(geometric) < 0.0 { -n } else { n };
            if n.dot(geometric) > 0.2 {
                surface.normal = n;
            }
        }
        surface
    }

    /// [`Materials::surface`] with the flat normal for the shading one: all
    /// a final gather's second hit needs (its cache lookup), three vertex
    /// normals fewer to fetch.
    pub fn surface_flat(&self, ray: &Ray, hit: &Hit) -> Surface {
        self.flat(ray, hit, 0.0)
    }

    fn flat(&self, ray: &Ray, hit: &Hit, spread: f32) -> Surface {
        let m = self.of(hit.triangle);
        let facing = hit.normal.dot(ray.dir);
        let geometric = if facing > 0.0 { -hit.normal } else { hit.normal };
        let level = if spread > 0.0 && !self.texel_density.is_empty() {
            // The footprint is an ellipse spread t across and spread t / cos
            // along the surface's slope: its width is taken as the geometric
            // mean of the two, so a floor seen at a grazing angle is neither
            // blurred as much as its long axis asks nor left to alias along
            // it. Its level: that width's log2 in texels of the full level.
            let length = ray.dir.length();
            let cos = (facing.abs() / length).max(1e-4);
            log2_approx(spread * hit.t * length) - 0.5 * log2_approx(cos) + self.texel_density[hit.triangle as usize]
        } else {
            f32::NEG_INFINITY
        };
        Surface {
            position: ray.at(hit.t),
            normal: geometric,
            geometric,
            albedo: self.colour_at(m, hit.triangle, hit.u, hit.v, level).min(Vec3::splat(0.98)),
            emission: m.emissive,
        }
    }
}

/// A gradient sky: radiance by elevation, also lighting the scene through
/// openings (it is reached by bounce rays and the radiance cache, not sampled
/// directly, so closed rooms never see it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sky {
    pub zenith: Vec3,
    pub horizon: Vec3,
    pub ground: Vec3,
}

impl Sky {
    pub const DAY: Sky = Sky { zenith: Vec3::new(0.25, 0.4, 0.75), horizon: Vec3::new(0.7, 0.75, 0.8), ground: Vec3::new(0.2, 0.18, 0.16) };
    pub const NONE: Sky = Sky { zenith: Vec3::ZERO, horizon: Vec3::ZERO, ground: Vec3::ZERO };

    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let y = dir.normalize_or_zero().y;
        if y >= 0.0 {
            self.horizon.lerp(self.zenith, y.sqrt())
        } else {
            self.horizon.lerp(self.ground, (-y * 4.0).min(1.0))
        }
    }
}

/// Which of the directly sampled lights to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    All,
    Suns,
    /// Point lights only (what the cache bakes for cheap renders).
    Points,
}

/// The lights the renderer samples directly (next-event estimation) plus the sky.
#[derive(Clone, Debug, PartialEq)]
pub struct Lighting {
    /// (unit direction toward the sun, irradiance).
    pub suns: Vec<(Vec3, Vec3)>,
    /// (position, radiant intensity).
    pub points: Vec<(Vec3, Vec3)>,
    pub sky: Sky,
    /// What was chosen and why, for the log and graph.json.
    pub description: String,
}

impl Lighting {
    /// The scene's own lights, or a default when it has none: sun and sky when
    /// the sky can be seen from the viewpoints, otherwise a ceiling light above
    /// each viewpoint (a closed interior).
    pub fn for_scene(scene: &Scene, rays: &RayScene, viewpoints: &[Vec3]) -> Lighting {
        let mut lighting = Lighting { suns: Vec::new(), points: Vec::new(), sky: Sky::DAY, description: String::new() };
        for l in &scene.lights {
            match *l {
                Light::Sun { direction, irradiance } => lighting.suns.push((direction.normalize(), irradiance)),
                Light::Point { position, intensity } => lighting.points.push((position, intensity)),
            }
        }
        let emissive = scene.materials.iter().any(|m| m.emissive != Vec3::ZERO);
        if !scene.lights.is_empty() || emissive {
            lighting.description = format!(
                "the scene's own lights: {} sun, {} point, {} emissive materials, and a sky",
                lighting.suns.len(),
                lighting.points.len(),
                scene.materials.iter().filter(|m| m.emissive != Vec3::ZERO).count()
            );
            return lighting;
        }
        let open = sky_fraction(rays, viewpoints);
        if open >= 0.01 || viewpoints.is_empty() {
            let (direction, lit) = best_sun(rays, viewpoints);
            let Light::Sun { irradiance, .. } = DEFAULT_SUN else { unreachable!() };
            lighting.suns.push((direction, irradiance));
            let (yaw, pitch) = exploremaps_format::yaw_pitch(direction.into());
            lighting.description = format!(
                "no lights in the scene and {:.0} % of the sky visible: a default sky and a sun at {:.0}° elevation, {:.0}° yaw, which lights {:.0} % of what the viewpoints see",
                open * 100.0,
                pitch.to_degrees(),
                yaw.to_degrees().rem_euclid(360.0),
                lit * 100.0
            );
            if lit < 0.02 && !viewpoints.is_empty() {
                lighting.points = ceiling_lights(scene, rays, viewpoints);
                lighting.description += &format!(", so also {} ceiling lights", lighting.points.len());
            }
        } else {
            lighting.sky = Sky::NONE;
            lighting.points = ceiling_lights(scene, rays, viewpoints);
            lighting.description = format!("no lights in a closed scene: {} default ceiling lights, one above each viewpoint", lighting.points.len());
        }
        lighting
    }

    /// The shadow rays of direct lighting at `s`, each with the irradiance it
    /// brings if unblocked: `sun_rays` per sun (points on its disk: `u`, and
    /// for more, a rank-1 lattice over the disk shifted by `u`, each ray
    /// with its share) and one per point light, as `which` says, each with
    /// its light's index (suns first, then point lights). Lights below the
    /// surface give none. A count of 0 is taken as 1.
    pub fn shadow_rays(&self, s: &Surface, u: Vec2, which: Which, sun_rays: u32, mut emit: impl FnMut(usize, Ray, Vec3)) {
        let from = s.lifted();
        let suns = if which == Which::Points { &[][..] } else { &self.suns[..] };
        let sun_rays = sun_rays.max(1);
        let share = 1.0 / sun_rays as f32;
        for (k, &(dir, irradiance)) in suns.iter().enumerate() {
            for j in 0..sun_rays {
                let v = lattice(j as usize, sun_rays as usize, u);
                let d = Lighting::sun_direction(dir, v);
                let cos = s.normal.dot(d);
                if cos > 0.0 && s.geometric.dot(d) > 0.0 {
                    emit(k, Ray::new(from, d), irradiance * cos * share);
                }
            }
        }
        if which == Which::Suns {
            return;
        }
        for (k, &(position, intensity)) in self.points.iter().enumerate() {
            let to = position - from;
            let r2 = to.length_squared().max(1e-12);
            let d = to / r2.sqrt();
            let cos = s.normal.dot(d);
            if cos > 0.0 && s.geometric.dot(d) > 0.0 {
                emit(self.suns.len() + k, Ray { t_max: 1.0, ..Ray::new(from, to) }, intensity * cos / r2);
            }
        }
    }

    /// A direction toward a point of the sun's disk around `dir`, from `u` in [0, 1)².
    pub fn sun_direction(dir: Vec3, u: Vec2) -> Vec3 {
        let (t1, t2) = dir.any_orthonormal_pair();
        let r = SUN_RADIUS * u.x.sqrt();
        let phi = std::f32::consts::TAU * u.y;
        (dir + (t1 * phi.cos() + t2 * phi.sin()) * r).normalize()
    }

    /// Irradiance at a surface from the lights `which` names, one shadow test
    /// each (`visible` says whether a ray is clear).
    pub fn direct(&self, s: &Surface, u: Vec2, which: Which, visible: impl Fn(&Ray) -> bool) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.shadow_rays(s, u, which, 1, |_, ray, irradiance| {
            if visible(&ray) {
                e += irradiance;
            }
        });
        e
    }
}

/// Of some high sun directions, the one that lights the most of what the
/// viewpoints see (a courtyard needs the sun along it), with that fraction;
/// the default sun wins ties.
fn best_sun(rays: &RayScene, viewpoints: &[Vec3]) -> (Vec3, f32) {
    let Light::Sun { direction, .. } = DEFAULT_SUN else { unreachable!() };
    let mut candidates = vec![direction.normalize()];
    for elevation in [50f32, 65.0, 78.0] {
        for k in 0..8 {
            let yaw = (22.5 + 45.0 * k as f32).to_radians();
            candidates.push(Vec3::from(exploremaps_format::direction(yaw, elevation.to_radians())));
        }
    }
    let dirs = fibonacci_sphere(512);
    let seen: Vec<Vec3> = viewpoints
        .iter()
        .take(16)
        .flat_map(|&p| dirs.iter().map(move |&d| Ray::new(p, d)))
        .filter_map(|r| rays.intersect(&r).map(|h| r.at(h.t) + h.normal * offset(r.at(h.t)) * if h.normal.dot(r.dir) > 0.0 { -1.0 } else { 1.0 }))
        .collect();
    if seen.is_empty() {
        return (candidates[0], 0.0);
    }
    let lit = |d: Vec3| {
        let shadow: Vec<Ray> = seen.iter().map(|&p| Ray::new(p, d)).collect();
        let blocked = rays.occluded_batch(&shadow, crate::raycast::Packing::Packets8);
        blocked.iter().filter(|&&b| !b).count() as f32 / seen.len() as f32
    };
    let mut best = (candidates[0], lit(candidates[0]));
    for &d in &candidates[1..] {
        let f = lit(d);
        if f > best.1 + 0.01 {
            best = (d, f);
        }
    }
    best
}

/// Fraction of rays from the viewpoints that escape to the sky.
fn sky_fraction(rays: &RayScene, viewpoints: &[Vec3]) -> f32 {
    let dirs = fibonacci_sphere(256);
    let probe_rays: Vec<Ray> = viewpoints.iter().take(64).flat_map(|&p| dirs.iter().map(move |&d| Ray::new(p, d))).collect();
    if probe_rays.is_empty() {
        return 1.0;
    }
    let hits = rays.occluded_batch(&probe_rays, crate::raycast::Packing::Packets8);
    hits.iter().filter(|&&h| !h).count() as f32 / hits.len() as f32
}

/// A light under the ceiling above each viewpoint (at most 64, spread out),
/// bright enough to light a room of the scene's scale.
fn ceiling_lights(scene: &Scene, rays: &RayScene, viewpoints: &[Vec3]) -> Vec<(Vec3, Vec3)> {
    let step = viewpoints.len().div_ceil(64).max(1);
    let metre = 1.0 / scene.metres_per_unit.max(1e-9);
    viewpoints
        .iter()
        .step_by(step)
        .map(|&p| {
            let up = rays.intersect(&Ray::new(p, Vec3::Y)).map_or(2.0 * metre, |h| h.t);
            let at = p + Vec3::Y * (0.6 * up);
            // About 60 W of warm light, in scene units (intensity falls with distance²).
            (at, Vec3::new(4.0, 3.7, 3.2) * metre * metre)
        })
        .collect()
}

/// Point `j` of a `k`-point Fibonacci lattice in [0, 1)², shifted by `shift`
/// (j/k along one axis, j times the golden ratio's fraction along the
/// other): even over the square for any count.
pub fn lattice(j: usize, k: usize, shift: Vec2) -> Vec2 {
    (Vec2::new(j as f32 / k as f32, j as f32 * 0.618_034) + shift).fract()
}

/// `n` nearly uniform unit directions (a Fibonacci spiral).
pub fn fibonacci_sphere(n: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

pub use crate::seeds::cosine_direction;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::srgb_to_linear;

    #[test]
    fn log2_approx_is_within_a_hundredth() {
        let worst = (0..20_000).map(|i| 1e-6f32 * 1.0013f32.powi(i)).map(|x| (log2_approx(x) - x.log2()).abs()).fold(0.0, f32::max);
        assert!(worst < 0.01, "{worst}");
    }

    /// The texture tiles in both directions and interpolates between texel
    /// centres: checked against the textbook formula (floor and wrap) at
    /// coordinates on texel centres and edges, negative, and beyond one tile;
    /// huge, infinite and NaN coordinates do not panic.
    #[test]
    fn bilinear_tiles_and_interpolates_like_the_textbook_formula() {
        let (w, h) = (5u32, 3u32);
        let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba([(40 * x + 7 * y) as u8, (50 * y) as u8, 200, (60 * x) as u8]));
        let textbook = |uv: Vec2| {
            let (x, y) = ((uv.x - uv.x.floor()) * w as f32 - 0.5, (uv.y - uv.y.floor()) * h as f32 - 0.5);
            let (x0, y0) = (x.floor(), y.floor());
            let at = |dx: i64, dy: i64| {
                let p = img.get_pixel((x0 as i64 + dx).rem_euclid(w as i64) as u32, (y0 as i64 + dy).rem_euclid(h as i64) as u32);
                Vec3::new(srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2])).extend(p[3] as f32 / 255.0)
            };
            let (fx, fy) = (x - x0, y - y0);
            (at(0, 0) * (1.0 - fx) + at(1, 0) * fx) * (1.0 - fy) + (at(0, 1) * (1.0 - fx) + at(1, 1) * fx) * fy
        };
        for uv in [Vec2::new(f32::INFINITY, 0.5), Vec2::new(-1e30, f32::NEG_INFINITY), Vec2::new(3e19, 1e10), Vec2::splat(f32::NAN)] {
            bilinear(&img, uv);
        }
        for i in -40..=40 {
            for j in -13..=13 {
                let uv = Vec2::new(i as f32 * 0.05 + 0.001 * j as f32, j as f32 * 0.1);
                let (rgb, alpha) = bilinear(&img, uv);
                let want = textbook(uv);
                assert!((rgb.extend(alpha) - want).abs().max_element() < 2e-3, "at {uv}: {rgb} {alpha} against {want}");
            }
        }
    }
}
