//! Render (first step): preview panoramas and thumbnails of probes, ray cast
//! on Embree (DESIGN.md section 3.10). The path tracer, cube-map levels and
//! transition videos come later; this is the `preview` quality.
//!
//! Inputs: the scene, its ray-casting structure, a probe position and view.
//! Outputs: linear RGB images, tone-mapped to sRGB bytes.
//!
//! Shading: base colour (texture, bilinear, sRGB decoded, times the factor)
//! times direct light from the scene's sun and point lights with shadow rays,
//! plus a sky term (brighter facing up) and emission; ACES-fitted tone mapping.
//! A scene without lights gets a default sun (and the log says so). Alpha
//! cut-outs are not honoured yet. Deterministic: no sampling noise at all.

use crate::orient::direction;
use crate::raycast::{Hit, Packing, Ray, RayScene};
use exploremaps_scenes::{Light, Scene};
use glam::{Vec2, Vec3};
use image::{Rgb, RgbImage};

/// The light used when a scene has none: a sun from the south-east, high.
pub const DEFAULT_SUN: Light = Light::Sun { direction: Vec3::new(0.4082, 0.8165, 0.4082), irradiance: Vec3::new(2.8, 2.7, 2.5) };

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

fn linear_to_srgb(x: f32) -> u8 {
    let x = x.clamp(0.0, 1.0);
    let s = if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0).round() as u8
}

/// ACES filmic curve (Narkowicz's fit).
fn tone_map(x: Vec3) -> Vec3 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (x * a + b)) / (x * (x * c + d) + e)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// Shades hits for a preview: one closest hit per pixel plus shadow rays.
pub struct Shader<'a> {
    scene: &'a Scene,
    rays: &'a RayScene,
    lights: Vec<Light>,
    /// Sky radiance seen by misses and used as ambient light.
    sky: Vec3,
}

impl<'a> Shader<'a> {
    pub fn new(scene: &'a Scene, rays: &'a RayScene) -> Shader<'a> {
        let lights = if scene.lights.is_empty() && scene.materials.iter().all(|m| m.emissive == Vec3::ZERO) {
            tracing::info!("{} has no lights: rendering it under a default sun and sky", scene.name);
            vec![DEFAULT_SUN]
        } else {
            scene.lights.clone()
        };
        Shader { scene, rays, lights, sky: Vec3::new(0.35, 0.45, 0.6) }
    }

    fn base_colour(&self, hit: &Hit) -> Vec3 {
        let s = self.scene;
        let t = hit.triangle as usize;
        let m = &s.materials[s.triangle_material[t] as usize];
        let factor = Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]);
        let Some(texture) = m.base_color_texture.map(|i| &s.textures[i].image) else { return factor };
        if s.uvs.is_empty() {
            return factor;
        }
        let [a, b, c] = s.triangles[t].map(|i| s.uvs[i as usize]);
        let uv = a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
        factor * bilinear(texture, uv)
    }

    /// Radiance arriving along `ray` from its hit (or the sky).
    pub fn shade(&self, ray: &Ray, hit: Option<Hit>) -> Vec3 {
        let Some(hit) = hit else { return self.sky };
        let m = &self.scene.materials[self.scene.triangle_material[hit.triangle as usize] as usize];
        let p = ray.at(hit.t);
        let n = if hit.normal.dot(ray.dir) > 0.0 { -hit.normal } else { hit.normal };
        let lift = n * 1e-4 * (1.0 + p.abs().max_element());
        let albedo = self.base_colour(&hit);
        let mut light = self.sky * (0.55 + 0.45 * n.y);
        for l in &self.lights {
            let (to_light, radiance, distance) = match *l {
                Light::Sun { direction, irradiance } => (direction.normalize(), irradiance, f32::INFINITY),
                Light::Point { position, intensity } => {
                    let d = position - p;
                    let r2 = d.length_squared().max(1e-8);
                    (d / r2.sqrt(), intensity / r2, r2.sqrt())
                }
            };
            let cos = n.dot(to_light);
            if cos <= 0.0 {
                continue;
            }
            let shadow = Ray { t_min: 0.0, t_max: distance, ..Ray::new(p + lift, to_light) };
            if !self.rays.occluded(&shadow) {
                light += radiance * cos;
            }
        }
        albedo * light / std::f32::consts::PI * 2.0 + m.emissive
    }

    /// Shades many rays: closest hits in packets, then shading in parallel.
    fn shade_all(&self, rays: &[Ray], packing: Packing) -> Vec<Vec3> {
        use rayon::prelude::*;
        let hits = self.rays.intersect_batch(rays, packing);
        rays.par_iter().zip(hits).map(|(r, h)| self.shade(r, h)).collect()
    }
}

