//! Wavefront OBJ + MTL through `tobj`: polygons are fan-triangulated, negative
//! (relative) indices resolved, `map_Kd` textures and `map_d` cut-outs loaded
//! with case-insensitive paths, `Ke` read as emission. Texture coordinates are
//! flipped to the image convention (v down) used by the whole pipeline.
//!
//! MTL colour statements with fewer than three numbers (`Kd 0.5`, which the
//! MTL format allows: g and b default to r; or a bare `Kd`) make tobj 4.0.5
//! panic (an `unwrap` in its `parse_float3`): they are completed, or left out,
//! before tobj reads the file, and any other panic inside tobj's MTL parser becomes a material
//! error (the scene then loads grey, with a warning naming the file).

use super::{check_triangle_count, decode_texture, require_text, resolve_path, LoadError};
use exploremaps_scenes::{AlphaMode, Material, ScaleSource, Scene, Texture};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

pub(super) fn load(path: &Path, bytes: &[u8], max_triangles: u64) -> Result<Scene, LoadError> {
    require_text(path, bytes, "OBJ")?;
    check_triangle_count(path, count_triangles(bytes), max_triangles)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    // tobj 4.0.5 multiplies a face's indices unchecked (an index far out of
    // range overflows, found by fuzzing): a panic there is a malformed file.
    let parsed = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |mtl| match resolve_path(&dir, &mtl.to_string_lossy()) {
            Some(found) => load_mtl(&found),
            None => Err(tobj::LoadError::OpenFileFailed),
        })
    })
    .map_err(|_| LoadError::malformed(path, "not a valid OBJ file (a face index is far out of range); it may be truncated or corrupt"))?;
    let (models, materials) =
        parsed.map_err(|e| LoadError::malformed(path, format!("not a valid OBJ file ({e}); it may be truncated or corrupt")))?;
    let obj_materials = materials.unwrap_or_else(|e| {
        tracing::warn!("{}: its material library could not be read ({e}); every surface will be grey", path.display());
        Vec::new()
    });
    let (mut materials, textures) = convert_materials(path, &dir, &obj_materials);
    let default_material = materials.len() as u32;
    materials.push(Material::diffuse("default", [0.7, 0.7, 0.7]));

    let mut scene = empty_scene(materials, textures);
    // Normals only where every vertex has one: faces that give none beside
    // faces that do leave tobj's lists of different lengths.
    let with_normals = models.iter().all(|m| !m.mesh.normals.is_empty() && m.mesh.normals.len() == m.mesh.positions.len());
    // Vertex colours (`v x y z r g b`, as scanning tools write, sRGB 0-1) where every vertex has one.
    let with_colours = models.iter().all(|m| !m.mesh.vertex_color.is_empty() && m.mesh.vertex_color.len() == m.mesh.positions.len());
    let mut object_index: HashMap<String, u32> = HashMap::new();
    for model in &models {
        let mesh = &model.mesh;
        let base = scene.positions.len() as u32;
        let count = mesh.positions.len() / 3;
        scene.positions.extend(mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        if with_normals {
            scene.normals.extend(mesh.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2])));
        }
        if with_colours {
            let decode = |x: f32| crate::colour::srgb_decode(x.clamp(0.0, 1.0));
            scene.colours.extend(mesh.vertex_color.chunks_exact(3).map(|c| Vec3::new(decode(c[0]), decode(c[1]), decode(c[2]))));
        }
        if mesh.texcoords.len() == count * 2 {
            scene.uvs.extend(mesh.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], 1.0 - t[1])));
        } else {
            scene.uvs.extend(std::iter::repeat_n(Vec2::ZERO, count));
        }
        let material = mesh.material_id.filter(|&m| m < obj_materials.len()).map_or(default_material, |m| m as u32);
        let next_object = object_index.len() as u32;
        let object = *object_index.entry(model.name.clone()).or_insert_with(|| {
            scene.objects.push(model.name.clone());
            next_object
        });
        for tri in mesh.indices.chunks_exact(3) {
            scene.triangles.push([base + tri[0], base + tri[1], base + tri[2]]);
            scene.triangle_material.push(material);
            scene.triangle_object.push(object);
        }
    }
    if scene.uvs.iter().all(|&uv| uv == Vec2::ZERO) {
        scene.uvs.clear();
    }
    scene.stats.missing_textures = count_missing(&obj_materials, &scene.materials);
    Ok(scene)
}

/// Reads a material library through tobj, with short colour statements
/// completed first and tobj's panics caught.
fn load_mtl(path: &Path) -> tobj::MTLLoadResult {
    let text = std::fs::read(path).map_err(|_| tobj::LoadError::OpenFileFailed)?;
    let text = complete_colours(path, &String::from_utf8_lossy(&text));
    std::panic::catch_unwind(|| tobj::load_mtl_buf(&mut std::io::Cursor::new(text.as_bytes()))).unwrap_or(Err(tobj::LoadError::MaterialParseError))
}

