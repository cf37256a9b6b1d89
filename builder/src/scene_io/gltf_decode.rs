//! The glTF extensions the `gltf` crate cannot read, decoded into a plain
//! glTF in memory before it reads the file, so the glTF loader and its
//! validation stay as they are: meshoptimizer-compressed buffer views
//! (`EXT_meshopt_compression` and `KHR_meshopt_compression`, decoded by
//! meshoptimizer itself, whose decoders are written for untrusted input),
//! Draco-compressed meshes (`KHR_draco_mesh_compression`, decoded by the
//! pure-Rust `draco-core`), quantized attributes (`KHR_mesh_quantization`:
//! byte and short positions, normals and texture coordinates, as `gltfpack`
//! writes them), meshes drawn many times by `EXT_mesh_gpu_instancing` (a
//! child node per instance), and textures whose image is given only by
//! `EXT_texture_webp` or `KHR_texture_basisu` (the image is then named as the
//! texture's source; WebP decodes, and KTX2 is transcoded by `basisu`).
//!
//! Decoded data goes in new buffer views of the first buffer (a GLB's own
//! chunk, which stays its first buffer; a `.gltf` gets a new first buffer).
//! Each compressed primitive's indices and named attributes, and each
//! quantized attribute, get accessors of plain `u32` and `f32` data. The
//! extensions are then dropped from the file's lists. The loader is handed
//! the new JSON and the buffers as they are here, so that nothing is read
//! or copied again.

use super::LoadError;
use draco_core::{decoder_buffer::DecoderBuffer, mesh::Mesh, mesh_decoder::MeshDecoder};
use serde_json::{json, Value};
use std::path::Path;

const EXTENSION: &str = "KHR_draco_mesh_compression";
const QUANTIZATION: &str = "KHR_mesh_quantization";
const MESHOPT: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];
const IMAGE_SOURCES: [&str; 2] = ["EXT_texture_webp", "KHR_texture_basisu"];
const INSTANCING: &str = "EXT_mesh_gpu_instancing";
/// The most bytes meshoptimizer-compressed views may decode to, together.
const MAX_DECODED_BYTES: u64 = 4 << 30;
const GLB_MAGIC: &[u8; 4] = b"glTF";
const JSON_CHUNK: u32 = 0x4E4F_534A;
const BIN_CHUNK: u32 = 0x004E_4942;

/// A plain glTF's JSON and its buffers' bytes (see [`transcode`]).
pub(super) type Transcoded = (Vec<u8>, Vec<Vec<u8>>);

/// The file as plain glTF when it uses any of the extensions above: its
/// JSON, and its buffers' bytes as read and decoded here (the first, which
/// has no URI, holding the decoded data), to be used as they are: files
/// beside the scene are not read again and no buffer is copied into a new
/// GLB. `None` otherwise (and for anything unreadable, which `gltf` then
/// reports as it does). `max_triangles` bounds each primitive's declared
/// index count and each compressed view's count before decoding.
pub(super) fn transcode(path: &Path, bytes: &[u8], dir: &Path, max_triangles: u64) -> Result<Option<Transcoded>, LoadError> {
    let Some((json_bytes, bin)) = split(bytes) else { return Ok(None) };
    let Ok(mut doc) = serde_json::from_slice::<Value>(json_bytes) else { return Ok(None) };
    let used = |name: &str| {
        ["extensionsUsed", "extensionsRequired"]
            .iter()
            .any(|list| doc.get(list).and_then(Value::as_array).is_some_and(|l| l.iter().any(|e| e == name)))
    };
    let quantized = used(QUANTIZATION);
    if ![EXTENSION, QUANTIZATION, INSTANCING].iter().chain(&MESHOPT).chain(&IMAGE_SOURCES).any(|e| used(e)) {
        return Ok(None);
    }
    let mut buffers = read_buffers(path, &doc, bin, dir)?;
    add_decoded_chunk(&mut doc, &mut buffers, bin.is_some());
    decode_meshopt_views(path, &mut doc, &mut buffers, max_triangles)?;
    name_image_sources(&mut doc);
    expand_instances(path, &mut doc, &buffers)?;
    let mut plain = Plain {
        old_views: doc.get("bufferViews").and_then(Value::as_array).map_or(0, Vec::len),
        views: Vec::new(),
        accessors: doc.get("accessors").and_then(Value::as_array).cloned().unwrap_or_default(),
        buffers,
    };
    let mut meshes = doc.get_mut("meshes").and_then(Value::as_array_mut).map(std::mem::take).unwrap_or_default();
    for (m, mesh) in meshes.iter_mut().enumerate() {
        for (p, primitive) in mesh.get_mut("primitives").and_then(Value::as_array_mut).into_iter().flatten().enumerate() {
            plain.decode_draco(path, &doc, primitive, &format!("mesh {m} primitive {p}"), max_triangles)?;
        }
    }
    if quantized {
        plain.dequantize(path, &doc, &meshes)?;
    }
    Ok(Some(plain.into_document(doc, meshes)))
}