fn bilinear(img: &image::RgbaImage, uv: Vec2) -> Vec3 {
    let (w, h) = (img.width() as f32, img.height() as f32);
    let (x, y) = (uv.x.rem_euclid(1.0) * w - 0.5, uv.y.rem_euclid(1.0) * h - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let texel = |xi: f32, yi: f32| {
        let p = img.get_pixel(xi.rem_euclid(w) as u32, yi.rem_euclid(h) as u32);
        Vec3::new(srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]))
    };
    let top = texel(x0, y0) * (1.0 - fx) + texel(x0 + 1.0, y0) * fx;
    let bottom = texel(x0, y0 + 1.0) * (1.0 - fx) + texel(x0 + 1.0, y0 + 1.0) * fx;
    top * (1.0 - fy) + bottom * fy
}

fn to_image(width: u32, height: u32, radiance: &[Vec3]) -> RgbImage {
    RgbImage::from_fn(width, height, |x, y| {
        let c = tone_map(radiance[(y * width + x) as usize]);
        Rgb([linear_to_srgb(c.x), linear_to_srgb(c.y), linear_to_srgb(c.z)])
    })
}

/// An equirectangular panorama, `width` × `width`/2: column 0 looks toward −Z
/// then turns toward +X (the bundle's yaw convention), row 0 looks straight up.
pub fn equirect(shader: &Shader, eye: Vec3, width: u32) -> RgbImage {
    let height = width / 2;
    let rays: Vec<Ray> = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let yaw = (x as f32 + 0.5) / width as f32 * std::f32::consts::TAU;
            let pitch = std::f32::consts::FRAC_PI_2 - (y as f32 + 0.5) / height as f32 * std::f32::consts::PI;
            Ray::new(eye, direction(yaw, pitch))
        })
        .collect();
    to_image(width, height, &shader.shade_all(&rays, Packing::Packets8))
}

/// A perspective view toward (yaw, pitch) with vertical field of view `fov_y`.
pub fn perspective(shader: &Shader, eye: Vec3, yaw: f32, pitch: f32, fov_y: f32, width: u32, height: u32) -> RgbImage {
    let forward = direction(yaw, pitch);
    let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let tan = (0.5 * fov_y).tan();
    let aspect = width as f32 / height as f32;
    let rays: Vec<Ray> = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let sx = (2.0 * (x as f32 + 0.5) / width as f32 - 1.0) * tan * aspect;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / height as f32) * tan;
            Ray::new(eye, (forward + right * sx + up * sy).normalize())
        })
        .collect();
    to_image(width, height, &shader.shade_all(&rays, Packing::Coherent8))
}

