//! Exports a bundle as a tour other viewers open: Pannellum, Marzipano and
//! Photo Sphere Viewer (with its virtual-tour plugin), from one set of tiles.
//! Each link plays the path's 360° transition video over the viewer, or
//! draws its glide from the panoramas and their depth ([`glides`]), with
//! `transition.js` through the viewer's own API, and falls back to the
//! viewer's own fade where video or WebGL is missing.
//!
//! The export is a folder for any static host:
//! ```text
//! index.html              links to each viewer's tour
//! tour.js                 the tour for our scripts: probes, tiles, links with videos or glides
//! transition.js           the transitions: video, or glide
//! glide/                  the glides' panoramas and depth ([`glides`])
//! tiles/<probe>/...       the tile pyramid ([`exploremaps_format::Tiles`] layout)
//! thumbs/<probe>.jpg, videos/<path>.mp4
//! pannellum/              index.html, tour.json (a Pannellum tour config)
//! marzipano/              index.html, data.js (APP_DATA)
//! psv/                    index.html (its nodes made from tour.js)
//! lib/                    the viewers' libraries, when copied from npm
//! ```
//! It is written beside the destination and renamed into place, so a failed
//! export leaves no half-written folder.

mod glides;
pub mod matterport;

use exploremaps_format::{Graph, Tiles};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Viewer {
    Pannellum,
    Marzipano,
    Psv,
}

impl Viewer {
    pub const ALL: [Viewer; 3] = [Viewer::Pannellum, Viewer::Marzipano, Viewer::Psv];

    /// The folder, and the name on the command line.
    pub fn folder(self) -> &'static str {
        match self {
            Viewer::Pannellum => "pannellum",
            Viewer::Marzipano => "marzipano",
            Viewer::Psv => "psv",
        }
    }

    fn title(self) -> &'static str {
        match self {
            Viewer::Pannellum => "Pannellum",
            Viewer::Marzipano => "Marzipano",
            Viewer::Psv => "Photo Sphere Viewer",
        }
    }

    /// The npm files each page loads: (package, version, file in the
    /// package). Versions are pinned so a CDN reference keeps working.
    fn library(self) -> &'static [(&'static str, &'static str, &'static str)] {
        match self {
            Viewer::Pannellum => &[("pannellum", "2.5.7", "build/pannellum.js"), ("pannellum", "2.5.7", "build/pannellum.css")],
            Viewer::Marzipano => &[("marzipano", "0.10.2", "dist/marzipano.js")],
            Viewer::Psv => &[
                ("three", "0.185.1", "build/three.module.js"),
                ("three", "0.185.1", "build/three.core.js"),
                ("@photo-sphere-viewer/core", "5.15.1", "index.module.js"),
                ("@photo-sphere-viewer/core", "5.15.1", "index.css"),
                ("@photo-sphere-viewer/cubemap-adapter", "5.15.1", "index.module.js"),
                ("@photo-sphere-viewer/cubemap-tiles-adapter", "5.15.1", "index.module.js"),
                ("@photo-sphere-viewer/virtual-tour-plugin", "5.15.1", "index.module.js"),
                ("@photo-sphere-viewer/virtual-tour-plugin", "5.15.1", "index.css"),
            ],
        }
    }

    fn page(self) -> &'static str {
        match self {
            Viewer::Pannellum => include_str!("pannellum.html"),
            Viewer::Marzipano => include_str!("marzipano.html"),
            Viewer::Psv => include_str!("psv.html"),
        }
    }
}

