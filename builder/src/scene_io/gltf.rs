//! glTF 2.0 (`.gltf` with its buffers, or `.glb`) through the `gltf` crate:
//! node transforms applied, base colour factor and texture, alpha mode and
//! cutoff, emissive factor times `KHR_materials_emissive_strength`,
//! `KHR_lights_punctual` lights (at 683 lumens a watt), the
//! diffuse of `KHR_materials_pbrSpecularGlossiness`, `KHR_texture_transform`
//! on the colour texture; Draco- and meshoptimizer-compressed data,
//! quantized attributes, GPU instancing and WebP-only textures are made plain first
//! (`gltf_decode.rs`). Units are metres by the glTF specification. Images
//! are decoded here, each on its own, so a broken image is a warning, not a
//! failed load.

use super::obj::empty_scene;
use super::{check_triangle_count, LoadError};
use exploremaps_scenes::{AlphaMode, Light, Material, ScaleSource, Scene, Texture};
use glam::{Mat3, Mat4, Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The largest buffer or image file a glTF may name (`gltf` reads it whole).
const MAX_EXTERNAL_BYTES: u64 = 4 << 30;

pub(super) fn load(path: &Path, bytes: &[u8], max_triangles: u64) -> Result<Scene, LoadError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let (document, buffers) = read(path, dir, bytes, max_triangles)?;
    let (textures, texture_index) = decode_images(path, dir, &document, &buffers);
    let (mut materials, uv_maps) = materials(&document, &texture_index);
    materials.push(Material::diffuse("default", [0.8, 0.8, 0.8]));
    let mut scene = empty_scene(materials, textures);
    scene.scale_source = ScaleSource::File;
    scene.metres_per_unit = 1.0;
    scene.stats.missing_textures = texture_index.iter().filter(|t| t.is_none()).count();
    let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => document.nodes().collect(),
    };
    let mut memo = vec![None; document.nodes().len()];
    let mut count = 0u64;
    for node in &roots {
        count = count.saturating_add(instanced_triangles(path, node, 0, &mut memo)?.0);
    }
    check_triangle_count(path, count, max_triangles)?;
    let mut meshes = Meshes { path, buffers: &buffers, uv_maps: &uv_maps, with_normals: true, with_colours: true, scene };
    meshes.add_nodes(roots)?;
    let Meshes { mut scene, with_normals, with_colours, .. } = meshes;
    if !with_normals || scene.normals.len() != scene.positions.len() {
        scene.normals.clear();
    }
    if !with_colours || scene.colours.len() != scene.positions.len() {
        scene.colours.clear();
    }
    Ok(scene)
}

/// The document and its buffers, the file made plain first where it is
/// compressed, quantized or instanced.
fn read(path: &Path, dir: &Path, bytes: &[u8], max_triangles: u64) -> Result<(gltf::Document, Vec<gltf::buffer::Data>), LoadError> {
    let bad = |e: gltf::Error| LoadError::malformed(path, format!("not a valid glTF file ({e}); it may be truncated or corrupt"));
    let (plain, read) = super::gltf_decode::transcode(path, bytes, dir, max_triangles)?.unzip();
    let bytes = plain.as_deref().unwrap_or(bytes);
    // gltf-json 1.4.1 validation indexes a primitive's POSITION accessor
    // before checking it exists (mesh.rs:151): that panic is a malformed file.
    let parsed = std::panic::catch_unwind(|| gltf::Gltf::from_slice(bytes)).map_err(|_| {
        LoadError::malformed(path, "not a valid glTF file (an attribute names an accessor that does not exist); it may be truncated or corrupt")
    })?;
    let gltf::Gltf { document, blob } = parsed.map_err(|e| match unsupported_required(bytes) {
        Some(names) => LoadError::malformed(
            path,
            format!("the file requires the glTF extension {names}, which ExploreMaps cannot read; export the scene again without it (Draco and meshoptimizer compression, mesh quantization, GPU instancing, WebP textures, KHR_materials_pbrSpecularGlossiness and KHR_texture_transform are read)"),
        ),
        None => bad(e),
    })?;
    check_image_sources(path, &document)?;
    check_external_files(path, dir, &document)?;
    let buffers = match read {
        Some(read) => transcoded_buffers(path, &document, read)?,
        None => gltf::import_buffers(&document, Some(dir), blob).map_err(bad)?,
    };
    Ok((document, buffers))
}

