//! Axis-aligned bounding boxes of scenes and BVH nodes.

use glam::Vec3;

/// An axis-aligned box; `EMPTY` (min > max) is the identity of [`Aabb::union`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box, so that growing it by a point gives that point.
    pub const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box of some points (empty for none).
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    /// This box grown to contain `p`.
    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// True when no point is inside (min > max on some axis).
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Centre point; cameras and default lights are placed relative to it.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Size along each axis.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Half the surface area, the quantity the SAH needs (0 for an empty box), in `f64`: the
    /// products of a box's sides overflow `f32` beyond about 10¹⁹ units.
    pub fn half_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.max.as_dvec3() - self.min.as_dvec3();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// True when `o` lies inside this box (closed).
    pub fn contains(&self, o: &Self) -> bool {
        o.min.cmpge(self.min).all() && o.max.cmple(self.max).all()
    }

    /// True when the boxes share at least one point (closed).
    pub fn overlaps(&self, o: &Self) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }
}
