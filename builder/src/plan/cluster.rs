//! Cluster: group probes that see the same surface, with the Markov Cluster
//! algorithm (van Dongen 2000), and replace each group by one synthesized
//! probe (the ExploreMaps paper, section 5).
//!
//! Inputs: per probe, the set of surface samples it sees (bitsets over the
//! same samples) and the area each sample stands for. Output: a cluster label
//! per probe (clusters numbered by their smallest member) and [`ClusterStats`].
//!
//! The graph weighs each pair by the area both probes see relative to what
//! each sees ([`similarity`]; why not the raw area is said there); the diagonal
//! is each probe's self-loop. MCL then alternates expansion (the
//! matrix squared: random walks of two steps) and inflation (entries squared,
//! columns renormalised: strong links get stronger) until the matrix stops
//! changing; entries below 1e-6 are pruned after each step, so the matrix stays
//! sparse. Each probe joins the attractor holding most of its column. The
//! number of clusters emerges. Deterministic; no randomness.

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ClusterStats {
    pub probes: usize,
    pub clusters: usize,
    pub iterations: usize,
    /// Largest entry change in the last iteration.
    pub residual: f64,
}

/// Synthesis parameters (defaults in `Default`).
#[derive(Clone, Debug, PartialEq)]
pub struct SynthesisParams {
    /// Selection samples (and at least 256 per object), as exploration's.
    pub selection_samples: usize,
    /// Simulated-annealing steps per cluster.
    pub anneal_steps: usize,
    /// Weight of view goodness against coverage of the cluster's surface.
    pub goodness_weight: f32,
    /// Probes are added back until the final set's coverage is within this of the candidates'.
    pub tolerance: f64,
    pub seed: u64,
}

impl Default for SynthesisParams {
    fn default() -> Self {
        SynthesisParams { selection_samples: 20_000, anneal_steps: 40, goodness_weight: 0.25, tolerance: 0.01, seed: 1 }
    }
}

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SynthesisStats {
    pub candidates: usize,
    pub clusters: usize,
    pub mcl_iterations: usize,
    /// Candidates put back because the synthesized set lost coverage.
    pub added_back: usize,
    /// Probes dropped afterwards because the others see what they see.
    pub pruned: usize,
    pub final_probes: usize,
    /// Selection-sample coverage of the candidates and of the final set.
    pub candidate_coverage: f64,
    pub final_coverage: f64,
    pub rays: usize,
    #[serde(skip)]
    pub seconds: f64,
}

/// The final probes and the clusters they stand for.
#[derive(Clone, Debug, PartialEq)]
pub struct Synthesized {
    pub probes: Vec<Vec3>,
    pub user_placed: Vec<bool>,
    /// Per final probe: its cluster (user probes and added-back ones keep theirs).
    pub cluster_of: Vec<u32>,
    /// Per cluster: (its synthesized probe, how many candidates it merged).
    pub clusters: Vec<(usize, usize)>,
}

