// The GPU estimator's sampling, compaction and per-task sums (thesis, section 3.3), around the
// reduced traversal of `traverse.wgsl` (MODE 2, or 3 for the first-leaf probe), mirroring
// `raytrace/src/cost/sample.rs`:
// - `gather`: one workgroup per task copies the task's sample (`sample_index`: pairs of
//   neighbouring rays at a stride) to `sampled[offset + j]`: the samples of all tasks
//   end up contiguous (compacted), task after task, in the CPU's order;
// - `sum`: one workgroup per task adds the reduced-traversal counts of its samples in 64-bit
//   integers (two u32 words with a carry), so the sums are exact and independent of the order
//   of the additions.
// The host gives each task's `k` and `offset` (the prefix sum of the `k`s): `k` comes from the
// same f64 rounding of the rate the CPU uses, which WGSL cannot reproduce without f64.

struct Task {
    // First ray of the task in `rays`.
    start: u32,
    // Rays in the task (the host keeps `(2k - 1)·len` below 2^32).
    len: u32,
    // Samples of the task.
    k: u32,
    // Where its samples start in `sampled`.
    offset: u32,
}

struct GpuRay {
    org: vec4<f32>,
    dir: vec4<f32>,
}

const LANES: u32 = 64u;

@group(0) @binding(0) var<storage, read> tasks: array<Task>;
@group(0) @binding(1) var<storage, read> rays: array<GpuRay>;
@group(0) @binding(2) var<storage, read_write> sampled: array<GpuRay>;
@group(0) @binding(3) var<storage, read> counts: array<vec2<u32>>;
// Per task: B low and high word, T low and high word.
@group(0) @binding(4) var<storage, read_write> sums: array<vec4<u32>>;
// `.x`: number of tasks.
@group(0) @binding(5) var<uniform> params: vec4<u32>;

var<workgroup> partial: array<vec4<u32>, LANES>;

// The task of this workgroup (the grid is two-dimensional: one dimension holds at most
// 65 535 workgroups).
fn task_index(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.y * nwg.x + wid.x;
}

@compute @workgroup_size(64)
fn gather(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = task_index(wid, nwg);
    if t >= params.x {
        return;
    }
    let task = tasks[t];
    for (var j = lid; j < task.k; j += LANES) {
        sampled[task.offset + j] = rays[task.start + sample_index(j, task.k, task.len)];
    }
}

// Index within a task of `len` rays of its sample `j` of `k`, as `sample_indices` (and SAMPLE_RUN) in
// `cost/sample.rs`: every ray when `k == len`, else runs of RUN adjacent rays (the last of an
// odd `k` has one), each centred in one of `ceil(k / RUN)` equal strata. Every product is at
// most `len²`, below 2^32 for tasks of at most MAX_TASK_RAYS rays.
const RUN: u32 = 2u;

fn sample_index(j: u32, k: u32, len: u32) -> u32 {
    if k == len {
        return j;
    }
    let runs = (k + RUN - 1u) / RUN;
    let r = j / RUN;
    let width = min(RUN, k - RUN * r);
    let lo = r * len / runs;
    let hi = (r + 1u) * len / runs;
    return lo + (hi - lo - width) / 2u + j % RUN;
}

// `acc + x` for a 64-bit `acc` (low, high) and a 32-bit `x`.
fn add32(acc: vec2<u32>, x: u32) -> vec2<u32> {
    let lo = acc.x + x;
    return vec2<u32>(lo, acc.y + select(0u, 1u, lo < x));
}

// `a + b` for two 64-bit numbers (low, high).
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < b.x));
}

@compute @workgroup_size(64)
fn sum(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = task_index(wid, nwg);
    // Every invocation of a workgroup has the same `t`: the barrier below is reached by all or
    // by none.
    if t >= params.x {
        return;
    }
    let task = tasks[t];
    var b = vec2<u32>(0u, 0u);
    var c = vec2<u32>(0u, 0u);
    for (var j = lid; j < task.k; j += LANES) {
        let n = counts[task.offset + j];
        b = add32(b, n.x);
        c = add32(c, n.y);
    }
    partial[lid] = vec4<u32>(b, c);
    workgroupBarrier();
    if lid == 0u {
        var sb = vec2<u32>(0u, 0u);
        var st = vec2<u32>(0u, 0u);
        for (var i = 0u; i < LANES; i++) {
            let p = partial[i];
            sb = add64(sb, p.xy);
            st = add64(st, p.zw);
        }
        sums[t] = vec4<u32>(sb, st);
    }
}
