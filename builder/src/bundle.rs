//! Writes a bundle folder: `graph.json` (the format crate's schema),
//! `coverage.json` and the report pictures. Every file is written under a
//! temporary name and renamed, and graph.json last, so a bundle with a
//! graph.json is complete. The stages' timings go to `timings.json`, not
//! graph.json: the same seed gives byte-identical bundles at any thread
//! count, timings apart.

use crate::files::write_atomic;
use crate::pipeline::Plan;
use exploremaps_format::GRAPH_FILE;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    #[error("cannot write {path}: {source}; check that the folder is writable and the disk has room")]
    Io { path: String, source: std::io::Error },
    #[error("the planned graph is inconsistent ({0}); this is a bug, please report it")]
    Invalid(#[from] exploremaps_format::FormatError),
    #[error("cannot denoise {path}: {message}")]
    Denoise { path: String, message: String },
    #[error("cannot encode the transition video {path}: {message}")]
    Video { path: String, message: String },
    #[error("cannot code the proxy mesh {path}: {message}; this is a bug, please report it")]
    Proxy { path: String, message: String },
    #[error(transparent)]
    Raycast(#[from] crate::raycast::RaycastError),
    #[error("{dir} is not complete; {} problems:\n  {}\nrun the shards named again (`exploremaps render {dir} --shard i/n`), then --finalize", problems.len(), list_some(problems))]
    Incomplete { dir: String, problems: Vec<String> },
}

/// The first 20 lines of a list, and how many more there are.
fn list_some(lines: &[String]) -> String {
    let mut shown = lines.iter().take(20).cloned().collect::<Vec<_>>().join("\n  ");
    if lines.len() > 20 {
        shown.push_str(&format!("\n  … and {} more", lines.len() - 20));
    }
    shown
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), BundleError> {
    let path = dir.join(name);
    write_atomic(&path, bytes).map_err(|source| BundleError::Io { path: path.display().to_string(), source })
}

fn png(image: &image::RgbImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).expect("PNG encoding to memory");
    bytes
}

/// The web viewer's files (`index.html`, `viewer/…`), relative to its folder.
pub const WEB_VIEWER_FILES: [&str; 3] = ["index.html", "viewer/exploremaps.js", "viewer/exploremaps_bg.wasm"];

/// Copies the built web viewer (web/build.sh writes it to target/web-viewer) into a
/// bundle, so the folder can be hosted anywhere as static files. Files that
/// are already identical are left alone. Returns how many were written.
pub fn install_web_viewer(dir: &Path, web: &Path) -> Result<usize, BundleError> {
    let mut written = 0;
    for name in WEB_VIEWER_FILES {
        let from = web.join(name);
        let bytes = std::fs::read(&from).map_err(|source| BundleError::Io { path: from.display().to_string(), source })?;
        let to = dir.join(name);
        if std::fs::read(&to).is_ok_and(|old| old == bytes) {
            continue;
        }
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent).map_err(|source| BundleError::Io { path: parent.display().to_string(), source })?;
        }
        write(dir, name, &bytes)?;
        written += 1;
    }
    Ok(written)
}

/// The coverage report as JSON: overall, per material and object, the curve,
/// and the baselines at the same probe count.
pub fn coverage_json(plan: &Plan) -> serde_json::Value {
    let groups = |g: &[(String, f64, f64)]| -> Vec<serde_json::Value> {
        g.iter()
            .map(|(name, r, c)| serde_json::json!({ "name": name, "reachable_area": r, "covered_area": c, "fraction": if *r > 0.0 { c / r } else { 1.0 } }))
            .collect()
    };
    let c = &plan.coverage;
    let ceiling = c.ceiling();
    serde_json::json!({
        "probes": plan.graph.probes.len(),
        "samples": c.samples.points.len(),
        "reachable_area": c.reachable_area,
        "covered_area": c.covered_area,
        "fraction": c.fraction(),
        "measured_from": match &plan.free_space.walk {
            Some(w) => format!("eye height ({} m) above the walkable floors: surface seen only from higher up or lower down is not counted here, but is in the ceiling", w.eye_height_m),
            None => "anywhere in the navigable space".to_string(),
        },
        "ceiling": {
            "what": "surface seen from the free space inside the scene's bounding box (outside closed solids) where a viewpoint fits (touching no occupied voxel), whatever space was chosen: the most any placement could see; crevices_area is surface seen only from narrower gaps, left out",
            "area": ceiling.area,
            "crevices_area": ceiling.crevices,
            "seen_from_space": ceiling.seen_from_space,
            "covered": ceiling.covered,
            "space_fraction": if ceiling.area > 0.0 { ceiling.seen_from_space / ceiling.area } else { 1.0 },
            "covered_fraction": if ceiling.area > 0.0 { ceiling.covered / ceiling.area } else { 1.0 },
        },
        "probes_for": { "0.90": c.probes_for(0.90), "0.95": c.probes_for(0.95), "0.98": c.probes_for(0.98), "0.99": c.probes_for(0.99) },
        "curve": c.curve,
        "per_material": groups(&plan.per_material),
        "per_object": groups(&plan.per_object),
        "baselines": plan.baselines.iter().map(|b| serde_json::json!({
            "name": b.name,
            "probes": b.probes.len(),
            "fraction": b.report.fraction(),
            "curve": b.report.curve,
        })).collect::<Vec<_>>(),
        "chart": "coverage_curve.png: explored probes green, random baseline orange, grid baseline blue; gridlines every 10 % of the y range and every 10 probes",
        "top_view": "coverage_top.png: a cutaway from the top of the navigable space; grey seen by a probe, magenta reachable but unseen, dim unreachable, amber free space the chosen space leaves out, green dots probes",
    })
}