/// Decoded data goes to the binary chunk, `buffers[0]`: a GLB's own, or a
/// new first buffer before a `.gltf`'s (every view then moves up one).
fn add_decoded_chunk(doc: &mut Value, buffers: &mut Vec<Vec<u8>>, has_chunk: bool) {
    if has_chunk && doc.get("buffers").and_then(|b| b.get(0)).is_some_and(|b| b.get("uri").is_none()) {
        return;
    }
    let shift = |at: &mut Value| {
        if let Some(b) = at.get("buffer").and_then(Value::as_u64) {
            at["buffer"] = json!(b + 1);
        }
    };
    for v in doc.get_mut("bufferViews").and_then(Value::as_array_mut).into_iter().flatten() {
        shift(v);
        for e in MESHOPT {
            if let Some(x) = v.get_mut("extensions").and_then(|x| x.get_mut(e)) {
                shift(x);
            }
        }
    }
    buffers.insert(0, Vec::new());
    match doc.get_mut("buffers").and_then(Value::as_array_mut) {
        Some(list) => list.insert(0, json!({ "byteLength": 0 })),
        None => doc["buffers"] = json!([{ "byteLength": 0 }]),
    }
}

/// The file's accessors and buffers as they are made plain: new views (after
/// the file's `old_views`) of decoded data appended to `buffers[0]`.
struct Plain {
    old_views: usize,
    views: Vec<Value>,
    accessors: Vec<Value>,
    buffers: Vec<Vec<u8>>,
}

impl Plain {
    /// Appends data to the chunk in a new view; returns the view's index.
    fn push_view(&mut self, bytes: &[u8]) -> usize {
        self.views.push(append(&mut self.buffers[0], bytes));
        self.old_views + self.views.len() - 1
    }

