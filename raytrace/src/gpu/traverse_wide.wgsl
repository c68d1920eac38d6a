// Closest-hit, any-hit and reduced traversal of the compressed 8-wide tree (`wide.rs`), with
// the binary kernel's rules (`traverse.wgsl`): the same conservative slab test and watertight
// triangle test, the same `better` hit and `cull_bound`, so the hits do not depend on the tree
// walked. A node is one 80-byte fetch: each used slot's box is decoded as `origin + q * scale`
// in f32, which the host made contain the child's true box, so every box a ray enters in the
// binary tree is entered here too. A leaf slot's triangles are tested when its box is entered;
// the inner children entered go on the stack nearest last, so they are popped nearest first.
//
// Persistent threads as in `traverse.wgsl` (`traverse_common.wgsl`); MODE 3 (the first-leaf
// walk) is not offered on this tree (the host refuses it) and runs as MODE 2.

// `CompressedNode` in `wide.rs`.
struct CNode {
    origin: vec3<f32>,
    exp: u32,
    child: u32,
    tri: u32,
    kinds: vec2<u32>,
    lo: array<u32, 6>,
    hi: array<u32, 6>,
}

@group(0) @binding(0) var<storage, read> nodes: array<CNode>;

// The bytes of four slots as floats.
fn bytes4(w: u32) -> vec4<f32> {
    return vec4<f32>(unpack4xU8(w));
}

// Traces ray `r` and writes its result: (t bits, prim) for hits, (B, T) for MODE 2; B counts
// the wide nodes fetched, T the triangles tested.
fn trace(r: u32) {
    let w = walk_of(r);
    var best_t = select(cull_bound(w.tmax), w.tmax, MODE >= 2u);
    var hit_t = w.tmax;
    var best_prim = MISS;
    var count_b = 0u;
    var count_t = 0u;
    var done = true;

    if w.valid {
        var stack_node: array<u32, STACK>;
        var stack_t: array<f32, STACK>;
        var sp = 0u;
        var i = 0u;
        done = false;
        loop {
            let node = nodes[i];
            count_b += 1u;
            let scale = vec3<f32>(
                bitcast<f32>((node.exp & 0xffu) << 23u),
                bitcast<f32>(((node.exp >> 8u) & 0xffu) << 23u),
                bitcast<f32>(((node.exp >> 16u) & 0xffu) << 23u),
            );
            // Every slot's kind and planes unpacked once (constant indices: an array indexed by
            // a variable would be copied at each use).
            let kinds = array<vec4<u32>, 2>(unpack4xU8(node.kinds.x), unpack4xU8(node.kinds.y));
            let lo_q = array<vec4<f32>, 6>(
                bytes4(node.lo[0]), bytes4(node.lo[1]), bytes4(node.lo[2]),
                bytes4(node.lo[3]), bytes4(node.lo[4]), bytes4(node.lo[5]),
            );
            let hi_q = array<vec4<f32>, 6>(
                bytes4(node.hi[0]), bytes4(node.hi[1]), bytes4(node.hi[2]),
                bytes4(node.hi[3]), bytes4(node.hi[4]), bytes4(node.hi[5]),
            );
            var inner = node.child;
            var first = node.tri;
            let base = sp;
            var found = false;
            for (var k = 0u; k < 8u; k++) {
                let upper = k >= 4u;
                let j = k % 4u;
                let m = select(kinds[0], kinds[1], upper)[j];
                if m == 0u {
                    continue;
                }
                let lq = vec3<f32>(select(lo_q[0], lo_q[1], upper)[j], select(lo_q[2], lo_q[3], upper)[j], select(lo_q[4], lo_q[5], upper)[j]);
                let hq = vec3<f32>(select(hi_q[0], hi_q[1], upper)[j], select(hi_q[2], hi_q[3], upper)[j], select(hi_q[4], hi_q[5], upper)[j]);
                let lo = node.origin + lq * scale;
                let hi = node.origin + hq * scale;
                let h = box_hit(w.bray, lo, hi, w.tmin, best_t);
                if m == 0xffu {
                    if h.y > 0.0 {
                        // Insert by entry distance, farthest lowest.
                        var j = sp;
                        while j > base && stack_t[j - 1u] < h.x {
                            stack_node[j] = stack_node[j - 1u];
                            stack_t[j] = stack_t[j - 1u];
                            j -= 1u;
                        }
                        stack_node[j] = inner;
                        stack_t[j] = h.x;
                        sp += 1u;
                    }
                    inner += 1u;
                    continue;
                }
                if h.y > 0.0 {
                    if MODE >= 2u {
                        count_t += m;
                    } else {
                        for (var t = first; t < first + m; t++) {
                            count_t += 1u;
                            let tri = tris[t];
                            let q = watertight(w.sh, w.o, tri.v0, tri.v1, tri.v2, w.tmin, w.tmax);
                            let nearer = q.x < hit_t || (q.x == hit_t && tri.prim < best_prim);
                            if q.w > 0.0 && (best_prim == MISS || nearer) {
                                hit_t = q.x;
                                best_t = cull_bound(q.x);
                                best_prim = tri.prim;
                                if MODE == 1u {
                                    found = true;
                                    break;
                                }
                            }
                        }
                        if found {
                            break;
                        }
                    }
                }
                first += m;
            }
            if found {
                done = true;
                break;
            }
            i = pop(&stack_node, &stack_t, &sp, best_t);
            if i == MISS {
                done = true;
                break;
            }
        }
    }
    finish(r, done, count_b, count_t, best_prim, hit_t);
}
