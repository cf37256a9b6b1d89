//! What the stages record about themselves and hand to the next: graph.json's
//! `stats` ([`Stats`]: the plan's command line, the render's settings, each
//! planning stage's figures), the storeys the render's dollhouse cuts at
//! ([`Floor`]), a split render's shard manifests ([`ShardManifest`]) and the
//! run-to-run times kept out of graph.json ([`Timings`], `timings.json`).
//!
//! `stats` is written through JSON values, so its keys are in alphabetical
//! order at every depth, whichever order the types list them in.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// graph.json's `stats`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "BTreeMap<String, Value>", into = "BTreeMap<String, Value>")]
pub struct Stats {
    /// How `plan` loaded the scene and what it was asked (`stats.plan`), so
    /// that `render` and `coverage` load and measure as it did.
    pub plan: Option<PlanRecord>,
    /// What the panoramas were rendered with (`stats.render`).
    pub render: Option<RenderRecord>,
    /// Each planning stage's figures by stage name (`scale`, `free_space`,
    /// `explore`, …), for people: the program reads only [`Stats::floors`].
    pub stages: BTreeMap<String, Value>,
}

impl Stats {
    /// The storeys the free-space stage found (`stats.free_space.walk.levels`),
    /// lowest first; none when probes fly or the plan predates them.
    pub fn floors(&self) -> Result<Vec<Floor>, String> {
        let Some(levels) = self.stages.get("free_space").and_then(|f| f.get("walk")).and_then(|w| w.get("levels")) else {
            return Ok(Vec::new());
        };
        let mut floors: Vec<Floor> =
            serde_json::from_value(levels.clone()).map_err(|e| format!("stats.free_space.walk.levels is not a list of [height, share]: {e}"))?;
        floors.sort_by(|a, b| a.height.total_cmp(&b.height));
        Ok(floors)
    }
}

impl TryFrom<BTreeMap<String, Value>> for Stats {
    type Error = String;

    fn try_from(mut entries: BTreeMap<String, Value>) -> Result<Stats, String> {
        fn typed<T: serde::de::DeserializeOwned>(entries: &mut BTreeMap<String, Value>, key: &str) -> Result<Option<T>, String> {
            entries.remove(key).map(|v| serde_json::from_value(v).map_err(|e| format!("stats.{key}: {e}"))).transpose()
        }
        Ok(Stats { plan: typed(&mut entries, "plan")?, render: typed(&mut entries, "render")?, stages: entries })
    }
}

impl From<Stats> for BTreeMap<String, Value> {
    fn from(stats: Stats) -> BTreeMap<String, Value> {
        let mut entries = stats.stages;
        let value = |v: Result<Value, serde_json::Error>| v.expect("JSON of plain values");
        if let Some(plan) = stats.plan {
            entries.insert("plan".into(), value(serde_json::to_value(plan)));
        }
        if let Some(render) = stats.render {
            entries.insert("render".into(), value(serde_json::to_value(render)));
        }
        entries
    }
}

/// `stats.plan`. Fields missing from older bundles take `plan`'s defaults
/// (a test of the command line checks that they agree).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlanRecord {
    pub seed: u64,
    /// The scene's up axis as given (`y`, `z`, `-z`, …).
    pub up: String,
    /// The scale given on the command line, if any.
    pub metres_per_unit: Option<f32>,
    pub max_triangles: u64,
    /// `auto`, `inside` or `outside`.
    pub space: String,
    /// `greedy`, `random` or `grid`.
    pub strategy: String,
    pub coverage_target: f64,
    pub near_m: Option<f32>,
    pub max_cells: usize,
    pub cluster: bool,
    /// `auto`, `walk` or `fly`.
    pub height: String,
    pub eye_height_m: f32,
}

impl Default for PlanRecord {
    fn default() -> Self {
        PlanRecord {
            seed: 1,
            up: "y".into(),
            metres_per_unit: None,
            max_triangles: 50_000_000,
            space: "auto".into(),
            strategy: "greedy".into(),
            coverage_target: 0.995,
            near_m: None,
            max_cells: 256,
            cluster: true,
            height: "auto".into(),
            eye_height_m: 1.6,
        }
    }
}

/// `stats.render`: what a render was made with. A split render's shards
/// each state it in their manifest, and must agree.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderRecord {
    /// `preview` or `final`.
    pub quality: String,
    /// The lights used, in words.
    pub lighting: String,
    /// The exposure every panorama and video shares.
    pub exposure: f32,
    /// Cells of the radiance cache, when one was built.
    pub cache_cells: Option<usize>,
    pub video_encoder: Option<String>,
    pub samples_per_pixel: u32,
    pub bounces: u32,
    pub denoised: bool,
    pub seed: u64,
    /// `--transitions` where it was not `video`, and the depth cubes' cells
    /// a face edge (absent: every path a video, no depth).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transitions: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_cells: Option<u32>,
}

/// A storey: a floor height (scene units) and its share of the walkable
/// floor area; written as `[height, share]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "(f32, f32)", into = "(f32, f32)")]
pub struct Floor {
    pub height: f32,
    pub share: f32,
}

impl From<(f32, f32)> for Floor {
    fn from((height, share): (f32, f32)) -> Floor {
        Floor { height, share }
    }
}

impl From<Floor> for (f32, f32) {
    fn from(f: Floor) -> (f32, f32) {
        (f.height, f.share)
    }
}

/// `shards/<index>-of-<count>.json`: written by a shard of a split render
/// after its last asset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardManifest {
    pub shard: usize,
    pub count: usize,
    /// The cube face sizes rendered, smallest first.
    pub levels: Vec<u32>,
    pub render: RenderRecord,
}