    /// A Draco-compressed primitive (`at` names it) made plain: its indices
    /// as u32 and each attribute as f32, each in its accessor.
    fn decode_draco(&mut self, path: &Path, doc: &Value, primitive: &mut Value, at: &str, max_triangles: u64) -> Result<(), LoadError> {
        let bad = |detail: String| LoadError::malformed(path, format!("{detail} (in its {EXTENSION} data); the file may be truncated or corrupt"));
        let Some(ext) = primitive.get_mut("extensions").and_then(Value::as_object_mut).and_then(|e| e.remove(EXTENSION)) else { return Ok(()) };
        let view = ext.get("bufferView").and_then(Value::as_u64).ok_or_else(|| bad(format!("{at} names no bufferView")))?;
        let compressed =
            view_bytes(doc, &self.buffers, view as usize).ok_or_else(|| bad(format!("{at}'s bufferView {view} lies outside its buffer")))?;
        let indices = primitive.get("indices").and_then(Value::as_u64);
        let declared = indices.and_then(|a| self.accessors.get(a as usize)).and_then(|a| a.get("count")).and_then(Value::as_u64).unwrap_or(0);
        if declared / 3 > max_triangles {
            return Err(LoadError::TooLarge { path: path.to_path_buf(), count: declared / 3, limit: max_triangles });
        }
        let mesh = decode(compressed).map_err(|e| bad(format!("{at} does not decode: {e}")))?;

        // Indices: u32, one accessor.
        let faces = mesh.faces();
        let bytes: Vec<u8> = faces.iter().flat_map(|face| face.iter().flat_map(|corner| corner.0.to_le_bytes())).collect();
        let indices_accessor = json!({ "bufferView": self.push_view(&bytes), "componentType": 5125, "count": 3 * faces.len(), "type": "SCALAR" });
        match indices {
            Some(a) if (a as usize) < self.accessors.len() => self.accessors[a as usize] = indices_accessor,
            _ => {
                self.accessors.push(indices_accessor);
                primitive["indices"] = json!(self.accessors.len() - 1);
            }
        }
        // Attributes: f32, each to its accessor, with the components it declares.
        let ids: Vec<(String, u64)> =
            ext.get("attributes").and_then(Value::as_object).into_iter().flatten().filter_map(|(k, v)| Some((k.clone(), v.as_u64()?))).collect();
        for (name, id) in ids {
            let accessor = primitive.get("attributes").and_then(|a| a.get(&name)).and_then(Value::as_u64);
            let Some(a) = accessor.map(|a| a as usize).filter(|&a| a < self.accessors.len()) else { continue };
            let kind = self.accessors[a].get("type").and_then(Value::as_str).unwrap_or("VEC3").to_string();
            let components = match kind.as_str() {
                "SCALAR" => 1,
                "VEC2" => 2,
                "VEC3" => 3,
                "VEC4" => 4,
                other => return Err(bad(format!("{at}'s attribute {name} is of type {other}"))),
            };
            let attribute = u32::try_from(id)
                .ok()
                .and_then(|id| mesh.attribute_by_unique_id(id))
                .ok_or_else(|| bad(format!("{at} has no attribute {id} for {name}")))?;
            let mut values = attribute.read_f32s(mesh.num_points(), components);
            if attribute.normalized() {
                let scale = match attribute.data_type() {
                    draco_core::draco_types::DataType::Uint8 => 255.0,
                    draco_core::draco_types::DataType::Int8 => 127.0,
                    draco_core::draco_types::DataType::Uint16 => 65535.0,
                    draco_core::draco_types::DataType::Int16 => 32767.0,
                    _ => 1.0,
                };
                values.iter_mut().for_each(|v| *v = (*v / scale).max(-1.0));
            }
            let mut plain =
                json!({ "bufferView": self.push_view(&floats(&values)), "componentType": 5126, "count": mesh.num_points(), "type": kind });
            // Positions keep their bounds (glTF requires them).
            for key in ["min", "max"] {
                if let Some(b) = self.accessors[a].get(key) {
                    plain[key] = b.clone();
                }
            }
            self.accessors[a] = plain;
        }
        Ok(())
    }

    /// Every attribute read that is not already f32, as f32 (an accessor
    /// shared by primitives is converted once: it is f32 after).
    fn dequantize(&mut self, path: &Path, doc: &Value, meshes: &[Value]) -> Result<(), LoadError> {
        for primitive in meshes.iter().flat_map(|m| m.get("primitives").and_then(Value::as_array).into_iter().flatten()) {
            for (name, a) in primitive.get("attributes").and_then(Value::as_object).into_iter().flatten() {
                let read = name == "POSITION" || name == "NORMAL" || name.starts_with("TEXCOORD_");
                let Some(a) = a.as_u64().map(|a| a as usize).filter(|&a| read && a < self.accessors.len()) else { continue };
                if self.accessors[a].get("componentType").and_then(Value::as_u64) == Some(5126) {
                    continue;
                }
                let (values, kind) = read_accessor(doc, &self.buffers, &self.accessors[a]).ok_or_else(|| {
                    LoadError::malformed(path, format!("accessor {a} ({name}) is not a quantized attribute {QUANTIZATION} allows, or lies outside its buffer; the file may be truncated or corrupt"))
                })?;
                let count = self.accessors[a]["count"].clone();
                let mut plain = json!({ "bufferView": self.push_view(&floats(&values)), "componentType": 5126, "count": count, "type": kind });
                if name == "POSITION" {
                    // glTF requires a position accessor's bounds: those of the values.
                    let (lo, hi) = values.chunks_exact(3).fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
                        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
                    });
                    (plain["min"], plain["max"]) = (json!(lo), json!(hi));
                }
                self.accessors[a] = plain;
            }
        }
        Ok(())
    }

    /// The plain document's JSON, with its buffers; the extensions made
    /// plain are no longer used.
    fn into_document(self, mut doc: Value, meshes: Vec<Value>) -> Transcoded {
        let mut all_views = doc.get("bufferViews").and_then(Value::as_array).cloned().unwrap_or_default();
        all_views.extend(self.views);
        doc["buffers"][0]["byteLength"] = json!(self.buffers[0].len());
        doc["meshes"] = json!(meshes);
        doc["accessors"] = json!(self.accessors);
        doc["bufferViews"] = json!(all_views);
        for list in ["extensionsUsed", "extensionsRequired"] {
            if let Some(l) = doc.get_mut(list).and_then(Value::as_array_mut) {
                l.retain(|e| ![EXTENSION, QUANTIZATION, INSTANCING].iter().chain(&MESHOPT).chain(&IMAGE_SOURCES).any(|x| e == x));
            }
        }
        (serde_json::to_vec(&doc).expect("a JSON value serializes"), self.buffers)
    }
}

