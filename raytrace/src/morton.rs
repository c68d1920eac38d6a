//! Morton (Z-curve) order of 3D points, so that consecutive queries or bodies, and the tasks
//! cut from them, are spatially coherent, as the primary rays of [`crate::camera`] are.

/// Spreads the low 10 bits of `v` to every third bit.
fn spread(v: u32) -> u32 {
    let mut x = v & 0x3FF;
    x = (x | (x << 16)) & 0x030000FF;
    x = (x | (x << 8)) & 0x0300F00F;
    x = (x | (x << 4)) & 0x030C30C3;
    (x | (x << 2)) & 0x09249249
}

/// The 30-bit Morton (Z-curve) code of `p` inside the box `lo..hi`, 10 bits per axis.
pub fn morton(p: [f32; 3], lo: [f32; 3], hi: [f32; 3]) -> u32 {
    let q = |a: usize| {
        let extent = (hi[a] - lo[a]).max(f32::MIN_POSITIVE);
        (((p[a] - lo[a]) / extent).clamp(0.0, 1.0) * 1023.0) as u32
    };
    spread(q(0)) | (spread(q(1)) << 1) | (spread(q(2)) << 2)
}

/// The permutation that sorts `points` along the Z curve of their bounding box: nearby
/// points get nearby indices, so a range of them is a spatially coherent task (the thesis
/// orders rays by the Morton code of their pixel for the same reason).
pub fn morton_order(points: &[[f32; 3]]) -> Vec<u32> {
    let (lo, hi) = bounds(points);
    let mut keys: Vec<(u32, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| (morton(p, lo, hi), i as u32))
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|(_, i)| i).collect()
}

/// The bounding box of `points`; an empty box at the origin for no points.
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

    #[test]
    fn corners_order_along_the_curve() {
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        assert_eq!(morton([0.0; 3], lo, hi), 0);
        assert_eq!(morton([1.0; 3], lo, hi), (1 << 30) - 1);
        assert_eq!(morton([1.0, 0.0, 0.0], lo, hi), spread(1023));
        let order = morton_order(&[[1.0; 3], [0.0; 3], [0.5; 3]]);
        assert_eq!(order, vec![1, 2, 0]);
    }
}