/// `Ka`, `Kd`, `Ks`, `Ke` (and `Tf`) with one or two numbers get the last one
/// repeated to three (the MTL format's rule for one number, g = b = r); with
/// none, the statement is left out.
fn complete_colours(path: &Path, text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 16);
    for (number, line) in text.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let colour = matches!(words.first(), Some(&("Ka" | "Kd" | "Ks" | "Ke" | "Tf")));
        let values = words.len().saturating_sub(1);
        if colour && values == 0 {
            tracing::warn!("{} line {}: `{}` has no colour numbers; left out", path.display(), number + 1, line.trim());
            continue;
        } else if colour && (1..3).contains(&values) && words[1..].iter().all(|w| w.parse::<f32>().is_ok()) {
            let last = words[values];
            let completed = format!("{} {}", line.trim(), vec![last; 3 - values].join(" "));
            tracing::warn!("{} line {}: `{}` has {values} of 3 colour numbers; read as `{completed}`", path.display(), number + 1, line.trim());
            out.push_str(&completed);
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

/// The triangles the `f` statements make once fan-triangulated, counted
/// before tobj reads the file (a few hundred MB a second).
fn count_triangles(bytes: &[u8]) -> u64 {
    bytes
        .split(|&b| b == b'\n')
        .map(|line| line.trim_ascii_start())
        .filter(|line| line.len() > 1 && line[0] == b'f' && line[1].is_ascii_whitespace())
        .map(|line| (line[1..].split(|b| b.is_ascii_whitespace()).filter(|w| !w.is_empty()).count() as u64).saturating_sub(2))
        .sum()
}

/// An empty scene to fill, with the scale left to be guessed.
pub(super) fn empty_scene(materials: Vec<Material>, textures: Vec<Texture>) -> Scene {
    Scene { materials, textures, scale_source: ScaleSource::Guessed, ..Scene::empty("") }
}

/// The file name in an MTL map statement, which may carry options before it
/// (`map_Kd -bm 1 textures/a.png`): the last token.
fn map_file(statement: &str) -> &str {
    statement.split_whitespace().last().unwrap_or("")
}

fn convert_materials(path: &Path, dir: &Path, obj_materials: &[tobj::Material]) -> (Vec<Material>, Vec<Texture>) {
    // Every distinct image file referenced as colour or cut-out, decoded in parallel.
    let mut files: Vec<PathBuf> = Vec::new();
    let mut find = |statement: &Option<String>| -> Option<usize> {
        let name = map_file(statement.as_deref()?);
        let Some(found) = resolve_path(dir, name) else {
            tracing::warn!("{}: texture {name} not found next to it; using the material's colour", path.display());
            return None;
        };
        Some(files.iter().position(|f| *f == found).unwrap_or_else(|| {
            files.push(found);
            files.len() - 1
        }))
    };
    let refs: Vec<(Option<usize>, Option<usize>)> = obj_materials.iter().map(|m| (find(&m.diffuse_texture), find(&m.dissolve_texture))).collect();
    let decoded: Vec<Option<Texture>> = files.par_iter().map(|f| decode_texture(path, f)).collect();

    let mut textures = Vec::new();
    let mut texture_of: HashMap<(Option<usize>, Option<usize>), Option<usize>> = HashMap::new();
    let mut materials = Vec::new();
    for (m, &(colour, cutout)) in obj_materials.iter().zip(&refs) {
        let colour = colour.filter(|&i| decoded[i].is_some());
        let cutout = cutout.filter(|&i| decoded[i].is_some());
        let texture = *texture_of.entry((colour, cutout)).or_insert_with(|| {
            let image = combine_alpha(colour.and_then(|i| decoded[i].as_ref()), cutout.and_then(|i| decoded[i].as_ref()))?;
            textures.push(image);
            Some(textures.len() - 1)
        });
        let kd = m.diffuse.unwrap_or([0.7, 0.7, 0.7]);
        let emissive = m.emissive.map_or(Vec3::ZERO, Vec3::from);
        materials.push(Material {
            name: m.name.clone(),
            // With a texture, Kd is often the texture's mean (it is in the shared Sponza); the texture wins.
            base_color: if texture.is_some() && colour.is_some() {
                [1.0, 1.0, 1.0, m.dissolve.unwrap_or(1.0)]
            } else {
                [kd[0], kd[1], kd[2], m.dissolve.unwrap_or(1.0)]
            },
            base_color_texture: texture,
            alpha_mode: if cutout.is_some() {
                AlphaMode::Mask { cutoff: 0.5 }
            } else if m.dissolve.is_some_and(|d| d < 1.0) {
                AlphaMode::Blend
            } else {
                AlphaMode::Opaque
            },
            emissive,
        });
    }
    (materials, textures)
}

/// A colour texture with the cut-out map's luminance as alpha (sizes may differ:
/// the cut-out is sampled at the colour texture's resolution).
fn combine_alpha(colour: Option<&Texture>, cutout: Option<&Texture>) -> Option<Texture> {
    match (colour, cutout) {
        (None, None) => None,
        (Some(c), None) => Some(c.clone()),
        (colour, Some(a)) => {
            let (w, h) = colour.map_or(a.image.dimensions(), |c| c.image.dimensions());
            let mut image = colour.map_or_else(|| image::RgbaImage::from_pixel(w, h, image::Rgba([255; 4])), |c| c.image.clone());
            let (aw, ah) = a.image.dimensions();
            for (x, y, p) in image.enumerate_pixels_mut() {
                let q = a.image.get_pixel(x * aw / w, y * ah / h);
                let luminance = (q[0] as u32 + q[1] as u32 + q[2] as u32) / 3;
                p[3] = if q[3] < 255 { q[3] } else { luminance as u8 };
            }
            Some(Texture { name: format!("{} + alpha {}", colour.map_or("white", |c| &c.name), a.name), image })
        }
    }
}

fn count_missing(obj_materials: &[tobj::Material], materials: &[Material]) -> usize {
    obj_materials.iter().zip(materials).filter(|(o, m)| o.diffuse_texture.is_some() && m.base_color_texture.is_none()).count()
}
