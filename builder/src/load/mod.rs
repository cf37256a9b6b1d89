//! Scene loading: OBJ + MTL, glTF 2.0 / GLB and PLY files into one [`Scene`].
//!
//! Every loader returns a scene whose up axis is +Y (other up axes are rotated
//! into it), whose bad triangles are dropped and counted, and whose unit scale
//! is known (from the file, the user, or a reported guess). Errors name the file
//! and say what to do; a texture that cannot be read is a warning, not an error,
//! and its material keeps its plain colour.

mod gltf_decode;
mod gltf;
pub(crate) use gltf::LUMENS_PER_WATT;
mod obj;
mod ply;

use exploremaps_scenes::{guess_metres_per_unit, Light, ScaleSource, Scene, Texture};
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};

/// What the user can tell the loader about a scene file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadOptions {
    /// The file's up direction; rotated to +Y.
    pub up: Vec3,
    /// Metres per scene unit; `None` keeps the file's (glTF: metres) or guesses.
    pub metres_per_unit: Option<f32>,
    /// The most triangles a file may hold, checked from its header or a scan
    /// before its data is decoded.
    pub max_triangles: u64,
}

/// The default of [`LoadOptions::max_triangles`], about 200 times the Crytek Sponza.
pub const MAX_TRIANGLES: u64 = 50_000_000;

impl Default for LoadOptions {
    fn default() -> LoadOptions {
        LoadOptions { up: Vec3::Y, metres_per_unit: None, max_triangles: MAX_TRIANGLES }
    }
}

/// Parses an up axis as given on the command line: `y`, `+z`, `-x`, ...
pub fn parse_up_axis(text: &str) -> Option<Vec3> {
    let text = text.trim().to_ascii_lowercase();
    let (sign, axis) = match text.strip_prefix('-') {
        Some(rest) => (-1.0, rest),
        None => (1.0, text.strip_prefix('+').unwrap_or(&text)),
    };
    let axis = match axis {
        "x" => Vec3::X,
        "y" => Vec3::Y,
        "z" => Vec3::Z,
        _ => return None,
    };
    Some(axis * sign)
}

#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("cannot read {path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: unknown scene format '{extension}'; ExploreMaps reads .obj (with .mtl), .gltf, .glb and .ply files")]
    UnknownFormat { path: PathBuf, extension: String },
    #[error("{path}: {detail}")]
    Malformed { path: PathBuf, detail: String },
    #[error("{path} holds no usable triangles{dropped}; check that it is a triangle or polygon mesh (point clouds and lines are not scenes)")]
    Empty { path: PathBuf, dropped: String },
    #[error("{path} holds {count} triangles, more than the limit of {limit}; --max-triangles {count} loads it anyway (memory grows with the count)")]
    TooLarge { path: PathBuf, count: u64, limit: u64 },
}

impl LoadError {
    fn malformed(path: &Path, detail: impl Into<String>) -> LoadError {
        LoadError::Malformed { path: path.to_path_buf(), detail: detail.into() }
    }
}

/// Refuses a file that holds (or claims) more than `limit` triangles.
fn check_triangle_count(path: &Path, count: u64, limit: u64) -> Result<(), LoadError> {
    if count > limit {
        return Err(LoadError::TooLarge { path: path.to_path_buf(), count, limit });
    }
    Ok(())
}

/// Loads a scene file, choosing the format by extension.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, LoadError> {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io { path: path.to_path_buf(), source })?;
    let mut scene = match extension.as_str() {
        "obj" => obj::load(path, &bytes, options.max_triangles)?,
        "gltf" | "glb" => gltf::load(path, &bytes, options.max_triangles)?,
        "ply" => ply::load(path, &bytes, options.max_triangles)?,
        _ => return Err(LoadError::UnknownFormat { path: path.to_path_buf(), extension }),
    };
    scene.name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    finish(path, &mut scene, options)?;
    Ok(scene)
}

/// The steps every loader shares: up axis, bad triangles, emptiness, scale.
fn finish(path: &Path, scene: &mut Scene, options: &LoadOptions) -> Result<(), LoadError> {
    let up = options.up.normalize_or(Vec3::Y);
    if up != Vec3::Y {
        let y_from_up = Quat::from_rotation_arc(up, Vec3::Y);
        scene.positions.iter_mut().for_each(|p| *p = y_from_up * *p);
        scene.normals.iter_mut().for_each(|n| *n = y_from_up * *n);
        for light in &mut scene.lights {
            match light {
                Light::Point { position, .. } => *position = y_from_up * *position,
                Light::Sun { direction, .. } => *direction = y_from_up * *direction,
            }
        }
    }
    scene.drop_bad_triangles();
    let stats = scene.stats;
    if stats.dropped_degenerate + stats.dropped_non_finite > 0 {
        tracing::warn!(
            "{}: dropped {} degenerate and {} non-finite triangles",
            path.display(),
            stats.dropped_degenerate,
            stats.dropped_non_finite
        );
    }
    if scene.triangles.is_empty() {
        let dropped = stats.dropped_degenerate + stats.dropped_non_finite;
        let dropped = if dropped > 0 { format!(" (all {dropped} were degenerate or had non-finite coordinates)") } else { String::new() };
        return Err(LoadError::Empty { path: path.to_path_buf(), dropped });
    }
    if let Some(m) = options.metres_per_unit {
        scene.metres_per_unit = m;
        scene.scale_source = ScaleSource::User;
    } else if scene.scale_source == ScaleSource::Guessed {
        scene.metres_per_unit = guess_metres_per_unit(&scene.bounds());
    }
    if let Err(e) = scene.validate() {
        return Err(LoadError::malformed(path, e));
    }
    Ok(())
}

