/// Point counts on a uniform grid over the cloud's bounding box, with a summed-volume table
/// so the count of any box of cells takes eight look-ups.
#[derive(Debug, Clone)]
pub struct DensityGrid {
    lo: [f32; 3],
    cell: [f32; 3],
    side: usize,
    counts: Vec<u32>,
    // (side+1)^3 prefix sums; index 0 on any axis is the empty prefix.
    sat: Vec<u64>,
}

impl DensityGrid {
    /// A grid of `side`³ cells (at least 1) over `points`.
    pub fn new(points: &[[f32; 3]], side: usize) -> Self {
        let side = side.max(1);
        let (lo, hi) = sched::locality::bounds(points);
        let cell = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / side as f32).max(f32::MIN_POSITIVE));
        let mut grid = DensityGrid {
            lo,
            cell,
            side,
            counts: vec![0; side * side * side],
            sat: vec![0; (side + 1).pow(3)],
        };
        for p in points {
            let c = grid.cell_of(p);
            grid.counts[(c[2] * side + c[1]) * side + c[0]] += 1;
        }
        let s1 = side + 1;
        for z in 1..=side {
            for y in 1..=side {
                for x in 1..=side {
                    let at = |x: usize, y: usize, z: usize| (z * s1 + y) * s1 + x;
                    let own = u64::from(grid.counts[((z - 1) * side + y - 1) * side + x - 1]);
                    grid.sat[at(x, y, z)] = own
                        + grid.sat[at(x - 1, y, z)]
                        + grid.sat[at(x, y - 1, z)]
                        + grid.sat[at(x, y, z - 1)]
                        - grid.sat[at(x - 1, y - 1, z)]
                        - grid.sat[at(x - 1, y, z - 1)]
                        - grid.sat[at(x, y - 1, z - 1)]
                        + grid.sat[at(x - 1, y - 1, z - 1)];
                }
            }
        }
        grid
    }

    /// Cells per axis.
    pub fn side(&self) -> usize {
        self.side
    }

    /// The cell holding `p`, clamped to the grid.
    pub fn cell_of(&self, p: &[f32; 3]) -> [usize; 3] {
        [0, 1, 2].map(|a| {
            let f = ((p[a] - self.lo[a]) / self.cell[a]).floor();
            (f.max(0.0) as usize).min(self.side - 1)
        })
    }

    /// Points in the cells `lo..=hi` (inclusive, already clamped).
    pub fn count(&self, lo: [usize; 3], hi: [usize; 3]) -> u64 {
        let s1 = self.side + 1;
        let at = |x: usize, y: usize, z: usize| self.sat[(z * s1 + y) * s1 + x];
        let (x0, y0, z0) = (lo[0], lo[1], lo[2]);
        let (x1, y1, z1) = (hi[0] + 1, hi[1] + 1, hi[2] + 1);
        at(x1, y1, z1) + at(x0, y0, z1) + at(x0, y1, z0) + at(x1, y0, z0)
            - at(x0, y1, z1)
            - at(x1, y0, z1)
            - at(x1, y1, z0)
            - at(x0, y0, z0)
    }

    /// Points expected in the axis-aligned cube of half-width `r` around `q`, assuming each
    /// cell's points are spread evenly over it: few cells are summed with their overlap
    /// fraction, many are counted whole through the table.
    pub fn points_in_cube(&self, q: &[f32; 3], r: f32) -> f64 {
        let lo = self.cell_of(&q.map(|x| x - r));
        let hi = self.cell_of(&q.map(|x| x + r));
        let cells: usize = (0..3).map(|a| hi[a] - lo[a] + 1).product();
        if cells > 64 {
            return self.count(lo, hi) as f64;
        }
        let overlap = |a: usize, i: usize| {
            let c0 = self.lo[a] + i as f32 * self.cell[a];
            let (a0, a1) = ((q[a] - r).max(c0), (q[a] + r).min(c0 + self.cell[a]));
            f64::from(((a1 - a0) / self.cell[a]).clamp(0.0, 1.0))
        };
        let mut total = 0.0;
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let n = self.counts[(z * self.side + y) * self.side + x];
                    if n > 0 {
                        total += f64::from(n) * overlap(0, x) * overlap(1, y) * overlap(2, z);
                    }
                }
            }
        }
        total
    }

    /// Half-width of the cube around `q` expected to hold `k` points. A cube of whole cells
    /// is grown until it holds `k` (eight look-ups a step), then the half-width is refined
    /// by bisection with the cells' overlap fractions: next to a dense cluster that is the
    /// distance to the cluster's edge, inside one it is far below a cell.
    pub fn knn_half_width(&self, q: &[f32; 3], k: usize) -> f32 {
        let c = self.cell_of(q);
        let h = self.cell.iter().copied().fold(0.0, f32::max);
        let mut w = 0;
        loop {
            let lo = c.map(|x| x.saturating_sub(w));
            let hi = c.map(|x| (x + w).min(self.side - 1));
            let whole = lo == [0; 3] && hi == [self.side - 1; 3];
            if self.count(lo, hi) >= k as u64 || whole {
                break;
            }
            w += 1;
        }
        // The cube of cells c±w holds k, so a cube of half-width (w+1)·h around q does too.
        let (mut a, mut b) = (0.0f32, (w + 1) as f32 * h);
        for _ in 0..12 {
            let m = 0.5 * (a + b);
            if self.points_in_cube(q, m) >= k as f64 {
                b = m;
            } else {
                a = m;
            }
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_counts_match_a_scan() {
        let cloud = crate::PointCloud::clustered(5000, crate::Clustered::default(), 3);
        let grid = DensityGrid::new(&cloud.points, 8);
        assert_eq!(grid.count([0; 3], [7; 3]), 5000);
        let (lo, hi) = ([1, 2, 3], [4, 6, 5]);
        let scan = cloud
            .points
            .iter()
            .filter(|p| {
                let c = grid.cell_of(p);
                (0..3).all(|a| (lo[a]..=hi[a]).contains(&c[a]))
            })
            .count();
        assert_eq!(grid.count(lo, hi), scan as u64);
    }
}
