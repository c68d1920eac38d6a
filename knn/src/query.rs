use std::num::NonZero;

use kiddo::{ImmutableKdTree, SquaredEuclidean};

use crate::KnnError;

/// The k-d tree over a point cloud: built once, queried by every device (it is `Sync`).
pub struct KnnIndex {
    tree: ImmutableKdTree<f32, 3>,
    points: Vec<[f32; 3]>,
}

impl std::fmt::Debug for KnnIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KnnIndex")
            .field("points", &self.points.len())
            .finish_non_exhaustive()
    }
}

impl KnnIndex {
    /// Builds kiddo's immutable tree (Eytzinger stems, 32-point leaves) over `points`.
    pub fn build(points: Vec<[f32; 3]>) -> Result<Self, KnnError> {
        check_finite(&points)?;
        let tree =
            ImmutableKdTree::new_from_slice(&points).map_err(|e| KnnError::Tree(e.to_string()))?;
        Ok(KnnIndex { tree, points })
    }

    /// The indexed points.
    pub fn points(&self) -> &[[f32; 3]] {
        &self.points
    }

    /// Appends the indices of the `k` points nearest `q` to `out`, nearest first.
    pub fn nearest(&self, q: &[f32; 3], k: NonZero<usize>, out: &mut Vec<u32>) {
        let found = self
            .tree
            .query(q)
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .execute();
        out.extend(found.iter().map(|r| r.item));
    }
}

/// A batch of kNN queries, sorted along the Z curve so that a range of them (a task) is a
/// compact region of space whose queries share tree nodes ([`sched::locality`]).
#[derive(Debug, Clone)]
pub struct KnnQueries {
    /// The queries in Morton order.
    pub points: Vec<[f32; 3]>,
    /// `order[i]` is the input index of `points[i]`.
    pub order: Vec<u32>,
    /// Neighbours per query.
    pub k: NonZero<usize>,
}

impl KnnQueries {
    /// Sorts `queries` spatially; checks `k` against the cloud it will run on.
    pub fn new(queries: Vec<[f32; 3]>, k: usize, index: &KnnIndex) -> Result<Self, KnnError> {
        let points = index.points().len();
        let k = NonZero::new(k)
            .filter(|k| k.get() <= points)
            .ok_or(KnnError::BadK { k, points })?;
        check_finite(&queries)?;
        let order = sched::locality::morton_order(&queries);
        Ok(KnnQueries {
            points: order.iter().map(|&i| queries[i as usize]).collect(),
            order,
            k,
        })
    }

    /// Number of queries.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no queries.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Puts the outputs of tasks covering the batch in order (`k` indices per query, in
    /// the sorted order) back into input order: `k` neighbours per input query.
    pub fn gather(&self, outputs: &[Vec<u32>]) -> Vec<u32> {
        let k = self.k.get();
        let mut result = vec![0; self.len() * k];
        let flat: Vec<u32> = outputs.iter().flatten().copied().collect();
        for (sorted, ids) in flat.chunks(k).enumerate() {
            let input = self.order[sorted] as usize;
            result[input * k..(input + 1) * k].copy_from_slice(ids);
        }
        result
    }
}

fn check_finite(points: &[[f32; 3]]) -> Result<(), KnnError> {
    match points.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        Some(index) => Err(KnnError::NonFinite {
            index,
            point: points[index],
        }),
        None => Ok(()),
    }
}
