// Per-task sums of an estimate's launch of paths: each trace added its rays' counts `B` and
// `T` to their path's entry (`paths`: primary, mirror and shadow rays; `probes`: AO probes),
// and one workgroup adds each task's entries. A task's slots run from its first slot to the
// next task's, the last one's to the launch's slots (the task list and the header as
// `header.wgsl` left them). Sums saturate at 2^32 - 1, which the host takes as "too large to
// count here": saturating addition of non-negative numbers does not depend on its order,
// so the sums are exact below that and the same on every run.

@group(0) @binding(0) var<storage, read> tasks: array<vec2<u32>>;
@group(0) @binding(1) var<storage, read> paths: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> probes: array<vec2<u32>>;
// Per task: the paths' B and T, then the probes' B and T.
@group(0) @binding(3) var<storage, read_write> sums: array<vec4<u32>>;
// Slots, chunk, tasks, secondary rays (`struct Header` in `header.rs`).
@group(0) @binding(4) var<storage, read> header: array<u32, 4>;

const LANES: u32 = 64u;

var<workgroup> partial: array<vec4<u32>, LANES>;

fn add(a: vec4<u32>, b: vec4<u32>) -> vec4<u32> {
    let s = a + b;
    return select(s, vec4<u32>(0xffffffffu), s < a);
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    // The grid is two-dimensional: one dimension holds at most 65 535 workgroups.
    let t = wid.y * nwg.x + wid.x;
    // Every invocation of a workgroup has the same `t`: the barrier is reached by all or none.
    if t >= header[2] {
        return;
    }
    let first = tasks[t].y;
    var end = header[0];
    if t + 1u < header[2] {
        end = tasks[t + 1u].y;
    }
    var acc = vec4<u32>(0u);
    for (var j = first + lid; j < end; j += LANES) {
        acc = add(acc, vec4<u32>(paths[j], probes[j]));
    }
    partial[lid] = acc;
    workgroupBarrier();
    if lid == 0u {
        var total = vec4<u32>(0u);
        for (var i = 0u; i < LANES; i++) {
            total = add(total, partial[i]);
        }
        sums[t] = total;
    }
}