impl std::str::FromStr for Viewer {
    type Err = String;
    fn from_str(s: &str) -> Result<Viewer, String> {
        Viewer::ALL.into_iter().find(|v| v.folder() == s).ok_or_else(|| format!("{s}: not a tour viewer; use pannellum, marzipano, psv or all"))
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TourError {
    #[error("{path}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: cannot read the image (render the bundle again)")]
    Image { path: String, source: image::ImageError },
    #[error("probe {0} has no panorama (or, for a glide, no depth); run `exploremaps render` on the bundle first")]
    NotRendered(u32),
    #[error("{path}: the depth cube does not decode (render the bundle again)")]
    Depth { path: String, source: exploremaps_format::edgebreaker::CodingError },
    #[error("{0} exists and is not a tour this command wrote; choose another folder or remove it")]
    Occupied(String),
    #[error("{path} is missing: install the viewers' libraries there with `npm install {packages}`, or leave out --library to reference them on the jsDelivr CDN")]
    Library { path: String, packages: String },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> TourError + '_ {
    move |source| TourError::Io { path: path.display().to_string(), source }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct TourReport {
    pub probes: usize,
    pub links: usize,
    pub tiles: usize,
    pub bytes: u64,
}

/// The file a finished export is marked with; an existing folder holding it
/// may be replaced.
pub const MARKER: &str = "exploremaps-tour.json";
/// Tiles cut here for bundles written before tiles existed.
const TILE: u32 = 512;
const TILE_QUALITY: u8 = 90;

/// Writes the tour of the bundle in `bundle` (its graph `graph`) for
/// `viewers` into `out`. `library`: a `node_modules` folder to copy the
/// viewers' scripts from; without it the pages load them from jsDelivr.
/// `progress(done, of)` follows the probes.
pub fn export(
    bundle: &Path,
    graph: &Graph,
    viewers: &[Viewer],
    out: &Path,
    library: Option<&Path>,
    mut progress: impl FnMut(usize, usize),
) -> Result<TourReport, TourError> {
    if let Some(p) = graph.probes.iter().find(|p| p.assets.tiles.is_none() && p.assets.cube_levels.is_empty()) {
        return Err(TourError::NotRendered(p.id));
    }
    if let Some(lib) = library {
        for (package, _, file) in viewers.iter().flat_map(|v| v.library()) {
            if !lib.join(package).join(file).exists() {
                let packages: Vec<String> = viewers
                    .iter()
                    .flat_map(|v| v.library())
                    .map(|(p, v, _)| format!("{p}@{v}"))
                    .collect::<std::collections::BTreeSet<_>>()
                    .into_iter()
                    .collect();
                return Err(TourError::Library { path: lib.join(package).join(file).display().to_string(), packages: packages.join(" ") });
            }
        }
    }
    into_folder(out, |part| write_tour(bundle, graph, viewers, part, library, &mut progress))
}

/// Fills `out` through `fill`, which writes into a hidden folder beside it
/// renamed into place at the end (no half-written folder, whatever fails).
/// `out` may be absent, empty, or a folder this command wrote.
fn into_folder<R>(out: &Path, fill: impl FnOnce(&Path) -> Result<R, TourError>) -> Result<R, TourError> {
    if out.exists() && !out.join(MARKER).exists() && std::fs::read_dir(out).map_err(io(out))?.next().is_some() {
        return Err(TourError::Occupied(out.display().to_string()));
    }
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "tour".into());
    let part = out.with_file_name(format!(".{name}.part"));
    if part.exists() {
        std::fs::remove_dir_all(&part).map_err(io(&part))?;
    }
    let result = fill(&part);
    let report = match result {
        Ok(report) => report,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&part);
            return Err(e);
        }
    };
    if out.exists() {
        std::fs::remove_dir_all(out).map_err(io(out))?;
    }
    std::fs::rename(&part, out).map_err(io(out))?;
    Ok(report)
}