/// Decodes every meshoptimizer-compressed buffer view into the chunk
/// (`buffers[0]`) and points the view there; fallback buffers (which hold
/// no data) become a byte of inline data so `gltf` can load them.
fn decode_meshopt_views(path: &Path, doc: &mut Value, buffers: &mut [Vec<u8>], max_triangles: u64) -> Result<(), LoadError> {
    let mut total = 0u64;
    let count = doc.get("bufferViews").and_then(Value::as_array).map_or(0, Vec::len);
    for i in 0..count {
        let view = &doc["bufferViews"][i];
        let Some((name, ext)) = MESHOPT.iter().find_map(|e| Some((*e, view.get("extensions")?.get(*e)?.clone()))) else { continue };
        let bad =
            |detail: &str| LoadError::malformed(path, format!("buffer view {i} {detail} (in its {name} data); the file may be truncated or corrupt"));
        let field = |key: &str| ext.get(key).and_then(Value::as_u64);
        let (Some(buffer), Some(length), Some(stride), Some(count)) = (field("buffer"), field("byteLength"), field("byteStride"), field("count"))
        else {
            return Err(bad("lacks one of buffer, byteLength, byteStride and count"));
        };
        let offset = field("byteOffset").unwrap_or(0);
        let mode = ext.get("mode").and_then(Value::as_str).unwrap_or("");
        let filter = ext.get("filter").and_then(Value::as_str).unwrap_or("NONE");
        let size = count
            .checked_mul(stride)
            .filter(|&n| total + n <= MAX_DECODED_BYTES)
            .ok_or_else(|| bad(&format!("decodes to over {} GiB", MAX_DECODED_BYTES >> 30)))?;
        // Indices, or vertices, past three a triangle of the most allowed.
        if count / 3 > max_triangles {
            return Err(LoadError::TooLarge { path: path.to_path_buf(), count: count / 3, limit: max_triangles });
        }
        // (Copied: the source may be the chunk the decoded data goes to.)
        let source = buffers
            .get(buffer as usize)
            .and_then(|b| b.get(offset as usize..offset.checked_add(length)? as usize))
            .ok_or_else(|| bad("lies outside its buffer"))?
            .to_vec();
        let decoded = meshopt_decode(&source, count as usize, stride as usize, mode, filter).map_err(|e| bad(&e))?;
        total += size;
        let plain = append(&mut buffers[0], &decoded);
        let view = &mut doc["bufferViews"][i];
        for key in ["buffer", "byteOffset", "byteLength"] {
            view[key] = plain[key].clone();
        }
        if let Some(x) = view.get_mut("extensions").and_then(Value::as_object_mut) {
            x.remove(name);
        }
    }
    for (b, buffer) in doc.get_mut("buffers").and_then(Value::as_array_mut).into_iter().flatten().enumerate().skip(1) {
        let fallback = MESHOPT
            .iter()
            .any(|e| buffer.get("extensions").and_then(|x| x.get(*e)).and_then(|x| x.get("fallback")).and_then(Value::as_bool) == Some(true));
        if fallback && buffer.get("uri").is_none() {
            *buffer = json!({ "byteLength": 1, "uri": "data:application/octet-stream;base64,AA==" });
            if let Some(bytes) = buffers.get_mut(b) {
                *bytes = vec![0];
            }
            tracing::debug!("{}: fallback buffer {b} replaced by decoded data", path.display());
        }
    }
    Ok(())
}

