/* Traces a ray file with Embree 4 through its C API, for scripts/embree-compare.
 *
 *   embree_harness VERTICES TRIANGLES RAYS HITS ANY_HIT THREADS PASSES
 *
 * VERTICES (f32 x 3 per vertex) and TRIANGLES (u32 x 3 per triangle) are the files the
 * `embree_inputs` example writes; RAYS is in `cobalt trace`'s format (ox oy oz dx dy dz tmin
 * tmax, f32 each). Builds one triangle mesh at RTC_BUILD_QUALITY_HIGH on a device of THREADS
 * threads, then traces the rays on THREADS pthreads (chunks handed out in turn) with
 * rtcIntersect1/8/16 (ANY_HIT 0) or rtcOccluded1/8/16 (ANY_HIT 1), PASSES times each, and
 * prints one JSON object: the build's seconds and each call's fastest pass. HITS receives one
 * u32 per ray from the single-ray call: the primitive hit or 0xFFFFFFFF (closest hit), or 1 for
 * occluded and 0 for free (any hit); `mismatches` counts the rays on which a packet call
 * answered otherwise.
 *
 * With `sah`, it also builds Embree's binary tree through rtcBuildBVH and prints its SAH cost
 * (`sah_cost`, see embree_sah below).
 *
 * No Embree header is needed: the few declarations below follow Embree 4's public rtcore.h.
 * Build: cc -O2 -pthread embree_harness.c LIBEMBREE4 -Wl,-rpath,LIBDIR -o embree_harness
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- Embree 4 declarations (rtcore_device.h, rtcore_scene.h, rtcore_ray.h) ---- */
typedef struct RTCDeviceTy *RTCDevice;
typedef struct RTCSceneTy *RTCScene;
typedef struct RTCGeometryTy *RTCGeometry;
enum { RTC_BUILD_QUALITY_HIGH = 2 };
enum { RTC_GEOMETRY_TYPE_TRIANGLE = 0 };
enum { RTC_BUFFER_TYPE_INDEX = 0, RTC_BUFFER_TYPE_VERTEX = 1 };
enum { RTC_FORMAT_UINT3 = 0x5003, RTC_FORMAT_FLOAT3 = 0x9003 };
#define RTC_INVALID_GEOMETRY_ID 0xFFFFFFFFu

RTCDevice rtcNewDevice(const char *config);
int rtcGetDeviceError(RTCDevice device);
void rtcReleaseDevice(RTCDevice device);
RTCScene rtcNewScene(RTCDevice device);
void rtcSetSceneBuildQuality(RTCScene scene, int quality);
void rtcCommitScene(RTCScene scene);
void rtcReleaseScene(RTCScene scene);
RTCGeometry rtcNewGeometry(RTCDevice device, int type);
void *rtcSetNewGeometryBuffer(RTCGeometry geometry, int type, unsigned int slot, int format,
                              size_t byteStride, size_t itemCount);
void rtcSetGeometryBuildQuality(RTCGeometry geometry, int quality);
void rtcCommitGeometry(RTCGeometry geometry);
unsigned int rtcAttachGeometry(RTCScene scene, RTCGeometry geometry);
void rtcReleaseGeometry(RTCGeometry geometry);

/* RTC_MAX_INSTANCE_LEVEL_COUNT is 1; instPrimID exists when instance arrays are compiled in.
 * It is declared either way: it follows every field read here, so only the padding differs. */