impl ShardManifest {
    /// Reads a manifest; an error names the file and what to do.
    pub fn read(path: &Path) -> Result<ShardManifest, String> {
        let redo = "delete it and run its shard again";
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot be read ({e}); {redo}", path.display()))?;
        let manifest: ShardManifest = serde_json::from_str(&text).map_err(|e| format!("{}: not a shard manifest ({e}); {redo}", path.display()))?;
        if manifest.count == 0 || manifest.shard >= manifest.count {
            return Err(format!("{}: shard {} of {} is out of range; {redo}", path.display(), manifest.shard, manifest.count));
        }
        Ok(manifest)
    }

    pub fn to_json(&self) -> String {
        // Through a JSON value, for keys in alphabetical order like graph.json's stats.
        serde_json::to_string_pretty(&serde_json::to_value(self).expect("JSON of plain values")).expect("JSON of plain values")
    }
}

/// `timings.json`: the seconds each stage took, by stage and then by step.
/// Times vary run to run, so graph.json holds none and bundles built from
/// the same seed stay identical.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings(pub BTreeMap<String, BTreeMap<String, Seconds>>);

/// A step's time: in one piece, or per job (`[job number, seconds]`) for
/// planning shards.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Seconds {
    Total(f64),
    PerJob(Vec<(usize, f64)>),
}

impl Timings {
    /// Records `seconds` for a stage's step.
    pub fn set(&mut self, stage: &str, step: &str, seconds: Seconds) {
        self.0.entry(stage.to_string()).or_default().insert(step.to_string(), seconds);
    }

    /// This run's times over `earlier` (a plan's, when the render follows):
    /// a stage's steps replace the same steps and keep the others.
    pub fn merged_over(self, earlier: Timings) -> Timings {
        let mut all = earlier;
        for (stage, steps) in self.0 {
            all.0.entry(stage).or_default().extend(steps);
        }
        all
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn render() -> RenderRecord {
        RenderRecord {
            quality: "preview".into(),
            lighting: "sun and sky".into(),
            exposure: 0.3,
            cache_cells: None,
            video_encoder: Some("x264".into()),
            samples_per_pixel: 1,
            bounces: 1,
            denoised: false,
            seed: 7,
            transitions: None,
            depth_cells: None,
        }
    }

    #[test]
    fn stats_round_trip_with_keys_in_order() {
        let mut stages = BTreeMap::new();
        stages.insert("free_space".to_string(), serde_json::json!({ "walk": { "levels": [[3.0, 0.4], [0.0, 0.6]] } }));
        stages.insert("explore".to_string(), serde_json::json!({ "probes": 4 }));
        let stats = Stats { plan: Some(PlanRecord::default()), render: Some(render()), stages };
        let text = serde_json::to_string(&stats).unwrap();
        let order: Vec<usize> = ["\"explore\"", "\"free_space\"", "\"plan\"", "\"render\""].iter().map(|k| text.find(k).unwrap()).collect();
        assert!(order.windows(2).all(|w| w[0] < w[1]), "{text}");
        // f32 figures are written as the JSON values they always were.
        assert!(text.contains("\"exposure\":0.30000001192092896"), "{text}");
        let back: Stats = serde_json::from_str(&text).unwrap();
        assert_eq!(back.render, stats.render);
        assert_eq!(back.plan, stats.plan);
        assert_eq!(back.floors().unwrap(), vec![Floor { height: 0.0, share: 0.6 }, Floor { height: 3.0, share: 0.4 }]);
    }

    #[test]
    fn a_malformed_record_is_an_error_that_names_it() {
        let bad: Result<Stats, _> = serde_json::from_value(serde_json::json!({ "render": { "quality": 3 } }));
        assert!(bad.unwrap_err().to_string().contains("stats.render"));
        let floors: Stats = serde_json::from_value(serde_json::json!({ "free_space": { "walk": { "levels": "high" } } })).unwrap();
        assert!(floors.floors().unwrap_err().contains("walk.levels"));
        // Older bundles' plan records lack fields: they take the old defaults.
        let old: Stats = serde_json::from_value(serde_json::json!({ "plan": { "seed": 9 } })).unwrap();
        assert_eq!(old.plan, Some(PlanRecord { seed: 9, ..Default::default() }));
    }

    #[test]
    fn a_shard_manifest_that_does_not_parse_names_its_file() {
        let dir = std::env::temp_dir().join(format!("em-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = ShardManifest { shard: 1, count: 3, levels: vec![512, 1024], render: render() };
        let path = dir.join("1-of-3.json");
        std::fs::write(&path, good.to_json()).unwrap();
        assert_eq!(ShardManifest::read(&path).unwrap(), good);
        for (text, says) in [("{\"shard\": 1}", "not a shard manifest"), ("", "not a shard manifest")] {
            std::fs::write(&path, text).unwrap();
            let e = ShardManifest::read(&path).unwrap_err();
            assert!(e.contains("1-of-3.json") && e.contains(says) && e.contains("run its shard again"), "{e}");
        }
        std::fs::write(&path, ShardManifest { shard: 3, ..good }.to_json()).unwrap();
        assert!(ShardManifest::read(&path).unwrap_err().contains("out of range"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn timings_merge_by_step() {
        let mut plan = Timings::default();
        plan.set("plan", "seconds", Seconds::Total(3.0));
        plan.set("render", "seconds_setup", Seconds::Total(1.0));
        let mut render = Timings::default();
        render.set("render", "seconds_jobs", Seconds::PerJob(vec![(0, 2.0)]));
        let all = render.merged_over(plan);
        assert_eq!(all.0["plan"]["seconds"], Seconds::Total(3.0));
        assert_eq!(all.0["render"].len(), 2);
        let text = serde_json::to_string(&all).unwrap();
        assert_eq!(serde_json::from_str::<Timings>(&text).unwrap(), all);
    }
}
