//! The image a render writes into: linear RGB per pixel, turned into 8-bit sRGB and PNG bytes
//! at the end. The PNG is returned as bytes, not written, so the caller can write it atomically.

use glam::Vec3;
use image::{ExtendedColorType, ImageEncoder, codecs::png::PngEncoder};

use crate::{Error, Result};

/// How stored values become 8-bit channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneMap {
    /// Values are linear radiance (or an AO fraction): clamped to `[0, 1]`, then encoded with
    /// the sRGB transfer curve, so mid-greys look mid-grey on a screen.
    #[default]
    Srgb,
    /// Values are already display-referred (a colour ramp): clamped to `[0, 1]` and quantised,
    /// with no curve, so the ramp's colours come out as designed.
    Display,
}

/// A `width x height` image of RGB values, row-major, `y = 0` at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

impl Film {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// A `width x height` image of `pixels`, row-major.
    ///
    /// # Panics
    /// Panics if `pixels` does not hold `width · height` values.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        assert_eq!(
            pixels.len(),
            width as usize * height as usize,
            "pixels for a {width}x{height} film"
        );
        Self {
            width,
            height,
            pixels,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// All pixels, row-major; index `y * width + x`.
    pub fn pixels(&self) -> &[Vec3] {
        &self.pixels
    }

    /// Pixel `(x, y)`.
    ///
    /// # Panics
    /// Panics if `(x, y)` is outside the image.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        assert!(x < self.width && y < self.height, "pixel outside the film");
        self.pixels[(y * self.width + x) as usize]
    }

    /// Sets pixel `index` (`y * width + x`).
    ///
    /// # Panics
    /// Panics if `index` is outside the image.
    pub fn set(&mut self, index: usize, value: Vec3) {
        self.pixels[index] = value;
    }

    /// Adds to pixel `index` (`y * width + x`): shading generations accumulate into a pixel.
    ///
    /// # Panics
    /// Panics if `index` is outside the image.
    pub fn add(&mut self, index: usize, value: Vec3) {
        self.pixels[index] += value;
    }

    /// 8-bit RGB bytes, row-major, three per pixel. NaN becomes 0.
    pub fn to_rgb8(&self, tone: ToneMap) -> Vec<u8> {
        let encode = |c: f32| {
            let c = saturate(c);
            let c = match tone {
                ToneMap::Srgb => srgb_encode(c),
                ToneMap::Display => c,
            };
            (c * 255.0 + 0.5) as u8
        };
        self.pixels
            .iter()
            .flat_map(|p| [encode(p.x), encode(p.y), encode(p.z)])
            .collect()
    }

    /// The image as PNG file bytes (8-bit RGB).
    pub fn png(&self, tone: ToneMap) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        PngEncoder::new(&mut out)
            .write_image(
                &self.to_rgb8(tone),
                self.width,
                self.height,
                ExtendedColorType::Rgb8,
            )
            .map_err(|e| Error::Encode {
                width: self.width,
                height: self.height,
                why: e.to_string(),
            })?;
        Ok(out)
    }
}

/// `c` clamped to `[0, 1]`, NaN to 0 (`f32::clamp` would keep the NaN).
pub fn saturate(c: f32) -> f32 {
    if c >= 0.0 { c.min(1.0) } else { 0.0 }
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in `[0, 1]`.
pub fn srgb_encode(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trips_through_the_decoder() {
        let mut film = Film::new(3, 2);
        film.set(0, Vec3::new(1.0, 0.0, 0.0));
        film.add(5, Vec3::splat(0.25));
        film.add(5, Vec3::splat(0.25));
        film.set(4, Vec3::splat(f32::NAN));
        let bytes = film.png(ToneMap::Srgb).unwrap();
        let img = image::load_from_memory(&bytes).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (3, 2));
        assert_eq!(img.get_pixel(0, 0).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(1, 1).0, [0, 0, 0], "NaN is black");
        // Linear 0.5 is sRGB 188.
        assert_eq!(img.get_pixel(2, 1).0, [188, 188, 188]);
        let raw = film.to_rgb8(ToneMap::Display);
        assert_eq!(&raw[15..18], &[128, 128, 128]);
    }

    #[test]
    fn srgb_curve_is_continuous_and_fixes_the_ends() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        let (a, b) = (srgb_encode(0.003_130_8), srgb_encode(0.003_130_9));
        assert!((a - b).abs() < 1e-4);
    }
}