struct __attribute__((aligned(16))) RTCRay {
    float org_x, org_y, org_z, tnear;
    float dir_x, dir_y, dir_z, time;
    float tfar;
    unsigned int mask, id, flags;
};
struct __attribute__((aligned(16))) RTCHit {
    float Ng_x, Ng_y, Ng_z, u, v;
    unsigned int primID, geomID, instID[1], instPrimID[1];
};
struct __attribute__((aligned(16))) RTCRayHit {
    struct RTCRay ray;
    struct RTCHit hit;
};
#define PACKET(N, ALIGN)                                                                    \
    struct __attribute__((aligned(ALIGN))) RTCRay##N {                                      \
        float org_x[N], org_y[N], org_z[N], tnear[N];                                       \
        float dir_x[N], dir_y[N], dir_z[N], time[N];                                        \
        float tfar[N];                                                                      \
        unsigned int mask[N], id[N], flags[N];                                              \
    };                                                                                      \
    struct __attribute__((aligned(ALIGN))) RTCHit##N {                                      \
        float Ng_x[N], Ng_y[N], Ng_z[N], u[N], v[N];                                        \
        unsigned int primID[N], geomID[N], instID[1][N], instPrimID[1][N];                  \
    };                                                                                      \
    struct __attribute__((aligned(ALIGN))) RTCRayHit##N {                                   \
        struct RTCRay##N ray;                                                               \
        struct RTCHit##N hit;                                                               \
    };                                                                                      \
    void rtcIntersect##N(const int *valid, RTCScene scene, struct RTCRayHit##N *rayhit,     \
                         void *args);                                                       \
    void rtcOccluded##N(const int *valid, RTCScene scene, struct RTCRay##N *ray, void *args);
PACKET(8, 32)
PACKET(16, 64)
void rtcIntersect1(RTCScene scene, struct RTCRayHit *rayhit, void *args);
void rtcOccluded1(RTCScene scene, struct RTCRay *ray, void *args);

/* ---- Embree 4 declarations (rtcore_builder.h) ---- */
typedef struct RTCBVHTy *RTCBVH;
typedef struct RTCThreadLocalAllocatorTy *RTCThreadLocalAllocator;
struct __attribute__((aligned(16))) RTCBounds {
    float lower_x, lower_y, lower_z, align0;
    float upper_x, upper_y, upper_z, align1;
};
struct __attribute__((aligned(32))) RTCBuildPrimitive {
    float lower_x, lower_y, lower_z;
    unsigned int geomID;
    float upper_x, upper_y, upper_z;
    unsigned int primID;
};
typedef void *(*RTCCreateNodeFunction)(RTCThreadLocalAllocator, unsigned int, void *);
typedef void (*RTCSetNodeChildrenFunction)(void *, void **, unsigned int, void *);
typedef void (*RTCSetNodeBoundsFunction)(void *, const struct RTCBounds **, unsigned int,
                                         void *);
typedef void *(*RTCCreateLeafFunction)(RTCThreadLocalAllocator,
                                       const struct RTCBuildPrimitive *, size_t, void *);
typedef void (*RTCSplitPrimitiveFunction)(const struct RTCBuildPrimitive *, unsigned int, float,
                                          struct RTCBounds *, struct RTCBounds *, void *);
typedef _Bool (*RTCProgressMonitorFunction)(void *, double);
struct RTCBuildArguments {
    size_t byteSize;
    int buildQuality, buildFlags;
    unsigned int maxBranchingFactor, maxDepth, sahBlockSize, minLeafSize, maxLeafSize;
    float traversalCost, intersectionCost;
    RTCBVH bvh;
    struct RTCBuildPrimitive *primitives;
    size_t primitiveCount, primitiveArrayCapacity;
    RTCCreateNodeFunction createNode;
    RTCSetNodeChildrenFunction setNodeChildren;
    RTCSetNodeBoundsFunction setNodeBounds;
    RTCCreateLeafFunction createLeaf;
    RTCSplitPrimitiveFunction splitPrimitive;
    RTCProgressMonitorFunction buildProgress;
    void *userPtr;
};
RTCBVH rtcNewBVH(RTCDevice device);
void *rtcBuildBVH(const struct RTCBuildArguments *args);
void *rtcThreadLocalAlloc(RTCThreadLocalAllocator allocator, size_t bytes, size_t align);
void rtcReleaseBVH(RTCBVH bvh);

/* ---- Embree's tree, for its SAH cost ----
 * rtcBuildBVH is the builder behind rtcCommitScene, exposed with callbacks: here at
 * RTC_BUILD_QUALITY_HIGH with spatial splits, a binary tree with cobalt's build costs (a box
 * step 3 triangle tests, at most 8 triangles a leaf), so that its cost and cobalt's are the
 * same formula over trees built for the same costs. */