/// A transcoded file's buffers, read already: each must be as long as
/// declared (as `gltf` checks), and is padded to four bytes as `gltf` pads
/// them.
fn transcoded_buffers(path: &Path, document: &gltf::Document, read: Vec<Vec<u8>>) -> Result<Vec<gltf::buffer::Data>, LoadError> {
    let held = |b: &gltf::Buffer| read.get(b.index()).map_or(0, Vec::len);
    if let Some(b) = document.buffers().find(|b| held(b) < b.length()) {
        // (Named by its URI: a transcoded file's buffers are numbered
        // from one when a first was added for the decoded data.)
        let what = match b.source() {
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => format!(
                "buffer {uri} holds {} bytes of the {} it declares; the file beside the scene may be missing or truncated",
                held(&b),
                b.length()
            ),
            _ => format!("a buffer's data URI holds {} bytes of the {} it declares", held(&b), b.length()),
        };
        return Err(LoadError::malformed(path, what));
    }
    Ok(read
        .into_iter()
        .map(|mut bytes| {
            bytes.resize(bytes.len().next_multiple_of(4), 0);
            gltf::buffer::Data(bytes)
        })
        .collect())
}

/// The images decoded here rather than by `gltf` (PNG and JPEG only, no
/// size limit), in parallel, each a warning if it fails: the decoded ones,
/// and per glTF image its index among them.
fn decode_images(path: &Path, dir: &Path, document: &gltf::Document, buffers: &[gltf::buffer::Data]) -> (Vec<Texture>, Vec<Option<usize>>) {
    let images: Vec<gltf::Image> = document.images().collect();
    let decoded: Vec<Option<Texture>> = images.par_iter().map(|image| decode_gltf_image(path, dir, image, buffers)).collect();
    let mut textures = Vec::new();
    let index = decoded
        .into_iter()
        .map(|t| {
            t.map(|t| {
                textures.push(t);
                textures.len() - 1
            })
        })
        .collect();
    (textures, index)
}

/// The materials, and each one's colour texture coordinates: the set it
/// reads and its `KHR_texture_transform` (applied to the coordinates of the
/// primitives drawn with it, as a material has one texture here).
fn materials(document: &gltf::Document, texture_index: &[Option<usize>]) -> (Vec<Material>, Vec<UvMap>) {
    document
        .materials()
        .map(|m| {
            // `KHR_materials_pbrSpecularGlossiness`'s diffuse, where given,
            // stands for the base colour (older exporters write only it).
            let (factor, info) = match m.pbr_specular_glossiness() {
                Some(sg) => (sg.diffuse_factor(), sg.diffuse_texture()),
                None => (m.pbr_metallic_roughness().base_color_factor(), m.pbr_metallic_roughness().base_color_texture()),
            };
            let uv_map = info.as_ref().map_or(UvMap::default(), UvMap::of);
            let texture = info.and_then(|t| texture_index.get(t.texture().source().index()).copied().flatten());
            let material = Material {
                name: m.name().map(str::to_string).unwrap_or_else(|| format!("material {}", m.index().unwrap_or(0))),
                base_color: factor,
                base_color_texture: texture,
                alpha_mode: match m.alpha_mode() {
                    gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                    gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: m.alpha_cutoff().unwrap_or(0.5) },
                    gltf::material::AlphaMode::Blend => AlphaMode::Blend,
                },
                emissive: Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0),
            };
            (material, uv_map)
        })
        .unzip()
}

/// The scene as its nodes' meshes and lights are added to it.
struct Meshes<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    uv_maps: &'a [UvMap],
    /// Whether every primitive so far had normals, and vertex colours.
    with_normals: bool,
    with_colours: bool,
    scene: Scene,
}

