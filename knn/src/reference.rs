//! The brute-force reference the scheduled results are checked against.

/// Squared Euclidean distance, in f64 so the reference does not share kiddo's rounding.
pub fn dist2(a: &[f32; 3], b: &[f32; 3]) -> f64 {
    (0..3)
        .map(|i| (f64::from(a[i]) - f64::from(b[i])).powi(2))
        .sum()
}

/// The `k` nearest points to `q` by scanning all of them; ties go to the lower index.
pub fn brute_force(points: &[[f32; 3]], q: &[f32; 3], k: usize) -> Vec<u32> {
    let mut all: Vec<(f64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| (dist2(p, q), i as u32))
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    all.truncate(k);
    all.into_iter().map(|(_, i)| i).collect()
}

/// True when `got` is a correct answer for `q`: `k` distinct points whose distances are the
/// `k` smallest. Under ties several sets are correct, so sets are compared by distances.
/// kiddo computes distances in f32, so a tie broken differently by rounding is accepted
/// when the two distances agree to f32 precision.
pub fn is_knn(points: &[[f32; 3]], q: &[f32; 3], k: usize, got: &[u32]) -> bool {
    let mut ids = got.to_vec();
    ids.sort_unstable();
    ids.dedup();
    if got.len() != k || ids.len() != k || ids.iter().any(|&i| i as usize >= points.len()) {
        return false;
    }
    let mut mine: Vec<f64> = got.iter().map(|&i| dist2(&points[i as usize], q)).collect();
    mine.sort_by(f64::total_cmp);
    let truth: Vec<f64> = brute_force(points, q, k)
        .iter()
        .map(|&i| dist2(&points[i as usize], q))
        .collect();
    mine.iter()
        .zip(&truth)
        .all(|(a, b)| (a - b).abs() <= 1e-5 * b.max(1e-12))
}