struct BNode {
    int leaf;
    unsigned int count;
    struct BNode *kid[2];
    struct RTCBounds box[2];
};
static const float *sah_vertices;
static const uint32_t *sah_triangles;

static void *sah_node(RTCThreadLocalAllocator a, unsigned int n, void *user) {
    (void)user;
    struct BNode *b = rtcThreadLocalAlloc(a, sizeof *b, 16);
    b->leaf = 0, b->count = n;
    b->kid[0] = b->kid[1] = NULL;
    return b;
}
static void sah_children(void *node, void **kids, unsigned int n, void *user) {
    (void)user;
    for (unsigned int i = 0; i < n && i < 2; i++)
        ((struct BNode *)node)->kid[i] = kids[i];
}
static void sah_bounds(void *node, const struct RTCBounds **b, unsigned int n, void *user) {
    (void)user;
    for (unsigned int i = 0; i < n && i < 2; i++)
        ((struct BNode *)node)->box[i] = *b[i];
}
static void *sah_leaf(RTCThreadLocalAllocator a, const struct RTCBuildPrimitive *p, size_t n,
                      void *user) {
    (void)p, (void)user;
    struct BNode *b = rtcThreadLocalAlloc(a, sizeof *b, 16);
    b->leaf = 1, b->count = (unsigned int)n;
    return b;
}
/* The triangle's part on each side of the plane, within the primitive's current box. */
static void sah_split(const struct RTCBuildPrimitive *p, unsigned int dim, float pos,
                      struct RTCBounds *l, struct RTCBounds *r, void *user) {
    (void)user;
    float lo[2][3], hi[2][3];
    for (int s = 0; s < 2; s++)
        for (int a = 0; a < 3; a++)
            lo[s][a] = INFINITY, hi[s][a] = -INFINITY;
    const uint32_t *t = sah_triangles + 3 * p->primID;
#define GROW(S, P)                                                                          \
    for (int a = 0; a < 3; a++)                                                             \
        lo[S][a] = fminf(lo[S][a], (P)[a]), hi[S][a] = fmaxf(hi[S][a], (P)[a]);
    for (int e = 0; e < 3; e++) {
        const float *v = sah_vertices + 3 * t[e], *w = sah_vertices + 3 * t[(e + 1) % 3];
        if (v[dim] <= pos)
            GROW(0, v)
        if (v[dim] >= pos)
            GROW(1, v)
        if ((v[dim] < pos && w[dim] > pos) || (v[dim] > pos && w[dim] < pos)) {
            float f = (pos - v[dim]) / (w[dim] - v[dim]), x[3];
            for (int a = 0; a < 3; a++)
                x[a] = v[a] + f * (w[a] - v[a]);
            x[dim] = pos;
            GROW(0, x)
            GROW(1, x)
        }
    }
#undef GROW
    const float plo[3] = {p->lower_x, p->lower_y, p->lower_z};
    const float phi[3] = {p->upper_x, p->upper_y, p->upper_z};
    for (int s = 0; s < 2; s++)
        for (int a = 0; a < 3; a++) {
            lo[s][a] = fmaxf(lo[s][a], plo[a]);
            hi[s][a] = fminf(hi[s][a], phi[a]);
        }
    hi[0][dim] = fminf(hi[0][dim], pos);
    lo[1][dim] = fmaxf(lo[1][dim], pos);
    *l = (struct RTCBounds){lo[0][0], lo[0][1], lo[0][2], 0, hi[0][0], hi[0][1], hi[0][2], 0};
    *r = (struct RTCBounds){lo[1][0], lo[1][1], lo[1][2], 0, hi[1][0], hi[1][1], hi[1][2], 0};
}
static double half_area(const struct RTCBounds *b) {
    double x = (double)b->upper_x - b->lower_x, y = (double)b->upper_y - b->lower_y,
           z = (double)b->upper_z - b->lower_z;
    return x * y + y * z + z * x;
}
/* cobalt's `sah_cost` sum below a node: each child's box, times its triangles for a leaf. */
static double sah_below(const struct BNode *n) {
    double sum = 0;
    for (int i = 0; i < 2; i++) {
        const struct BNode *k = n->kid[i];
        if (!k)
            continue;
        sum += half_area(&n->box[i]) * (k->leaf ? k->count : 1);
        if (!k->leaf)
            sum += sah_below(k);
    }
    return sum;
}
/* The SAH cost of Embree's tree over the non-degenerate triangles, in cobalt's formula:
 * (inner boxes' half areas + leaves' half areas times their triangles) / the root's. */