/// Writes the planned bundle into `dir` (created if missing).
pub fn write_plan(dir: &Path, plan: &Plan) -> Result<(), BundleError> {
    plan.graph.validate()?;
    for (name, image) in &plan.images {
        write(dir, name, &png(image))?;
    }
    let coverage = serde_json::to_string_pretty(&coverage_json(plan)).expect("JSON of plain values");
    write(dir, "coverage.json", coverage.as_bytes())?;
    write_graph(dir, &plan.graph)
}

/// What varies from run to run, kept out of graph.json.
pub const TIMINGS_FILE: &str = "timings.json";

/// Writes graph.json without the stages' timings (`seconds`, `seconds_*`),
/// which are merged into timings.json (written first).
fn write_graph(dir: &Path, graph: &exploremaps_format::Graph) -> Result<(), BundleError> {
    let mut graph = graph.clone();
    let mut timings: serde_json::Map<String, serde_json::Value> =
        std::fs::read_to_string(dir.join(TIMINGS_FILE)).ok().and_then(|t| serde_json::from_str(&t).ok()).unwrap_or_default();
    let mut moved = false;
    for (stage, value) in graph.stats.iter_mut() {
        let Some(fields) = value.as_object_mut() else { continue };
        let keys: Vec<String> = fields.keys().filter(|k| *k == "seconds" || k.starts_with("seconds_")).cloned().collect();
        for key in keys {
            let entry = timings.entry(stage.clone()).or_insert_with(|| serde_json::json!({}));
            if let (Some(entry), Some(v)) = (entry.as_object_mut(), fields.remove(&key)) {
                entry.insert(key, v);
                moved = true;
            }
        }
    }
    if moved {
        write(dir, TIMINGS_FILE, serde_json::to_string_pretty(&timings).expect("JSON of plain values").as_bytes())?;
    }
    write(dir, GRAPH_FILE, graph.to_json().as_bytes())
}

/// Which assets a shard renders: job `k` (probes first, then paths, then the
/// proxy) belongs to shard `k % count`. Shards of a split render (count > 1)
/// never touch graph.json: each writes its assets and then its manifest,
/// `shards/<index>-of-<count>.json`; [`finalize`] checks the whole and writes
/// graph.json once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    fn manifest(&self) -> String {
        format!("shards/{}-of-{}.json", self.index, self.count)
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderReport {
    pub probes_rendered: usize,
    pub paths_rendered: usize,
    pub proxy_rendered: bool,
    /// Jobs of this shard whose files were all there already.
    pub skipped: usize,
    pub video_encoder: Option<String>,
    pub seconds: f64,
}

/// Random-number streams of thumbnails and video frames, apart from the cube
/// faces' (probe id × 8 + face), so no two images share samples.
const THUMBNAIL_STREAMS: u64 = 1 << 48;
const VIDEO_STREAMS: u64 = 2 << 48;

/// File names of a probe's assets.
struct ProbeFiles {
    /// Cube faces per level.
    cube: Vec<exploremaps_format::CubeLevel>,
    tiles: exploremaps_format::Tiles,
    pano: String,
    thumb: String,
}

