//! Locality ordering: Morton (Z-curve) order of 3D points.
//!
//! Tasks cut as consecutive ranges of a workload are cheaper to run, and their costs easier
//! to estimate, when each range is a compact region of space: its items share cache lines
//! and tree nodes, and a sample of them stands for the rest. Sorting the items along a
//! Z curve before [`split_ranges`](crate::split_ranges) gives that.
//!
//! ```
//! use sched::locality::morton_order;
//!
//! // Two clusters, interleaved in the input.
//! let points = [[0.0, 0.0, 0.0], [9.0, 9.0, 9.0], [0.1, 0.0, 0.0], [9.0, 9.1, 9.0]];
//! let order = morton_order(&points);
//! assert_eq!(order, vec![0, 2, 1, 3]); // each cluster is now one range
//! let sorted: Vec<[f32; 3]> = order.iter().map(|&i| points[i as usize]).collect();
//! let tasks = sched::split_ranges(sorted.len(), 2);
//! assert_eq!(tasks, vec![0..2, 2..4]);
//! ```

/// Spreads the low 10 bits of `v` to every third bit.
fn spread(v: u32) -> u32 {
    let mut x = v & 0x3FF;
    x = (x | (x << 16)) & 0x030000FF;
    x = (x | (x << 8)) & 0x0300F00F;
    x = (x | (x << 4)) & 0x030C30C3;
    (x | (x << 2)) & 0x09249249
}

/// The 30-bit Morton (Z-curve) code of `p` inside the box `lo..hi`, 10 bits per axis.
///
/// Points outside the box are clamped to it; a flat axis (`lo == hi`) quantises to 0, so
/// any box is valid, and a NaN coordinate counts as `lo`.
pub fn morton(p: [f32; 3], lo: [f32; 3], hi: [f32; 3]) -> u32 {
    let q = |a: usize| {
        let extent = (hi[a] - lo[a]).max(f32::MIN_POSITIVE);
        // `as` saturates and maps NaN to 0, so no input can overflow the 10 bits.
        (((p[a] - lo[a]) / extent).clamp(0.0, 1.0) * 1023.0) as u32
    };
    spread(q(0)) | (spread(q(1)) << 1) | (spread(q(2)) << 2)
}

/// The permutation that sorts `points` along the Z curve of their bounding box: nearby
/// points get nearby indices, so a range of them is a spatially coherent task.
///
/// `order[i]` is the input index of the `i`-th point in Morton order. Points with equal
/// codes keep their input order, so the result depends only on the input.
///
/// # Panics
/// Panics if there are more than `u32::MAX` points (indices are `u32` to halve the memory
/// of the permutation).
pub fn morton_order(points: &[[f32; 3]]) -> Vec<u32> {
    assert!(
        u32::try_from(points.len()).is_ok(),
        "more than 2^32 - 1 points"
    );
    let (lo, hi) = bounds(points);
    let mut keys: Vec<(u32, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| (morton(p, lo, hi), i as u32))
        .collect();
    // Sorting the (code, index) pairs breaks ties by index, without a stable sort.
    keys.sort_unstable();
    keys.into_iter().map(|(_, i)| i).collect()
}

/// The axis-aligned bounding box `(lo, hi)` of `points`; an empty box at the origin for no
/// points. NaN coordinates are ignored.
pub fn bounds(points: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    if points.is_empty() {
        return ([0.0; 3], [0.0; 3]);
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rng;

    #[test]
    fn corners_order_along_the_curve() {
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        assert_eq!(morton([0.0; 3], lo, hi), 0);
        assert_eq!(morton([1.0; 3], lo, hi), (1 << 30) - 1);
        assert_eq!(morton([1.0, 0.0, 0.0], lo, hi), spread(1023));
        assert_eq!(morton([0.0, 1.0, 0.0], lo, hi), spread(1023) << 1);
        let order = morton_order(&[[1.0; 3], [0.0; 3], [0.5; 3]]);
        assert_eq!(order, vec![1, 2, 0]);
    }

    #[test]
    fn degenerate_inputs_are_fine() {
        assert!(morton_order(&[]).is_empty());
        assert_eq!(bounds(&[]), ([0.0; 3], [0.0; 3]));
        // All points equal: every code is 0, ties keep the input order.
        assert_eq!(morton_order(&[[2.0; 3]; 4]), vec![0, 1, 2, 3]);
        // Outside the box and NaN are clamped, never out of 30 bits.
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        assert_eq!(morton([5.0, -5.0, f32::NAN], lo, hi), spread(1023));
        assert!(morton([f32::INFINITY; 3], lo, hi) < 1 << 30);
    }

    #[test]
    fn order_is_a_permutation_that_groups_neighbours() {
        let mut rng = Rng::new(9);
        let points: Vec<[f32; 3]> = (0..2000).map(|_| rng.unit_vector()).collect();
        let order = morton_order(&points);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..2000).collect::<Vec<u32>>());
        // Consecutive points in Morton order are far closer on average than in input order.
        let mean_step = |ids: &mut dyn Iterator<Item = usize>| {
            let ids: Vec<usize> = ids.collect();
            let d = |a: [f32; 3], b: [f32; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>();
            ids.windows(2)
                .map(|w| d(points[w[0]], points[w[1]]).sqrt())
                .sum::<f32>()
                / (ids.len() - 1) as f32
        };
        let sorted = mean_step(&mut order.iter().map(|&i| i as usize));
        let input = mean_step(&mut (0..points.len()));
        assert!(sorted < input / 4.0, "{sorted} vs {input}");
    }
}