static double embree_sah(RTCDevice device, const float *vertices, const uint32_t *triangles,
                         size_t ntri) {
    sah_vertices = vertices, sah_triangles = triangles;
    size_t cap = 4 * ntri + 16, n = 0;
    struct RTCBuildPrimitive *prims = aligned_alloc(32, cap * sizeof *prims);
    if (!prims) {
        fprintf(stderr, "embree_harness: out of memory\n");
        exit(2);
    }
    struct RTCBounds root = {INFINITY, INFINITY, INFINITY, 0, -INFINITY, -INFINITY, -INFINITY, 0};
    for (size_t i = 0; i < ntri; i++) {
        const float *v[3];
        for (int c = 0; c < 3; c++)
            v[c] = vertices + 3 * triangles[3 * i + c];
        float e1[3], e2[3];
        for (int a = 0; a < 3; a++)
            e1[a] = v[1][a] - v[0][a], e2[a] = v[2][a] - v[0][a];
        float cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
              cz = e1[0] * e2[1] - e1[1] * e2[0];
        if (cx == 0 && cy == 0 && cz == 0)
            continue; /* degenerate: cobalt leaves it out too */
        struct RTCBuildPrimitive p = {INFINITY, INFINITY, INFINITY, 0,
                                      -INFINITY, -INFINITY, -INFINITY, (unsigned int)i};
        for (int c = 0; c < 3; c++) {
            p.lower_x = fminf(p.lower_x, v[c][0]), p.upper_x = fmaxf(p.upper_x, v[c][0]);
            p.lower_y = fminf(p.lower_y, v[c][1]), p.upper_y = fmaxf(p.upper_y, v[c][1]);
            p.lower_z = fminf(p.lower_z, v[c][2]), p.upper_z = fmaxf(p.upper_z, v[c][2]);
        }
        root.lower_x = fminf(root.lower_x, p.lower_x), root.upper_x = fmaxf(root.upper_x, p.upper_x);
        root.lower_y = fminf(root.lower_y, p.lower_y), root.upper_y = fmaxf(root.upper_y, p.upper_y);
        root.lower_z = fminf(root.lower_z, p.lower_z), root.upper_z = fmaxf(root.upper_z, p.upper_z);
        prims[n++] = p;
    }
    if (n == 0) {
        free(prims);
        return 1.0;
    }
    RTCBVH bvh = rtcNewBVH(device);
    struct RTCBuildArguments args = {
        .byteSize = sizeof args,
        .buildQuality = RTC_BUILD_QUALITY_HIGH,
        .maxBranchingFactor = 2,
        .maxDepth = 64,
        .sahBlockSize = 1,
        .minLeafSize = 1,
        .maxLeafSize = 8,
        .traversalCost = 3.0f,
        .intersectionCost = 1.0f,
        .bvh = bvh,
        .primitives = prims,
        .primitiveCount = n,
        .primitiveArrayCapacity = cap,
        .createNode = sah_node,
        .setNodeChildren = sah_children,
        .setNodeBounds = sah_bounds,
        .createLeaf = sah_leaf,
        .splitPrimitive = sah_split,
    };
    const struct BNode *top = rtcBuildBVH(&args);
    int err = rtcGetDeviceError(device);
    if (!top || err) {
        fprintf(stderr, "embree_harness: rtcBuildBVH failed (Embree error %d)\n", err);
        exit(2);
    }
    double area = half_area(&root), cost;
    if (top->leaf)
        cost = top->count;
    else
        cost = (area + sah_below(top)) / (area > 0 ? area : 1e-300);
    rtcReleaseBVH(bvh);
    free(prims);
    return cost;
}

/* ---- the harness ---- */
#define CHUNK 1024 /* rays a thread takes at a time: a multiple of 16 */

