//! Cost images (thesis Figure 3.2): where in the picture the traversal work is, per pixel of
//! the primary rays, as the two numbers the cost model `C = kB·B + kT·T` uses.
//!
//! Layout: two panels side by side, so the image is `2 width x height`: on the **left `B`**
//! (nodes entered), on the **right `T`** (triangle tests). Each panel is normalised to its own
//! maximum (so both use the whole ramp even though `T` and `B` differ in scale) and coloured
//! with one ramp, black (no work) → indigo → magenta → orange → near-white (the panel's
//! maximum). Side by side rather than `B` and `T` in two channels of one pixel, because a
//! blend of two colours cannot be read back as two magnitudes; with one ramp per panel the
//! eye compares brightness, and the two panels align pixel for pixel.

use glam::Vec3;

use crate::traverse::counts::Counts;
use crate::{Bvh, Camera, Film};

/// Stops of the colour ramp, evenly spaced over `[0, 1]` (display-referred RGB).
const RAMP: [Vec3; 5] = [
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(0.15, 0.05, 0.6),
    Vec3::new(0.85, 0.1, 0.45),
    Vec3::new(1.0, 0.6, 0.0),
    Vec3::new(1.0, 1.0, 0.9),
];

/// The ramp's colour at `x` (clamped to `[0, 1]`; NaN is black).
pub fn ramp(x: f32) -> Vec3 {
    let x = crate::film::saturate(x) * (RAMP.len() - 1) as f32;
    let i = (x as usize).min(RAMP.len() - 2);
    RAMP[i].lerp(RAMP[i + 1], x - i as f32)
}

/// `B` and `T` of every primary ray of `camera`'s `width x height` image, by pixel
/// (`y * width + x`), traced on the host's threads apart from any render: a render's devices
/// keep their rays, so the map is counted where the BVH's host copy is.
pub fn primary_counts(bvh: &Bvh, camera: &Camera, width: u32, height: u32) -> Vec<Counts> {
    let primary = camera.primary_rays(width, height);
    let (_, counts) = crate::traverse::batch::closest_hits_counted(bvh, &primary.rays);
    let mut by_pixel = vec![Counts::default(); counts.len()];
    for (c, &p) in counts.iter().zip(&primary.pixels) {
        by_pixel[p as usize] = *c;
    }
    by_pixel
}

/// The cost image of `camera`'s `width x height` primary rays: [`primary_counts`] drawn by
/// [`cost_image`].
pub fn primary_cost_image(bvh: &Bvh, camera: &Camera, width: u32, height: u32) -> Film {
    cost_image(&primary_counts(bvh, camera, width, height), width, height)
}

/// The `2 width x height` heat map of `counts` (row-major, `y * width + x`), `B` left and `T`
/// right; encode it with [`crate::film::ToneMap::Display`].
///
/// # Panics
/// Panics if `counts.len() != width * height`.
pub fn cost_image(counts: &[Counts], width: u32, height: u32) -> Film {
    assert_eq!(
        counts.len(),
        width as usize * height as usize,
        "one count per pixel"
    );
    // Each panel's top colour stands for its largest count; a panel with no work at all stays
    // black instead of dividing by zero.
    let scale = |m: Option<u32>| m.filter(|&m| m > 0).map_or(0.0, |m| 1.0 / m as f32);
    let sb = scale(counts.iter().map(|c| c.nodes).max());
    let st = scale(counts.iter().map(|c| c.tris).max());
    let mut film = Film::new(2 * width, height);
    let w2 = 2 * width as usize;
    for (i, c) in counts.iter().enumerate() {
        let (x, y) = (i % width as usize, i / width as usize);
        film.set(y * w2 + x, ramp(c.nodes as f32 * sb));
        film.set(y * w2 + width as usize + x, ramp(c.tris as f32 * st));
    }
    film
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_runs_from_black_to_the_brightest_stop() {
        assert_eq!(ramp(0.0), Vec3::ZERO);
        assert_eq!(ramp(f32::NAN), Vec3::ZERO);
        assert_eq!(ramp(1.0), RAMP[4]);
        assert_eq!(ramp(7.0), RAMP[4]);
        // Brightness (sum of channels) rises along the ramp.
        let mut last = -1.0;
        for k in 0..=100 {
            let s = ramp(k as f32 / 100.0).element_sum();
            assert!(s >= last, "{k}");
            last = s;
        }
    }

    #[test]
    fn panels_are_side_by_side_and_normalised_separately() {
        let c = |nodes, tris| Counts { nodes, tris };
        let counts = [c(10, 0), c(5, 100), c(0, 50), c(10, 100)];
        let film = cost_image(&counts, 2, 2);
        assert_eq!((film.width(), film.height()), (4, 2));
        assert_eq!(film.get(0, 0), ramp(1.0));
        assert_eq!(film.get(1, 0), ramp(0.5));
        assert_eq!(film.get(2, 0), ramp(0.0)); // T of pixel (0, 0)
        assert_eq!(film.get(3, 0), ramp(1.0));
        assert_eq!(film.get(2, 1), ramp(0.5));
        let empty = cost_image(&[Counts::default(); 4], 2, 2);
        assert!(empty.pixels().iter().all(|p| *p == Vec3::ZERO));
    }
}
