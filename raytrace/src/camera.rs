//! Pinhole cameras and primary rays in Morton (Z-curve) order, so that consecutive rays (and so
//! the tasks cut from them) cover compact image regions and stay coherent.

use glam::Vec3;
use rayon::slice::ParallelSliceMut;

use crate::{Aabb, Ray, RayBatch};

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub at: Vec3,
    /// Up direction (need not be exactly perpendicular to the view).
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_degrees: f32,
}

impl Camera {
    /// A camera at `eye` looking at `at`, +Y up, 60° vertical field of view.
    pub fn look_at(eye: Vec3, at: Vec3) -> Self {
        Self {
            eye,
            at,
            up: Vec3::Y,
            fov_y_degrees: 60.0,
        }
    }

    /// Orbit camera `index` (0..=3), the thesis's four: positions at the maximum Y of the scene's
    /// bounding box, looking at its centre.
    ///
    /// Our choice of the four: above the four quadrants, `x = c.x ± 0.45 ext.x`,
    /// `z = c.z ± 0.45 ext.z` (90 % of the way from the centre towards each top corner, in the
    /// order `(-,-), (+,-), (+,+), (-,+)`), at `y = max.y - 0.001 ext.y`, just under the top so
    /// a camera in a closed room (Conference, Sibenik) is inside the ceiling, not on it. A
    /// scene flat along an axis is seen from 0.45 of its widest extent off its plane.
    /// `index` is taken modulo 4.
    pub fn orbit(bounds: &Aabb, index: usize) -> Self {
        let c = bounds.center();
        let e = bounds.extent();
        let (sx, sz) = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)][index % 4];
        // A flat scene's own plane would hold the eye, and show the scene exactly edge-on, as
        // nothing: along an axis where it has no extent, the eye steps out of the plane.
        let off = |ext: f32| {
            if ext == 0.0 {
                0.45 * e.max_element()
            } else {
                0.0
            }
        };
        let eye = Vec3::new(
            c.x + sx * 0.45 * e.x + off(e.x),
            bounds.max.y - 0.001 * e.y + off(e.y),
            c.z + sz * 0.45 * e.z + off(e.z),
        );
        let mut cam = Self::look_at(eye, c);
        if (c - eye)
            .normalize_or_zero()
            .cross(Vec3::Y)
            .length_squared()
            < 1e-6
        {
            cam.up = Vec3::Z; // looking straight down
        }
        cam
    }

    /// The ray through pixel `(x, y)` (`y = 0` is the top row), through the pixel centre.
    pub fn ray(&self, x: u32, y: u32, width: u32, height: u32) -> Ray {
        self.ray_in(&self.frame(width, height), x, y, width, height)
    }

    /// [`Camera::ray`] with the image's frame already computed.
    fn ray_in(&self, f: &CameraFrame, x: u32, y: u32, width: u32, height: u32) -> Ray {
        let px = ((x as f32 + 0.5) / width as f32 * 2.0 - 1.0) * f.half_width;
        let py = (1.0 - (y as f32 + 0.5) / height as f32 * 2.0) * f.half_height;
        Ray::new(self.eye, (f.forward + px * f.right + py * f.up).normalize())
    }

    /// The orthonormal frame and image-plane half extents that [`Camera::ray`] uses for an
    /// image of `width × height` (the GPU's ray generation takes them from here, so both
    /// agree to the bit).
    pub fn frame(&self, width: u32, height: u32) -> CameraFrame {
        let forward = (self.at - self.eye).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let half_height = (self.fov_y_degrees.to_radians() * 0.5).tan();
        CameraFrame {
            forward,
            right,
            up,
            half_width: half_height * width as f32 / height as f32,
            half_height,
        }
    }

    /// One ray per pixel in Morton order; `pixels[i]` is ray `i`'s pixel index `y * width + x`.
    pub fn primary_rays(&self, width: u32, height: u32) -> PrimaryRays {
        let order = morton_order(width, height);
        // The frame once per image, not per pixel: it was most of this function's time.
        let f = self.frame(width, height);
        let rays = order
            .iter()
            .map(|&p| self.ray_in(&f, p % width, p / width, width, height))
            .collect();
        PrimaryRays {
            rays,
            pixels: order,
        }
    }

    /// The primary rays of the paths `ranks` (indices into the image's Morton order, as
    /// [`Camera::primary_rays`] orders them): the same rays, bit for bit, made without
    /// ordering the whole image, so a device makes only the rays of its own tasks.
    ///
    /// # Panics
    /// Panics if a side exceeds 65536 pixels or a rank is not below `width · height`.
    pub fn primary_rays_of(
        &self,
        width: u32,
        height: u32,
        ranks: impl IntoIterator<Item = usize>,
    ) -> PrimaryRays {
        let f = self.frame(width, height);
        let mut out = PrimaryRays::default();
        for rank in ranks {
            let p = morton_pixel(width, height, rank);
            out.rays
                .push(&self.ray_in(&f, p % width, p / width, width, height));
            out.pixels.push(p);
        }
        out
    }
}