/// Clusters the candidates and synthesizes one probe per cluster by simulated
/// annealing, maximising coverage of the cluster's surface plus view goodness;
/// then puts candidates back until coverage is within `tolerance` of the
/// candidates'. User probes stay as they are, each its own cluster.
pub fn synthesize(
    scene: &Scene,
    rays: &RayScene,
    space: &FreeSpace,
    candidates: &[Candidate],
    params: &SynthesisParams,
) -> (Synthesized, SynthesisStats) {
    let started = Instant::now();
    let mut stats = SynthesisStats { candidates: candidates.len(), ..Default::default() };
    let (targets, cast) = Targets::new(scene, rays, space, params.selection_samples, 256, crate::seeds::Stream::Synthesis.seed(params.seed));
    stats.rays += cast;
    let seen: Vec<Vec<u64>> = candidates.par_iter().map(|c| targets.seen_by(rays, c.position, None).0).collect();
    let (labels, mcl) = markov_cluster(&similarity(&overlap(&seen, 1.0)));
    stats.mcl_iterations = mcl.iterations;
    // User probes are clusters of their own and are not moved.
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut group_of_label = vec![usize::MAX; mcl.clusters];
    for (k, c) in candidates.iter().enumerate() {
        if c.user_placed {
            groups.push(vec![k]);
        } else {
            let l = labels[k] as usize;
            if group_of_label[l] == usize::MAX {
                group_of_label[l] = groups.len();
                groups.push(Vec::new());
            }
            groups[group_of_label[l]].push(k);
        }
    }
    let annealing = Annealing { rays, space, targets: &targets, seen: &seen, candidates, diagonal: scene.bounds().diagonal(), params };
    let results: Vec<(Vec3, usize)> = groups
        .par_iter()
        .enumerate()
        .map(|(g, members)| {
            // A cluster of one has nothing to merge: its candidate is its probe.
            if members.len() == 1 {
                return (candidates[members[0]].position, 0);
            }
            let seed = crate::seeds::substream(crate::seeds::Stream::Anneal.seed(params.seed), g as u64);
            annealing.probe(members, seed)
        })
        .collect();
    stats.rays += results.iter().map(|r| r.1).sum::<usize>();

    let mut out = Synthesized { probes: Vec::new(), user_placed: Vec::new(), cluster_of: Vec::new(), clusters: Vec::new() };
    for (g, (position, _)) in results.iter().enumerate() {
        out.clusters.push((out.probes.len(), groups[g].len()));
        out.probes.push(*position);
        out.user_placed.push(groups[g].len() == 1 && candidates[groups[g][0]].user_placed);
        out.cluster_of.push(g as u32);
    }
    // Coverage check on the selection samples, and add-back.
    let union = |sets: &mut dyn Iterator<Item = &Vec<u64>>| {
        let mut u = vec![0u64; targets.words()];
        for s in sets {
            u.iter_mut().zip(s).for_each(|(a, b)| *a |= b);
        }
        u
    };
    let total = targets.len().max(1) as f64;
    stats.candidate_coverage = count_bits(&union(&mut seen.iter())) as f64 / total;
    let mut views: Vec<Vec<u64>> = out.probes.par_iter().map(|&p| targets.seen_by(rays, p, None).0).collect();
    let mut covered = union(&mut views.iter());
    let group_of_candidate: Vec<usize> = {
        let mut g = vec![0; candidates.len()];
        groups.iter().enumerate().for_each(|(i, members)| members.iter().for_each(|&k| g[k] = i));
        g
    };
    while (count_bits(&covered) as f64) / total < stats.candidate_coverage - params.tolerance {
        let gain = |k: usize| seen[k].iter().zip(&covered).map(|(s, c)| (s & !c).count_ones()).sum::<u32>();
        let Some(best) = (0..candidates.len()).max_by(|&a, &b| gain(a).cmp(&gain(b)).then(b.cmp(&a))) else { break };
        if gain(best) == 0 {
            break;
        }
        covered.iter_mut().zip(&seen[best]).for_each(|(c, s)| *c |= s);
        views.push(seen[best].clone());
        out.probes.push(candidates[best].position);
        out.user_placed.push(candidates[best].user_placed);
        out.cluster_of.push(group_of_candidate[best] as u32);
        stats.added_back += 1;
    }
    let floor = (stats.candidate_coverage - params.tolerance).min(count_bits(&covered) as f64 / total);
    stats.pruned = prune(&mut out, &mut views, (floor * total).ceil() as usize);
    stats.final_coverage = count_bits(&union(&mut views.iter())) as f64 / total;
    stats.clusters = out.clusters.len();
    stats.final_probes = out.probes.len();
    stats.seconds = started.elapsed().as_secs_f64();
    (out, stats)
}