/// Tour tiles are 512 pixels, as tour viewers' are; the preview strip's
/// faces 256 (or the face, if smaller).
const TILE: u32 = 512;
const TILE_PREVIEW: u32 = 256;

impl ProbeFiles {
    fn new(id: usize, levels: &[u32]) -> ProbeFiles {
        let cube = levels
            .iter()
            .map(|&size| exploremaps_format::CubeLevel { size, faces: exploremaps_format::CUBE_FACES.map(|f| format!("probes/{id}/{size}_{f}.jpg")) })
            .collect();
        let face = levels.last().copied().unwrap_or(TILE);
        let tiles = exploremaps_format::Tiles::new(format!("probes/{id}/tiles"), face, TILE, TILE_PREVIEW.min(face));
        ProbeFiles { cube, tiles, pano: format!("probes/{id}/pano.jpg"), thumb: format!("thumbs/{id}.jpg") }
    }

    /// Every file, each level's faces, the tiles and their preview.
    fn all(&self) -> Vec<String> {
        let faces = self.cube.iter().flat_map(|l| l.faces.iter().cloned());
        faces.chain(self.tiles.files()).chain([self.tiles.preview.clone(), self.pano.clone(), self.thumb.clone()]).collect()
    }
}

fn path_files(id: usize) -> (String, String) {
    (format!("paths/{id}.mp4"), format!("paths/{id}.jpg"))
}

const PROXY_GLB: &str = "proxy/proxy.glb";
/// The most triangles of a proxy chunk: about 2 ms of decoding in a browser.
const CHUNK_TRIANGLES: usize = 7_000;
/// Triangles a packet of vertex splits brings back: applying one takes a
/// few milliseconds in a phone's browser (splits cost more a triangle to
/// decode than a level sent whole).
const PACKET_TRIANGLES: usize = 750;
/// Texels a face of a probe's point-to-go depth cube.
const DEPTH_MAP_SIZE: u32 = 32;
/// The proxy's entry for graph.json, written after its files: shards and
/// resumed runs find it there whoever made it.
const PROXY_LIST: &str = "proxy/proxy.json";

/// The proxy's entry, if it and every file it lists are in the bundle.
fn proxy_listed(dir: &Path) -> Option<exploremaps_format::Proxy> {
    let text = std::fs::read_to_string(dir.join(PROXY_LIST)).ok()?;
    let proxy: exploremaps_format::Proxy = serde_json::from_str(&text).ok()?;
    let complete = proxy_files(&proxy).iter().all(|f| dir.join(f).exists());
    complete.then_some(proxy)
}

fn proxy_files(proxy: &exploremaps_format::Proxy) -> Vec<String> {
    let chunks = proxy.levels.iter().flat_map(|l| &l.chunks).flat_map(|c| std::iter::once(&c.file).chain(&c.seen));
    let listed = proxy.levels.iter().flat_map(|l| std::iter::once(&l.file).chain(&l.seen)).chain(&proxy.glb).chain(&proxy.depth_maps).chain(chunks);
    // Packets share files: each file once.
    listed.cloned().chain(proxy.stream.iter().flat_map(|s| s.files().into_iter().map(|(file, _)| file))).collect()
}

/// Storey floor heights the free-space stage found (its `walk.levels`), for
/// the dollhouse's floor cut; none when probes fly.
fn floors(graph: &exploremaps_format::Graph) -> Vec<f32> {
    let levels = graph.stats.get("free_space").and_then(|f| f.get("walk")).and_then(|w| w.get("levels")).and_then(|l| l.as_array());
    let mut floors: Vec<f32> = levels.into_iter().flatten().filter_map(|l| l.get(0)?.as_f64()).map(|h| h as f32).filter(|h| h.is_finite()).collect();
    floors.sort_by(f32::total_cmp);
    floors
}