impl Meshes<'_> {
    /// Adds the nodes under `roots`, transformed to the world.
    fn add_nodes(&mut self, roots: Vec<gltf::Node>) -> Result<(), LoadError> {
        let mut stack: Vec<(gltf::Node, Mat4, usize)> = roots.into_iter().map(|n| (n, Mat4::IDENTITY, 0)).collect();
        while let Some((node, parent, depth)) = stack.pop() {
            if depth > 64 {
                return Err(LoadError::malformed(self.path, "node hierarchy deeper than 64 levels (a cycle?)"));
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            if let Some(light) = node.light() {
                if let Some(l) = punctual_light(self.path, &light, world) {
                    self.scene.lights.push(l);
                }
            }
            if let Some(mesh) = node.mesh() {
                let object = self.scene.objects.len() as u32;
                self.scene.objects.push(node.name().or(mesh.name()).map(str::to_string).unwrap_or_else(|| format!("node {}", node.index())));
                for primitive in mesh.primitives() {
                    self.add_primitive(&mesh, &primitive, world, object)?;
                }
            }
            stack.extend(node.children().map(|c| (c, world, depth + 1)));
        }
        Ok(())
    }

    /// Adds a primitive's triangles, with their vertices' attributes.
    fn add_primitive(&mut self, mesh: &gltf::Mesh, primitive: &gltf::Primitive, world: Mat4, object: u32) -> Result<(), LoadError> {
        let (path, scene) = (self.path, &mut self.scene);
        if primitive.mode() != gltf::mesh::Mode::Triangles {
            tracing::warn!("{}: skipping a {:?} primitive in mesh {}; only triangles are scenes", path.display(), primitive.mode(), mesh.index());
            return Ok(());
        }
        check_attribute_types(path, primitive)?;
        let reader = primitive.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
        let Some(positions) = reader.read_positions() else { return Ok(()) };
        let base = scene.positions.len() as u32;
        scene.positions.extend(positions.map(|p| world.transform_point3(Vec3::from(p))));
        let count = scene.positions.len() - base as usize;
        match reader.read_normals() {
            Some(normals) if self.with_normals => {
                let normal_from_local = Mat3::from_mat4(world).inverse().transpose();
                scene.normals.extend(normals.map(|n| (normal_from_local * Vec3::from(n)).normalize_or_zero()));
            }
            _ => self.with_normals = false,
        }
        let uv_map = primitive.material().index().and_then(|m| self.uv_maps.get(m)).copied().unwrap_or_default();
        match reader.read_tex_coords(uv_map.set) {
            Some(uv) => scene.uvs.extend(uv.into_f32().map(|uv| uv_map.apply(Vec2::from(uv)))),
            None => scene.uvs.extend(std::iter::repeat_n(Vec2::ZERO, count)),
        }
        // Vertex colours (linear, as glTF states them) where every primitive has them.
        match reader.read_colors(0) {
            Some(c) if self.with_colours => scene.colours.extend(c.into_rgb_f32().map(Vec3::from)),
            _ => self.with_colours = false,
        }
        scene.uvs.truncate(scene.positions.len());
        scene.uvs.resize(scene.positions.len(), Vec2::ZERO);
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..count as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= count) {
            return Err(LoadError::malformed(path, format!("mesh {} indexes vertex {bad}, but the primitive has {count}", mesh.index())));
        }
        // The default material is the last.
        let material = primitive.material().index().map_or(self.uv_maps.len() as u32, |m| m as u32);
        for tri in indices.chunks_exact(3) {
            scene.triangles.push([base + tri[0], base + tri[1], base + tri[2]]);
            scene.triangle_material.push(material);
            scene.triangle_object.push(object);
        }
        Ok(())
    }
}

/// Lumens a watt: `KHR_lights_punctual` gives candela and lux, the renderer
/// radiant intensity and irradiance; Blender converts its watts to those
/// units at this efficacy, so its lights come back as they were made.
pub(crate) const LUMENS_PER_WATT: f32 = 683.0;

