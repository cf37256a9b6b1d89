//! The ExploreMaps bundle format: the `graph.json` at the root of a bundle
//! folder, shared by the builder (which writes it) and the viewer (which reads
//! it, natively and in the browser). Documented field by field in SCHEMA.md.
//!
//! Conventions: positions are in scene units with +Y up (`scene.metres_per_unit`
//! converts to metres); directions are yaw (radians, 0 = −Z, growing toward +X)
//! and pitch (radians, + up); asset names are relative paths inside the bundle.

use serde::{Deserialize, Serialize};

pub mod depthcube;
pub mod depthmap;
pub mod edgebreaker;
pub mod meshcode;
pub mod record;
pub mod seen;
pub mod splits;
pub mod timing;
#[cfg(feature = "video")]
pub mod video;

/// Bumped whenever a reader of the previous version would misread a bundle.
pub const FORMAT_VERSION: u32 = 1;
pub const GRAPH_FILE: &str = "graph.json";

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Graph {
    pub format_version: u32,
    /// Program and version that wrote the bundle.
    pub generator: String,
    pub scene: SceneInfo,
    pub probes: Vec<Probe>,
    #[serde(default)]
    pub clusters: Vec<Cluster>,
    #[serde(default)]
    pub paths: Vec<Path>,
    /// Probe ids in thumbnail-bar order (empty until the order stage runs).
    #[serde(default)]
    pub bar_order: Vec<u32>,
    #[serde(default)]
    pub coverage: Option<Coverage>,
    /// A light 3D stand-in of the scene (absent until rendered).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proxy: Option<Proxy>,
    /// What the stages recorded: the plan's and the render's settings, and
    /// each planning stage's figures (no times: timings.json has them).
    #[serde(default)]
    pub stats: record::Stats,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneInfo {
    pub name: String,
    /// Where the scene came from: a file name, or `builtin:<name>`.
    pub source: String,
    pub triangles: u64,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    pub metres_per_unit: f32,
    /// `file`, `user` or `guessed`.
    pub scale_source: String,
    /// Navigable space the probes live in: `inside` or `outside`.
    #[serde(default)]
    pub space: Option<String>,
    /// Near distance r (minimum clearance of probes and paths), scene units.
    #[serde(default)]
    pub near_distance: Option<f32>,
    /// Eye height above the floor in metres when probes stand on floors (walk
    /// mode); absent when they fly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eye_height_m: Option<f32>,
    /// Attribution to show wherever the scene is shown.
    #[serde(default)]
    pub credits: Vec<String>,
}

/// The scene simplified for an overview and point-to-go: levels coded whole
/// (the `EMMC` format of [`meshcode`]), each with colour baked from the same
/// lighting as the panoramas.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Proxy {
    /// Finest first.
    pub levels: Vec<ProxyLevel>,
    /// The finest level as a standard glTF binary (vertex colours, unlit).
    #[serde(default)]
    pub glb: Option<String>,
    /// Heights of the storeys' floors (scene units, lowest first) where
    /// probes stand on floors, for the dollhouse's floor cut; empty otherwise.
    #[serde(default)]
    pub floors: Vec<f32>,
    /// Per probe (by id), its point-to-go depth cube ([`depthmap`]); empty
    /// in bundles written before they existed.
    #[serde(default)]
    pub depth_maps: Vec<String>,
    /// The vertex splits that refine the coarsest level into the finest, in
    /// packets; absent in bundles written before them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stream: Option<ProxyStream>,
}

/// A progressive proxy: packets of vertex splits ([`splits`]) that, applied
/// in order to level `from` as decoded (its groups replaced by its
/// point-to-go table), rebuild level `to` triangle for triangle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProxyStream {
    pub from: usize,
    pub to: usize,
    /// Each triangle's group in the packets is its point-to-go entry (the
    /// probe that sees it best; the probe count for none), continuing the
    /// coarse level's table ([`ProxyLevel::seen`]).
    pub packets: Vec<ProxyPacket>,
}

/// A packet of vertex splits: `bytes` bytes from `offset` in `file` (a
/// file holds several, so a viewer fetches a few files yet applies small
/// packets), and the mesh's triangle count once it is applied.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProxyPacket {
    pub file: String,
    #[serde(default)]
    pub offset: u64,
    pub bytes: u64,
    pub triangles: u64,
}

impl ProxyPacket {
    /// The packet's bytes in its file's, or an error to show.
    pub fn slice<'a>(&self, file: &'a [u8]) -> Result<&'a [u8], String> {
        let end = self.offset.checked_add(self.bytes).filter(|&e| e <= file.len() as u64);
        end.map(|e| &file[self.offset as usize..e as usize]).ok_or_else(|| {
            format!("is {} bytes, shorter than graph.json says (a packet at {}..{})", file.len(), self.offset, self.offset.saturating_add(self.bytes))
        })
    }
}

impl ProxyStream {
    /// The files the packets are in, in order, each with its packets' indices.
    pub fn files(&self) -> Vec<(String, Vec<usize>)> {
        let mut out: Vec<(String, Vec<usize>)> = Vec::new();
        for (k, p) in self.packets.iter().enumerate() {
            match out.last_mut() {
                Some((file, ks)) if *file == p.file => ks.push(k),
                _ => out.push((p.file.clone(), vec![k])),
            }
        }
        out
    }