/// The six faces of a cube level of the bundle.
fn read_faces(bundle: &Path, level: &exploremaps_format::CubeLevel) -> Result<Vec<image::RgbImage>, TourError> {
    level
        .faces
        .iter()
        .map(|f| {
            let path = bundle.join(f);
            image::open(&path).map(|i| i.to_rgb8()).map_err(|source| TourError::Image { path: path.display().to_string(), source })
        })
        .collect()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<u64, TourError> {
    let path = dir.join(name);
    crate::files::write_atomic(&path, bytes).map_err(io(&path))?;
    Ok(bytes.len() as u64)
}

fn copy(from: &Path, dir: &Path, name: &str) -> Result<u64, TourError> {
    let to = dir.join(name);
    std::fs::create_dir_all(to.parent().expect("a file in the folder")).map_err(io(&to))?;
    std::fs::copy(from, &to).map_err(io(from))
}

/// The angle in degrees, rounded to a thousandth.
fn degrees(radians: f32) -> f64 {
    (f64::from(radians).to_degrees() * 1e3).round() / 1e3
}

fn radians(radians: f32) -> f64 {
    (f64::from(radians) * 1e6).round() / 1e6
}

/// A probe's tiles in the export, copied from the bundle or cut from its
/// largest cube faces. Returns the tiles (paths inside the export) and the
/// files and bytes written.
fn probe_tiles(bundle: &Path, graph: &Graph, id: usize, dir: &Path) -> Result<(Tiles, usize, u64), TourError> {
    let assets = &graph.probes[id].assets;
    let folder = format!("tiles/{id}");
    if let Some(tiles) = &assets.tiles {
        let mut bytes = 0;
        let files = tiles.files();
        for file in files.iter().chain([&tiles.preview]) {
            let inside = file.strip_prefix(&tiles.path).unwrap_or(file);
            bytes += copy(&bundle.join(file), dir, &format!("{folder}{inside}"))?;
        }
        let moved = Tiles { path: folder.clone(), preview: format!("{folder}/preview.jpg"), ..tiles.clone() };
        return Ok((moved, files.len(), bytes));
    }
    let largest = assets.cube_levels.iter().max_by_key(|l| l.size).ok_or(TourError::NotRendered(id as u32))?;
    let faces = read_faces(bundle, largest)?;
    let tiles = Tiles::new(folder, largest.size, TILE, 256.min(largest.size));
    let (mut files, mut bytes) = (0, 0);
    crate::tiles::cut(&tiles, &[(largest.size, faces)], |name, tile| {
        let jpeg = crate::files::jpeg(&tile, TILE_QUALITY);
        files += 1;
        bytes += write(dir, name, &jpeg)?;
        Ok::<_, TourError>(())
    })?;
    Ok((tiles, files - 1, bytes))
}

/// One way along a path, as a link from one probe to the next.
struct Link {
    from: u32,
    to: u32,
    path: u32,
    reversed: bool,
    departure: (f32, f32),
    arrival: (f32, f32),
}

fn links(graph: &Graph) -> Vec<Link> {
    let mut links = Vec::new();
    for p in &graph.paths {
        for reversed in [false, true] {
            let (from, to) = if reversed { (p.to, p.from) } else { (p.from, p.to) };
            links.push(Link {
                from,
                to,
                path: p.id,
                reversed,
                departure: p.travel_direction(reversed, false),
                arrival: graph.arrival_direction(p, reversed),
            });
        }
    }
    links
}

fn write_tour(
    bundle: &Path,
    graph: &Graph,
    viewers: &[Viewer],
    dir: &Path,
    library: Option<&Path>,
    progress: &mut impl FnMut(usize, usize),
) -> Result<TourReport, TourError> {
    // Titles follow the thumbnail bar: "View 1" is the first there.
    let mut rank: Vec<usize> = (0..graph.probes.len()).collect();
    for (k, &id) in graph.bar_order.iter().enumerate() {
        rank[id as usize] = k;
    }
    let mut tour = TourFiles { bundle, graph, dir, rank, report: TourReport { probes: graph.probes.len(), ..Default::default() } };
    let probes = tour.probes(progress)?;
    let videos = tour.videos()?;
    let (glide_sources, bytes) = glides::write_sources(bundle, graph, dir)?;
    tour.report.bytes += bytes;
    let links = links(graph);
    tour.report.links = links.len();
    let direction = |(yaw, pitch): (f32, f32)| json!({ "yaw": radians(yaw), "pitch": radians(pitch) });
    let tour_links: Vec<Value> = links
        .iter()
        .map(|l| {
            json!({
                "from": l.from.to_string(), "to": l.to.to_string(), "video": videos[l.path as usize], "reversed": l.reversed,
                "duration": graph.paths[l.path as usize].duration_s, "departure": direction(l.departure), "arrival": direction(l.arrival),
                "glide": glides::link(&graph.paths[l.path as usize], l.reversed),
            })
        })
        .collect();
    let first = graph.bar_order.first().copied().unwrap_or(0);
    let data =
        json!({ "title": graph.scene.name, "first": first.to_string(), "probes": probes, "links": tour_links, "glide_sources": glide_sources });
    let tour_js = format!(
        "// The tour, for ExploreMaps' scripts (written by `exploremaps export`).\nwindow.EXPLOREMAPS_TOUR = {};\n",
        serde_json::to_string_pretty(&data).expect("JSON of plain values")
    );
    tour.report.bytes += write(dir, "tour.js", tour_js.as_bytes())?;
    tour.report.bytes += write(dir, "transition.js", include_str!("transition.js").as_bytes())?;
    for &viewer in viewers {
        tour.viewer(viewer, library, &data, &links)?;
    }
    let items: String = viewers.iter().map(|v| format!("<li><a href=\"{}/index.html\">{}</a></li>\n", v.folder(), v.title())).collect();
    let index = include_str!("index.html").replace("{{TITLE}}", &html_escape(&graph.scene.name)).replace("{{VIEWERS}}", &items);
    tour.report.bytes += write(dir, "index.html", index.as_bytes())?;
    let marker =
        json!({ "generator": concat!("exploremaps ", env!("CARGO_PKG_VERSION")), "viewers": viewers.iter().map(|v| v.folder()).collect::<Vec<_>>() });
    write(dir, MARKER, marker.to_string().as_bytes())?;
    Ok(tour.report)
}

/// A tour's files as they are written into `dir`, counted in `report`.
struct TourFiles<'a> {
    bundle: &'a Path,
    graph: &'a Graph,
    dir: &'a Path,
    /// Per probe, its place in the thumbnail bar.
    rank: Vec<usize>,
    report: TourReport,
}