/// JPEG bytes of an equirectangular panorama with photo-sphere (GPano) XMP
/// metadata, so panorama viewers and photo apps show it as a sphere.
pub fn photo_sphere_jpeg(image: &RgbImage, quality: u8) -> Vec<u8> {
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, quality).encode_image(image).expect("JPEG encoding to memory");
    let (w, h) = image.dimensions();
    let xmp = format!(
        "http://ns.adobe.com/xap/1.0/\0<?xpacket begin=\"\u{feff}\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\
<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\
<rdf:Description rdf:about=\"\" xmlns:GPano=\"http://ns.google.com/photos/1.0/panorama/\" \
GPano:ProjectionType=\"equirectangular\" GPano:UsePanoramaViewer=\"True\" \
GPano:FullPanoWidthPixels=\"{w}\" GPano:FullPanoHeightPixels=\"{h}\" \
GPano:CroppedAreaImageWidthPixels=\"{w}\" GPano:CroppedAreaImageHeightPixels=\"{h}\" \
GPano:CroppedAreaLeftPixels=\"0\" GPano:CroppedAreaTopPixels=\"0\"/></rdf:RDF></x:xmpmeta><?xpacket end=\"w\"?>"
    );
    // An APP1 segment right after the start-of-image marker.
    let mut out = Vec::with_capacity(jpeg.len() + xmp.len() + 4);
    out.extend_from_slice(&jpeg[..2]);
    out.extend_from_slice(&[0xFF, 0xE1]);
    out.extend_from_slice(&((xmp.len() + 2) as u16).to_be_bytes());
    out.extend_from_slice(xmp.as_bytes());
    out.extend_from_slice(&jpeg[2..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use exploremaps_scenes::mesh::MeshBuilder;
    use exploremaps_scenes::Material;

    #[test]
    fn equirect_columns_follow_the_yaw_convention() {
        // A red wall toward −Z and a green one toward +X, around an otherwise open sky.
        let mut m = MeshBuilder::new("walls");
        let red = m.add_material(Material { emissive: Vec3::new(1.0, 0.0, 0.0), ..Material::diffuse("red", [0.0; 3]) });
        let green = m.add_material(Material { emissive: Vec3::new(0.0, 1.0, 0.0), ..Material::diffuse("green", [0.0; 3]) });
        m.set_material(red);
        m.cuboid(Vec3::new(-5.0, -5.0, -6.0), Vec3::new(5.0, 5.0, -5.0));
        m.set_material(green);
        m.cuboid(Vec3::new(5.0, -5.0, -4.0), Vec3::new(6.0, 5.0, 4.0));
        let scene = m.finish();
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let shader = Shader::new(&scene, &rays);
        let img = equirect(&shader, Vec3::ZERO, 64);
        let centre = |x: u32| img.get_pixel(x, 16).0;
        let red_px = centre(0);
        let green_px = centre(16);
        assert!(red_px[0] > 150 && red_px[1] < 60, "yaw 0 (column 0) sees the red wall: {red_px:?}");
        assert!(green_px[1] > 150 && green_px[0] < 60, "yaw π/2 (a quarter across) sees the green wall: {green_px:?}");
        let sky = img.get_pixel(32, 0).0;
        assert!(sky[2] > sky[0], "row 0 looks up at the sky: {sky:?}");
    }

    #[test]
    fn photo_sphere_jpeg_decodes_and_carries_gpano() {
        let img = RgbImage::from_pixel(64, 32, Rgb([10, 200, 30]));
        let bytes = photo_sphere_jpeg(&img, 90);
        assert_eq!(&bytes[..4], &[0xFF, 0xD8, 0xFF, 0xE1]);
        let needle = b"GPano:ProjectionType=\"equirectangular\"";
        assert!(bytes.windows(needle.len()).any(|w| w == needle));
        let back = image::load_from_memory(&bytes).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), (64, 32));
        assert!((back.get_pixel(5, 5)[1] as i32 - 200).abs() < 8);
    }

    #[test]
    fn lit_faces_are_brighter_than_shadowed_ones() {
        // A floor under the default sun, half of it shadowed by a roof.
        let mut m = MeshBuilder::new("floor");
        m.add_material(Material::diffuse("grey", [0.5; 3]));
        m.cuboid(Vec3::new(-10.0, -0.1, -10.0), Vec3::new(10.0, 0.0, 10.0));
        m.cuboid(Vec3::new(-10.0, 3.0, -10.0), Vec3::new(0.0, 3.1, 10.0));
        let scene = m.finish();
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let shader = Shader::new(&scene, &rays);
        let look_down = |x: f32| shader.shade(&Ray::new(Vec3::new(x, 1.0, 0.0), Vec3::NEG_Y), rays.intersect(&Ray::new(Vec3::new(x, 1.0, 0.0), Vec3::NEG_Y)));
        let (lit, shaded) = (look_down(6.0), look_down(-6.0));
        assert!(lit.x > 2.0 * shaded.x, "lit {lit} vs shadow {shaded}");
    }
}