    /// The level the proxy is at once packet `k` is applied.
    pub fn level_after(&self, k: usize) -> usize {
        if k + 1 >= self.packets.len() {
            self.to
        } else {
            self.from
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProxyLevel {
    pub file: String,
    pub triangles: u64,
    pub vertices: u64,
    /// Largest distance from the scene's surface the simplification allowed,
    /// scene units (an estimate from its quadrics, summed over levels).
    pub error: f32,
    pub bytes: u64,
    /// The level's point-to-go table ([`seen`]): per decoded triangle, the
    /// probe that sees it best.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seen: Option<String>,
    /// The level cut into spatial chunks, each coded on its own (a viewer
    /// decodes one between two frames); when present they are the level, and
    /// `file` and `seen` name the first of them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub chunks: Vec<ProxyChunk>,
}

/// A chunk of a proxy level: a coded mesh and its point-to-go table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProxyChunk {
    pub file: String,
    pub seen: Option<String>,
    pub triangles: u64,
    pub bytes: u64,
}

impl ProxyLevel {
    /// How many parts the level comes in.
    pub fn part_count(&self) -> usize {
        self.chunks.len().max(1)
    }

    /// The level's parts: its chunks, or the level whole.
    pub fn parts(&self) -> Vec<ProxyChunk> {
        if self.chunks.is_empty() {
            vec![ProxyChunk { file: self.file.clone(), seen: self.seen.clone(), triangles: self.triangles, bytes: self.bytes }]
        } else {
            self.chunks.clone()
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ceiling {
    pub area: f64,
    /// Of `area`, what some point of the navigable space sees.
    pub seen_from_space: f64,
    /// Of `area`, what the probes see.
    pub covered: f64,
    /// Surface seen from the free space only through crevices (gaps about two
    /// voxels wide or less, where no viewpoint fits); not part of `area`.
    #[serde(default)]
    pub crevices: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewDirection {
    pub yaw: f32,
    pub pitch: f32,
    /// View goodness, higher is better (orient stage).
    pub goodness: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Probe {
    /// Equal to the probe's index in `probes`.
    pub id: u32,
    pub position: [f32; 3],
    #[serde(default)]
    pub cluster: Option<u32>,
    /// Best first; the first is the arrival and thumbnail direction.
    #[serde(default)]
    pub preferred_directions: Vec<ViewDirection>,
    /// Placed by the user (`--probe`) rather than by exploration.
    #[serde(default)]
    pub user_placed: bool,
    #[serde(default)]
    pub assets: ProbeAssets,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ProbeAssets {
    /// Cube maps from low to high resolution, for progressive loading.
    #[serde(default)]
    pub cube_levels: Vec<CubeLevel>,
    #[serde(default)]
    pub equirect: Option<String>,
    #[serde(default)]
    pub thumbnail: Option<String>,
    /// The cube as a pyramid of 512-pixel tiles (absent in bundles written
    /// before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tiles: Option<Tiles>,
    /// The probe's depth for glides ([`depthcube`]), where the bundle has them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<String>,
}

/// A probe's cube faces cut into square tiles, level by level, in the
/// orientation tour viewers use (Pannellum, Marzipano, krpano, Photo Sphere
/// Viewer): each face as seen from the cube's centre, upright for the four
/// side faces; the top face's upper edge toward the back (+Z), the bottom
/// face's toward the front (−Z). Faces are named `f` (−Z, yaw 0), `r` (+X),
/// `b` (+Z), `l` (−X), `u` (+Y), `d` (−Y). Level 1 is the smallest (one tile
/// a face when the largest face is a power of two times the tile); each level
/// doubles, the last is `size`. Tile (x, y), x to the right and y down, is
/// `<path>/<level>/<face>/<y>/<x>.jpg`; tiles on a face's right and bottom
/// edges are cut short when the level's size is not a multiple of the tile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tiles {
    /// The largest level's face edge, pixels.
    pub size: u32,
    /// Tile edge, pixels.
    pub tile: u32,
    /// How many levels.
    pub levels: u32,
    /// Folder of the tiles.
    pub path: String,
    /// The six faces at `preview_size`, stacked top to bottom in the order
    /// `b d f l r u` (Marzipano's preview strip).
    pub preview: String,
    pub preview_size: u32,
}

/// Tour-viewer face names of the bundle's cube faces, in [`CUBE_FACES`]
/// order: +X is `r`, −X `l`, +Y `u`, −Y `d`, +Z `b`, −Z `f`.
pub const TILE_FACES: [char; 6] = ['r', 'l', 'u', 'd', 'b', 'f'];
/// The order of faces in a [`Tiles`] preview strip.
pub const PREVIEW_ORDER: [char; 6] = ['b', 'd', 'f', 'l', 'r', 'u'];

impl Tiles {
    /// The pyramid for faces up to `size`: levels halve from `size` until one
    /// tile covers a face. The tile is at most `max_tile`, and the smallest
    /// level's size when halving is exact, so each level is a whole number of
    /// tiles (viewers that scale tiles to a grid need that); otherwise it is
    /// `max_tile` and the edge tiles are cut short.
    pub fn new(path: String, size: u32, max_tile: u32, preview_size: u32) -> Tiles {
        let mut levels = 1;
        while size.div_ceil(1 << (levels - 1)) > max_tile {
            levels += 1;
        }
        let halves = 1 << (levels - 1);
        let tile = if size.is_multiple_of(halves) { size / halves } else { max_tile };
        let preview = format!("{path}/preview.jpg");
        Tiles { size, tile, levels, path, preview, preview_size }
    }

    /// Face edge of `level` (1..=levels), pixels.
    pub fn level_size(&self, level: u32) -> u32 {
        self.size.div_ceil(1 << (self.levels - level.clamp(1, self.levels)))
    }

    /// Tiles across a face at `level`.
    pub fn across(&self, level: u32) -> u32 {
        self.level_size(level).div_ceil(self.tile)
    }

    pub fn file(&self, level: u32, face: char, x: u32, y: u32) -> String {
        format!("{}/{level}/{face}/{y}/{x}.jpg", self.path)
    }

    /// Every tile file, smallest level first.
    pub fn files(&self) -> Vec<String> {
        let mut files = Vec::new();
        for level in 1..=self.levels {
            let n = self.across(level);
            for face in TILE_FACES {
                for y in 0..n {
                    files.extend((0..n).map(|x| self.file(level, face, x, y)));
                }
            }
        }
        files
    }

    /// Pixel (s, t) of bundle cube face `face` ([`CUBE_FACES`] order), both
    /// in [0, 1], lies at (s', t') of tour face `TILE_FACES[face]`: the side
    /// faces are mirrored left to right, top and bottom upside down.
    pub fn face_coordinates(face: usize, s: f32, t: f32) -> (f32, f32) {
        if face == 2 || face == 3 {
            (s, 1.0 - t)
        } else {
            (1.0 - s, t)
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CubeLevel {
    /// Face edge in pixels.
    pub size: u32,
    /// Faces in the order +X, −X, +Y, −Y, +Z, −Z.
    pub faces: [String; 6],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cluster {
    pub id: u32,
    /// The final probe that represents the cluster.
    pub probe: u32,
    /// How many candidate probes the cluster merged.
    pub candidates: u32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Path {
    pub id: u32,
    pub from: u32,
    pub to: u32,
    /// Smoothed camera path from `from` to `to`, at least two points.
    pub polyline: Vec<[f32; 3]>,
    /// Scene units.
    pub length: f32,
    pub duration_s: f32,
    /// Camera keys along the path (time, position, view); empty until timed.
    #[serde(default)]
    pub camera: Vec<CameraKey>,
    #[serde(default)]
    pub assets: PathAssets,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraKey {
    pub t_s: f32,
    pub position: [f32; 3],
    pub yaw: f32,
    pub pitch: f32,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PathAssets {
    #[serde(default)]
    pub video: Option<String>,
    #[serde(default)]
    pub poster: Option<String>,
    /// How the render chose to show this path (absent: by its video, as in
    /// bundles rendered with `--transitions video` or before glides).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transition: Option<Transition>,
}

/// A path's transition as the render chose it, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transition {
    pub kind: TransitionKind,
    /// The largest share of the view from the path (by solid angle) that
    /// neither end of its leg sees (or sees only at under a quarter of the
    /// camera's detail), over the points measured along each leg.
    pub unseen: f32,
    /// Why, in words.
    pub reason: String,
    /// Panoramas part way, in order along the path: the glide goes in legs
    /// from the departure to the first, ..., from the last to the arrival.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub waypoints: Vec<Waypoint>,
}

/// Where a glide draws from: a probe, or a panorama part way along the path
/// (its index in the path's waypoints).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlideSource {
    Probe(u32),
    Waypoint(usize),
}

/// A panorama part way along a path, seen only in passing (smaller than a
/// probe's, one level, no tiles).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Waypoint {
    /// The camera key it stands at.
    pub key: u32,
    pub position: [f32; 3],
    /// Its cube faces (+X, −X, +Y, −Y, +Z, −Z).
    pub cube: CubeLevel,
    /// Its depth cube (`.emdc`).
    pub depth: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TransitionKind {
    /// Drawn by the viewer from the two ends' panoramas and depth.
    Depth,
    /// The path's 360° video.
    Video,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coverage {
    /// Area-uniform surface samples used.
    pub samples: u32,
    /// Surface area seeable from navigable space, scene units² (from eye
    /// height when walking).
    pub reachable_area: f64,
    pub covered_area: f64,
    /// The ceiling: surface seeable from anywhere in the free space inside the
    /// scene's bounding box (outside closed solids), and how much of it the
    /// navigable space and the probes see, scene units².
    #[serde(default)]
    pub ceiling: Option<Ceiling>,
    /// Per material (or object): name, reachable area, covered area.
    #[serde(default)]
    pub per_group: Vec<GroupCoverage>,
    /// (probe count, covered fraction) in placement order.
    #[serde(default)]
    pub curve: Vec<(u32, f64)>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupCoverage {
    pub name: String,
    pub reachable_area: f64,
    pub covered_area: f64,
}

/// An error and its sources, each once, joined by ": " (as anyhow's `{:#}`).
/// Errors here never repeat their source in their own text.
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        text.push_str(": ");
        text.push_str(&cause.to_string());
        source = cause.source();
    }
    text
}

#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    #[error("this bundle has format version {found}, but this program reads version {expected}; rebuild the bundle with this version of exploremaps, or use the matching viewer")]
    Version { found: u32, expected: u32 },
    #[error("graph.json is not valid JSON or lacks required fields")]
    Json(#[from] serde_json::Error),
    #[error("graph.json is inconsistent: {0}")]
    Invalid(String),
}

impl Path {
    /// A glide's sources along this path travelled one way, in that order:
    /// the departure, the panoramas part way, the arrival; each with where
    /// it stands as the fraction of the way the camera has come there (its
    /// eased time, as the viewers move the camera: departure 0, arrival 1).
    pub fn glide_sources(&self, reversed: bool) -> Vec<(GlideSource, f32)> {
        let duration = self.duration_s.max(1e-3);
        let waypoints = self.assets.transition.iter().flat_map(|t| &t.waypoints).enumerate().map(|(i, w)| {
            let s = self.camera.get(w.key as usize).map_or(0.5, |k| timing::ease(k.t_s / duration));
            (GlideSource::Waypoint(i), s)
        });
        let mut sources: Vec<(GlideSource, f32)> =
            [(GlideSource::Probe(self.from), 0.0)].into_iter().chain(waypoints).chain([(GlideSource::Probe(self.to), 1.0)]).collect();
        if reversed {
            sources.reverse();
            sources.iter_mut().for_each(|(_, s)| *s = 1.0 - *s);
        }
        sources
    }

    /// The direction of travel, (yaw, pitch), at the start of the path
    /// (`at_end == false`) or at its end, travelled forward or `reversed`:
    /// toward the first point a tenth of the path away from that end, so a
    /// kink at the probe does not set it.
    pub fn travel_direction(&self, reversed: bool, at_end: bool) -> (f32, f32) {
        let n = self.polyline.len();
        // Points in the order of travel.
        let point = |i: usize| self.polyline[if reversed { n - 1 - i } else { i }];
        let order: Vec<usize> = if at_end { (0..n).rev().collect() } else { (0..n).collect() };
        let reach = self.length * 0.1;
        let dist = |a: [f32; 3], b: [f32; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        let a = point(order[0]);
        let b = order[1..].iter().map(|&i| point(i)).find(|b| dist(a, *b) >= reach).unwrap_or(point(order[n - 1]));
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        yaw_pitch(if at_end { [-d[0], -d[1], -d[2]] } else { d })
    }
}

impl Graph {
    /// The direction to face on arriving by `path` (forward or `reversed`):
    /// the destination's best preferred direction, else the direction of
    /// travel at the end.
    pub fn arrival_direction(&self, path: &Path, reversed: bool) -> (f32, f32) {
        let to = if reversed { path.from } else { path.to };
        match self.probes.get(to as usize).and_then(|p| p.preferred_directions.first()) {
            Some(d) => (d.yaw, d.pitch),
            None => path.travel_direction(reversed, true),
        }
    }

    /// An empty graph for a scene, to be filled by the stages.
    pub fn new(scene: SceneInfo) -> Graph {
        Graph {
            format_version: FORMAT_VERSION,
            generator: format!("exploremaps {}", env!("CARGO_PKG_VERSION")),
            scene,
            probes: Vec::new(),
            clusters: Vec::new(),
            paths: Vec::new(),
            bar_order: Vec::new(),
            coverage: None,
            proxy: None,
            stats: record::Stats::default(),
        }
    }

    /// Parses and validates; a bundle of another format version is refused
    /// before any other check so the user gets the helpful message.
    pub fn from_json(text: &str) -> Result<Graph, FormatError> {
        #[derive(Deserialize)]
        struct VersionOnly {
            format_version: u32,
        }
        let version: VersionOnly = serde_json::from_str(text)?;
        if version.format_version != FORMAT_VERSION {
            return Err(FormatError::Version { found: version.format_version, expected: FORMAT_VERSION });
        }
        let graph: Graph = serde_json::from_str(text)?;
        graph.validate()?;
        Ok(graph)
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a Graph always serializes")
    }

    /// Checks every invariant a reader relies on; the first violation is returned.
    pub fn validate(&self) -> Result<(), FormatError> {
        if self.format_version != FORMAT_VERSION {
            return Err(FormatError::Version { found: self.format_version, expected: FORMAT_VERSION });
        }
        self.check().map_err(FormatError::Invalid)
    }

    fn check(&self) -> Result<(), String> {
        let s = &self.scene;
        if !(all_finite(&s.bounds_min) && all_finite(&s.bounds_max) && s.metres_per_unit.is_finite() && s.metres_per_unit > 0.0) {
            return Err("scene bounds or metres_per_unit are not finite and positive".into());
        }
        self.stats.floors()?;
        if s.near_distance.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
            return Err("scene.near_distance must be finite and positive".into());
        }
        let n = self.probes.len() as u32;
        for (i, p) in self.probes.iter().enumerate() {
            p.check(i, self.clusters.len())?;
        }
        for (i, c) in self.clusters.iter().enumerate() {
            if c.id != i as u32 || c.probe >= n {
                return Err(format!("cluster {i} has id {} or names probe {} (of {n})", c.id, c.probe));
            }
        }
        for (i, p) in self.paths.iter().enumerate() {
            p.check(i, n)?;
        }
        self.check_bar_order()?;
        if let Some(proxy) = &self.proxy {
            proxy.check(self.probes.len())?;
        }
        if let Some(c) = &self.coverage {
            if !(c.reachable_area.is_finite() && c.covered_area.is_finite() && c.covered_area <= c.reachable_area * (1.0 + 1e-9) + 1e-12) {
                return Err("coverage areas are not finite or covered exceeds reachable".into());
            }
        }
        Ok(())
    }

    /// Empty, or a permutation of the probes.
    fn check_bar_order(&self) -> Result<(), String> {
        if self.bar_order.is_empty() {
            return Ok(());
        }
        let n = self.probes.len();
        let mut seen = vec![false; n];
        for &id in &self.bar_order {
            if id as usize >= n || std::mem::replace(&mut seen[id as usize], true) {
                return Err(format!("bar_order is not a permutation of the {n} probes (at id {id})"));
            }
        }
        if seen.iter().any(|s| !s) {
            return Err("bar_order leaves out some probes".into());
        }
        Ok(())
    }
}

impl Probe {
    /// The checks of probe `i` among `clusters` clusters.
    fn check(&self, i: usize, clusters: usize) -> Result<(), String> {
        if self.id != i as u32 {
            return Err(format!("probe at index {i} has id {}", self.id));
        }
        if !all_finite(&self.position) {
            return Err(format!("probe {i} has a non-finite position"));
        }
        if self.preferred_directions.iter().any(|d| !(d.yaw.is_finite() && d.pitch.is_finite() && d.goodness.is_finite())) {
            return Err(format!("probe {i} has a non-finite preferred direction"));
        }
        if let Some(c) = self.cluster.filter(|&c| c as usize >= clusters) {
            return Err(format!("probe {i} names cluster {c}, but there are {clusters}"));
        }
        let a = &self.assets;
        if let Some(t) = &a.tiles {
            // Tiles of at least 64 pixels (or the whole face) bound the
            // count a hostile graph can make readers walk.
            if !(16..=16384).contains(&t.size)
                || !(64.min(t.size)..=4096).contains(&t.tile)
                || !(1..=15).contains(&t.levels)
                || t.size.div_ceil(1 << (t.levels - 1)) > t.tile
                || t.preview_size > 4096
            {
                return Err(format!("probe {i}: tiles of {} pixels a face, {} a tile, in {} levels do not agree", t.size, t.tile, t.levels));
            }
        }
        let tiles = a.tiles.iter().flat_map(|t| [&t.path, &t.preview]);
        let names = a.cube_levels.iter().flat_map(|l| l.faces.iter()).chain(&a.equirect).chain(&a.thumbnail).chain(tiles).chain(&a.depth);
        for name in names {
            check_asset_name(name).map_err(|m| format!("probe {i}: {m}"))?;
        }
        Ok(())
    }
}

impl Path {
    /// The checks of path `i` among `probes` probes.
    fn check(&self, i: usize, probes: u32) -> Result<(), String> {
        if self.id != i as u32 {
            return Err(format!("path at index {i} has id {}", self.id));
        }
        if self.from >= probes || self.to >= probes || self.from == self.to {
            return Err(format!("path {i} joins probes {} and {}, but there are {probes} probes", self.from, self.to));
        }
        if self.polyline.len() < 2 || !self.polyline.iter().all(all_finite) {
            return Err(format!("path {i} needs a finite polyline of at least two points"));
        }
        if !(self.length.is_finite() && self.length >= 0.0 && self.duration_s.is_finite() && self.duration_s >= 0.0) {
            return Err(format!("path {i} has a negative or non-finite length or duration"));
        }
        if self.camera.iter().any(|k| !(k.t_s.is_finite() && all_finite(&k.position) && k.yaw.is_finite() && k.pitch.is_finite())) {
            return Err(format!("path {i} has a non-finite camera key"));
        }
        for name in self.assets.video.iter().chain(&self.assets.poster) {
            check_asset_name(name).map_err(|m| format!("path {i}: {m}"))?;
        }
        if let Some(t) = &self.assets.transition {
            if !(0.0..=1.0).contains(&t.unseen) {
                return Err(format!("path {i}: its transition's unseen share {} is not between 0 and 1", t.unseen));
            }
            if t.kind == TransitionKind::Video && self.assets.video.is_none() {
                return Err(format!("path {i}: its transition is a video, but no video is listed"));
            }
            self.check_waypoints(t).map_err(|m| format!("path {i}: {m}"))?;
        }
        Ok(())
    }
}

impl Path {
    /// A glide's waypoints stand at inner camera keys, in order, with
    /// well-named files.
    fn check_waypoints(&self, t: &Transition) -> Result<(), String> {
        if !t.waypoints.is_empty() && t.kind != TransitionKind::Depth {
            return Err("only a glide has waypoints".into());
        }
        let mut last = 0;
        for w in &t.waypoints {
            if w.key <= last || w.key as usize + 1 >= self.camera.len() {
                return Err(format!("waypoint at camera key {} is not after the last and before the arrival", w.key));
            }
            last = w.key;
            if !all_finite(&w.position) || w.cube.size == 0 {
                return Err(format!("waypoint at camera key {} has no finite position or an empty cube", w.key));
            }
            for name in w.cube.faces.iter().chain([&w.depth]) {
                check_asset_name(name)?;
            }
        }
        Ok(())
    }
}

impl Proxy {
    /// The checks of the proxy of a graph of `probes` probes.
    fn check(&self, probes: usize) -> Result<(), String> {
        for level in &self.levels {
            check_asset_name(&level.file).map_err(|m| format!("proxy: {m}"))?;
            if !(level.error.is_finite() && level.error >= 0.0) {
                return Err(format!("proxy level {} has a negative or non-finite error", level.file));
            }
        }
        if !self.depth_maps.is_empty() && self.depth_maps.len() != probes {
            return Err(format!("proxy has {} depth maps for {probes} probes", self.depth_maps.len()));
        }
        let chunk_files = self.levels.iter().flat_map(|l| &l.chunks).flat_map(|c| std::iter::once(&c.file).chain(&c.seen));
        for name in self.glb.iter().chain(self.levels.iter().flat_map(|l| &l.seen)).chain(&self.depth_maps).chain(chunk_files) {
            check_asset_name(name).map_err(|m| format!("proxy: {m}"))?;
        }
        if self.floors.iter().any(|f| !f.is_finite()) || !self.floors.is_sorted() {
            return Err("proxy floors must be finite heights, lowest first".to_string());
        }
        Ok(())
    }
}

/// Unit direction of a yaw and pitch in the bundle's convention (module header).
pub fn direction(yaw: f32, pitch: f32) -> [f32; 3] {
    [yaw.sin() * pitch.cos(), pitch.sin(), -yaw.cos() * pitch.cos()]
}

/// Cube-face file suffixes in the bundle's face order: +X, −X, +Y, −Y, +Z, −Z.
pub const CUBE_FACES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];

/// The world direction through face coordinates (s, t) of cube face `face`
/// (0..6 in [`CUBE_FACES`] order), s to the right and t down the image, both
/// in [0, 1]. This is the GPU cube-map convention (OpenGL, Vulkan, WebGPU), so
/// a viewer uploads the face images as they are and samples with world
/// directions.
pub fn cube_direction(face: usize, s: f32, t: f32) -> [f32; 3] {
    let (a, b) = (2.0 * s - 1.0, 2.0 * t - 1.0);
    match face {
        0 => [1.0, -b, -a],
        1 => [-1.0, -b, a],
        2 => [a, 1.0, b],
        3 => [a, -1.0, -b],
        4 => [a, -b, 1.0],
        _ => [-a, -b, -1.0],
    }
}

/// The cube face and (s, t) a direction passes through: the inverse of
/// [`cube_direction`]. A zero direction gives face −Z's centre.
pub fn cube_face_of(d: [f32; 3]) -> (usize, f32, f32) {
    let [x, y, z] = d;
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let (face, a, b, m) = if ax >= ay && ax >= az && ax > 0.0 {
        if x > 0.0 {
            (0, -z, -y, ax)
        } else {
            (1, z, -y, ax)
        }
    } else if ay >= az && ay > 0.0 {
        if y > 0.0 {
            (2, x, z, ay)
        } else {
            (3, x, -z, ay)
        }
    } else if az > 0.0 {
        if z > 0.0 {
            (4, x, -y, az)
        } else {
            (5, -x, -y, az)
        }
    } else {
        (5, 0.0, 0.0, 1.0)
    };
    (face, 0.5 * (a / m + 1.0), 0.5 * (b / m + 1.0))
}

/// Yaw and pitch of a direction (need not be unit length; zero gives (0, 0)).
pub fn yaw_pitch(d: [f32; 3]) -> (f32, f32) {
    let horizontal = (d[0] * d[0] + d[2] * d[2]).sqrt();
    if horizontal == 0.0 && d[1] == 0.0 {
        return (0.0, 0.0);
    }
    (d[0].atan2(-d[2]), d[1].atan2(horizontal))
}

fn all_finite(v: &[f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Asset names are relative paths inside the bundle: no absolute paths, no
/// `..`, no backslashes, so neither the viewer nor `serve` can be led outside it.
pub fn check_asset_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && !name.starts_with('/')
        && !name.contains('\\')
        && !name.contains(':')
        && name.split('/').all(|c| !c.is_empty() && c != "." && c != "..");
    if ok {
        Ok(())
    } else {
        Err(format!("asset name {name:?} is not a plain relative path inside the bundle"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_round_trip_and_match_the_gpu_table() {
        // Face centres look along their axes; the top row of +Z looks up (t down).
        assert_eq!(cube_direction(0, 0.5, 0.5), [1.0, 0.0, 0.0]);
        assert_eq!(cube_direction(5, 0.5, 0.5), [0.0, 0.0, -1.0]);
        assert_eq!(cube_direction(4, 0.5, 0.0), [0.0, 1.0, 1.0]);
        assert_eq!(cube_direction(2, 0.5, 1.0), [0.0, 1.0, 1.0], "+Y's bottom edge meets +Z");
        for face in 0..6 {
            for (s, t) in [(0.1, 0.2), (0.5, 0.5), (0.9, 0.7), (0.3, 0.95)] {
                let (f, s2, t2) = cube_face_of(cube_direction(face, s, t));
                assert_eq!(f, face);
                assert!((s - s2).abs() < 1e-6 && (t - t2).abs() < 1e-6, "face {face}: ({s}, {t}) -> ({s2}, {t2})");
            }
        }
    }

    #[test]
    fn tour_faces_are_seen_from_inside_with_the_top_toward_the_back() {
        // The tour convention written out on its own: a viewer at the centre
        // facing a side face has +Y up; looking up from yaw 0, the top of
        // the view points to +Z.
        let tour = |face: char, s: f32, t: f32| {
            let (a, b) = (2.0 * s - 1.0, 2.0 * t - 1.0);
            match face {
                'f' => [a, -b, -1.0],
                'r' => [1.0, -b, a],
                'b' => [-a, -b, 1.0],
                'l' => [-1.0, -b, -a],
                'u' => [a, 1.0, -b],
                _ => [a, -1.0, b],
            }
        };
        for face in 0..6 {
            for (s, t) in [(0.1, 0.2), (0.9, 0.7), (0.3, 0.95)] {
                let (s2, t2) = Tiles::face_coordinates(face, s, t);
                let (a, b) = (tour(TILE_FACES[face], s2, t2), cube_direction(face, s, t));
                assert!((0..3).all(|i| (a[i] - b[i]).abs() < 1e-5), "face {}: {a:?} {b:?}", CUBE_FACES[face]);
            }
        }
        // Yaw 0 looks at the middle of f, yaw π/2 at the middle of r.
        assert_eq!(tour('f', 0.5, 0.5), [0.0, 0.0, -1.0]);
        let d = direction(std::f32::consts::FRAC_PI_2, 0.0);
        assert!((d[0] - 1.0).abs() < 1e-6 && tour('r', 0.5, 0.5) == [1.0, 0.0, 0.0]);
    }

    #[test]
    fn tile_levels_halve_down_to_one_tile() {
        let t = Tiles::new("probes/0/tiles".into(), 4096, 512, 256);
        assert_eq!(t.levels, 4);
        assert_eq!((1..=4).map(|l| (t.level_size(l), t.across(l))).collect::<Vec<_>>(), [(512, 1), (1024, 2), (2048, 4), (4096, 8)]);
        assert_eq!(t.files().len(), 6 * (1 + 4 + 16 + 64));
        assert_eq!(t.file(2, 'u', 1, 0), "probes/0/tiles/2/u/0/1.jpg");
        let even = Tiles::new("t".into(), 1000, 512, 64);
        assert_eq!(
            (even.levels, even.tile, even.level_size(1), even.level_size(2), even.across(2)),
            (2, 500, 500, 1000, 2),
            "whole tiles when halving is exact"
        );
        let odd = Tiles::new("t".into(), 999, 512, 64);
        assert_eq!((odd.levels, odd.tile, odd.level_size(1), odd.across(2)), (2, 512, 500, 2), "cut-short edge tiles otherwise");
        assert_eq!(Tiles::new("t".into(), 300, 512, 64).levels, 1);
        // A graph may not ask for millions of tiny tiles.
        let mut g = sample();
        g.probes[0].assets.tiles = Some(Tiles::new("t".into(), 16384, 1, 64));
        assert!(g.validate().is_err());
        g.probes[0].assets.tiles = Some(Tiles::new("t".into(), 16384, 512, 64));
        assert!(g.validate().is_ok());
        g.probes[0].assets.tiles = Some(Tiles::new("t".into(), 32, 512, 16));
        assert!(g.validate().is_ok(), "a face smaller than 64 is one tile");
    }

    fn sample() -> Graph {
        let mut g = Graph::new(SceneInfo {
            name: "gallery".into(),
            source: "builtin:gallery".into(),
            triangles: 70_000,
            bounds_min: [0.0, -0.3, -16.0],
            bounds_max: [40.0, 4.3, 20.0],
            metres_per_unit: 1.0,
            scale_source: "file".into(),
            space: Some("inside".into()),
            near_distance: Some(0.3),
            eye_height_m: None,
            credits: vec![],
        });
        for (i, x) in [2.0f32, 10.0, 20.0].iter().enumerate() {
            g.probes.push(Probe {
                id: i as u32,
                position: [*x, 1.6, 2.0],
                cluster: Some(0),
                preferred_directions: vec![ViewDirection { yaw: 0.5, pitch: 0.0, goodness: 1.0 }],
                user_placed: false,
                assets: ProbeAssets { thumbnail: Some(format!("thumbs/{i}.jpg")), ..Default::default() },
            });
        }
        g.clusters.push(Cluster { id: 0, probe: 1, candidates: 3 });
        g.paths.push(Path {
            id: 0,
            from: 0,
            to: 1,
            polyline: vec![[2.0, 1.6, 2.0], [10.0, 1.6, 2.0]],
            length: 8.0,
            duration_s: 5.7,
            camera: vec![CameraKey { t_s: 0.0, position: [2.0, 1.6, 2.0], yaw: 0.0, pitch: 0.0 }],
            assets: PathAssets { video: Some("paths/0.mp4".into()), ..Default::default() },
        });
        g.bar_order = vec![2, 0, 1];
        g.coverage = Some(Coverage {
            samples: 1000,
            reachable_area: 10.0,
            covered_area: 9.9,
            ceiling: None,
            per_group: vec![],
            curve: vec![(1, 0.5), (3, 0.99)],
        });
        g.stats.stages.insert("explore".into(), serde_json::json!({ "probes": 3 }));
        g
    }

    #[test]
    fn round_trips_through_json() {
        let g = sample();
        let back = Graph::from_json(&g.to_json()).unwrap();
        assert_eq!(back, g);
    }

    #[test]
    fn minimal_json_fills_defaults() {
        let mut g = sample();
        g.clusters.clear();
        g.paths.clear();
        g.bar_order.clear();
        g.coverage = None;
        g.stats = Default::default();
        g.probes.iter_mut().for_each(|p| p.cluster = None);
        let mut v: serde_json::Value = serde_json::from_str(&g.to_json()).unwrap();
        for key in ["clusters", "paths", "bar_order", "coverage", "stats"] {
            v.as_object_mut().unwrap().remove(key);
        }
        assert_eq!(Graph::from_json(&v.to_string()).unwrap(), g);
    }

    #[test]
    fn other_versions_are_refused_with_a_clear_message() {
        let text = sample().to_json().replace("\"format_version\": 1", "\"format_version\": 7");
        let err = Graph::from_json(&text).unwrap_err();
        assert!(matches!(err, FormatError::Version { found: 7, expected: 1 }));
        assert!(err.to_string().contains("version 7"));
    }

    /// Makes path 0 a transition of `kind` through panoramas part way at `keys` (of 4 camera keys).
    fn glide(g: &mut Graph, kind: TransitionKind, keys: &[u32]) {
        let path = &mut g.paths[0];
        path.camera = (0..4).map(|i| CameraKey { t_s: i as f32, position: [2.0 + i as f32, 1.6, 2.0], yaw: 0.0, pitch: 0.0 }).collect();
        let waypoints = keys
            .iter()
            .map(|&key| Waypoint {
                key,
                position: [3.0, 1.6, 2.0],
                cube: CubeLevel { size: 8, faces: CUBE_FACES.map(|f| format!("paths/0/{key}_{f}.jpg")) },
                depth: format!("paths/0/{key}.emdc"),
            })
            .collect();
        path.assets.transition = Some(Transition { kind, unseen: 0.0, reason: String::new(), waypoints });
    }

    #[test]
    fn a_glide_through_panoramas_part_way_round_trips() {
        let mut g = sample();
        glide(&mut g, TransitionKind::Depth, &[1, 2]);
        g.validate().unwrap();
        assert_eq!(Graph::from_json(&g.to_json()).unwrap(), g);
    }

    #[test]
    fn each_inconsistency_is_named() {
        type Mutation = Box<dyn Fn(&mut Graph)>;
        let cases: Vec<(&str, Mutation)> = vec![
            ("probe at index 1 has id 5", Box::new(|g| g.probes[1].id = 5)),
            ("non-finite position", Box::new(|g| g.probes[0].position[1] = f32::NAN)),
            ("path 0 joins probes 0 and 9", Box::new(|g| g.paths[0].to = 9)),
            ("path 0 joins probes 1 and 1", Box::new(|g| g.paths[0].from = 1)),
            ("at least two points", Box::new(|g| g.paths[0].polyline.truncate(1))),
            ("negative or non-finite length", Box::new(|g| g.paths[0].length = -1.0)),
            ("not a permutation", Box::new(|g| g.bar_order = vec![0, 0, 1])),
            ("leaves out", Box::new(|g| g.bar_order = vec![0, 1])),
            ("names cluster 4", Box::new(|g| g.probes[0].cluster = Some(4))),
            ("not a plain relative path", Box::new(|g| g.probes[0].assets.thumbnail = Some("../../etc/passwd".into()))),
            ("not a plain relative path", Box::new(|g| g.paths[0].assets.video = Some("/abs.mp4".into()))),
            ("covered exceeds reachable", Box::new(|g| g.coverage.as_mut().unwrap().covered_area = 11.0)),
            ("metres_per_unit", Box::new(|g| g.scene.metres_per_unit = 0.0)),
            ("only a glide has waypoints", Box::new(|g| glide(g, TransitionKind::Video, &[1]))),
            ("camera key 0 is not after", Box::new(|g| glide(g, TransitionKind::Depth, &[0]))),
            ("camera key 3 is not after", Box::new(|g| glide(g, TransitionKind::Depth, &[3]))),
            ("camera key 1 is not after", Box::new(|g| glide(g, TransitionKind::Depth, &[2, 1]))),
        ];
        for (expected, mutate) in cases {
            let mut g = sample();
            mutate(&mut g);
            let err = g.validate().expect_err(expected).to_string();
            assert!(err.contains(expected), "expected {expected:?} in {err:?}");
        }
    }

    #[test]
    fn malformed_json_is_an_error_not_a_panic() {
        for text in ["", "{", "[]", "{\"format_version\": 1}", "{\"format_version\": \"one\"}", "\u{0}\u{1}"] {
            assert!(Graph::from_json(text).is_err(), "{text:?}");
        }
        let full = sample().to_json();
        for cut in (0..full.len()).step_by(97) {
            assert!(Graph::from_json(&full[..cut]).is_err());
        }
    }
}
