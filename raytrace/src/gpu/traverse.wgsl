// Closest-hit, any-hit and reduced traversal of cobalt's flat BVH, mirroring
// `raytrace/src/traverse.rs`, `slab.rs` and `triangle.rs` operation for operation so that the
// GPU finds the same hits as the CPU:
// - stack-based, near child first (children tested as a pair, ties `a <= b` go left), popped
//   nodes skipped when their entry distance is beyond the nearest hit;
// - Ize's conservative slab test: far distance times `FAR_SCALE` (1 + 2 gamma(3), from the
//   host so it is the CPU's float bit for bit), NaN slabs ignored;
// - the watertight test of Woop, Benthin and Wald in f32 only (`ray.wgsl`, which the host puts
//   in front of this file with `traverse_common.wgsl`): where the CPU re-evaluates an edge
//   function that is exactly 0 in f64, this kernel keeps the f32 value, so rays through a
//   shared edge or vertex may pick the other triangle of the pair (same distance);
// - the hit queries test triangles against the ray's own range and keep the nearer hit, the
//   smaller primitive id on a tie (`better`), and enter nodes up to `cull_bound` of it, so
//   that the hit and the counts do not depend on the walk's order.
//
// Persistent threads (`main`, in `traverse_common.wgsl`): each workgroup of 64 invocations
// takes batches of 64 rays from a global queue head (`atomicAdd`), at most `BATCHES` per
// dispatch; the host re-dispatches until the queue is drained (Debian 12's lavapipe silently
// ends loops after ~65 535 iterations of one invocation, so no invocation may loop for long).

struct Node {
    min: vec3<f32>,
    index: u32,
    max: vec3<f32>,
    count: u32,
}

@group(0) @binding(0) var<storage, read> nodes: array<Node>;

// traverse.rs `near_child_first`: true when the first-leaf walk enters the left child first.
fn near_child_first(l: Node, r: Node, neg: vec3<bool>) -> bool {
    let g = (r.min + r.max) - (l.min + l.max);
    let a = abs(g);
    var axis = 2u;
    if a.x >= a.y {
        if a.x >= a.z {
            axis = 0u;
        }
    } else if a.y >= a.z {
        axis = 1u;
    }
    return (g[axis] >= 0.0) != neg[axis];
}

// Traces ray `r` and writes its result: (t bits, prim) for hits, (B, T) for MODEs 2 and 3;
// B counts the nodes entered, T the triangles tested (up to the first hit for any hit), as
// `traverse.rs` counts them.
fn trace(r: u32) {
    let w = walk_of(r);
    // Boxes are entered up to `best_t`: the range's end for the reduced traversals, and
    // `cull_bound` of the nearest hit so far (`hit_t`) for the hit queries.
    var best_t = select(cull_bound(w.tmax), w.tmax, MODE >= 2u);
    var hit_t = w.tmax;
    var best_prim = MISS;
    var count_b = 0u;
    var count_t = 0u;
    var done = true;

    // The same early outs as the CPU (`walk_of`), and a missed root (the host never launches
    // on a tree without triangles).
    if w.valid && box_hit(w.bray, nodes[0].min, nodes[0].max, w.tmin, best_t).y > 0.0 {
        var stack_node: array<u32, STACK>;
        var stack_t: array<f32, STACK>;
        var sp = 0u;
        var i = 0u;
        done = false;
        loop {
            let node = nodes[i];
            count_b += 1u;
            var descend = false;
            if node.count > 0u {
                if MODE >= 2u {
                    count_t += node.count;
                    if MODE == 3u {
                        best_t = box_exit(w.bray, node.min, node.max, best_t);
                    }
                } else {
                    var found = false;
                    for (var k = node.index; k < node.index + node.count; k++) {
                        count_t += 1u;
                        let tri = tris[k];
                        let h = watertight(w.sh, w.o, tri.v0, tri.v1, tri.v2, w.tmin, w.tmax);
                        let nearer = h.x < hit_t || (h.x == hit_t && tri.prim < best_prim);
                        if h.w > 0.0 && (best_prim == MISS || nearer) {
                            hit_t = h.x;
                            best_t = cull_bound(h.x);
                            best_prim = tri.prim;
                            if MODE == 1u {
                                found = true;
                                break;
                            }
                        }
                    }
                    if found {
                        done = true;
                        break;
                    }
                }
            } else {
                let l = node.index;
                let a = box_hit(w.bray, nodes[l].min, nodes[l].max, w.tmin, best_t);
                let b = box_hit(w.bray, nodes[l + 1u].min, nodes[l + 1u].max, w.tmin, best_t);
                if a.y > 0.0 && b.y > 0.0 {
                    var left = a.x <= b.x;
                    if MODE == 3u {
                        left = near_child_first(nodes[l], nodes[l + 1u], w.bray.neg);
                    }
                    if left {
                        stack_node[sp] = l + 1u;
                        stack_t[sp] = b.x;
                        i = l;
                    } else {
                        stack_node[sp] = l;
                        stack_t[sp] = a.x;
                        i = l + 1u;
                    }
                    sp += 1u;
                    descend = true;
                } else if a.y > 0.0 {
                    i = l;
                    descend = true;
                } else if b.y > 0.0 {
                    i = l + 1u;
                    descend = true;
                }
            }
            if !descend {
                i = pop(&stack_node, &stack_t, &sp, best_t);
                if i == MISS {
                    done = true;
                    break;
                }
            }
        }
    }
    finish(r, done, count_b, count_t, best_prim, hit_t);
}