/// A `KHR_lights_punctual` light in the scene's lights. A spot light is lit as
/// a point light of its intensity (the renderer has no cones), said once per light.
fn punctual_light(path: &Path, light: &gltf::khr_lights_punctual::Light, world: Mat4) -> Option<Light> {
    use gltf::khr_lights_punctual::Kind;
    let power = Vec3::from(light.color()) * light.intensity() / LUMENS_PER_WATT;
    if !power.is_finite() || power.min_element() < 0.0 || power == Vec3::ZERO {
        return None;
    }
    match light.kind() {
        // A directional light shines along its node's -Z: the sun lies toward +Z.
        Kind::Directional => Some(Light::Sun { direction: world.transform_vector3(Vec3::Z).try_normalize()?, irradiance: power }),
        kind => {
            if matches!(kind, Kind::Spot { .. }) {
                tracing::warn!("{}: spot light {} is lit as a point light (no cone)", path.display(), light.name().unwrap_or("without a name"));
            }
            let position = world.transform_point3(Vec3::ZERO);
            position.is_finite().then_some(Light::Point { position, intensity: power })
        }
    }
}

/// Which texture coordinates a material's colour texture reads, and their
/// `KHR_texture_transform` (offset · rotation · scale, as the extension
/// defines it), as the two rows of a 2×3 affine map.
#[derive(Clone, Copy, Debug)]
struct UvMap {
    set: u32,
    rows: [[f32; 3]; 2],
}

impl Default for UvMap {
    fn default() -> UvMap {
        UvMap { set: 0, rows: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] }
    }
}

impl UvMap {
    fn of(info: &gltf::texture::Info) -> UvMap {
        let Some(t) = info.texture_transform() else { return UvMap { set: info.tex_coord(), ..UvMap::default() } };
        let ([ox, oy], [sx, sy], (sin, cos)) = (t.offset(), t.scale(), t.rotation().sin_cos());
        UvMap { set: t.tex_coord().unwrap_or(info.tex_coord()), rows: [[cos * sx, sin * sy, ox], [-sin * sx, cos * sy, oy]] }
    }
    fn apply(&self, uv: Vec2) -> Vec2 {
        let [a, b] = self.rows;
        Vec2::new(a[0] * uv.x + a[1] * uv.y + a[2], b[0] * uv.x + b[1] * uv.y + b[2])
    }
}

/// The extensions a file requires that `gltf` does not read, when its JSON
/// can be read at all.
fn unsupported_required(bytes: &[u8]) -> Option<String> {
    let (json, _) = super::gltf_decode::split(bytes)?;
    let doc: serde_json::Value = serde_json::from_slice(json).ok()?;
    let names: Vec<&str> = doc
        .get("extensionsRequired")?
        .as_array()?
        .iter()
        .filter_map(|e| e.as_str())
        .filter(|e| !gltf::json::extensions::ENABLED_EXTENSIONS.contains(e))
        .collect();
    (!names.is_empty()).then(|| names.join(", "))
}

/// Checks that each image has a source: gltf 1.4's `Image::source` unwraps an
/// image's URI when it has no buffer view, and its MIME type when it has one,
/// and its validation checks neither.
fn check_image_sources(path: &Path, document: &gltf::Document) -> Result<(), LoadError> {
    for (i, image) in document.as_json().images.iter().enumerate() {
        let missing = match image.buffer_view {
            Some(_) => image.mime_type.is_none().then_some("a bufferView but no mimeType"),
            None => image.uri.is_none().then_some("neither a uri nor a bufferView"),
        };
        if let Some(missing) = missing {
            return Err(LoadError::malformed(path, format!("image {i} has {missing}, which glTF requires; the file may be truncated or corrupt")));
        }
    }
    Ok(())
}