/// Drops the probes the others make redundant, the one that alone sees
/// least first, while the set still sees `floor` samples; user probes stay.
/// (Candidates put back for coverage often see all that a synthesized probe
/// sees, and greedy's early picks all that its later ones see.) Clusters left
/// without a probe are dropped and the rest renumbered. Returns how many went.
fn prune(out: &mut Synthesized, views: &mut Vec<Vec<u64>>, floor: usize) -> usize {
    let words = views.first().map_or(0, Vec::len);
    let mut dropped = 0;
    loop {
        // Samples seen by some probe, and by two or more.
        let (mut once, mut twice) = (vec![0u64; words], vec![0u64; words]);
        for v in views.iter() {
            for ((o, t), b) in once.iter_mut().zip(twice.iter_mut()).zip(v) {
                *t |= *o & b;
                *o |= b;
            }
        }
        let covered = count_bits(&once);
        let alone: Vec<usize> = views.iter().map(|v| v.iter().zip(&twice).map(|(v, t)| (v & !t).count_ones() as usize).sum()).collect();
        // Least seen alone; ties go to the later probe (put back or picked later).
        let Some(k) = (0..views.len()).filter(|&k| !out.user_placed[k]).min_by(|&a, &b| alone[a].cmp(&alone[b]).then(b.cmp(&a))) else { break };
        if covered - alone[k] < floor {
            break;
        }
        out.probes.remove(k);
        out.user_placed.remove(k);
        out.cluster_of.remove(k);
        views.remove(k);
        dropped += 1;
    }
    // Each cluster's probe: its synthesized one if kept, else a member put back.
    let mut renumber = vec![u32::MAX; out.clusters.len()];
    let mut clusters = Vec::new();
    for (c, &(_, merged)) in out.clusters.iter().enumerate() {
        if let Some(probe) = out.cluster_of.iter().position(|&o| o as usize == c) {
            renumber[c] = clusters.len() as u32;
            clusters.push((probe, merged));
        }
    }
    out.cluster_of.iter_mut().for_each(|o| *o = renumber[*o as usize]);
    out.clusters = clusters;
    dropped
}

/// What annealing a cluster's probe needs: the candidates and which target
/// samples each sees.
struct Annealing<'a> {
    rays: &'a RayScene,
    space: &'a FreeSpace,
    targets: &'a Targets,
    seen: &'a [Vec<u64>],
    candidates: &'a [Candidate],
    /// The scene's diagonal, for the goodness of views.
    diagonal: f32,
    params: &'a SynthesisParams,
}

impl Annealing<'_> {
    /// Simulated annealing of one cluster's probe: from the member that sees
    /// most of the cluster's surface, random moves shrinking from the
    /// cluster's spread to a voxel, accepted by the Metropolis rule; the best
    /// position wins. Returns it and the rays cast.
    fn probe(&self, members: &[usize], seed: u64) -> (Vec3, usize) {
        let Annealing { rays, space, targets, seen, candidates, diagonal, params } = *self;
        let mut union = vec![0u64; targets.words()];
        for &k in members {
            union.iter_mut().zip(&seen[k]).for_each(|(u, s)| *u |= s);
        }
        let size = count_bits(&union).max(1) as f32;
        let mut cast = 0usize;
        let mut score = |p: Vec3| -> f32 {
            let (bits, n) = targets.seen_by(rays, p, Some(&union));
            let best_view = orient::goodness(rays, p, space.near, diagonal).iter().map(|g| g.1).fold(0.0f32, f32::max);
            cast += n + 5 * 6 * 24 * 24;
            count_bits(&bits) as f32 / size + params.goodness_weight * best_view
        };
        let start = *members.iter().max_by_key(|&&k| count_bits(&seen[k])).expect("clusters are not empty");
        let mut current = candidates[start].position;
        let mut current_score = score(current);
        let (mut best, mut best_score) = (current, current_score);
        let centre = members.iter().map(|&k| candidates[k].position).sum::<Vec3>() / members.len() as f32;
        let spread = members.iter().map(|&k| (candidates[k].position - centre).length()).fold(0.0f32, f32::max).max(4.0 * space.grid.voxel);
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let steps = params.anneal_steps.max(1);
        for step in 0..steps {
            let progress = step as f32 / steps as f32;
            let temperature = 0.05 * (0.02f32).powf(progress);
            let radius = spread * (1.0 - progress) + space.grid.voxel;
            let offset = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * radius;
            let Some(proposal) = space.stand(rays, current + offset) else { continue };
            let s = score(proposal);
            if s >= current_score || rng.random::<f32>() < ((s - current_score) / temperature).exp() {
                current = proposal;
                current_score = s;
                if s > best_score {
                    best = proposal;
                    best_score = s;
                }
            }
        }
        (best, cast)
    }
}

