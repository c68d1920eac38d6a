// What both trace kernels (`traverse.wgsl` on the binary tree, `traverse_wide.wgsl` on the
// compressed 8-wide one) share, put by the host between `ray.wgsl` and the kernel: their
// constants, bindings (but the tree's nodes), the conservative slab test, the stack's pop and
// the persistent threads that take batches of rays from the queue.

// 0: closest hit, 1: any hit, 2: reduced traversal (counts B and T), 3: the first-leaf
// reduced traversal (`Walk::FirstLeaf`: counts B and T, each ray ending at the exit of the
// first leaf it reaches, children in `near_child_first` order).
override MODE: u32 = 0u;
// Batches of 64 rays a workgroup takes per dispatch.
override BATCHES: u32 = 8u;
// Ize's far-distance scale, passed by the host.
override FAR_SCALE: f32 = 1.0;
// `cull_bound`'s factor, 16 gamma(3), passed by the host.
override CULL: f32 = 0.0;

// Traversal stack entries; the host replaces this line with the tree's need (>= depth - 1).
const STACK: u32 = 64u;
const LANES: u32 = 64u;

struct Tri {
    v0: vec3<f32>,
    prim: u32,
    v1: vec3<f32>,
    pad1: u32,
    v2: vec3<f32>,
    pad2: u32,
}

struct Params {
    // Rays in this launch.
    count: u32,
    // With `counted`: rays per path (ray `r` belongs to path `r / per_path`).
    per_path: u32,
    // Nonzero: add each ray's counts B and T (closest and any hit included) to its path's
    // entry of `path_counts`.
    counted: u32,
    pad: u32,
}

// `queue[0]`: the queue head; `queue[1]`: nonzero when a traversal loop was cut short. Each
// kernel binds its tree's nodes at binding 0.
@group(0) @binding(1) var<storage, read> tris: array<Tri>;
@group(0) @binding(2) var<storage, read> rays: array<GpuRay>;
@group(0) @binding(3) var<storage, read_write> out: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> queue: array<atomic<u32>, 2>;
@group(0) @binding(5) var<uniform> params: Params;
// Per path: B and T summed over its rays (with `params.counted`).
@group(0) @binding(6) var<storage, read_write> path_counts: array<atomic<u32>>;

var<workgroup> wg_base: u32;

fn inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn is_finite3(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

// `max` that keeps `acc` when `x` is NaN (slab.rs `max_keep`).
fn max_keep(acc: f32, x: f32) -> f32 {
    return select(acc, x, x > acc);
}

fn min_keep(acc: f32, x: f32) -> f32 {
    return select(acc, x, x < acc);
}

struct BoxRay {
    org: vec3<f32>,
    inv: vec3<f32>,
    // True where the direction's sign bit is set (the near plane is the box's max).
    neg: vec3<bool>,
}

// Ray `r` as both kernels start its walk: its origin and range, its shear and box test, and
// whether it can hit anything at all (the CPU's early outs: a zero or non-finite direction, a
// non-finite origin, an empty or NaN range).
struct Walk {
    o: vec3<f32>,
    tmin: f32,
    tmax: f32,
    sh: Shear,
    bray: BoxRay,
    valid: bool,
}

fn walk_of(r: u32) -> Walk {
    let ray = rays[r];
    let o = ray.org.xyz;
    let d = ray.dir.xyz;
    let tmin = ray.org.w;
    let tmax = ray.dir.w;
    let sh = shear(d);
    let valid = is_finite3(o) && is_finite3(d) && d[sh.k.z] != 0.0 && tmin <= tmax;
    let neg = (bitcast<vec3<u32>>(d) & vec3<u32>(0x80000000u)) != vec3<u32>(0u);
    return Walk(o, tmin, tmax, sh, BoxRay(o, vec3<f32>(1.0) / d, neg), valid);
}

// How far past the nearest hit so far nodes are still entered (traverse.rs `cull_bound`).
fn cull_bound(t: f32) -> f32 {
    return t + abs(t) * CULL;
}

// Entry distance in `.x`, and `.y > 0` when the ray meets the box `lo`..`hi` within
// [tmin, tmax].
fn box_hit(b: BoxRay, lo: vec3<f32>, hi: vec3<f32>, tmin: f32, tmax: f32) -> vec2<f32> {
    let near = select(lo, hi, b.neg);
    let t_near = (near - b.org) * b.inv;
    let t0 = max_keep(max_keep(max_keep(tmin, t_near.x), t_near.y), t_near.z);
    let t1 = box_exit(b, lo, hi, tmax);
    return vec2<f32>(t0, select(0.0, 1.0, t0 <= t1));
}

// Where the ray leaves the box, clipped to `tmax` (slab.rs `BoxRay::exit`).
fn box_exit(b: BoxRay, lo: vec3<f32>, hi: vec3<f32>, tmax: f32) -> f32 {
    let far = select(hi, lo, b.neg);
    let t_far = (far - b.org) * b.inv;
    let t1 = min_keep(min_keep(min_keep(inf(), t_far.x), t_far.y), t_far.z) * FAR_SCALE;
    return select(tmax, t1, t1 < tmax);
}

// Pops the nearest node left on the stack (`sp` entries of node and entry distance), skipping
// those whose entry is beyond `best_t` (a nearer hit was found since they were pushed); MISS
// when none is left.
fn pop(
    stack_node: ptr<function, array<u32, STACK>>,
    stack_t: ptr<function, array<f32, STACK>>,
    sp: ptr<function, u32>,
    best_t: f32,
) -> u32 {
    var next = MISS;
    loop {
        if *sp == 0u {
            break;
        }
        *sp -= 1u;
        if (*stack_t)[*sp] <= best_t {
            next = (*stack_node)[*sp];
            break;
        }
    }
    return next;
}

// Writes ray `r`'s result: (t bits, prim) for hits, (B, T) for the counting modes, and adds
// its counts to its path's with `params.counted`; `done` false flags a walk cut short.
fn finish(r: u32, done: bool, count_b: u32, count_t: u32, best_prim: u32, hit_t: f32) {
    if !done {
        // Only reachable when the implementation cut the loop short (see `traverse.wgsl`).
        atomicOr(&queue[1], 1u);
    }
    if params.counted != 0u {
        let p = 2u * (r / params.per_path);
        atomicAdd(&path_counts[p], count_b);
        atomicAdd(&path_counts[p + 1u], count_t);
    }
    if MODE >= 2u {
        out[r] = vec2<u32>(count_b, count_t);
    } else if best_prim == MISS {
        out[r] = vec2<u32>(bitcast<u32>(inf()), MISS);
    } else {
        out[r] = vec2<u32>(bitcast<u32>(hit_t), best_prim);
    }
}

@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) lid: u32) {
    for (var batch = 0u; batch < BATCHES; batch++) {
        if lid == 0u {
            wg_base = atomicAdd(&queue[0], LANES);
        }
        let base = workgroupUniformLoad(&wg_base);
        if base >= params.count {
            break;
        }
        let r = base + lid;
        if r < params.count {
            trace(r);
        }
        // Nobody may still read `wg_base` when invocation 0 overwrites it.
        workgroupBarrier();
    }
}
