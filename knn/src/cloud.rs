use sched::Rng;

/// Points in 3D: generated ([`PointCloud::clustered`], [`PointCloud::uniform`]) or the
/// caller's own, such as a mesh's vertices (`PointCloud { points }`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointCloud {
    /// The points, in no particular order.
    pub points: Vec<[f32; 3]>,
}

/// A mixture of tight Gaussian clusters in sparse uniform noise, inside the unit cube: the
/// density varies by orders of magnitude, so some queries cost far more than others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clustered {
    /// Number of clusters.
    pub clusters: usize,
    /// Share of the points that are uniform noise, in `[0, 1]`.
    pub noise: f32,
    /// Standard deviation of the widest cluster; each cluster's is drawn log-uniformly down
    /// to a tenth of it.
    pub sigma: f32,
}

impl Default for Clustered {
    fn default() -> Self {
        Clustered {
            clusters: 12,
            noise: 0.1,
            sigma: 0.03,
        }
    }
}

impl PointCloud {
    /// `n` points from the mixture `spec`, reproducible from `seed`.
    pub fn clustered(n: usize, spec: Clustered, seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let centres: Vec<([f32; 3], f32)> = (0..spec.clusters.max(1))
            .map(|_| {
                let c = [0.0; 3].map(|_: f32| 0.15 + 0.7 * rng.f32());
                (c, spec.sigma * 10f32.powf(-rng.f32()))
            })
            .collect();
        let points = (0..n)
            .map(|_| {
                if spec.clusters == 0 || rng.f32() < spec.noise {
                    [0.0; 3].map(|_: f32| rng.f32())
                } else {
                    let (c, s) = centres[rng.below(centres.len() as u32) as usize];
                    c.map(|x| (x + s * rng.normal()).clamp(0.0, 1.0))
                }
            })
            .collect();
        PointCloud { points }
    }

    /// `n` points uniform in the unit cube.
    pub fn uniform(n: usize, seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        PointCloud {
            points: (0..n).map(|_| [0.0; 3].map(|_: f32| rng.f32())).collect(),
        }
    }

    /// `n` query points: half jittered copies of cloud points (queries where the data is),
    /// half uniform in the cloud's bounding box (queries in the sparse space between
    /// clusters, whose neighbours are far and costly to find).
    pub fn queries(&self, n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut rng = Rng::new(seed ^ 0x5151_5151);
        let (lo, hi) = sched::locality::bounds(&self.points);
        let jitter = 1e-3 * (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f32::max);
        (0..n)
            .map(|i| {
                if i % 2 == 0 && !self.points.is_empty() {
                    let p = self.points[rng.below(self.points.len() as u32) as usize];
                    p.map(|x| x + jitter * rng.normal())
                } else {
                    [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * rng.f32())
                }
            })
            .collect()
    }
}