/// The proxy's levels simplified from the scene, coloured by the renderer's
/// lighting, coded into `proxy/<level>.emmc` with its point-to-go table in
/// `proxy/<level>.seen`, the finest also as a GLB, then listed in
/// `proxy/proxy.json`.
fn render_proxy(dir: &Path, scene: &exploremaps_scenes::Scene, graph: &exploremaps_format::Graph, renderer: &crate::render::Renderer, params: &crate::proxy::ProxyParams) -> Result<(), BundleError> {
    use exploremaps_format::{meshcode, seen, Proxy, ProxyChunk, ProxyLevel, ProxyStream};
    let started = std::time::Instant::now();
    let mut proxy = Proxy { levels: Vec::new(), glb: None, floors: floors(graph), depth_maps: Vec::new(), stream: None };
    let probes: Vec<glam::Vec3> = graph.probes.iter().map(|p| glam::Vec3::from(p.position)).collect();
    // Point-to-go from panoramas: a 32² depth cube a probe (a few KB), from
    // the near distance to twice the scene's size.
    let diagonal = scene.bounds().diagonal();
    let near = graph.scene.near_distance.unwrap_or(1e-3 * diagonal).max(1e-4 * diagonal);
    let mut depth_bytes = 0;
    for (id, &eye) in probes.iter().enumerate() {
        let map = crate::proxy::seen::depth_map(renderer.tracer.rays, eye, &probes, DEPTH_MAP_SIZE, near, 2.0 * diagonal, 1e-4 * diagonal).encode();
        let file = format!("proxy/depth/{id}.emdm");
        write(dir, &file, &map)?;
        depth_bytes += map.len();
        proxy.depth_maps.push(file);
    }
    // The finer level's colours and table, for the stream that rebuilds it.
    let mut finer: Option<(Vec<[u8; 3]>, Vec<u32>)> = None;
    for (i, level) in crate::proxy::levels(scene, params).into_iter().enumerate() {
        let colours = crate::proxy::bake::bake(renderer, &level.mesh, level.error, params.bake_samples, i as u64);
        let best = crate::proxy::seen::best_probes(renderer.tracer.rays, &level.mesh, &probes, level.error);
        // A large level in spatial chunks (a viewer decodes one between two frames).
        let parts = crate::proxy::chunks(&level.mesh, CHUNK_TRIANGLES);
        let mut chunks = Vec::new();
        // A level in one part: its bytes and decoded order, for its stream.
        let mut whole = None;
        for (c, triangles) in parts.iter().enumerate() {
            let name = if parts.len() == 1 { format!("proxy/{i}") } else { format!("proxy/{i}-{c}") };
            let (mesh, was) = level.mesh.subset(triangles);
            let mut data = mesh.to_coded();
            data.colours = was.iter().map(|&v| colours[v as usize]).collect();
            let file = format!("{name}.emmc");
            let coded = meshcode::encode(&data, params.bits).map_err(|e| BundleError::Proxy { path: dir.join(&file).display().to_string(), message: e.to_string() })?;
            write(dir, &file, &coded.bytes)?;
            let seen_file = format!("{name}.seen");
            write(dir, &seen_file, &seen::encode(&coded.order.triangles.iter().map(|&t| best[triangles[t as usize]]).collect::<Vec<u32>>()))?;
            chunks.push(ProxyChunk { file, seen: Some(seen_file), triangles: triangles.len() as u64, bytes: coded.bytes.len() as u64 });
            if parts.len() == 1 {
                // Decoded vertex and triangle k are the level's `vertices[k]` and `triangles[k]`.
                let vertices = coded.order.vertices.iter().map(|&v| was[v as usize]).collect();
                whole = Some(CodedWhole { bytes: coded.bytes, vertices, triangles: coded.order.triangles.iter().map(|&t| triangles[t as usize] as u32).collect() });
            }
        }
        if i == 0 {
            write(dir, PROXY_GLB, &crate::export::proxy_glb(&scene.name, &level.mesh, &colours))?;
            proxy.glb = Some(PROXY_GLB.to_string());
        }
        let (triangles, vertices) = (level.mesh.triangles.len() as u64, level.mesh.positions.len() as u64);
        let (file, seen) = (chunks[0].file.clone(), chunks[0].seen.clone());
        let bytes = chunks.iter().map(|c| c.bytes).sum();
        let chunks = if chunks.len() > 1 { chunks } else { Vec::new() };
        // A level coded whole that refines into the one before it: its vertex splits.
        if let (Some(stream), Some((finer_colours, finer_best)), Some(whole)) = (level.refines, finer.take(), whole) {
            let packets = write_splits(dir, (&file, whole, &best), stream, (&finer_colours, &finer_best), probes.len() as u32, params.bits)?;
            proxy.stream = Some(ProxyStream { from: i, to: i - 1, packets });
        }
        finer = Some((colours, best));
        proxy.levels.push(ProxyLevel { file, triangles, vertices, error: level.error, bytes, seen, chunks });
    }
    let sizes: Vec<String> = proxy.levels.iter().map(|l| format!("{} triangles in {} bytes", l.triangles, l.bytes)).collect();
    tracing::info!("proxy: {}; depth maps {} bytes a probe ({:.2} s)", sizes.join(", "), depth_bytes / probes.len().max(1), started.elapsed().as_secs_f64());
    write(dir, PROXY_LIST, serde_json::to_string_pretty(&proxy).expect("JSON of plain values").as_bytes())
}

