//! Order: the thumbnail bar's order of probes, a weighted minimum linear
//! arrangement: minimise Σ w_ij·|pos(i) − pos(j)|, so
//! probes close in the graph sit close in the bar.
//!
//! Inputs: the number of probes and weighted edges (1 / path length once paths
//! exist; until then 1 / Euclidean distance between all pairs, see
//! [`euclidean_edges`]). Output: probe ids in bar order, and [`OrderStats`].
//!
//! Method: a spectral start (probes sorted by the Fiedler vector of the
//! weighted Laplacian, found by power iteration on a shifted, deflated matrix),
//! then local search: moves of one probe by up to 12 positions, each accepted
//! when it lowers the cost, until a pass changes nothing. The stats
//! report the cost against the spectral start and against random orders.
//! Deterministic: no randomness except the seeded random baseline.

use rand::seq::SliceRandom;

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct OrderStats {
    /// Σ w·|Δpos| of the final order.
    pub cost: f64,
    pub spectral_cost: f64,
    /// Mean over 16 seeded random orders.
    pub random_cost: f64,
    pub improving_moves: usize,
}

/// All pairs weighted by 1 / distance (distances floored at a millionth of the largest).
pub fn euclidean_edges(points: &[[f32; 3]]) -> Vec<(usize, usize, f64)> {
    let dist = |a: [f32; 3], b: [f32; 3]| ((0..3).map(|k| ((a[k] - b[k]) as f64).powi(2)).sum::<f64>()).sqrt();
    let mut edges = Vec::new();
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            edges.push((i, j, dist(points[i], points[j])));
        }
    }
    let floor = edges.iter().map(|e| e.2).fold(0.0, f64::max) * 1e-6 + f64::MIN_POSITIVE;
    edges.into_iter().map(|(i, j, d)| (i, j, 1.0 / d.max(floor))).collect()
}

/// Σ w·|pos(i) − pos(j)| for positions `pos`.
pub fn arrangement_cost(pos: &[usize], edges: &[(usize, usize, f64)]) -> f64 {
    edges.iter().map(|&(i, j, w)| w * (pos[i] as f64 - pos[j] as f64).abs()).sum()
}

fn positions(order: &[usize]) -> Vec<usize> {
    let mut pos = vec![0; order.len()];
    for (p, &v) in order.iter().enumerate() {
        pos[v] = p;
    }
    pos
}

/// Nodes sorted by the Fiedler vector (ties by id).
fn spectral_order(n: usize, edges: &[(usize, usize, f64)]) -> Vec<usize> {
    let mut adjacency = vec![Vec::new(); n];
    let mut degree = vec![0.0; n];
    for &(i, j, w) in edges {
        adjacency[i].push((j, w));
        adjacency[j].push((i, w));
        degree[i] += w;
        degree[j] += w;
    }
    // Power iteration on (s·I − L), orthogonal to the constant vector: converges to
    // the eigenvector of L's second-smallest eigenvalue. s bounds L's spectrum.
    let shift = 2.0 * degree.iter().copied().fold(0.0, f64::max) + 1.0;
    let mut x: Vec<f64> = (0..n).map(|i| (i as f64 + 1.0).sin() + 0.01 * i as f64).collect();
    for _ in 0..500 {
        let mean = x.iter().sum::<f64>() / n as f64;
        x.iter_mut().for_each(|v| *v -= mean);
        let mut y: Vec<f64> = (0..n).map(|i| (shift - degree[i]) * x[i]).collect();
        for i in 0..n {
            for &(j, w) in &adjacency[i] {
                y[i] += w * x[j];
            }
        }
        let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm == 0.0 {
            break;
        }
        x = y.into_iter().map(|v| v / norm).collect();
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]).then(a.cmp(&b)));
    order
}

/// How far (in bar positions) the local search moves a probe at once.
const WINDOW: usize = 12;