/// Checks the files a glTF's buffers and images name before `gltf` reads them
/// whole: each must be a regular file (a URI naming /dev/zero or a pipe would
/// never end) of at most `MAX_EXTERNAL_BYTES`, and its name must decode to
/// UTF-8 (gltf 1.4 panics on one that does not). Missing files are left to
/// `gltf`, whose error names them.
fn check_external_files(path: &Path, dir: &Path, document: &gltf::Document) -> Result<(), LoadError> {
    let buffers = document.buffers().filter_map(|b| match b.source() {
        gltf::buffer::Source::Uri(uri) => Some((format!("buffer {}", b.index()), uri)),
        gltf::buffer::Source::Bin => None,
    });
    let images = document.images().filter_map(|i| match i.source() {
        gltf::image::Source::Uri { uri, .. } => Some((format!("image {}", i.index()), uri)),
        gltf::image::Source::View { .. } => None,
    });
    for (what, uri) in buffers.chain(images) {
        // data: URIs are decoded in memory; other schemes are refused by gltf.
        if let Some(file) = uri_file(dir, uri) {
            let file = file.map_err(|()| LoadError::malformed(path, format!("{what}'s URI '{uri}' does not decode to a UTF-8 file name")))?;
            check_file(path, &file, &what)?;
        }
    }
    Ok(())
}

/// The file a URI names (relative to the glTF's directory, or a `file:`
/// URI); `None` for a `data:` URI or another scheme, `Err` for a name that
/// does not decode to UTF-8.
pub(super) fn uri_file(dir: &Path, uri: &str) -> Option<Result<PathBuf, ()>> {
    if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        Some(Ok(PathBuf::from(rest)))
    } else if uri.contains(':') {
        None
    } else {
        Some(urlencoding::decode(uri).map(|name| dir.join(&*name)).map_err(|_| ()))
    }
}

/// One glTF image as a texture: from its buffer view, a `data:` URI or a
/// file beside the scene (already checked by `check_external_files`); a
/// warning and `None` where it cannot be read or decoded.
fn decode_gltf_image(path: &Path, dir: &Path, image: &gltf::Image, buffers: &[gltf::buffer::Data]) -> Option<Texture> {
    let warn = |name: &str, why: &str| super::texture_warning(path, name, why);
    let name = image.name().map(str::to_string);
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let name = name.unwrap_or_else(|| format!("image {}", image.index()));
            let start = view.offset();
            match buffers.get(view.buffer().index()).and_then(|b| b.get(start..start.checked_add(view.length())?)) {
                Some(bytes) => super::decode_image(path, &name, image::ImageReader::new(std::io::Cursor::new(bytes))),
                None => warn(&name, &format!("lies outside its buffer (buffer view {})", view.index())),
            }
        }
        gltf::image::Source::Uri { uri, .. } => {
            let name = name.unwrap_or_else(|| if uri.starts_with("data:") { format!("image {}", image.index()) } else { uri.to_string() });
            match uri_file(dir, uri) {
                Some(Ok(file)) => match image::ImageReader::open(&file) {
                    Ok(reader) => super::decode_image(path, &name, reader),
                    Err(e) => warn(&name, &format!("cannot be read from {} ({e})", file.display())),
                },
                Some(Err(())) => warn(&name, "has a URI that does not decode to a UTF-8 file name"),
                None => match uri.strip_prefix("data:").and_then(|d| d.split_once(";base64,")).map(|(_, payload)| base64::decode(payload)) {
                    Some(Ok(bytes)) => super::decode_image(path, &name, image::ImageReader::new(std::io::Cursor::new(&bytes[..]))),
                    _ => warn(&name, "has a URI that is neither a file nor base64 data"),
                },
            }
        }
    }
}

/// A file a glTF names must be a regular file of at most `MAX_EXTERNAL_BYTES`
/// (a missing one passes: its reader's error names it).
pub(super) fn check_file(path: &Path, file: &Path, what: &str) -> Result<(), LoadError> {
    match std::fs::metadata(file) {
        Ok(m) if !m.is_file() => Err(LoadError::malformed(path, format!("{what} names {}, which is not a regular file", file.display()))),
        Ok(m) if m.len() > MAX_EXTERNAL_BYTES => Err(LoadError::malformed(
            path,
            format!(
                "{what} names {}, of {:.1} GiB; buffers and images of at most {} GiB are read",
                file.display(),
                m.len() as f64 / (1u64 << 30) as f64,
                MAX_EXTERNAL_BYTES >> 30
            ),
        )),
        _ => Ok(()),
    }
}