/// A level coded in one part: its bytes, and per decoded vertex and
/// triangle, the level's.
struct CodedWhole {
    bytes: Vec<u8>,
    vertices: Vec<u32>,
    triangles: Vec<u32>,
}

/// Writes the vertex splits that rebuild the finer level from `coarse` (its
/// file, its coded bytes with their decoded vertex and triangle order, and
/// its point-to-go table per level triangle) as `proxy/splits-<k>.emvs`:
/// packets of `PACKET_TRIANGLES` (a few ms each to apply), a file bringing
/// back a chunk's worth. Triangle groups carry the point-to-go entries
/// (the probe count for none): the coarse level's, then `finer`'s (colours
/// per vertex and table per triangle of the finer level).
fn write_splits(dir: &Path, coarse: (&str, CodedWhole, &[u32]), mut stream: crate::proxy::progressive::Progressive, finer: (&[[u8; 3]], &[u32]), probes: u32, bits: u32) -> Result<Vec<exploremaps_format::ProxyPacket>, BundleError> {
    use exploremaps_format::{meshcode, splits, ProxyPacket};
    let (file, CodedWhole { bytes, vertices, triangles }, best) = coarse;
    let fail = |file: &str, e: exploremaps_format::edgebreaker::CodingError| BundleError::Proxy { path: dir.join(file).display().to_string(), message: e.to_string() };
    // The coder predicts from the coarse level exactly as a viewer decodes it.
    let mut base = meshcode::decode(&bytes).map_err(|e| fail(file, e))?;
    base.groups = triangles.iter().map(|&t| best[t as usize].min(probes)).collect();
    stream.renumber_base(&vertices, &triangles);
    stream.colour(finer.0);
    stream.regroup(&finer.1.iter().map(|&p| p.min(probes)).collect::<Vec<u32>>());
    let packets = splits::encode(&base, &stream.refinements, bits, PACKET_TRIANGLES).map_err(|e| fail("proxy/splits-0.emvs", e))?;
    let (mut listed, mut file_bytes, mut files, mut first) = (Vec::new(), Vec::new(), 0, base.triangles.len() as u64);
    for (k, packet) in packets.iter().enumerate() {
        let file = format!("proxy/splits-{files}.emvs");
        listed.push(ProxyPacket { file: file.clone(), offset: file_bytes.len() as u64, bytes: packet.bytes.len() as u64, triangles: packet.triangles });
        file_bytes.extend_from_slice(&packet.bytes);
        if packet.triangles - first >= CHUNK_TRIANGLES as u64 || k + 1 == packets.len() {
            write(dir, &file, &std::mem::take(&mut file_bytes))?;
            (files, first) = (files + 1, packet.triangles);
        }
    }
    Ok(listed)
}

/// JPEG quality of tiles: as the whole faces'.
const TILE_QUALITY: u8 = 90;

fn jpeg(image: &image::RgbImage, quality: u8) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality).encode_image(image).expect("JPEG encoding to memory");
    bytes
}