impl TourFiles<'_> {
    fn title(&self, id: u32) -> String {
        format!("View {}", self.rank[id as usize] + 1)
    }

    /// Each probe's tiles and thumbnail copied, and its entry in the tour.
    fn probes(&mut self, progress: &mut impl FnMut(usize, usize)) -> Result<Vec<Value>, TourError> {
        let (bundle, graph, dir) = (self.bundle, self.graph, self.dir);
        let mut probes = Vec::new();
        for (id, probe) in graph.probes.iter().enumerate() {
            progress(id, graph.probes.len());
            let (tiles, count, bytes) = probe_tiles(bundle, graph, id, dir)?;
            self.report.tiles += count;
            self.report.bytes += bytes;
            let thumbnail = match &probe.assets.thumbnail {
                Some(file) => {
                    let name = format!("thumbs/{id}.jpg");
                    self.report.bytes += copy(&bundle.join(file), dir, &name)?;
                    Some(name)
                }
                None => None,
            };
            let (yaw, pitch) = probe.preferred_directions.first().map_or((0.0, 0.0), |d| (d.yaw, d.pitch));
            probes.push(json!({
                "id": id.to_string(), "title": self.title(id as u32), "thumbnail": thumbnail,
                "yaw": radians(yaw), "pitch": radians(pitch), "tiles": tiles,
            }));
        }
        progress(graph.probes.len(), graph.probes.len());
        Ok(probes)
    }

    /// The paths' videos copied; per path, its name in the tour.
    fn videos(&mut self) -> Result<Vec<Option<String>>, TourError> {
        let mut videos = vec![None; self.graph.paths.len()];
        for p in &self.graph.paths {
            if let Some(file) = &p.assets.video {
                let name = format!("videos/{}.mp4", p.id);
                self.report.bytes += copy(&self.bundle.join(file), self.dir, &name)?;
                videos[p.id as usize] = Some(name);
            }
        }
        Ok(videos)
    }

    /// A viewer's page, its library copied from `library` (or linked from
    /// a CDN), and its own description of the tour.
    fn viewer(&mut self, viewer: Viewer, library: Option<&Path>, tour: &Value, links: &[Link]) -> Result<(), TourError> {
        let (graph, dir) = (self.graph, self.dir);
        let mut page = viewer.page().replace("{{TITLE}}", &html_escape(&graph.scene.name));
        for (package, version, file) in viewer.library() {
            let url = match library {
                Some(lib) => {
                    let name = format!("lib/{package}/{file}");
                    self.report.bytes += copy(&lib.join(package).join(file), dir, &name)?;
                    format!("../{name}")
                }
                None => format!("https://cdn.jsdelivr.net/npm/{package}@{version}/{file}"),
            };
            page = page.replace(&format!("{{{{{package}/{file}}}}}"), &url);
        }
        debug_assert!(!page.contains("{{"), "every placeholder of {} is filled", viewer.folder());
        let folder = viewer.folder();
        self.report.bytes += write(dir, &format!("{folder}/index.html"), page.as_bytes())?;
        let title = |id: u32| self.title(id);
        let written = match viewer {
            Viewer::Pannellum => {
                let json = serde_json::to_string_pretty(&pannellum(graph, tour, links, &title)).expect("JSON");
                write(dir, "pannellum/tour.json", json.as_bytes())?
            }
            Viewer::Marzipano => {
                let data = format!("var APP_DATA = {};\n", serde_json::to_string_pretty(&marzipano(graph, tour, links, &title)).expect("JSON"));
                write(dir, "marzipano/data.js", data.as_bytes())?
            }
            Viewer::Psv => 0,
        };
        self.report.bytes += written;
        Ok(())
    }
}