/// What [`Camera::ray`] computes once per image: the view direction, the image plane's axes
/// and its half extents at distance 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit image-plane x axis.
    pub right: Vec3,
    /// Image-plane y axis.
    pub up: Vec3,
    /// Half the image plane's width.
    pub half_width: f32,
    /// Half its height: `tan(fov_y / 2)`.
    pub half_height: f32,
}

/// Primary rays and the pixel each came from.
#[derive(Clone, Debug, Default)]
pub struct PrimaryRays {
    /// The rays, in Morton order.
    pub rays: RayBatch,
    /// Pixel index (`y * width + x`) of each ray.
    pub pixels: Vec<u32>,
}

/// Interleaves the low 16 bits of `v` with zeros.
fn spread(v: u32) -> u32 {
    let mut x = v & 0xFFFF;
    x = (x | (x << 8)) & 0x00FF_00FF;
    x = (x | (x << 4)) & 0x0F0F_0F0F;
    x = (x | (x << 2)) & 0x3333_3333;
    (x | (x << 1)) & 0x5555_5555
}

/// Pixel indices `y * width + x` of a `width x height` image in Z-curve order (for sizes that
/// are not powers of two, the curve over the enclosing square with outside pixels skipped).
///
/// # Panics
/// Panics if a side exceeds 65536.
pub fn morton_order(width: u32, height: u32) -> Vec<u32> {
    assert!(width <= 1 << 16 && height <= 1 << 16, "image too large");
    let side = u64::from(width.max(height).next_power_of_two());
    let pixels = u64::from(width) * u64::from(height);
    if side * side <= 4 * pixels {
        // The curve's keys in order, walked directly: linear, where sorting the keys is not,
        // and the renderer orders every image it draws.
        (0..side * side)
            .filter_map(|k| {
                let (x, y) = (compact(k as u32), compact((k >> 1) as u32));
                (x < width && y < height).then_some(y * width + x)
            })
            .collect()
    } else {
        // A long, thin image: its enclosing square is mostly outside it.
        let mut keyed: Vec<(u32, u32)> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (spread(x) | (spread(y) << 1), y * width + x)))
            .collect();
        keyed.par_sort_unstable_by_key(|&(k, _)| k);
        keyed.into_iter().map(|(_, p)| p).collect()
    }
}

/// The inverse of `spread`: the even bits of `k`, packed.
fn compact(k: u32) -> u32 {
    let mut x = k & 0x5555_5555;
    x = (x | (x >> 1)) & 0x3333_3333;
    x = (x | (x >> 2)) & 0x0F0F_0F0F;
    x = (x | (x >> 4)) & 0x00FF_00FF;
    (x | (x >> 8)) & 0x0000_FFFF
}