/// Rejects binary data in a text format early, with a clear message, instead of
/// letting a text parser report a confusing error deep inside it.
fn require_text(path: &Path, bytes: &[u8], format: &str) -> Result<(), LoadError> {
    let head = &bytes[..bytes.len().min(64 * 1024)];
    if head.contains(&0) {
        return Err(LoadError::malformed(path, format!("this is binary data, not a text {format} file; is the extension right?")));
    }
    Ok(())
}

/// Finds `relative` under `dir`, matching each path component case-insensitively
/// when the exact name is missing (scenes made on Windows often differ in case),
/// and accepting backslashes as separators.
pub(crate) fn resolve_path(dir: &Path, relative: &str) -> Option<PathBuf> {
    let relative = relative.trim().replace('\\', "/");
    let exact = dir.join(&relative);
    if exact.is_file() {
        return Some(exact);
    }
    let mut current = dir.to_path_buf();
    for component in relative.split('/').filter(|c| !c.is_empty() && *c != ".") {
        if component == ".." {
            current.pop();
            continue;
        }
        let direct = current.join(component);
        if direct.exists() {
            current = direct;
            continue;
        }
        let lower = component.to_lowercase();
        let found = std::fs::read_dir(&current).ok()?.filter_map(|e| e.ok()).find(|e| e.file_name().to_string_lossy().to_lowercase() == lower)?;
        current = found.path();
    }
    current.is_file().then_some(current)
}

/// The largest texture side decoded: 16384² RGBA is 1 GiB, and panoramas of
/// 4096² faces never need more.
pub(crate) const MAX_TEXTURE_SIDE: u32 = 16384;

/// Decodes an image file into a texture; on failure logs a warning naming both
/// files and returns `None`, so the material keeps its colour.
pub(crate) fn decode_texture(scene_path: &Path, texture_path: &Path) -> Option<Texture> {
    let name = texture_path.display().to_string();
    match image::ImageReader::open(texture_path) {
        Ok(reader) => decode_image(scene_path, &name, reader),
        Err(e) => texture_warning(scene_path, &name, &format!("cannot be read ({e})")),
    }
}

/// Warns that texture `name` of the scene is not used, and why; `None`.
pub(crate) fn texture_warning(scene_path: &Path, name: &str, why: &str) -> Option<Texture> {
    tracing::warn!("{}: texture {name} {why}; using the material's colour", scene_path.display());
    None
}

/// Decodes an image (its format guessed from its first bytes: PNG, JPEG, TGA,
/// DDS, BMP, TIFF, GIF or WebP) into a texture named `name`, or warns naming
/// the scene and the image and returns `None`. Images over `MAX_TEXTURE_SIDE`
/// are refused from their header, before any allocation.
pub(crate) fn decode_image<R: std::io::BufRead + std::io::Seek>(scene_path: &Path, name: &str, reader: image::ImageReader<R>) -> Option<Texture> {
    let decoded = (|| {
        let mut reader = reader.with_guessed_format().map_err(|e| format!("cannot be read ({e})"))?;
        if reader.format().is_none() {
            let mut magic = [0u8; 12];
            let ktx2 = std::io::Read::read_exact(&mut reader.into_inner(), &mut magic).is_ok() && magic == *b"\xABKTX 20\xBB\r\n\x1A\n";
            return Err(if ktx2 { "is a KTX2 (Basis Universal) image, which ExploreMaps cannot decode" } else { "is in no image format ExploreMaps reads" }.to_string()
                + " (PNG, JPEG, TGA, DDS, BMP, TIFF, GIF and WebP are read)");
        }
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_TEXTURE_SIDE);
        limits.max_image_height = Some(MAX_TEXTURE_SIDE);
        limits.max_alloc = Some(2 * (MAX_TEXTURE_SIDE as u64).pow(2) * 4);
        reader.limits(limits);
        reader.decode().map_err(|e| match e {
            image::ImageError::Limits(_) => format!("is larger than {MAX_TEXTURE_SIDE} pixels on a side, the most ExploreMaps decodes (scale the image down to use it)"),
            e => format!("cannot be decoded ({e})"),
        })
    })();
    match decoded {
        Ok(img) => Some(Texture { name: name.to_string(), image: img.to_rgba8() }),
        Err(why) => texture_warning(scene_path, name, &why),
    }
}

#[cfg(test)]
mod tests;