/// One meshoptimizer-compressed view decoded: `count` elements of `stride`
/// bytes, then its filter applied. The parameters meshoptimizer asserts on
/// are checked first, so bad ones are errors rather than an abort.
fn meshopt_decode(source: &[u8], count: usize, stride: usize, mode: &str, filter: &str) -> Result<Vec<u8>, String> {
    use meshopt::ffi;
    let mut out = vec![0u8; count * stride];
    let (dst, src) = (out.as_mut_ptr().cast(), source.as_ptr());
    let index_stride = stride == 2 || stride == 4;
    // SAFETY: `out` holds `count * stride` bytes and `source` its length;
    // the sizes meshoptimizer asserts on are checked in each arm.
    let status = unsafe {
        match mode {
            "ATTRIBUTES" if stride.is_multiple_of(4) && (4..=256).contains(&stride) => {
                ffi::meshopt_decodeVertexBuffer(dst, count, stride, src, source.len())
            }
            "TRIANGLES" if index_stride && count.is_multiple_of(3) => ffi::meshopt_decodeIndexBuffer(dst, count, stride, src, source.len()),
            "INDICES" if index_stride => ffi::meshopt_decodeIndexSequence(dst, count, stride, src, source.len()),
            _ => return Err(format!("has mode {mode:?} with a stride of {stride} bytes and {count} elements, which meshoptimizer does not decode")),
        }
    };
    if status != 0 {
        return Err(format!("does not decode (meshoptimizer's error {status})"));
    }
    let ok = match (filter, mode) {
        ("NONE", _) => true,
        ("OCTAHEDRAL" | "COLOR", "ATTRIBUTES") => stride == 4 || stride == 8,
        ("QUATERNION", "ATTRIBUTES") => stride == 8,
        ("EXPONENTIAL", "ATTRIBUTES") => true,
        _ => false,
    };
    if !ok {
        return Err(format!("has filter {filter:?} on mode {mode:?} with a stride of {stride} bytes, which meshoptimizer does not decode"));
    }
    // SAFETY: as above; each filter works in place on `count` elements of `stride` bytes.
    unsafe {
        match filter {
            "OCTAHEDRAL" => ffi::meshopt_decodeFilterOct(dst, count, stride),
            "QUATERNION" => ffi::meshopt_decodeFilterQuat(dst, count, stride),
            "EXPONENTIAL" => ffi::meshopt_decodeFilterExp(dst, count, stride),
            "COLOR" => ffi::meshopt_decodeFilterColor(dst, count, stride),
            _ => {}
        }
    }
    Ok(out)
}

/// Textures whose image is named only by `EXT_texture_webp` or
/// `KHR_texture_basisu` get it as their source (a fallback source, where
/// given, is kept: every reader decodes it).
fn name_image_sources(doc: &mut Value) {
    for texture in doc.get_mut("textures").and_then(Value::as_array_mut).into_iter().flatten() {
        if texture.get("source").is_some() {
            continue;
        }
        if let Some(source) = IMAGE_SOURCES.iter().find_map(|e| texture.get("extensions")?.get(*e)?.get("source").cloned()) {
            texture["source"] = source;
        }
    }
}

/// Nodes drawn many times by `EXT_mesh_gpu_instancing` get a child node per
/// instance (its translation, rotation and scale, in the node's space, as
/// the extension defines them) drawing the node's mesh, which the node
/// itself then no longer draws.
fn expand_instances(path: &Path, doc: &mut Value, buffers: &[Vec<u8>]) -> Result<(), LoadError> {
    let count = doc.get("nodes").and_then(Value::as_array).map_or(0, Vec::len);
    let mut added: Vec<Value> = Vec::new();
    for i in 0..count {
        let Some(attributes) = doc["nodes"][i].get("extensions").and_then(|e| e.get(INSTANCING)).and_then(|e| e.get("attributes")).cloned() else {
            continue;
        };
        let bad = |detail: String| LoadError::malformed(path, format!("node {i}'s {INSTANCING} {detail}; the file may be truncated or corrupt"));
        let read = |name: &str, components: usize| -> Result<Option<Vec<f32>>, LoadError> {
            let Some(a) = attributes.get(name) else { return Ok(None) };
            let accessor = a.as_u64().and_then(|a| doc.get("accessors")?.get(a as usize)).ok_or_else(|| bad(format!("{name} names no accessor")))?;
            let kind = if components == 3 { "VEC3" } else { "VEC4" };
            match read_accessor(doc, buffers, accessor) {
                Some((values, k)) if k == kind => Ok(Some(values)),
                _ => Err(bad(format!("{name} is not an accessor of {kind} inside its buffer"))),
            }
        };
        let (t, r, s) = (read("TRANSLATION", 3)?, read("ROTATION", 4)?, read("SCALE", 3)?);
        let counts: Vec<usize> = [(&t, 3), (&r, 4), (&s, 3)].iter().filter_map(|(v, k)| v.as_ref().map(|v| v.len() / k)).collect();
        let Some(&n) = counts.first() else { continue };
        if counts.iter().any(|&c| c != n) {
            return Err(bad(format!("attributes give different instance counts ({counts:?})")));
        }
        if added.len() + n > super::gltf::MAX_NODE_INSTANCES as usize {
            return Err(LoadError::malformed(path, format!("its {INSTANCING} instances number more than {}", super::gltf::MAX_NODE_INSTANCES)));
        }
        let Some(mesh) = doc["nodes"][i].as_object_mut().and_then(|n| n.remove("mesh")) else { continue };
        let mut children = doc["nodes"][i].get("children").and_then(Value::as_array).cloned().unwrap_or_default();
        for k in 0..n {
            let mut node = json!({ "mesh": mesh });
            if let Some(t) = &t {
                node["translation"] = json!(&t[3 * k..3 * k + 3]);
            }
            if let Some(r) = &r {
                let q = glam::Vec4::from_slice(&r[4 * k..4 * k + 4]);
                node["rotation"] = json!(if q.length_squared() > 0.0 { q.normalize() } else { glam::Vec4::W }.to_array());
            }
            if let Some(s) = &s {
                node["scale"] = json!(&s[3 * k..3 * k + 3]);
            }
            children.push(json!(count + added.len()));
            added.push(node);
        }
        doc["nodes"][i]["children"] = json!(children);
    }
    if let Some(nodes) = doc.get_mut("nodes").and_then(Value::as_array_mut) {
        nodes.extend(added);
    }
    Ok(())
}