/// The pixel at `rank` in [`morton_order`]`(width, height)`, found without sorting: from the
/// smallest aligned block of the Z-curve that holds the image down, the half of a block with
/// its top free bit clear holds a rectangle of the image's pixels, and a rank past them lies
/// in the other half. Once a block lies inside the image, the rank's own bits are the rest
/// of the key, so most pixels of an image take a few steps (a power-of-two square, none).
/// The render kernels' `morton_pixel` walks the same blocks.
///
/// # Panics
/// Panics if a side exceeds 65536 pixels or `rank` is not below `width · height`.
pub fn morton_pixel(width: u32, height: u32, rank: usize) -> u32 {
    assert!(width <= 1 << 16 && height <= 1 << 16, "image too large");
    assert!(
        rank < width as usize * height as usize,
        "rank {rank} outside a {width}x{height} image"
    );
    // Pixels of the block at (`x0`, `y0`) spanning 2^fx by 2^fy that lie in the image.
    let inside = |x0: u32, y0: u32, fx: u32, fy: u32| {
        let side = |origin: u32, free: u32, size: u32| {
            u64::from(size.saturating_sub(origin).min(1 << free))
        };
        side(x0, fx, width) * side(y0, fy, height)
    };
    let mut rank = rank as u64;
    let (mut x0, mut y0) = (0u32, 0u32);
    // Free key bits below the current block: x takes the even ones, y the odd ones.
    let mut free = 2 * width.max(height).next_power_of_two().trailing_zeros();
    loop {
        let (fx, fy) = (free.div_ceil(2), free / 2);
        if x0 + (1 << fx) <= width && y0 + (1 << fy) <= height {
            // `rank` < 2^free here: the block is whole, and its Z order is the rank's bits.
            let low = rank as u32;
            return (y0 + compact(low >> 1)) * width + x0 + compact(low);
        }
        free -= 1;
        let lower = inside(x0, y0, free.div_ceil(2), free / 2);
        if rank >= lower {
            rank -= lower;
            if free.is_multiple_of(2) {
                x0 |= 1 << (free / 2);
            } else {
                y0 |= 1 << (free / 2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_order_is_a_z_curve_permutation() {
        assert_eq!(morton_order(2, 2), vec![0, 1, 2, 3]);
        assert_eq!(&morton_order(4, 4)[..8], &[0, 1, 4, 5, 2, 3, 6, 7]);
        let mut o = morton_order(13, 7);
        o.sort_unstable();
        assert_eq!(o, (0..91).collect::<Vec<_>>());
    }

    /// The walk of the enclosing square and the sort of the keys give one order, for square,
    /// wide, tall and thin images.
    #[test]
    fn morton_order_walks_as_the_keys_sort() {
        for (w, h) in [
            (1, 1),
            (3, 3),
            (13, 7),
            (100, 37),
            (300, 200),
            (5, 300),
            (64, 1),
            (1, 33),
        ] {
            let mut keyed: Vec<(u32, u32)> = (0..h)
                .flat_map(|y| (0..w).map(move |x| (spread(x) | (spread(y) << 1), y * w + x)))
                .collect();
            keyed.sort_unstable();
            let sorted: Vec<u32> = keyed.into_iter().map(|(_, p)| p).collect();
            assert_eq!(morton_order(w, h), sorted, "{w}x{h}");
        }
    }

    /// The image's rays, made with its frame computed once, are each pixel's `ray`, bit for
    /// bit.
    #[test]
    fn morton_pixel_inverts_the_sorted_order() {
        for (w, h) in [
            (1, 1),
            (2, 2),
            (13, 7),
            (7, 13),
            (64, 1),
            (1, 33),
            (100, 37),
            (64, 64),
            (320, 200),
            (257, 3),
        ] {
            let order = morton_order(w, h);
            for (rank, &p) in order.iter().enumerate() {
                assert_eq!(morton_pixel(w, h, rank), p, "{w}x{h} rank {rank}");
            }
        }
    }

    #[test]
    fn a_range_of_paths_gets_the_rays_of_the_whole_image() {
        let b = Aabb {
            min: Vec3::new(-1.0, 0.0, -2.0),
            max: Vec3::new(1.0, 3.0, 2.0),
        };
        let c = Camera::orbit(&b, 2);
        let (w, h) = (29, 17);
        let all = c.primary_rays(w, h);
        let part = c.primary_rays_of(w, h, 100..250);
        assert_eq!(part.pixels, all.pixels[100..250]);
        for (k, i) in (100..250).enumerate() {
            assert_eq!(part.rays.get(k), all.rays.get(i));
        }
    }

    #[test]
    fn primary_rays_are_the_rays_of_their_pixels() {
        let b = Aabb {
            min: Vec3::new(-1.0, 0.0, -2.0),
            max: Vec3::new(1.0, 3.0, 2.0),
        };
        let c = Camera::orbit(&b, 1);
        let (w, h) = (37, 23);
        let p = c.primary_rays(w, h);
        assert_eq!(p.rays.len(), (w * h) as usize);
        for (i, &q) in p.pixels.iter().enumerate() {
            assert_eq!(p.rays.get(i), c.ray(q % w, q / w, w, h), "pixel {q}");
        }
    }

    #[test]
    fn orbit_cameras_look_at_the_centre_from_the_top() {
        let b = Aabb {
            min: Vec3::new(-1.0, 0.0, -2.0),
            max: Vec3::new(1.0, 3.0, 2.0),
        };
        let mut eyes = Vec::new();
        for i in 0..4 {
            let c = Camera::orbit(&b, i);
            assert!((c.eye.y - 3.0).abs() < 0.01 && c.eye.y < 3.0);
            assert_eq!(c.at, b.center());
            let mid = c.ray(50, 50, 101, 101);
            assert!(mid.dir.dot((b.center() - c.eye).normalize()) > 0.9999);
            eyes.push(c.eye);
        }
        eyes.dedup();
        assert_eq!(eyes.len(), 4);
    }
}
