//! Building with obvhs (PLOC, reinsertion, leaf collapse, optional spatial pre-splits) or by
//! binned SAH (`sah.rs`), then flattening depth-first into sibling pairs with triangles
//! gathered in leaf order.

use std::time::Instant;

use glam::Vec3A;
use obvhs::{
    BvhBuildParams,
    aabb::Aabb as OAabb,
    bvh2::Bvh2,
    bvh2::leaf_collapser::collapse,
    bvh2::reinsertion::ReinsertionOptimizer,
    ploc::{PlocBuilder, PlocSearchDistance},
    splits::split_aabbs_preset,
    triangle::Triangle,
};
use rayon::prelude::*;

use super::node::{BvhTriangle, Node, leaf_triangle};
use super::preset::BuildPreset;
use super::report::BuildReport;
use super::wide::WideBvh;
use super::{Bvh, MAX_DEPTH, bound, sah};
use crate::{Error, Result, Scene};

/// How many times over the triangles' boxes may cover the scene's box (their summed areas
/// over its area) before PLOC searches only its nearest neighbours: the shared scenes stay
/// below 10, a fanned polygon of n vertices reaches about n / 6.
const MAX_OVERLAP: f32 = 64.0;

fn v3a(p: glam::Vec3) -> Vec3A {
    Vec3A::new(p.x, p.y, p.z)
}

impl Bvh {
    /// Builds over the scene's non-degenerate triangles.
    ///
    /// The depth stays within [`MAX_DEPTH`], which any scene that fits in memory can keep.
    pub fn build(scene: &Scene, preset: BuildPreset) -> Result<Self> {
        Self::build_within(scene, preset, MAX_DEPTH)
    }

    /// [`Bvh::build`] with the depth bounded by `max_depth` instead of [`MAX_DEPTH`]: subtrees
    /// that would go deeper are rebuilt by object median (see [`super::bound`]).
    pub(crate) fn build_within(
        scene: &Scene,
        preset: BuildPreset,
        max_depth: usize,
    ) -> Result<Self> {
        let start = Instant::now();
        let mut bvh = Self::build_binary(scene, preset, max_depth, start)?;
        let collapsing = Instant::now();
        bvh.wide = WideBvh::collapse(&bvh.nodes, &bvh.tris);
        bvh.report.collapse_seconds = collapsing.elapsed().as_secs_f64();
        bvh.report.total_seconds = start.elapsed().as_secs_f64();
        Ok(bvh)
    }