/// An accessor's values as f32, with its type: components of floats, or of
/// signed or unsigned bytes or shorts (normalized ones to [-1, 1] or [0, 1]),
/// read at the view's stride. `None` for other types or data outside the view.
fn read_accessor(doc: &Value, buffers: &[Vec<u8>], accessor: &Value) -> Option<(Vec<f32>, String)> {
    let kind = accessor.get("type")?.as_str()?;
    let components = match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        _ => return None,
    };
    let (size, top, signed): (usize, f32, bool) = match accessor.get("componentType")?.as_u64()? {
        5120 => (1, 127.0, true),
        5121 => (1, 255.0, false),
        5122 => (2, 32767.0, true),
        5123 => (2, 65535.0, false),
        5126 => (4, 1.0, true),
        _ => return None,
    };
    let normalized = accessor.get("normalized").and_then(Value::as_bool).unwrap_or(false);
    let count = accessor.get("count")?.as_u64()? as usize;
    let view_index = accessor.get("bufferView")?.as_u64()? as usize;
    let view_bytes = view_bytes(doc, buffers, view_index)?;
    let stride = doc["bufferViews"][view_index].get("byteStride").and_then(Value::as_u64).map_or(components * size, |s| s as usize);
    // A stride under an element would let a small view claim any count.
    if stride < components * size {
        return None;
    }
    let offset = accessor.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
    let end = count.checked_sub(1).map_or(Some(offset), |last| last.checked_mul(stride)?.checked_add(offset + components * size))?;
    let bytes = view_bytes.get(offset..end)?;
    let mut out = Vec::with_capacity(count * components);
    for i in 0..count {
        for k in 0..components {
            let at = i * stride + k * size;
            let raw = match (size, signed) {
                (4, _) => f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]),
                (1, true) => bytes[at] as i8 as f32,
                (1, false) => bytes[at] as f32,
                (_, true) => i16::from_le_bytes([bytes[at], bytes[at + 1]]) as f32,
                (_, false) => u16::from_le_bytes([bytes[at], bytes[at + 1]]) as f32,
            };
            out.push(if normalized { (raw / top).max(-1.0) } else { raw });
        }
    }
    Some((out, kind.to_string()))
}

/// Decodes one Draco stream; `draco-core` panicking on a hostile stream is an error too.
fn decode(bytes: &[u8]) -> Result<Mesh, String> {
    std::panic::catch_unwind(|| {
        let mut mesh = Mesh::new();
        MeshDecoder::new().decode(&mut DecoderBuffer::new(bytes), &mut mesh).map(|()| mesh).map_err(|e| format!("{e:?}"))
    })
    .unwrap_or_else(|_| Err("the decoder stopped on damaged data".into()))
}

