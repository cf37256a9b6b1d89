//! Scene files in and out: OBJ + MTL, glTF 2.0 / GLB and PLY files loaded
//! into one [`Scene`], and scenes (and the 3D stand-in) written as OBJ or GLB
//! by [`write`].
//!
//! Every loader returns a scene whose up axis is +Y (other up axes are rotated
//! into it), whose bad triangles are dropped and counted, and whose unit scale
//! is known (from the file, the user, or a reported guess). Errors name the file
//! and say what to do; a texture that cannot be read is a warning, not an error,
//! and its material keeps its plain colour.

mod gltf;
mod gltf_decode;
pub(crate) use gltf::LUMENS_PER_WATT;
mod obj;
mod ply;
pub mod write;

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
    #[error("cannot read {path}")]
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
        tracing::warn!("{}: dropped {} degenerate and {} non-finite triangles", path.display(), stats.dropped_degenerate, stats.dropped_non_finite);
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
/// DDS, BMP, TIFF, GIF, WebP or KTX2) into a texture named `name`, or warns naming
/// the scene and the image and returns `None`. Images over `MAX_TEXTURE_SIDE`
/// are refused from their header, before any allocation.
pub(crate) fn decode_image<R: std::io::BufRead + std::io::Seek>(scene_path: &Path, name: &str, reader: image::ImageReader<R>) -> Option<Texture> {
    let decoded = (|| {
        let mut reader = reader.with_guessed_format().map_err(|e| format!("cannot be read ({e})"))?;
        if reader.format().is_none() {
            // The `image` crate knows no KTX2: read it whole and transcode it
            // (at most 1 GiB, 16,384² RGBA8 uncompressed: Basis data is smaller).
            use std::io::Read;
            let mut input = reader.into_inner().take(1 << 30);
            let mut bytes = vec![0; KTX2_MAGIC.len()];
            if input.read_exact(&mut bytes).is_err() || bytes != KTX2_MAGIC {
                return Err("is in no image format ExploreMaps reads (PNG, JPEG, TGA, DDS, BMP, TIFF, GIF, WebP and KTX2 are read)".to_string());
            }
            input.read_to_end(&mut bytes).map_err(|e| format!("cannot be read ({e})"))?;
            return decode_ktx2(&bytes).map(image::DynamicImage::ImageRgba8);
        }
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_TEXTURE_SIDE);
        limits.max_image_height = Some(MAX_TEXTURE_SIDE);
        limits.max_alloc = Some(2 * (MAX_TEXTURE_SIDE as u64).pow(2) * 4);
        reader.limits(limits);
        reader.decode().map_err(|e| match e {
            image::ImageError::Limits(_) => {
                format!("is larger than {MAX_TEXTURE_SIDE} pixels on a side, the most ExploreMaps decodes (scale the image down to use it)")
            }
            e => format!("cannot be decoded ({e})"),
        })
    })();
    match decoded {
        Ok(img) => Some(Texture { name: name.to_string(), image: img.to_rgba8() }),
        Err(why) => texture_warning(scene_path, name, &why),
    }
}

const KTX2_MAGIC: &[u8; 12] = b"\xABKTX 20\xBB\r\n\x1A\n";

/// Transcodes the first level of a KTX2 image holding Basis Universal data
/// (ETC1S or UASTC, as glTF's `KHR_texture_basisu` requires) to RGBA8.
fn decode_ktx2(bytes: &[u8]) -> Result<image::RgbaImage, String> {
    let failed =
        |e: basisu::Error| format!("is a KTX2 image that cannot be transcoded ({e:?}; KTX2 textures must hold Basis Universal ETC1S or UASTC data)");
    check_ktx2_index(bytes).map_err(|why| format!("is a damaged KTX2 image ({why})"))?;
    let texture = basisu::Transcoder::new(bytes).map_err(failed)?;
    let (width, height) = texture.base_dimensions();
    if width == 0 || height == 0 {
        return Err("is a KTX2 image with no pixels".to_string());
    }
    if width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(format!("is larger than {MAX_TEXTURE_SIDE} pixels on a side, the most ExploreMaps decodes (scale the image down to use it)"));
    }
    let rgba = texture.transcode(0, basisu::TargetFormat::Rgba32, basisu::DecodeFlags::NONE).map_err(failed)?;
    image::RgbaImage::from_raw(width, height, rgba).ok_or_else(|| "is a KTX2 image whose transcoded size does not match its header".to_string())
}

/// Checks what the transcoder would trust in a KTX2 file's header: that its
/// index and levels lie inside the file, and that no level claims to inflate
/// to more than its blocks hold (a hostile length would otherwise be
/// allocated as given).
fn check_ktx2_index(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |o: usize| bytes.get(o..o + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()) as u64);
    let u64_at = |o: usize| bytes.get(o..o + 8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()));
    let [width, height, layers, faces, levels] = [20, 24, 32, 36, 40].map(|o| u32_at(o).unwrap_or(0));
    let size = bytes.len() as u64;
    let inside = |offset: u64, length: u64| offset.checked_add(length).is_some_and(|end| end <= size);
    // Index: data format descriptor, key/value data, supercompression data.
    let index = [(u32_at(48), u32_at(52)), (u32_at(56), u32_at(60)), (u64_at(64), u64_at(72))];
    if index.iter().any(|&(o, l)| o.zip(l).is_none_or(|(o, l)| !inside(o, l))) {
        return Err("its index points outside the file".to_string());
    }
    // Key/value entries: a length, that many bytes, padding to a multiple of
    // four; the transcoder's scan of them runs off the data where the padding
    // of an entry passes the end of the key/value data.
    if let (Some(offset), Some(length)) = index[1] {
        let (mut at, end) = (offset as usize, (offset + length) as usize);
        while end - at > 4 {
            let entry = u32_at(at).unwrap_or(0) as usize;
            at += 4;
            if entry < 2 || end - at < entry {
                break; // where the transcoder's scan stops too
            }
            at += entry;
            at += (4 - at % 4) % 4;
            if at > end {
                return Err("its key/value data overruns its length".to_string());
            }
        }
    }
    if levels > 16 || layers > 2048 || faces > 6 {
        return Err(format!("{levels} levels, {layers} layers, {faces} faces"));
    }
    // 16 bytes a 4 × 4 block, the most either Basis format stores.
    let most = [height.div_ceil(4), 16, layers.max(1), faces.max(1)].iter().fold(width.div_ceil(4), |n, &k| n.saturating_mul(k));
    for level in 0..levels.max(1) as usize {
        let at = 80 + 24 * level;
        let (Some(offset), Some(length), Some(inflated)) = (u64_at(at), u64_at(at + 8), u64_at(at + 16)) else {
            return Err("its level index is cut short".to_string());
        };
        if !inside(offset, length) || inflated > most {
            return Err(format!("level {level} lies outside the file or is larger than its size allows"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