/// Renders what the bundle is missing, for this shard: per probe the cube
/// faces at every level, a photo-sphere equirectangular JPEG and a thumbnail;
/// per path a 360° MP4 and its poster; once, the proxy (the last job). A finished file is never redone and
/// every file is written atomically, so a killed run loses at most the asset
/// in progress. graph.json then lists every asset whose files exist.
pub fn render_missing(
    dir: &Path,
    scene: &exploremaps_scenes::Scene,
    graph: &mut exploremaps_format::Graph,
    settings: &crate::render::Settings,
    shard: Shard,
    mut progress: impl FnMut(usize, usize),
) -> Result<RenderReport, BundleError> {
    use crate::render::{downsample, equirect_from_cube, photo_sphere_jpeg, Renderer};
    use glam::Vec3;
    let started = std::time::Instant::now();
    let abandoned = crate::files::remove_abandoned(dir);
    if abandoned > 0 {
        tracing::info!("removed {abandoned} temporary files a killed run left behind");
    }
    let levels = settings.face_levels();
    let pano_width = settings.face.max(1024);
    let exists = |name: &String| dir.join(name).exists();
    let probe_done = |id: usize| ProbeFiles::new(id, &levels).all().iter().all(exists);
    let path_done = |id: usize| {
        let (video, poster) = path_files(id);
        exists(&video) && exists(&poster)
    };
    let probes = graph.probes.len();
    let proxy_job = probes + graph.paths.len();
    let jobs: Vec<usize> = (0..=proxy_job).filter(|k| k % shard.count == shard.index).collect();
    let todo: Vec<usize> = jobs
        .iter()
        .copied()
        .filter(|&k| if k < probes { !probe_done(k) } else if k < proxy_job { !path_done(k - probes) } else { proxy_listed(dir).is_none() })
        .collect();
    let mut report = RenderReport { skipped: jobs.len() - todo.len(), ..Default::default() };
    // The renderer also states its settings (in graph.json, or a shard's
    // manifest): a run killed after its last asset but before that file
    // leaves them to the next run.
    let split = shard.count > 1;
    let stated = if split { exists(&shard.manifest()) } else { graph.stats.contains_key("render") };
    if !todo.is_empty() || !stated {
        let setup_started = std::time::Instant::now();
        let rays = crate::raycast::RayScene::new(&scene.positions, &scene.triangles, 0)?;
        let mut viewpoints: Vec<Vec3> = graph.probes.iter().map(|p| Vec3::from(p.position)).collect();
        viewpoints.extend(graph.paths.iter().flat_map(|p| p.camera.iter().step_by(10).map(|k| Vec3::from(k.position))));
        let renderer = Renderer::new(scene, &rays, &viewpoints, settings.clone());
        let encoder = crate::video::Encoder::detect();
        report.video_encoder = Some(encoder.name());
        let seconds_setup = setup_started.elapsed().as_secs_f64();
        let mut job_starts = Vec::with_capacity(todo.len() + 1);
        for (done, &k) in todo.iter().enumerate() {
            job_starts.push(std::time::Instant::now());
            progress(done, todo.len());
            if k == proxy_job {
                render_proxy(dir, scene, graph, &renderer, &settings.proxy)?;
                report.proxy_rendered = true;
            } else if k < probes {
                let probe = &graph.probes[k];
                let eye = Vec3::from(probe.position);
                let ProbeFiles { cube, tiles, pano, thumb } = ProbeFiles::new(k, &levels);
                let denoised = |mut f: crate::render::Frame| -> Result<Vec<Vec3>, BundleError> {
                    if settings.denoise {
                        crate::render::denoise(&mut f).map_err(|message| BundleError::Denoise { path: dir.join(&pano).display().to_string(), message })?;
                    }
                    Ok(f.color)
                };
                let mut faces: Vec<Vec<Vec3>> = renderer.cube(&settings.panorama, eye, settings.face, k as u64).into_iter().map(denoised).collect::<Result<_, _>>()?;
                let full = faces.clone();
                let mut images = Vec::with_capacity(cube.len());
                for level in cube.iter().rev() {
                    if faces.len() == 6 && level.size < settings.face {
                        faces = faces.iter().map(|f| downsample(level.size * 2, f)).collect();
                    }
                    let level_images: Vec<image::RgbImage> = faces.iter().map(|face| renderer.to_image(level.size, level.size, face)).collect();
                    for (image, name) in level_images.iter().zip(&level.faces) {
                        if !exists(name) {
                            write(dir, name, &jpeg(image, 90))?;
                        }
                    }
                    images.push((level.size, level_images));
                }
                crate::tiles::cut(&tiles, &images, |name, tile| if dir.join(name).exists() { Ok(()) } else { write(dir, name, &jpeg(tile, TILE_QUALITY)) })?;
                let equirect = equirect_from_cube(&full, settings.face, pano_width);
                write(dir, &pano, &photo_sphere_jpeg(&renderer.to_image(pano_width, pano_width / 2, &equirect), 90))?;
                let (yaw, pitch) = probe.preferred_directions.first().map_or((0.0, 0.0), |d| (d.yaw, d.pitch));
                let view = denoised(renderer.perspective(&settings.panorama, eye, yaw, pitch, 1.0, 320, 180, THUMBNAIL_STREAMS + k as u64))?;
                write(dir, &thumb, &jpeg(&renderer.to_image(320, 180, &view), 85))?;
                report.probes_rendered += 1;
            } else {
                let id = k - probes;
                let path = &graph.paths[id];
                let (video, poster) = path_files(id);
                let w = settings.video_width;
                let eyes: Vec<Vec3> = path.camera.iter().map(|key| Vec3::from(key.position)).collect();
                let mut frames: Vec<image::RgbImage> = Vec::with_capacity(eyes.len());
                renderer.path_frames(&settings.video, &eyes, w, VIDEO_STREAMS + ((id as u64) << 24), settings.video_keys, |_, frame| frames.push(renderer.to_image(w, w / 2, &frame.color)));
                let Some(first) = frames.first() else { continue };
                let mp4 = encoder.encode(&frames, crate::smooth::FPS).map_err(|e| BundleError::Video { path: dir.join(&video).display().to_string(), message: e.to_string() })?;
                write(dir, &poster, &jpeg(first, 85))?;
                write(dir, &video, &mp4)?;
                report.paths_rendered += 1;
            }
        }
        job_starts.push(std::time::Instant::now());
        progress(todo.len(), todo.len());
        let mut stats = serde_json::json!({
                "quality": settings.quality.name(),
                "lighting": renderer.tracer.lighting.description,
                "exposure": renderer.exposure,
                "cache_cells": renderer.tracer.cache.as_ref().map(|c| c.stats.cells),
                "video_encoder": report.video_encoder,
                "samples_per_pixel": settings.panorama.samples,
                "bounces": settings.panorama.bounces,
                "denoised": settings.denoise,
                "seed": settings.seed,
        });
        if split {
            let manifest = serde_json::json!({ "shard": shard.index, "count": shard.count, "levels": levels, "render": stats });
            write(dir, &shard.manifest(), serde_json::to_string_pretty(&manifest).expect("JSON of plain values").as_bytes())?;
        } else {
            // Timings (moved to timings.json): the renderer's set-up, which
            // every shard repeats, and each job's time, for planning shards.
            let jobs: Vec<(usize, f64)> = todo.iter().zip(job_starts.windows(2)).map(|(&k, w)| (k, (w[1] - w[0]).as_secs_f64())).collect();
            stats["seconds_setup"] = seconds_setup.into();
            stats["seconds_jobs"] = serde_json::json!(jobs);
            graph.stats.insert("render".into(), stats);
        }
    }
    if !split {
        list_assets(dir, graph, &levels);
        graph.validate()?;
        write_graph(dir, graph)?;
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// Lists in graph.json every asset whose files exist.
fn list_assets(dir: &Path, graph: &mut exploremaps_format::Graph, levels: &[u32]) {
    let exists = |name: &String| dir.join(name).exists();
    for (id, probe) in graph.probes.iter_mut().enumerate() {
        let files = ProbeFiles::new(id, levels);
        let tiled = files.tiles.files().iter().chain([&files.tiles.preview]).all(exists);
        let ProbeFiles { cube, tiles, pano, thumb } = files;
        probe.assets.cube_levels = cube.into_iter().filter(|l| l.faces.iter().all(exists)).collect();
        probe.assets.tiles = tiled.then_some(tiles);
        probe.assets.equirect = exists(&pano).then_some(pano);
        probe.assets.thumbnail = exists(&thumb).then_some(thumb);
    }
    for (id, path) in graph.paths.iter_mut().enumerate() {
        let (video, poster) = path_files(id);
        path.assets.video = exists(&video).then_some(video);
        path.assets.poster = exists(&poster).then_some(poster);
    }
    graph.proxy = proxy_listed(dir);
}

/// Completes a split render: reads the shards' manifests, checks that every
/// shard finished and every asset exists and decodes (JPEGs whole, each
/// video's first frame, each proxy level), then writes graph.json. Otherwise
/// an error lists each problem with the shard that owns it, and graph.json is
/// not written; files that do not decode are removed, so running their
/// shard again redoes them. Running it again is harmless. Returns the files
/// checked.
pub fn finalize(dir: &Path, graph: &mut exploremaps_format::Graph) -> Result<usize, BundleError> {
    let incomplete = |problems: Vec<String>| BundleError::Incomplete { dir: dir.display().to_string(), problems };
    let mut manifests: Vec<serde_json::Value> = Vec::new();
    for entry in std::fs::read_dir(dir.join("shards")).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "json") {
            let parsed = std::fs::read_to_string(&path).ok().and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
            manifests.push(parsed.ok_or_else(|| incomplete(vec![format!("{}: not a shard manifest; delete it and run its shard again", path.display())]))?);
        }
    }
    let Some(first) = manifests.first() else {
        return Err(incomplete(vec!["no shard has finished (shards/ holds no manifest)".into()]));
    };
    let count = first["count"].as_u64().unwrap_or(0) as usize;
    let (render, levels) = (first["render"].clone(), first["levels"].clone());
    let mut problems = Vec::new();
    if let Some(odd) = manifests.iter().find(|m| m["count"] != first["count"] || m["render"] != render || m["levels"] != levels) {
        problems.push(format!("shard {}/{} rendered with other settings or another shard count than shard {}/{count}; render every shard with the same options", odd["shard"], odd["count"], first["shard"]));
    }
    let levels: Vec<u32> = serde_json::from_value(levels).unwrap_or_default();
    let finished: std::collections::BTreeSet<u64> = manifests.iter().filter_map(|m| m["shard"].as_u64()).collect();
    for index in (0..count as u64).filter(|i| !finished.contains(i)) {
        problems.push(format!("shard {index}/{count} has not finished (no shards/{index}-of-{count}.json)"));
    }
    // Every expected file, with its owner.
    let probes = graph.probes.len();
    let mut expected: Vec<(String, usize)> = Vec::new();
    for id in 0..probes {
        expected.extend(ProbeFiles::new(id, &levels).all().into_iter().map(|f| (f, id)));
    }
    for id in 0..graph.paths.len() {
        let (video, poster) = path_files(id);
        expected.extend([(video, probes + id), (poster, probes + id)]);
    }
    let proxy_job = probes + graph.paths.len();
    match proxy_listed(dir) {
        Some(proxy) => expected.extend(proxy_files(&proxy).into_iter().map(|f| (f, proxy_job))),
        None => expected.push((PROXY_LIST.to_string(), proxy_job)),
    }
    // A file that exists but does not decode goes, so its shard redoes it.
    let checked: Vec<Option<String>> = {
        use rayon::prelude::*;
        expected
            .par_iter()
            .map(|(name, job)| {
                let owner = format!("{name} (shard {}/{count})", job % count.max(1));
                match check_asset(dir, name) {
                    Ok(()) => None,
                    Err(None) => Some(format!("{owner}: missing")),
                    Err(Some(why)) => {
                        let _ = std::fs::remove_file(dir.join(name));
                        Some(format!("{owner}: {why}; removed"))
                    }
                }
            })
            .collect()
    };
    problems.extend(checked.into_iter().flatten());
    if !problems.is_empty() {
        return Err(incomplete(problems));
    }
    graph.stats.insert("render".into(), render);
    list_assets(dir, graph, &levels);
    graph.validate()?;
    write_graph(dir, graph)?;
    Ok(expected.len())
}