/// The most node instances a scene's hierarchy may make.
pub(super) const MAX_NODE_INSTANCES: u64 = 1 << 24;

/// The triangles and node instances a node and its descendants make, from
/// the accessors' counts, before any data is read; saturating and memoized
/// per node, as a hierarchy can name the same child many times at every level.
fn instanced_triangles(path: &Path, node: &gltf::Node, depth: usize, memo: &mut [Option<(u64, u64)>]) -> Result<(u64, u64), LoadError> {
    if depth > 64 {
        return Err(LoadError::malformed(path, "node hierarchy deeper than 64 levels (a cycle?)"));
    }
    if let Some(counts) = memo[node.index()] {
        return Ok(counts);
    }
    let own: u64 = node.mesh().map_or(0, |mesh| {
        let triangles = mesh.primitives().filter(|p| p.mode() == gltf::mesh::Mode::Triangles);
        triangles.map(|p| p.indices().or_else(|| p.get(&gltf::Semantic::Positions)).map_or(0, |a| a.count() as u64 / 3)).sum()
    });
    let (mut triangles, mut instances) = (own, 1u64);
    for child in node.children() {
        let (t, i) = instanced_triangles(path, &child, depth + 1, memo)?;
        (triangles, instances) = (triangles.saturating_add(t), instances.saturating_add(i));
    }
    if instances > MAX_NODE_INSTANCES {
        return Err(LoadError::malformed(
            path,
            format!("its node hierarchy makes more than {MAX_NODE_INSTANCES} node instances (children named many times over)"),
        ));
    }
    memo[node.index()] = Some((triangles, instances));
    Ok((triangles, instances))
}

/// The component types and shapes the glTF specification allows for the
/// attributes read here, and a count of at least one. gltf 1.4 does not
/// validate them, and its readers reach `unreachable!()` on other types
/// (indices of floats) and overflow on a count of 0 (both found by fuzzing).
fn check_attribute_types(path: &Path, primitive: &gltf::Primitive) -> Result<(), LoadError> {
    use gltf::accessor::{DataType::*, Dimensions::*};
    use gltf::Semantic;
    // `None` is the index list.
    let allowed = |semantic: Option<&Semantic>, a: &gltf::Accessor| match semantic {
        None => matches!((a.data_type(), a.dimensions()), (U8 | U16 | U32, Scalar)),
        Some(Semantic::Positions | Semantic::Normals) => matches!((a.data_type(), a.dimensions()), (F32, Vec3)),
        Some(Semantic::TexCoords(_)) => matches!((a.data_type(), a.dimensions()), (F32 | U8 | U16, Vec2)),
        Some(Semantic::Colors(_)) => matches!((a.data_type(), a.dimensions()), (F32 | U8 | U16, Vec3 | Vec4)),
        Some(Semantic::Joints(_)) => matches!(a.data_type(), U8 | U16),
        Some(_) => true,
    };
    let indices = primitive.indices().map(|a| (None, a));
    for (semantic, a) in indices.into_iter().chain(primitive.attributes().map(|(s, a)| (Some(s), a))) {
        // The specification's minimum; gltf's reader computes `count - 1`.
        if a.count() == 0 {
            return Err(LoadError::malformed(path, format!("accessor {} has a count of 0; glTF requires at least 1", a.index())));
        }
        let what = || semantic.as_ref().map_or("indices".to_string(), |s| format!("{s:?}"));
        if !allowed(semantic.as_ref(), &a) {
            return Err(LoadError::malformed(
                path,
                format!("accessor {} ({}) holds {:?} {:?}, which glTF does not allow there", a.index(), what(), a.dimensions(), a.data_type()),
            ));
        }
        // Elements may not overlap (gltf's reader asserts it).
        if let Some(stride) = a.view().and_then(|v| v.stride()).filter(|&s| s < a.size()) {
            return Err(LoadError::malformed(
                path,
                format!(
                    "accessor {} ({}) has elements of {} bytes {stride} bytes apart; glTF requires at least the element's size",
                    a.index(),
                    what(),
                    a.size()
                ),
            ));
        }
    }
    Ok(())
}