/// A GLB's JSON and binary chunks, or a `.gltf`'s JSON and no chunk.
pub(super) fn split(bytes: &[u8]) -> Option<(&[u8], Option<&[u8]>)> {
    if !bytes.starts_with(GLB_MAGIC) {
        return Some((bytes, None));
    }
    let word = |at: usize| bytes.get(at..at + 4).map(|w| u32::from_le_bytes(w.try_into().unwrap()) as usize);
    let (json_len, json_kind) = (word(12)?, word(16)? as u32);
    let json = bytes.get(20..20usize.checked_add(json_len)?)?;
    if json_kind != JSON_CHUNK {
        return None;
    }
    let next = (20 + json_len).next_multiple_of(4);
    let bin = match (word(next), word(next + 4)) {
        (Some(len), Some(kind)) if kind as u32 == BIN_CHUNK => Some(bytes.get(next + 8..(next + 8).checked_add(len)?)?),
        _ => None,
    };
    Some((json, bin))
}

/// Each buffer's bytes: the GLB chunk, a data URI, or a file beside the scene
/// (checked as the glTF loader checks files). Unreadable ones are empty; a
/// view into one is an error where it is used.
fn read_buffers(path: &Path, doc: &Value, bin: Option<&[u8]>, dir: &Path) -> Result<Vec<Vec<u8>>, LoadError> {
    let mut out = Vec::new();
    for (i, b) in doc.get("buffers").and_then(Value::as_array).into_iter().flatten().enumerate() {
        let bytes = match b.get("uri").and_then(Value::as_str) {
            // A GLB's chunk is its first buffer; others without a URI (a
            // meshoptimizer fallback) hold nothing.
            None if i == 0 => bin.unwrap_or(&[]).to_vec(),
            None => Vec::new(),
            Some(uri) if uri.starts_with("data:") => {
                let payload = uri.split_once(";base64,").map_or("", |(_, p)| p);
                base64::decode(payload).unwrap_or_default()
            }
            // (Files named as the glTF loader names them, `file:` URIs too:
            // these bytes are the ones it uses.)
            Some(uri) => match super::gltf::uri_file(dir, uri) {
                Some(Ok(file)) => {
                    super::gltf::check_file(path, &file, "a buffer")?;
                    std::fs::read(&file).unwrap_or_default()
                }
                Some(Err(())) => return Err(LoadError::malformed(path, format!("buffer URI '{uri}' does not decode to a UTF-8 file name"))),
                None => {
                    return Err(LoadError::malformed(
                        path,
                        format!("buffer URI '{uri}' is neither a file beside the scene nor a data URI, the only buffers read"),
                    ))
                }
            },
        };
        out.push(bytes);
    }
    Ok(out)
}

/// The bytes of buffer view `view`, if it lies inside its buffer.
fn view_bytes<'a>(doc: &Value, buffers: &'a [Vec<u8>], view: usize) -> Option<&'a [u8]> {
    let v = doc.get("bufferViews")?.get(view)?;
    let buffer = buffers.get(v.get("buffer")?.as_u64()? as usize)?;
    let start = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
    buffer.get(start..start.checked_add(v.get("byteLength")?.as_u64()? as usize)?)
}

/// Appends `bytes` to the chunk at a 16-byte boundary (enough for any
/// component) and returns a buffer view of them.
fn append(chunk: &mut Vec<u8>, bytes: &[u8]) -> Value {
    chunk.resize(chunk.len().next_multiple_of(16), 0);
    let start = chunk.len();
    chunk.extend_from_slice(bytes);
    json!({ "buffer": 0, "byteOffset": start, "byteLength": bytes.len() })
}

/// Little-endian bytes of `f32`s.
fn floats(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A GLB of a JSON chunk and a binary chunk, each padded to four bytes.
#[cfg(test)]
pub(super) fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let (json_len, bin_len) = (json.len().next_multiple_of(4), bin.len().next_multiple_of(4));
    let total = 12 + 8 + json_len + 8 + bin_len;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(GLB_MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(&JSON_CHUNK.to_le_bytes());
    out.extend_from_slice(json);
    out.resize(20 + json_len, b' ');
    out.extend_from_slice(&(bin_len as u32).to_le_bytes());
    out.extend_from_slice(&BIN_CHUNK.to_le_bytes());
    out.extend_from_slice(bin);
    out.resize(total, 0);
    out
}