use crate::plan::explore::Candidate;
use crate::plan::freespace::FreeSpace;
use crate::plan::orient;
use crate::plan::visibility::{count_bits, Targets};
use crate::raycast::RayScene;
use exploremaps_scenes::Scene;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use std::time::Instant;

const PRUNE: f64 = 1e-6;
const MAX_ITERATIONS: usize = 200;

/// Area seen by both probes of every pair (the diagonal: by the probe itself).
pub fn overlap(seen: &[Vec<u64>], area_each: f64) -> Vec<Vec<f64>> {
    let n = seen.len();
    let mut w = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i..n {
            let shared: u32 = seen[i].iter().zip(&seen[j]).map(|(a, b)| (a & b).count_ones()).sum();
            w[i][j] = shared as f64 * area_each;
            w[j][i] = w[i][j];
        }
    }
    w
}

fn normalize_columns(m: &mut [Vec<f64>]) {
    let mut sums = vec![0.0; m.len()];
    for row in m.iter() {
        sums.iter_mut().zip(row).for_each(|(s, v)| *s += v);
    }
    for row in m.iter_mut() {
        row.iter_mut().zip(&sums).filter(|(_, &s)| s > 0.0).for_each(|(v, s)| *v /= s);
    }
}

/// The clustering weights: area seen by both, relative to what each sees
/// (shared / √(seen_i · seen_j), 1 on the diagonal). Raw shared area, the
/// paper's weight, merged two 10 × 8 m rooms joined by a door in our tests:
/// probes peeking through the door make cross-room weights 20-40 % of the
/// in-room ones, and the large raw self-loops do not hold the walks back.
/// Normalised, with self-loops at 1, MCL separates the rooms.
pub fn similarity(overlap: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = overlap.len();
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let d = (overlap[i][i] * overlap[j][j]).sqrt();
                    if d > 0.0 {
                        overlap[i][j] / d
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// Markov clustering of a symmetric weight matrix (expansion 2, inflation 2).
pub fn markov_cluster(weights: &[Vec<f64>]) -> (Vec<u32>, ClusterStats) {
    let n = weights.len();
    let mut m: Vec<Vec<f64>> = weights.to_vec();
    for (i, row) in m.iter_mut().enumerate() {
        // Every probe needs a self-loop; keep the largest of its links if it has none.
        if row[i] <= 0.0 {
            row[i] = row.iter().copied().fold(0.0, f64::max).max(1.0);
        }
    }
    normalize_columns(&mut m);
    let mut stats = ClusterStats { probes: n, ..Default::default() };
    for iteration in 1..=MAX_ITERATIONS {
        // Expansion: sparse rows of m times columns.
        let nonzero: Vec<Vec<(usize, f64)>> = m.iter().map(|row| row.iter().copied().enumerate().filter(|&(_, v)| v > 0.0).collect()).collect();
        let mut next = vec![vec![0.0; n]; n];
        for i in 0..n {
            for &(k, a) in &nonzero[i] {
                for &(j, b) in &nonzero[k] {
                    next[i][j] += a * b;
                }
            }
        }
        // Inflation, pruning, renormalisation.
        for row in next.iter_mut() {
            for v in row.iter_mut() {
                *v = if *v * *v < PRUNE { 0.0 } else { *v * *v };
            }
        }
        normalize_columns(&mut next);
        let residual = m.iter().flatten().zip(next.iter().flatten()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        m = next;
        stats.iterations = iteration;
        stats.residual = residual;
        if residual < 1e-9 {
            break;
        }
    }
    // Each probe joins the attractor with the largest share of its column
    // (ties: the lowest index); clusters are numbered by their smallest member.
    let attractor: Vec<usize> = (0..n).map(|j| (0..n).max_by(|&a, &b| m[a][j].total_cmp(&m[b][j]).then(b.cmp(&a))).unwrap_or(j)).collect();
    let mut label_of_attractor = vec![u32::MAX; n];
    let mut labels = vec![0u32; n];
    let mut next_label = 0;
    for j in 0..n {
        let a = attractor[j];
        if label_of_attractor[a] == u32::MAX {
            label_of_attractor[a] = next_label;
            next_label += 1;
        }
        labels[j] = label_of_attractor[a];
    }
    stats.clusters = next_label as usize;
    (labels, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of `sizes` with strong links inside (1.0) and weak links across (0.01).
    fn blocks(sizes: &[usize]) -> (Vec<Vec<f64>>, Vec<usize>) {
        let block: Vec<usize> = sizes.iter().enumerate().flat_map(|(b, &s)| std::iter::repeat_n(b, s)).collect();
        let n = block.len();
        // Interleave the blocks' members so labels cannot follow index order.
        let perm: Vec<usize> = (0..n).map(|i| (i * 7) % n).collect();
        let mut w = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..n {
                w[i][j] = if block[perm[i]] == block[perm[j]] { 1.0 } else { 0.01 };
            }
        }
        (w, perm.iter().map(|&p| block[p]).collect())
    }

    #[test]
    fn probes_the_rest_see_for_are_dropped_and_clusters_renumbered() {
        // Four probes over 8 samples (one word): probe 1 sees only what 0 and
        // 2 see; probe 3 (a user's) sees only what 2 sees, and stays.
        let views: Vec<Vec<u64>> = vec![vec![0b0000_1111], vec![0b0011_1000], vec![0b1111_0000], vec![0b0100_0000]];
        let mut out = Synthesized {
            probes: (0..4).map(|k| Vec3::splat(k as f32)).collect(),
            user_placed: vec![false, false, false, true],
            cluster_of: vec![0, 1, 2, 3],
            clusters: vec![(0, 2), (1, 1), (2, 3), (3, 1)],
        };
        let mut kept = views.clone();
        assert_eq!(prune(&mut out, &mut kept, 8), 1);
        assert_eq!(out.probes, vec![Vec3::splat(0.0), Vec3::splat(2.0), Vec3::splat(3.0)]);
        assert_eq!(out.cluster_of, vec![0, 1, 2]);
        assert_eq!(out.clusters, vec![(0, 2), (1, 3), (2, 1)]);
        // With half the samples to spare, of two probes seeing 4 alone each
        // the later goes too, and the last stays: never below the floor.
        let mut out2 = Synthesized {
            probes: (0..3).map(|k| Vec3::splat(k as f32)).collect(),
            user_placed: vec![false; 3],
            cluster_of: vec![0, 0, 1],
            clusters: vec![(0, 2), (2, 1)],
        };
        let mut v2 = vec![views[0].clone(), views[1].clone(), views[2].clone()];
        assert_eq!(prune(&mut out2, &mut v2, 4), 2);
        assert_eq!(out2.probes, vec![Vec3::splat(0.0)]);
        assert_eq!(out2.clusters, vec![(0, 2)]);
    }

    #[test]
    fn mcl_recovers_blocks() {
        let (w, truth) = blocks(&[5, 8, 3, 6]);
        let (labels, stats) = markov_cluster(&w);
        assert_eq!(stats.clusters, 4, "{stats:?}");
        for i in 0..truth.len() {
            for j in 0..truth.len() {
                assert_eq!(labels[i] == labels[j], truth[i] == truth[j], "probes {i} and {j}");
            }
        }
        assert!(stats.residual < 1e-9);
    }

    #[test]
    fn unconnected_probes_are_their_own_clusters() {
        let w = vec![vec![2.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 0.0]];
        let (labels, stats) = markov_cluster(&w);
        assert_eq!(labels, vec![0, 1, 2]);
        assert_eq!(stats.clusters, 3);
    }

    #[test]
    fn overlap_counts_shared_samples() {
        let seen = vec![vec![0b1111u64], vec![0b1100u64], vec![0b0001u64]];
        let w = overlap(&seen, 0.5);
        assert_eq!(w[0], vec![2.0, 1.0, 0.5]);
        assert_eq!(w[1][2], 0.0);
        assert_eq!(w[2][2], 0.5);
    }

    #[test]
    fn synthesis_keeps_coverage_within_a_point_with_fewer_probes() {
        use crate::plan::coverage::{coverage, CoverageParams};
        use crate::plan::explore::{explore, ExploreParams};
        use crate::plan::freespace::{free_space, FreeSpaceParams};
        use crate::raycast::RayScene;
        let scene = exploremaps_scenes::BuiltIn::Pillars.generate(2);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (space, _) = free_space(&scene, &rays, &FreeSpaceParams::default()).unwrap();
        let (candidates, _) = explore(&scene, &rays, &space, &ExploreParams::default());
        let (out, stats) = synthesize(&scene, &rays, &space, &candidates, &SynthesisParams::default());
        assert!(stats.clusters < candidates.len(), "{stats:?}");
        assert!(out.probes.len() <= candidates.len(), "{stats:?}");
        assert_eq!(out.probes.len(), stats.clusters + stats.added_back);
        assert!(out.probes.iter().all(|&p| space.is_navigable(p)));
        assert!(out.clusters.iter().map(|c| c.1).sum::<usize>() == candidates.len());
        // The independent metric: within one point of the candidates.
        let params = CoverageParams { samples: 50_000, seed: 4, ..Default::default() };
        let before = coverage(&scene, &rays, &space, &candidates.iter().map(|c| c.position).collect::<Vec<_>>(), &params).fraction();
        let after = coverage(&scene, &rays, &space, &out.probes, &params).fraction();
        assert!(after >= before - 0.01, "{after} vs {before}: {stats:?}");
    }

    #[test]
    fn two_rooms_give_two_clusters() {
        use crate::plan::freespace::{free_space, FreeSpaceParams, HeightMode, SpaceMode};
        use crate::plan::samples::{reachability, surface_samples};
        use crate::raycast::{Packing, Ray, RayScene};
        use glam::Vec3;
        // Two 10 × 8 rooms joined by a door, three probes in each, in the far
        // half of each room: probes 2 m from the door see so much of the other
        // room (similarity up to 0.38) that inflation 2 sits on the edge
        // between one cluster and two.
        let scene = crate::testing::rooms(2, 10.0, 3.0, 8.0, &[1]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (space, _) =
            free_space(&scene, &rays, &FreeSpaceParams { space: SpaceMode::Inside, height: HeightMode::Fly, ..Default::default() }).unwrap();
        let probes = [
            Vec3::new(1.5, 1.5, 2.0),
            Vec3::new(2.5, 1.2, 6.0),
            Vec3::new(3.0, 1.8, 3.5),
            Vec3::new(18.5, 1.5, 2.0),
            Vec3::new(17.5, 1.2, 6.0),
            Vec3::new(17.0, 1.8, 3.5),
        ];
        let samples = surface_samples(&scene, 4000, 3);
        let (side, _, _) = reachability(&rays, &space, &samples, 8, 3);
        let seen: Vec<Vec<u64>> = probes
            .iter()
            .map(|&p| {
                let mut bits = vec![0u64; samples.points.len().div_ceil(64)];
                let segments: Vec<Ray> =
                    (0..samples.points.len()).map(|i| Ray::segment(p, samples.points[i] + samples.normals[i] * 1e-3 * side[i] as f32)).collect();
                for (i, blocked) in rays.occluded_batch(&segments, Packing::Packets8).into_iter().enumerate() {
                    if side[i] != 0 && !blocked && (p - samples.points[i]).dot(samples.normals[i]) * side[i] as f32 > 0.0 {
                        bits[i / 64] |= 1 << (i % 64);
                    }
                }
                bits
            })
            .collect();
        let w = overlap(&seen, samples.area_each);
        let sim = similarity(&w);
        let across = (0..3).flat_map(|i| (3..6).map(move |j| (i, j))).map(|(i, j)| sim[i][j]).fold(0.0f64, f64::max);
        let within = [(0, 1), (0, 2), (1, 2), (3, 4), (3, 5), (4, 5)].iter().map(|&(i, j)| sim[i][j]).fold(1.0f64, f64::min);
        assert!(across < 0.5 * within, "across rooms {across:.2}, within {within:.2}");
        let (labels, stats) = markov_cluster(&sim);
        assert_eq!(stats.clusters, 2, "{labels:?}");
        assert_eq!(labels, vec![0, 0, 0, 1, 1, 1]);
    }
}