fn html_escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The tiles of probe `id` as the tour lists them.
fn tiles_of(tour: &Value, id: u32) -> Tiles {
    serde_json::from_value(tour["probes"][id as usize]["tiles"].clone()).expect("written above")
}

/// Pannellum's tour config: one `multires` scene a probe, its links as
/// `scene` hot spots at the departure direction, arriving at `targetYaw`.
/// Paths are relative to `pannellum/`.
fn pannellum(graph: &Graph, tour: &Value, links: &[Link], title: &dyn Fn(u32) -> String) -> Value {
    let mut scenes = serde_json::Map::new();
    for probe in &graph.probes {
        let tiles = tiles_of(tour, probe.id);
        let hot_spots: Vec<Value> = links
            .iter()
            .filter(|l| l.from == probe.id)
            .map(|l| {
                json!({
                    "type": "scene", "sceneId": l.to.to_string(), "text": title(l.to),
                    "yaw": degrees(l.departure.0), "pitch": degrees(l.departure.1),
                    "targetYaw": degrees(l.arrival.0), "targetPitch": degrees(l.arrival.1),
                })
            })
            .collect();
        let (yaw, pitch) = probe.preferred_directions.first().map_or((0.0, 0.0), |d| (d.yaw, d.pitch));
        scenes.insert(
            probe.id.to_string(),
            json!({
                "title": title(probe.id), "type": "multires", "yaw": degrees(yaw), "pitch": degrees(pitch),
                "multiRes": {
                    "basePath": format!("../{}", tiles.path), "path": "/%l/%s/%y/%x", "extension": "jpg",
                    "tileResolution": tiles.tile, "maxLevel": tiles.levels, "cubeResolution": tiles.size,
                },
                "hotSpots": hot_spots,
            }),
        );
    }
    json!({
        "default": { "firstScene": tour["first"], "title": graph.scene.name, "autoLoad": true, "sceneFadeDuration": 600, "hfov": 100 },
        "scenes": scenes,
    })
}

/// Marzipano's `APP_DATA` (as its tool writes it): per scene the levels,
/// the first a preview strip, the face size, the initial view in radians
/// and link hot spots. Marzipano's pitch is positive downward. Paths are
/// relative to `marzipano/`.
fn marzipano(graph: &Graph, tour: &Value, links: &[Link], title: &dyn Fn(u32) -> String) -> Value {
    let scenes: Vec<Value> = graph
        .probes
        .iter()
        .map(|probe| {
            let tiles = tiles_of(tour, probe.id);
            let mut levels = vec![json!({ "tileSize": tiles.preview_size, "size": tiles.preview_size, "fallbackOnly": true })];
            levels.extend((1..=tiles.levels).map(|l| json!({ "tileSize": tiles.tile, "size": tiles.level_size(l) })));
            let hotspots: Vec<Value> = links
                .iter()
                .filter(|l| l.from == probe.id)
                .map(|l| json!({ "yaw": radians(l.departure.0), "pitch": radians(-l.departure.1), "rotation": 0, "target": l.to.to_string() }))
                .collect();
            let (yaw, pitch) = probe.preferred_directions.first().map_or((0.0, 0.0), |d| (d.yaw, d.pitch));
            json!({
                "id": probe.id.to_string(), "name": title(probe.id), "levels": levels, "faceSize": tiles.size,
                "tiles": format!("../{}", tiles.path), "preview": format!("../{}", tiles.preview),
                "initialViewParameters": { "yaw": radians(yaw), "pitch": radians(-pitch), "fov": 1.2 },
                "linkHotspots": hotspots, "infoHotspots": [],
            })
        })
        .collect();
    json!({ "scenes": scenes, "name": graph.scene.name })
}

/// Where `exploremaps export` writes by default: `<bundle>-tour` beside it.
pub fn default_folder(bundle: &Path) -> PathBuf {
    let name = bundle.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "bundle".into());
    bundle.with_file_name(format!("{name}-tour"))
}
