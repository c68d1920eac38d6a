// The kernels of a GPU device's launch of ambient-occlusion paths: primary rays made on the
// device for the launch's tasks (ranges of paths in the image's Morton order), AO probes
// with the CPU's Halton points and per-path scrambling, and each path's value, every stage
// a kernel over buffers that stay on the device (the traces between them are the trace
// kernels', `traverse_wide.wgsl` on the compressed wide tree). A launch's paths sit in slots,
// task after task. The host puts `shading.wgsl` in front. Every function mirrors its CPU
// counterpart operation for operation, in f32:
// - `raygen`: `Camera::primary_rays_of` and `camera::morton_pixel`;
// - `shade_ao`: `ao::ao_rays` (re-intersection, `Scene::surface_point`, `spawn.rs`'s offset,
//   `Rng`'s SplitMix64 in pairs of u32, `cosine_hemisphere`, glam's `any_orthonormal_pair`);
// - `accumulate`: `shade::ao::render`'s fraction of open probes.
// Where results may differ from the CPU: `cos`/`sin` (WGSL does not require correct
// rounding; Rust calls the C library's), and an edge function that is exactly 0, which the
// CPU re-evaluates in f64 (as in the trace kernels).

struct Params {
    // Camera: eye, and the frame `Camera::ray` builds (forward, right, up), `.w` unused.
    eye: vec4<f32>,
    fwd: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // Half extents of the image plane `w`, `h`; probe length; gamma(8).
    plane_w: f32,
    plane_h: f32,
    max_distance: f32,
    gamma8: f32,
    width: u32,
    height: u32,
    // Probes per primary hit.
    samples: u32,
    // First primary ray of this chunk (shade and accumulate).
    base: u32,
    // The AO seed's low and high words.
    seed_lo: u32,
    seed_hi: u32,
    // Paths between a task's slots: 1 to render, the sample's stride to estimate.
    stride: u32,
    pad1: u32,
    // The launch's counts, copied in on the device from its header. Slots of the launch: one
    // path each.
    count: u32,
    // Primaries of this chunk (shade and accumulate).
    chunk: u32,
    // Tasks of the launch (entries of `tasks`).
    tasks: u32,
    pad2: u32,
}


@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> primary: array<GpuRay>;
// Per slot: the rank of its path.
@group(0) @binding(2) var<storage, read_write> ranks: array<u32>;
@group(0) @binding(3) var<storage, read> hits: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> scene_tris: array<SceneTri>;
@group(0) @binding(5) var<storage, read_write> probes: array<GpuRay>;
@group(0) @binding(6) var<storage, read> probe_hits: array<vec2<u32>>;
// Per slot: the path's grey value.
@group(0) @binding(7) var<storage, read_write> film: array<f32>;
// Per task of the launch: its first path's rank, and its first slot (slot `s` of the task's
// slots holds its path `s * stride`).
@group(0) @binding(8) var<storage, read> tasks: array<vec2<u32>>;

// ---- raygen ----

// The even bits of `k`, packed (`camera.rs`'s `compact`).
fn compact(k: u32) -> u32 {
    var x = k & 0x55555555u;
    x = (x | (x >> 1u)) & 0x33333333u;
    x = (x | (x >> 2u)) & 0x0f0f0f0fu;
    x = (x | (x >> 4u)) & 0x00ff00ffu;
    return (x | (x >> 8u)) & 0x0000ffffu;
}

// The pixel at Morton rank `rank` (`camera.rs`'s `morton_pixel`): from the smallest aligned
// block of the Z-curve holding the image down, the half of a block with its top free bit
// clear holds a rectangle of the image's pixels, and a rank past them lies in the other half;
// a block inside the image ends the walk.
fn morton_pixel(rank_in: u32) -> u32 {
    var rank = rank_in;
    var x0 = 0u;
    var y0 = 0u;
    // Free key bits below the block: those of the smallest power-of-two square holding the
    // image, then one fewer at each step.
    let m = max(params.width, params.height);
    var free = select(2u * (32u - countLeadingZeros(m - 1u)), 0u, m <= 1u);
    for (var i = 0u; i <= 32u; i++) {
        if x0 + (1u << ((free + 1u) / 2u)) <= params.width && y0 + (1u << (free / 2u)) <= params.height {
            // A block inside the image: its Z order is the rank's own bits.
            return (y0 + compact(rank >> 1u)) * params.width + x0 + compact(rank);
        }
        free -= 1u;
        let cx = select(0u, min(params.width - x0, 1u << ((free + 1u) / 2u)), x0 < params.width);
        let cy = select(0u, min(params.height - y0, 1u << (free / 2u)), y0 < params.height);
        // At most 2^32 - 1 pixels are inside: the image is checked on the host.
        let inside = cx * cy;
        if rank >= inside {
            rank -= inside;
            if free % 2u == 0u {
                x0 |= 1u << (free / 2u);
            } else {
                y0 |= 1u << (free / 2u);
            }
        }
    }
    return y0 * params.width + x0;
}