static RTCScene scene;
static const float *rays;
static size_t nrays;
static int any_hit;
static uint32_t *answers;
static atomic_size_t next_chunk;

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static void *read_file(const char *path, size_t unit, size_t *count) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "embree_harness: cannot open %s\n", path);
        exit(2);
    }
    fseek(f, 0, SEEK_END);
    long bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (bytes < 0 || bytes % unit) {
        fprintf(stderr, "embree_harness: %s is not a whole number of %zu-byte records\n", path,
                unit);
        exit(2);
    }
    void *data = malloc(bytes ? bytes : 1);
    if (!data || fread(data, 1, bytes, f) != (size_t)bytes) {
        fprintf(stderr, "embree_harness: cannot read %s\n", path);
        exit(2);
    }
    fclose(f);
    *count = bytes / unit;
    return data;
}

static void trace1(size_t s, size_t e) {
    for (size_t i = s; i < e; i++) {
        const float *r = rays + 8 * i;
        struct RTCRayHit rh;
        rh.ray = (struct RTCRay){r[0], r[1], r[2], r[6], r[3], r[4], r[5], 0.0f, r[7],
                                 0xFFFFFFFFu, 0, 0};
        if (any_hit) {
            rtcOccluded1(scene, &rh.ray, NULL);
            answers[i] = rh.ray.tfar < 0.0f;
        } else {
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &rh, NULL);
            answers[i] = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? 0xFFFFFFFFu : rh.hit.primID;
        }
    }
}

/* Packets of N consecutive rays; the last one masked. */
#define TRACE_PACKET(N)                                                                     \
    static void trace##N(size_t s, size_t e) {                                              \
        for (size_t b = s; b < e; b += N) {                                                 \
            struct RTCRayHit##N rh;                                                         \
            int valid[N];                                                                   \
            for (int k = 0; k < N; k++) {                                                   \
                size_t i = b + k < e ? b + k : b;                                           \
                const float *r = rays + 8 * i;                                              \
                valid[k] = b + k < e ? -1 : 0;                                              \
                rh.ray.org_x[k] = r[0], rh.ray.org_y[k] = r[1], rh.ray.org_z[k] = r[2];     \
                rh.ray.dir_x[k] = r[3], rh.ray.dir_y[k] = r[4], rh.ray.dir_z[k] = r[5];     \
                rh.ray.tnear[k] = r[6], rh.ray.tfar[k] = r[7], rh.ray.time[k] = 0.0f;       \
                rh.ray.mask[k] = 0xFFFFFFFFu, rh.ray.id[k] = 0, rh.ray.flags[k] = 0;        \
                rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;                                 \
            }                                                                               \
            if (any_hit)                                                                    \
                rtcOccluded##N(valid, scene, &rh.ray, NULL);                                \
            else                                                                            \
                rtcIntersect##N(valid, scene, &rh, NULL);                                   \
            for (int k = 0; k < N && b + k < e; k++)                                        \
                answers[b + k] = any_hit ? rh.ray.tfar[k] < 0.0f                            \
                                 : rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID              \
                                     ? 0xFFFFFFFFu                                          \
                                     : rh.hit.primID[k];                                    \
        }                                                                                   \
    }
TRACE_PACKET(8)
TRACE_PACKET(16)

static void (*trace)(size_t, size_t);

static void *worker(void *unused) {
    (void)unused;
    for (;;) {
        size_t s = atomic_fetch_add(&next_chunk, 1) * CHUNK;
        if (s >= nrays)
            return NULL;
        trace(s, s + CHUNK < nrays ? s + CHUNK : nrays);
    }
}

static double timed_pass(int threads) {
    pthread_t pool[256];
    atomic_store(&next_chunk, 0);
    double start = now();
    for (int t = 0; t < threads; t++)
        if (pthread_create(&pool[t], NULL, worker, NULL)) {
            fprintf(stderr, "embree_harness: cannot start a thread\n");
            exit(2);
        }
    for (int t = 0; t < threads; t++)
        pthread_join(pool[t], NULL);
    return now() - start;
}

