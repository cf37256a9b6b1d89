//! Cluster: group probes that see the same surface, with the Markov Cluster
//! algorithm (van Dongen 2000; DESIGN.md section 3.5, the paper's section 5).
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
                    if d > 0.0 { overlap[i][j] / d } else { 0.0 }
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
    let attractor: Vec<usize> = (0..n)
        .map(|j| (0..n).max_by(|&a, &b| m[a][j].total_cmp(&m[b][j]).then(b.cmp(&a))).unwrap_or(j))
        .collect();
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
    fn two_rooms_give_two_clusters() {
        use crate::coverage::{reachability, surface_samples};
        use crate::freespace::{free_space, FreeSpaceParams, SpaceMode};
        use crate::raycast::{Packing, Ray, RayScene};
        use glam::Vec3;
        // Two 10 × 8 rooms joined by a door, three probes in each.
        let scene = crate::testing::rooms(2, 10.0, 3.0, 8.0, &[1]);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (space, _) = free_space(&scene, &rays, &FreeSpaceParams { space: SpaceMode::Inside, ..Default::default() }).unwrap();
        let probes = [
            Vec3::new(2.0, 1.5, 2.0),
            Vec3::new(5.0, 1.2, 6.0),
            Vec3::new(8.0, 1.8, 3.0),
            Vec3::new(12.0, 1.5, 2.0),
            Vec3::new(15.0, 1.2, 6.0),
            Vec3::new(18.0, 1.8, 3.0),
        ];
        let samples = surface_samples(&scene, 4000, 3);
        let (side, _) = reachability(&rays, &space, &samples, 8, 3);
        let seen: Vec<Vec<u64>> = probes
            .iter()
            .map(|&p| {
                let mut bits = vec![0u64; samples.points.len().div_ceil(64)];
                let segments: Vec<Ray> = (0..samples.points.len()).map(|i| Ray::segment(p, samples.points[i] + samples.normals[i] * 1e-3 * side[i] as f32)).collect();
                for (i, blocked) in rays.occluded_batch(&segments, Packing::Packets8).into_iter().enumerate() {
                    if side[i] != 0 && !blocked && (p - samples.points[i]).dot(samples.normals[i]) * side[i] as f32 > 0.0 {
                        bits[i / 64] |= 1 << (i % 64);
                    }
                }
                bits
            })
            .collect();
        let w = overlap(&seen, samples.area_each);
        assert_eq!(markov_cluster(&w).0, vec![0; 6], "raw shared area merges the rooms (see `similarity`)");
        let (labels, stats) = markov_cluster(&similarity(&w));
        assert_eq!(stats.clusters, 2, "{labels:?}");
        assert_eq!(labels, vec![0, 0, 0, 1, 1, 1]);
    }
}