/// Orders `n` probes for the thumbnail bar.
pub fn order(n: usize, edges: &[(usize, usize, f64)], seed: u64) -> (Vec<u32>, OrderStats) {
    if n == 0 {
        return (Vec::new(), OrderStats::default());
    }
    let mut stats = OrderStats::default();
    let mut rng = crate::seeds::Stream::Order.rng(seed);
    stats.random_cost = (0..16)
        .map(|_| {
            let mut o: Vec<usize> = (0..n).collect();
            o.shuffle(&mut rng);
            arrangement_cost(&positions(&o), edges)
        })
        .sum::<f64>()
        / 16.0;
    let mut order = spectral_order(n, edges);
    stats.spectral_cost = arrangement_cost(&positions(&order), edges);
    let mut cost = stats.spectral_cost;
    // Local search: move one node to another position within WINDOW while that helps.
    let tolerance = 1e-12 * cost.max(1.0);
    loop {
        let mut improved = false;
        for from in 0..n {
            let mut best = (cost, from);
            for to in from.saturating_sub(WINDOW)..(from + WINDOW + 1).min(n) {
                if to == from {
                    continue;
                }
                let mut candidate = order.clone();
                let v = candidate.remove(from);
                candidate.insert(to, v);
                let c = arrangement_cost(&positions(&candidate), edges);
                if c < best.0 - tolerance {
                    best = (c, to);
                }
            }
            if best.1 != from {
                let v = order.remove(from);
                order.insert(best.1, v);
                cost = best.0;
                stats.improving_moves += 1;
                improved = true;
            }
        }
        if !improved || stats.improving_moves > 50 * n {
            break;
        }
    }
    stats.cost = cost;
    (order.into_iter().map(|v| v as u32).collect(), stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_graph_comes_out_in_path_order() {
        // Path 3 - 0 - 4 - 1 - 2 with equal weights, labels scrambled.
        let chain = [3usize, 0, 4, 1, 2];
        let edges: Vec<_> = chain.windows(2).map(|w| (w[0], w[1], 1.0)).collect();
        let (order, stats) = order(5, &edges, 1);
        let order: Vec<usize> = order.into_iter().map(|v| v as usize).collect();
        let reversed: Vec<usize> = chain.iter().rev().copied().collect();
        assert!(order == chain || order == reversed, "{order:?}");
        assert_eq!(stats.cost, 4.0, "the optimum: every edge spans one position");
    }

    #[test]
    fn points_on_a_line_are_ordered_along_it() {
        let xs = [5.0f32, -2.0, 9.0, 0.5, 3.0, 7.5, -6.0];
        let points: Vec<[f32; 3]> = xs.iter().map(|&x| [x, 1.0, 2.0]).collect();
        let (order, stats) = order(points.len(), &euclidean_edges(&points), 3);
        let along: Vec<f32> = order.iter().map(|&i| xs[i as usize]).collect();
        let sorted = along.windows(2).all(|w| w[0] < w[1]) || along.windows(2).all(|w| w[0] > w[1]);
        assert!(sorted, "{along:?}");
        assert!(stats.cost <= stats.spectral_cost && stats.cost < stats.random_cost, "{stats:?}");
    }

    #[test]
    fn two_clumps_stay_together() {
        let mut points = Vec::new();
        for k in 0..5 {
            points.push([k as f32 * 0.1, 0.0, 0.0]);
            points.push([100.0 + k as f32 * 0.1, 0.0, 0.0]);
        }
        let (order, _) = order(points.len(), &euclidean_edges(&points), 1);
        let sides: Vec<bool> = order.iter().map(|&i| points[i as usize][0] > 50.0).collect();
        assert_eq!(sides.windows(2).filter(|w| w[0] != w[1]).count(), 1, "{sides:?}");
    }

    #[test]
    fn degenerate_inputs() {
        assert_eq!(order(0, &[], 1).0, Vec::<u32>::new());
        assert_eq!(order(1, &[], 1).0, vec![0]);
        let (o, _) = order(3, &[], 1);
        let mut sorted = o.clone();
        sorted.sort();
        assert_eq!(sorted, vec![0, 1, 2], "a permutation even without edges");
    }
}