// The launch's slot `s` belongs to the last task whose first slot is at most `s`.
fn task_of(s: u32) -> u32 {
    var lo = 0u;
    var hi = params.tasks;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if tasks[mid].y <= s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Slot `s` of the launch: the primary ray of its path (`Camera::primary_rays_of`), and the
// path's rank (its index in the image's Morton order), which seeds its AO probes.
@compute @workgroup_size(64)
fn raygen(inv: Invocation) {
    let s = flat(inv);
    if s >= params.count {
        return;
    }
    let task = tasks[task_of(s)];
    let rank = task.x + (s - task.y) * params.stride;
    let p = morton_pixel(rank);
    let x = p % params.width;
    let y = p / params.width;
    let fw = f32(params.width);
    let fh = f32(params.height);
    let px = (((f32(x) + 0.5) / fw) * 2.0 - 1.0) * params.plane_w;
    let py = (1.0 - ((f32(y) + 0.5) / fh) * 2.0) * params.plane_h;
    let d = (params.fwd.xyz + px * params.right.xyz) + py * params.up.xyz;
    let dir = d * (1.0 / sqrt(dot3(d, d)));
    primary[s] = GpuRay(vec4<f32>(params.eye.xyz, 0.0), vec4<f32>(dir, bitcast<f32>(0x7f800000u)));
    ranks[s] = rank;
}

// ---- AO probes ----

// 64-bit integers as (low, high) words, for `Rng`'s SplitMix64.
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// The full 64-bit product of two u32.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// Wrapping 64-bit product.
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = mul_wide(a.x, b.x);
    return vec2<u32>(lo.x, lo.y + a.x * b.y + a.y * b.x);
}

// `z >> s` for 0 < s < 32.
fn shr64(z: vec2<u32>, s: u32) -> vec2<u32> {
    return vec2<u32>((z.x >> s) | (z.y << (32u - s)), z.y >> s);
}

const GOLDEN: vec2<u32> = vec2<u32>(0x7f4a7c15u, 0x9e3779b9u);

// `Rng::next_u64`, advancing `state`.
fn next_u64(state: ptr<function, vec2<u32>>) -> vec2<u32> {
    *state = add64(*state, GOLDEN);
    var z = *state;
    z = mul64(z ^ shr64(z, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return z ^ shr64(z, 31u);
}

// `Rng::f32`: the top 24 bits, exactly representable.
fn next_f32(state: ptr<function, vec2<u32>>) -> f32 {
    return f32(next_u64(state).y >> 8u) * (1.0 / 16777216.0);
}

// `ao::radical_inverse(i, base)`: the Halton sequence's coordinate, by the same operations.
fn radical_inverse(index: u32, base: u32) -> f32 {
    var i = index;
    let inv = 1.0 / f32(base);
    var f = inv;
    var r = 0.0;
    while i > 0u {
        r += f * f32(i % base);
        i /= base;
        f *= inv;
    }
    return min(r, 1.0 - bitcast<f32>(0x34000000u) / 2.0);
}

// Writes the probes of primary ray `i` to slots `(i - base)·samples ..`; a primary that
// spawns none (a miss) gets probes with an empty range, which `accumulate` does not count.
@compute @workgroup_size(64)
fn shade_ao(inv: Invocation) {
    let k = flat(inv);
    if k >= params.chunk {
        return;
    }
    let i = params.base + k;
    let first = k * params.samples;
    let hit = hits[i];
    let r = primary[i];
    var ok = hit.y != MISS;
    var q = vec4<f32>(0.0);
    var tri: SceneTri;
    if ok {
        tri = scene_tris[hit.y];
        q = intersect(r.org.xyz, r.dir.xyz, tri, r.org.w, max(r.dir.w, bitcast<f32>(hit.x)));
        ok = q.w > 0.0;
    }
    if !ok {
        for (var s = 0u; s < params.samples; s++) {
            probes[first + s] = no_ray();
        }
        return;
    }
    let sp = surface_point(tri, q.y, q.z, params.gamma8);
    let n = sp.n;
    let facing = select(-n, n, dot3(n, r.dir.xyz) < 0.0);
    // `Rng::new(seed ^ rank·golden)` (the state starts xor-ed with the golden ratio again).
    var state = mul64(vec2<u32>(ranks[i], 0u), GOLDEN) ^ vec2<u32>(params.seed_lo, params.seed_hi) ^ GOLDEN;
    let s1 = next_f32(&state);
    let s2 = next_f32(&state);
    // glam's `any_orthonormal_pair` of `facing`.
    let sign = signum(facing.z);
    let a = -1.0 / (sign + facing.z);
    let bb = facing.x * facing.y * a;
    let tan = vec3<f32>(1.0 + sign * facing.x * facing.x * a, sign * bb, -sign * facing.x);
    let bit = vec3<f32>(bb, sign + facing.y * facing.y * a, -facing.y);
    for (var s = 0u; s < params.samples; s++) {
        let h = vec2<f32>(radical_inverse(s + 1u, 2u), radical_inverse(s + 1u, 3u));
        let u1 = fract(h.x + s1);
        let u2 = fract(h.y + s2);
        // `cosine_hemisphere`.
        let rr = sqrt(u1);
        let phi = bitcast<f32>(0x40c90fdbu) * u2;
        let z = sqrt(max(1.0 - u1, 0.0));
        let dir = normalize_or(
            (tan * (rr * cos(phi)) + bit * (rr * sin(phi))) + facing * z,
            facing,
        );
        let po = offset_origin(sp, dir, params.gamma8);
        probes[first + s] = GpuRay(vec4<f32>(po, 0.0), vec4<f32>(dir, params.max_distance));
    }
}

// The value of slot `i`'s path: the fraction of its probes that escaped, 1 without probes.
@compute @workgroup_size(64)
fn accumulate(inv: Invocation) {
    let k = flat(inv);
    if k >= params.chunk {
        return;
    }
    let i = params.base + k;
    let first = k * params.samples;
    var sent = 0u;
    var open = 0u;
    for (var s = 0u; s < params.samples; s++) {
        // Empty-range probes stand for none.
        if probes[first + s].org.w <= probes[first + s].dir.w {
            sent += 1u;
            if probe_hits[first + s].y == MISS {
                open += 1u;
            }
        }
    }
    var value = 1.0;
    if sent != 0u {
        value = f32(open) / f32(sent);
    }
    film[i] = value;
}