int main(int argc, char **argv) {
    if (argc != 8 && !(argc == 9 && !strcmp(argv[8], "sah"))) {
        fprintf(stderr, "usage: embree_harness VERTICES TRIANGLES RAYS HITS ANY_HIT THREADS "
                        "PASSES [sah]\n");
        return 2;
    }
    size_t nvert, ntri;
    float *vertices = read_file(argv[1], 12, &nvert);
    uint32_t *triangles = read_file(argv[2], 12, &ntri);
    rays = read_file(argv[3], 32, &nrays);
    any_hit = atoi(argv[5]);
    int threads = atoi(argv[6]), passes = atoi(argv[7]);
    if (threads < 1 || threads > 256 || passes < 1) {
        fprintf(stderr, "embree_harness: THREADS must be 1 to 256 and PASSES at least 1\n");
        return 2;
    }
    for (size_t i = 0; i < 3 * ntri; i++)
        if (triangles[i] >= nvert) {
            fprintf(stderr, "embree_harness: triangle %zu indexes vertex %u of %zu\n", i / 3,
                    triangles[i], nvert);
            return 2;
        }

    char config[64];
    snprintf(config, sizeof config, "threads=%d", threads);
    RTCDevice device = rtcNewDevice(config);
    if (!device) {
        fprintf(stderr, "embree_harness: rtcNewDevice failed (%d)\n", rtcGetDeviceError(NULL));
        return 2;
    }
    /* The build: from the mesh's buffers to the committed scene. */
    double start = now();
    scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry mesh = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(mesh, RTC_BUILD_QUALITY_HIGH);
    void *vb = rtcSetNewGeometryBuffer(mesh, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12,
                                       nvert);
    void *ib = rtcSetNewGeometryBuffer(mesh, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12,
                                       ntri);
    if (!vb || !ib) {
        fprintf(stderr, "embree_harness: no geometry buffers (%d)\n", rtcGetDeviceError(device));
        return 2;
    }
    memcpy(vb, vertices, 12 * nvert);
    memcpy(ib, triangles, 12 * ntri);
    rtcCommitGeometry(mesh);
    rtcAttachGeometry(scene, mesh);
    rtcReleaseGeometry(mesh);
    rtcCommitScene(scene);
    double build = now() - start;
    int err = rtcGetDeviceError(device);
    if (err) {
        fprintf(stderr, "embree_harness: the build failed (Embree error %d)\n", err);
        return 2;
    }

    answers = malloc(4 * (nrays ? nrays : 1));
    uint32_t *first = malloc(4 * (nrays ? nrays : 1));
    if (!answers || !first) {
        fprintf(stderr, "embree_harness: out of memory\n");
        return 2;
    }
    static void (*const calls[])(size_t, size_t) = {trace1, trace8, trace16};
    static const char *const names[2][3] = {{"rtcIntersect1", "rtcIntersect8", "rtcIntersect16"},
                                            {"rtcOccluded1", "rtcOccluded8", "rtcOccluded16"}};
    printf("{\"build_seconds\": %.6f, \"rays\": %zu, ", build, nrays);
    if (argc == 9)
        printf("\"sah_cost\": %.6f, ", embree_sah(device, vertices, triangles, ntri));
    printf("\"calls\": {");
    for (int c = 0; c < 3; c++) {
        trace = calls[c];
        double best = INFINITY;
        for (int p = 0; p < passes; p++) {
            double s = timed_pass(threads);
            best = s < best ? s : best;
        }
        size_t mismatches = 0;
        if (c == 0)
            memcpy(first, answers, 4 * nrays);
        else
            for (size_t i = 0; i < nrays; i++)
                mismatches += answers[i] != first[i];
        err = rtcGetDeviceError(device);
        printf("%s\"%s\": {\"seconds\": %.6f, \"mismatches\": %zu, \"error\": %d}",
               c ? ", " : "", names[any_hit != 0][c], best, mismatches, err);
    }
    printf("}}\n");

    FILE *out = fopen(argv[4], "wb");
    if (!out || fwrite(first, 4, nrays, out) != nrays || fclose(out)) {
        fprintf(stderr, "embree_harness: cannot write %s\n", argv[4]);
        return 2;
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    return 0;
}