/// Whether a bundle file exists and decodes, by its kind: `Err(None)` when
/// it is missing, `Err(Some(why))` when it does not decode.
fn check_asset(dir: &Path, name: &str) -> Result<(), Option<String>> {
    let bytes = std::fs::read(dir.join(name)).map_err(|_| None)?;
    let bad = |e: &dyn std::fmt::Display| Some(format!("does not decode ({e})"));
    match name.rsplit('.').next().unwrap_or("") {
        "jpg" => image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg).map(drop).map_err(|e| bad(&e)),
        "mp4" => match exploremaps_format::video::Mp4Decoder::new(bytes).map_err(|e| bad(&e))?.next_frame() {
            Ok(Some(_)) => Ok(()),
            Ok(None) => Err(Some("does not decode (no frame)".into())),
            Err(e) => Err(bad(&e)),
        },
        "emmc" => exploremaps_format::meshcode::decode(&bytes).map(drop).map_err(|e| bad(&e)),
        "seen" => exploremaps_format::seen::decode_runs(&bytes, None).map(drop).map_err(|e| bad(&e)),
        "emdm" => exploremaps_format::depthmap::DepthMap::decode(&bytes, u32::MAX).map(drop).map_err(|e| bad(&e)),
        // A packet applies to the mesh before it; alone, each one's frame is checked.
        "emvs" => exploremaps_format::splits::packets(&bytes).map(drop).map_err(|e| bad(&e)),
        "glb" => match std::panic::catch_unwind(|| gltf::Gltf::from_slice(&bytes)) {
            Ok(parsed) => parsed.map(drop).map_err(|e| bad(&e)),
            Err(_) => Err(bad(&"a panic in gltf")),
        },
        _ => Ok(()),
    }
}