    /// The binary tree; its wide tree is left empty.
    fn build_binary(
        scene: &Scene,
        preset: BuildPreset,
        max_depth: usize,
        start: Instant,
    ) -> Result<Self> {
        // obvhs wants dense indices 0..n into the primitives it is given, so it gets only the
        // non-degenerate triangles and `ids` maps its indices back to primitive ids.
        let ids: Vec<u32> = (0..scene.len() as u32)
            .into_par_iter()
            .filter(|&i| !scene.is_degenerate(i as usize))
            .collect();
        let degenerate_skipped = scene.len() - ids.len();
        if ids.is_empty() {
            return Err(crate::Error::NothingToTrace {
                name: scene.name.clone(),
                triangles: scene.len(),
            });
        }
        // In parallel, as the steps below that touch every triangle: their time, and that of
        // mapping their fresh pages, is shared by the threads.
        let tris: Vec<Triangle> = ids
            .par_iter()
            .map(|&i| {
                let [a, b, c] = scene.vertices(i as usize);
                Triangle {
                    v0: v3a(a),
                    v1: v3a(b),
                    v2: v3a(c),
                }
            })
            .collect();
        let mut indices: Vec<u32> = (0..ids.len() as u32).into_par_iter().collect();
        let mut aabbs: Vec<OAabb> = tris.par_iter().map(Triangle::aabb).collect();

        let preset = match preset {
            BuildPreset::Auto => {
                let mut areas: Vec<f32> = aabbs.iter().map(OAabb::half_area).collect();
                BuildPreset::for_areas(&mut areas)
            }
            p => p,
        };
        let mut params = preset.params();
        let mut report = BuildReport {
            preset,
            degenerate_skipped,
            spatial_splits: params.pre_split,
            ..Default::default()
        };
        if ids.is_empty() {
            // Nothing to hit: one empty leaf whose (inverted) box no ray enters.
            let empty = Node {
                min: [f32::MAX; 3],
                index: 0,
                max: [f32::MIN; 3],
                count: 0,
            };
            report.nodes = 1;
            report.total_seconds = start.elapsed().as_secs_f64();
            return Ok(Self {
                nodes: vec![empty].into(),
                tris: Vec::new(),
                depth: 1,
                report,
                wide: Default::default(),
            });
        }

        let core = Instant::now();
        if ids.len() == 1 {
            // obvhs stores a lone primitive's id in the root instead of an index into
            // `primitive_indices`; one leaf is all there is to build anyway.
            let prim = ids[0];
            let t = &tris[0];
            let b = t.aabb();
            report.build_seconds = core.elapsed().as_secs_f64();
            report.nodes = 1;
            report.leaves = 1;
            report.leaf_triangles = 1;
            report.sah_cost = 1.0;
            report.spatial_splits = false;
            report.total_seconds = start.elapsed().as_secs_f64();
            return Ok(Self {
                nodes: vec![Node {
                    min: b.min.to_array(),
                    index: 0,
                    max: b.max.to_array(),
                    count: 1,
                }]
                .into(),
                tris: vec![leaf_triangle(t, prim)],
                depth: 1,
                report,
                wide: Default::default(),
            });
        }
        let (mut largest, mut sum, mut scene_box) = (0f32, 0f32, OAabb::empty());
        for b in &aabbs {
            largest = largest.max(b.half_area());
            sum += b.half_area();
            scene_box = scene_box.union(b);
        }
        // PLOC merges only the nodes that pick each other. Where the boxes overlap many times
        // over (the slivers of a fanned polygon, stacked copies), few do in each pass, and a
        // search past the nearest neighbours takes time growing with n² (39 s for a polygon of
        // 10⁵ vertices) for a tree no better; reinsertion finds little to gain in it either.
        if sum > MAX_OVERLAP * scene_box.half_area() {
            params.ploc_search_distance = PlocSearchDistance::Minimum;
            params.reinsertion_batch_ratio = 0.0;
        }
        if params.pre_split {
            let avg = sum / aabbs.len() as f32;
            split_aabbs_preset(&mut aabbs, &mut indices, &tris, avg, largest);
        }
        let bvh2 = if preset == BuildPreset::Sah {
            sah::build(&aabbs, &indices)
        } else {
            Self::ploc(&aabbs, indices, &params)
        };
        report.build_seconds = core.elapsed().as_secs_f64();

        // Flatten depth-first; each inner node's children are allocated as an adjacent pair,
        // at an even index after the root and its pad (see `Node::PAD`).
        let src = &bvh2.nodes;
        let to_node = |n: &obvhs::bvh2::node::Bvh2Node, index: u32, count: u32| Node {
            min: n.aabb().min.to_array(),
            index,
            max: n.aabb().max.to_array(),
            count,
        };
        let mut nodes: Vec<Node> = Vec::with_capacity(src.len());
        // The leaves' triangles by reference (indices into `tris`) first: gathered in
        // parallel after the walk, which then does not wait on their scattered loads.
        let mut refs: Vec<u32> = Vec::with_capacity(aabbs.len());
        nodes.push(Node::default());
        nodes.push(Node::PAD);
        let shape = bound::Shape::of(&bvh2);
        let mut depth = 0usize;
        let mut stack: Vec<(usize, usize, usize)> = vec![(0, 0, 1)];
        while let Some((s, d, level)) = stack.pop() {
            depth = depth.max(level);
            let n = &src[s];
            if shape.rebuild_here(&bvh2, s, level, max_depth) {
                let mut prims = bound::gather(&bvh2, s);
                let mut out = bound::Out {
                    nodes: &mut nodes,
                    refs: &mut refs,
                };
                let below = bound::median(&mut prims, d, &tris, &mut out);
                depth = depth.max(level + below - 1);
            } else if n.is_leaf() {
                let first = refs.len() as u32;
                let range = n.first_index as usize..(n.first_index + n.prim_count) as usize;
                refs.extend_from_slice(&bvh2.primitive_indices[range]);
                nodes[d] = to_node(n, first, n.prim_count);
            } else {
                let l = nodes.len();
                nodes.push(Node::default());
                nodes.push(Node::default());
                nodes[d] = to_node(n, l as u32, 0);
                let c = n.first_index as usize;
                stack.push((c + 1, l + 1, level + 1));
                stack.push((c, l, level + 1));
            }
        }
        if depth > max_depth {
            return Err(Error::BvhTooDeep {
                depth,
                max: max_depth,
            });
        }

        let root_area = nodes[0].aabb().half_area().max(f64::MIN_POSITIVE);
        let mut sah = 0.0f64;
        for n in nodes.iter().filter(|n| **n != Node::PAD) {
            let a = n.aabb().half_area();
            sah += if n.is_leaf() { a * n.count as f64 } else { a };
            report.leaves += n.is_leaf() as usize;
        }
        report.sah_cost = sah / root_area;
        report.nodes = nodes.len() - 1;
        let out_tris: Vec<BvhTriangle> = refs
            .par_iter()
            .map(|&p| leaf_triangle(&tris[p as usize], ids[p as usize]))
            .collect();
        report.leaf_triangles = out_tris.len();
        report.total_seconds = start.elapsed().as_secs_f64();
        Ok(Self {
            nodes: nodes.into(),
            tris: out_tris,
            depth,
            report,
            wide: Default::default(),
        })
    }

    /// obvhs's PLOC build over `aabbs`, then its reinsertion and leaf collapse.
    fn ploc(aabbs: &[OAabb], indices: Vec<u32>, params: &BvhBuildParams) -> Bvh2 {
        let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
            params.ploc_search_distance,
            aabbs,
            indices,
            params.sort_precision,
            params.search_depth_threshold,
        );
        bvh2.uses_spatial_splits = params.pre_split;
        let mut reinsertion = ReinsertionOptimizer::default();
        reinsertion.run(&mut bvh2, params.reinsertion_batch_ratio, None);
        collapse(
            &mut bvh2,
            params.max_prims_per_leaf.clamp(1, 255),
            params.collapse_traversal_cost,
        );
        reinsertion.run(
            &mut bvh2,
            params.reinsertion_batch_ratio
                * params.post_collapse_reinsertion_batch_ratio_multiplier,
            None,
        );
        bvh2
    }
}
