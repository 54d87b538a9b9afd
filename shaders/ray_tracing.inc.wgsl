// The ray-tracing core: closest-hit and any-hit traversal of the two-level BVH.
//
// The alpha test of candidate hits (rt_instance_alpha_tested, rt_alpha_cuts) is the includer's to
// choose: `#include "rt_alpha.inc.wgsl"` (masked materials cut texels out of every ray) or
// `#include "rt_opaque.inc.wgsl"` (every surface solid: a pipeline that must stay within a small
// GPU's storage buffers, since the test reads materials, vertices and indices).
//
// TLAS and BLASes (one per mesh): 8-wide compressed BVHs (CWBVH, Ylitie, Karras and Laine 2017),
// walked in one loop with node groups in ray-octant order. The TLAS's leaves are instances; the ray
// is taken into instance space with the instance's inverse transform and its direction is NOT
// normalized, so t means the same thing in every instance and in the world.
#include "scene.inc.wgsl"

// Where a mesh's BLAS lives in blas_nodes (5 × vec4<u32> = 80 bytes a node) and blas_triangles.
struct GpuBlas {
    node_offset: u32,
    triangle_offset: u32,
    node_count: u32,
    triangle_count: u32,
    // Where the mesh's indices and vertices start in `indices` and `vertices`.
    first_index: u32,
    base_vertex: u32,
    _pad0: u32,
    _pad1: u32,
}

// A TLAS leaf: the instance a ray enters there, where its BLAS lives (as in GpuBlas), and the BLAS
// node the walk starts at (0, the root; a node below it where re-braiding opened the instance).
struct TlasEntry {
    instance: u32,
    node_offset: u32,
    triangle_offset: u32,
    start_node: u32,
}

@group(0) @binding(7) var<storage, read> blas_nodes: array<vec4<u32>>;
// Three vec4 a triangle, in leaf order: (v0, mesh triangle index as bits), (v1 - v0, tag), (v2 - v0, 0);
// the tag is 0 in a mesh's BLAS and the member's instance slot + 1 (as bits) in a static group's
// (engine/src/rt/groups.rs), whose leaf is entered in its frame instance's space.
@group(0) @binding(8) var<storage, read> blas_triangles: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> blas_info: array<GpuBlas>;
// The TLAS: CWBVH nodes (5 × vec4<u32> each) whose leaves hold one TlasEntry each, then the entries
// (one vec4 each, eight a node, one per child slot; primitive_base_idx is an index into this array).
@group(0) @binding(10) var<storage, read> tlas_nodes: array<vec4<u32>>;
@group(0) @binding(11) var<storage, read> indices: array<u32>;

const RT_NO_HIT: u32 = 0xffffffffu;

// Diagnostics: when a pipeline sets RT_COUNT_WORK, traversal counts its work in rt_work
// (x: TLAS nodes, y: instances entered, z: BLAS nodes, w: triangles tested). Off, it costs nothing.
override RT_COUNT_WORK: bool = false;
var<private> rt_work: vec4<u32>;
// Also counted with RT_COUNT_WORK: the traversal loop's steps (its iterations and the triangle
// tests inside them), whose spread over a warp's lanes measures how much of the warp idles.
var<private> rt_steps: u32;
// Groups waiting in the walk of both levels (8-wide trees are shallow; the TLAS's depth is checked
// against its share on the CPU, engine::rt::TLAS_STACK_SIZE).
const RT_STACK_SIZE: u32 = 48u;
// Also counted with RT_COUNT_WORK: x, the stack entries moved from workgroup memory to the
// function-memory stack (RT_SHARED_STACK_ENTRIES); y, the deepest the ray's stack got.
var<private> rt_stack_work: vec2<u32>;

// Where the stack lives. 0 (the engine's): all of it in function memory (`stack` in rt_trace,
// which NVIDIA places in local memory, through L1 and L2). K > 0: each lane keeps the top K
// entries of its stack in workgroup memory (rt_shared_stack, a ring of K slots a lane, interleaved
// by lane so that a warp's accesses fall in distinct banks) and moves the oldest one to the
// function-memory stack when a push finds its K slots full (Aila and Laine 2009; Ylitie, Karras and
// Laine 2017). A pipeline that sets K must also set RT_SHARED_STACK_LANES to its workgroup's
// threads and rt_stack_lane to each thread's local_invocation_index before tracing. The stack
// holds RT_STACK_SIZE entries either way, so both find the same hits.
override RT_SHARED_STACK_ENTRIES: u32 = 0u;
override RT_SHARED_STACK_LANES: u32 = 64u;
// One slot when the stack is not shared (an array cannot be empty).
override RT_SHARED_STACK_SLOTS: u32 = max(RT_SHARED_STACK_ENTRIES * RT_SHARED_STACK_LANES, 1u);
var<workgroup> rt_shared_stack: array<vec2<u32>, RT_SHARED_STACK_SLOTS>;
var<private> rt_stack_lane: u32;

// The workgroup-memory slot of stack entry `i` of this lane (RT_SHARED_STACK_ENTRIES > 0).
fn rt_shared_stack_slot(i: u32) -> u32 {
    // (max: the function is compiled, though never called, when the stack is not shared.)
    return (i % max(RT_SHARED_STACK_ENTRIES, 1u)) * RT_SHARED_STACK_LANES + rt_stack_lane;
}

// Pushes `e` on the walk's stack, unless it is full (RT_STACK_SIZE entries; the entry is then
// dropped, as the TLAS's depth check on the CPU warns). Entries below `spilled` live in `stack`
// (function memory), the others in workgroup memory (RT_SHARED_STACK_ENTRIES > 0).
fn rt_walk_push(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>, e: vec2<u32>) {
    let sp = (*w).sp;
    if sp >= RT_STACK_SIZE {
        return;
    }
    (*w).sp = sp + 1u;
    if RT_COUNT_WORK {
        rt_stack_work.y = max(rt_stack_work.y, sp + 1u);
    }
    if RT_SHARED_STACK_ENTRIES == 0u {
        (*stack)[sp] = e;
        return;
    }
    let spilled = (*w).spilled;
    if sp - spilled == RT_SHARED_STACK_ENTRIES {
        // The lane's slots are full: the oldest of them (in the slot the new entry takes) moves to
        // function memory.
        (*stack)[spilled] = rt_shared_stack[rt_shared_stack_slot(spilled)];
        (*w).spilled = spilled + 1u;
        if RT_COUNT_WORK {
            rt_stack_work.x += 1u;
        }
    }
    rt_shared_stack[rt_shared_stack_slot(sp)] = e;
}

// Pops the top entry of the walk's stack (which must not be empty): from workgroup memory, or from
// `stack` once the entries there are all that is left.
fn rt_walk_pop(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>) -> vec2<u32> {
    let sp = (*w).sp - 1u;
    (*w).sp = sp;
    if RT_SHARED_STACK_ENTRIES == 0u {
        return (*stack)[sp];
    }
    if sp < (*w).spilled {
        (*w).spilled = sp;
        return (*stack)[sp];
    }
    return rt_shared_stack[rt_shared_stack_slot(sp)];
}

struct Ray {
    origin: vec3<f32>,
    tmin: f32,
    // Need not be unit length: t is measured in multiples of it.
    direction: vec3<f32>,
    tmax: f32,
}

struct RayHit {
    t: f32,
    // Instance slot, or RT_NO_HIT.
    instance: u32,
    // Triangle index within the instance's mesh.
    primitive: u32,
    // Weights of vertices 1 and 2 (vertex 0 gets 1 - u - v).
    barycentrics: vec2<f32>,
    // The ray met the side the triangle's winding faces (counter-clockwise seen from the ray).
    front_face: bool,
}

fn rt_no_hit(tmax: f32) -> RayHit {
    return RayHit(tmax, RT_NO_HIT, 0u, vec2<f32>(0.0), false);
}

// Directions with zero components would turn slab tests into 0 × inf = NaN: nudge them.
fn rt_safe_direction(d: vec3<f32>) -> vec3<f32> {
    let tiny = vec3<f32>(1e-30);
    return select(d, select(tiny, -tiny, d < vec3<f32>(0.0)), abs(d) < tiny);
}

// Slab test; returns the entry distance, or +inf when the box is missed within [tmin, tmax].
fn rt_aabb_entry(lo: vec3<f32>, hi: vec3<f32>, origin: vec3<f32>, inv_dir: vec3<f32>, tmin: f32, tmax: f32) -> f32 {
    let t0 = (lo - origin) * inv_dir;
    let t1 = (hi - origin) * inv_dir;
    let tn = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), tmin));
    let tf = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), tmax));
    return select(3.4e38, tn, tn <= tf);
}

// Ray octant with each of the four bytes holding (7 - octant), as the CWBVH child order expects.
fn rt_octant_inv4(d: vec3<f32>) -> u32 {
    return select(0x04040404u, 0u, d.x < 0.0) | select(0x02020202u, 0u, d.y < 0.0) | select(0x01010101u, 0u, d.z < 0.0);
}

// Intersects the ray with the eight quantized child boxes of a CWBVH node. Returns the hit mask:
// bits 24..31 inner children (in octant order), bits 0..23 triangles of the hit leaves.
// n0..n4: the node's five vec4 (from blas_nodes or tlas_nodes).
fn rt_cwbvh_node_hits(n0: vec4<u32>, n1: vec4<u32>, n2: vec4<u32>, n3: vec4<u32>, n4: vec4<u32>, origin: vec3<f32>, dir: vec3<f32>, oct_inv4: u32, tmin: f32, tmax: f32) -> u32 {
    let p = bitcast<vec3<f32>>(n0.xyz);
    let e = vec3<u32>(n0.w & 0xffu, (n0.w >> 8u) & 0xffu, (n0.w >> 16u) & 0xffu);
    // Child planes are p + 2^(e - 127) · q: fold the scale and origin into the ray instead.
    let scaled_inv_dir = bitcast<vec3<f32>>(e << vec3<u32>(23u)) / dir;
    let shifted_origin = (p - origin) / dir;
    let neg = dir < vec3<f32>(0.0);
    var hit_mask = 0u;
    for (var half = 0u; half < 2u; half++) {
        let meta4 = select(n1.w, n1.z, half == 0u);
        let is_inner4 = (meta4 & (meta4 << 1u)) & 0x10101010u;
        let inner_mask4 = (is_inner4 >> 4u) * 0xffu;
        let bit_index4 = (meta4 ^ (oct_inv4 & inner_mask4)) & 0x1f1f1f1fu;
        let child_bits4 = (meta4 >> 5u) & 0x07070707u;
        let lo = vec3<u32>(select(n2.y, n2.x, half == 0u), select(n3.y, n3.x, half == 0u), select(n4.y, n4.x, half == 0u));
        let hi = vec3<u32>(select(n2.w, n2.z, half == 0u), select(n3.w, n3.z, half == 0u), select(n4.w, n4.z, half == 0u));
        let near4 = select(lo, hi, neg);
        let far4 = select(hi, lo, neg);
        for (var j = 0u; j < 4u; j++) {
            let shift = j * 8u;
            let qn = vec3<f32>((near4 >> vec3<u32>(shift)) & vec3<u32>(0xffu));
            let qf = vec3<f32>((far4 >> vec3<u32>(shift)) & vec3<u32>(0xffu));
            let tn3 = qn * scaled_inv_dir + shifted_origin;
            let tf3 = qf * scaled_inv_dir + shifted_origin;
            let tn = max(max(tn3.x, tn3.y), max(tn3.z, tmin));
            let tf = min(min(tf3.x, tf3.y), min(tf3.z, tmax));
            if tn <= tf {
                let child_bits = (child_bits4 >> shift) & 0xffu;
                let bit_index = (bit_index4 >> shift) & 0xffu;
                hit_mask |= child_bits << bit_index;
            }
        }
    }
    return hit_mask;
}

struct TriangleHit {
    hit: bool,
    t: f32,
    barycentrics: vec2<f32>,
    front_face: bool,
}

// Möller–Trumbore against the triangle stored at `index` of blas_triangles. Degenerate triangles and
// rays in their plane have det == 0 and never hit.
fn rt_intersect_triangle(index: u32, origin: vec3<f32>, dir: vec3<f32>, tmin: f32, tmax: f32) -> TriangleHit {
    var out = TriangleHit(false, tmax, vec2<f32>(0.0), false);
    let v0 = blas_triangles[index * 3u].xyz;
    let e1 = blas_triangles[index * 3u + 1u].xyz;
    let e2 = blas_triangles[index * 3u + 2u].xyz;
    let pvec = cross(dir, e2);
    let det = dot(e1, pvec);
    if det == 0.0 {
        return out;
    }
    let inv_det = 1.0 / det;
    let tvec = origin - v0;
    let u = dot(tvec, pvec) * inv_det;
    let qvec = cross(tvec, e1);
    let v = dot(dir, qvec) * inv_det;
    let t = dot(e2, qvec) * inv_det;
    // Written so that NaN fails every test.
    if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= tmin && t < tmax {
        out.hit = true;
        out.t = t;
        out.barycentrics = vec2<f32>(u, v);
        out.front_face = det > 0.0;
    }
    return out;
}

// Moves bit k of the 8-bit mask m to bit k ^ x. A TLAS node's leaf entries sit at their slots; their
// hit mask permuted by the ray octant and walked from the top bit enters them in octant order
// (nearest first, as inner children are visited).
fn rt_xor_permute8(m: u32, x: u32) -> u32 {
    var r = m;
    if (x & 1u) != 0u {
        r = ((r & 0x55u) << 1u) | ((r >> 1u) & 0x55u);
    }
    if (x & 2u) != 0u {
        r = ((r & 0x33u) << 2u) | ((r >> 2u) & 0x33u);
    }
    if (x & 4u) != 0u {
        r = ((r & 0x0fu) << 4u) | ((r >> 4u) & 0x0fu);
    }
    return r;
}

fn rt_tlas_entry(index: u32) -> TlasEntry {
    let v = tlas_nodes[index];
    return TlasEntry(v.x, v.y, v.z, v.w);
}

// A ray's walk over both levels: one loop, so that the lanes of a warp test nodes together whether
// they are in the TLAS or in an instance's BLAS. Each step (rt_walk_step) tests one CWBVH node
// (TLAS or BLAS, same code), then either the triangles it hit (in a BLAS) or one of the TLAS
// entries it hit: entering an instance pushes what is left of the TLAS walk, takes the ray into
// instance space and starts the BLAS walk at the entry's start node; the walk returns to the TLAS
// when the stack is back at the level it entered at. rt_trace runs a walk to its end; a persistent
// kernel (lab's bench_trace.wgsl) starts the next ray's walk where one ends, inside its loop.
struct RtWalk {
    ray: Ray,
    // The closest hit so far (its primitive is filled in by rt_walk_hit), and its triangle's index
    // in blas_triangles.
    best: RayHit,
    best_triangle: u32,
    world_dir: vec3<f32>,
    world_oct: u32,
    // The ray in the space of the level being walked: world for the TLAS, instance space in a BLAS
    // (`dir` nudged off zero for slab tests, `tri_dir` as given for triangle tests).
    origin: vec3<f32>,
    dir: vec3<f32>,
    tri_dir: vec3<f32>,
    oct_inv4: u32,
    in_blas: bool,
    instance: u32,
    // The entered instance's material cuts texels (alpha-masked): its candidate hits test the alpha.
    alpha_tested: bool,
    node_offset: u32,
    triangle_offset: u32,
    // Stack entries in use; those below `spilled` live in the caller's function-memory stack, the
    // others in workgroup memory (RT_SHARED_STACK_ENTRIES); the depth at which the BLAS walk began.
    sp: u32,
    spilled: u32,
    tlas_sp: u32,
    // Inner children still to visit (base, hit bits 24..31 in octant order | imask bits 0..7), and
    // primitives still to test (base, bits): triangles in a BLAS, entries in the TLAS.
    group: vec2<u32>,
    prims: vec2<u32>,
}

// The walk of `ray`, at its start: the TLAS root as the only inner child of a virtual parent.
fn rt_walk_start(ray: Ray) -> RtWalk {
    let world_dir = rt_safe_direction(ray.direction);
    let world_oct = rt_octant_inv4(world_dir);
    return RtWalk(
        ray,
        rt_no_hit(ray.tmax),
        0u,
        world_dir,
        world_oct,
        ray.origin,
        world_dir,
        ray.direction,
        world_oct,
        false,
        0u,
        false,
        0u,
        0u,
        0u,
        0u,
        0u,
        vec2<u32>(0u, 0x80000000u),
        vec2<u32>(0u, 0u),
    );
}

// One step of the walk; true when it is over (every node it must visit visited, or with `any_hit`
// a hit found). `stack` is the function-memory stack.
fn rt_walk_step(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>, any_hit: bool) -> bool {
    rt_walk_node(w, stack);
    return rt_walk_prims(w, stack, any_hit);
}

// A step's first half: tests the next node of the walk's group (TLAS or BLAS), unless primitives
// of the last one wait for their tests.
fn rt_walk_node(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>) {
    if RT_COUNT_WORK {
        rt_steps += 1u;
    }
    if rt_walk_has_node(w) {
        let node = rt_walk_next_node(w, stack);
        rt_walk_enter_node(w, node, rt_walk_node_hits(w, node));
    }
}

// A CWBVH node: 80 bytes, five vec4 words (obvhs's encoding, `engine::rt::Blas::nodes`).
struct RtNode {
    n0: vec4<u32>,
    n1: vec4<u32>,
    n2: vec4<u32>,
    n3: vec4<u32>,
    n4: vec4<u32>,
}

// Whether the walk's next step tests a node: its group has children left and no primitives of the
// last node wait.
fn rt_walk_has_node(w: ptr<function, RtWalk>) -> bool {
    return ((*w).group.y & 0xff000000u) != 0u && (*w).prims.y == 0u;
}

// Takes the group's next child (nearest first in the walk's octant order), pushes the rest of the
// group, and loads the child's node from the BLAS or the TLAS. Only when rt_walk_has_node.
fn rt_walk_next_node(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>) -> RtNode {
    let hits = (*w).group.y;
    let child_bit = firstLeadingBit(hits);
    (*w).group.y &= ~(1u << child_bit);
    if ((*w).group.y & 0xff000000u) != 0u {
        rt_walk_push(w, stack, (*w).group);
    }
    let slot = (child_bit - 24u) ^ ((*w).oct_inv4 & 0xffu);
    let node = (*w).group.x + countOneBits(hits & ~(0xffffffffu << slot));
    var n: RtNode;
    if (*w).in_blas {
        let b = ((*w).node_offset + node) * 5u;
        n = RtNode(blas_nodes[b], blas_nodes[b + 1u], blas_nodes[b + 2u], blas_nodes[b + 3u], blas_nodes[b + 4u]);
        if RT_COUNT_WORK {
            rt_work.z += 1u;
        }
    } else {
        let b = node * 5u;
        n = RtNode(tlas_nodes[b], tlas_nodes[b + 1u], tlas_nodes[b + 2u], tlas_nodes[b + 3u], tlas_nodes[b + 4u]);
        if RT_COUNT_WORK {
            rt_work.x += 1u;
        }
    }
    return n;
}

// The children of `n` that the walk's ray hits before its closest hit so far (rt_cwbvh_node_hits'
// mask).
fn rt_walk_node_hits(w: ptr<function, RtWalk>, n: RtNode) -> u32 {
    return rt_cwbvh_node_hits(n.n0, n.n1, n.n2, n.n3, n.n4, (*w).origin, (*w).dir, (*w).oct_inv4, (*w).ray.tmin, (*w).best.t);
}

// Makes the children in `hit_mask` (rt_cwbvh_node_hits' layout) the walk's group: the internal
// ones to visit next, the leaves' primitives to test (BLAS triangles, TLAS instances).
fn rt_walk_enter_node(w: ptr<function, RtWalk>, n: RtNode, hit_mask: u32) {
    let oct_inv4 = (*w).oct_inv4;
    (*w).group = vec2<u32>(n.n1.x, (hit_mask & 0xff000000u) | (n.n0.w >> 24u));
    (*w).prims = vec2<u32>(n.n1.y, select(rt_xor_permute8(hit_mask & 0xffu, oct_inv4 & 7u), hit_mask & 0x00ffffffu, (*w).in_blas));
}

// Whether the walk holds triangles to test (in a BLAS; rt_walk_prims tests them all).
fn rt_walk_wants_triangles(w: ptr<function, RtWalk>) -> bool {
    return (*w).in_blas && (*w).prims.y != 0u;
}

// Puts off the triangle tests the walk wants (rt_walk_wants_triangles), in place of a step's second
// half (Ylitie, Karras and Laine 2017, postponed triangle tests): with nodes left to visit, the
// triangles wait on the stack above them and the next step tests a node; without (or with a full
// stack), they stay and the next step does nothing but ask again. The closest hit's distance is
// the same (of two triangles at exactly that distance, the other may be found); the nodes and
// triangles tested may differ (a closer hit found later culls less).
fn rt_walk_postpone_triangles(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>) {
    if ((*w).group.y & 0xff000000u) != 0u && (*w).sp < RT_STACK_SIZE {
        rt_walk_push(w, stack, (*w).prims);
        (*w).prims = vec2<u32>(0u, 0u);
    }
}

// A step's second half: tests the triangles the node hit (BLAS) or enters the next instance it hit
// (TLAS), and pops the stack when the group is done; true when the walk is over.
fn rt_walk_prims(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>, any_hit: bool) -> bool {
    if (*w).in_blas {
        while (*w).prims.y != 0u {
            let local = firstLeadingBit((*w).prims.y);
            (*w).prims.y &= ~(1u << local);
            let index = (*w).triangle_offset + (*w).prims.x + local;
            if RT_COUNT_WORK {
                rt_work.w += 1u;
                rt_steps += 1u;
            }
            let h = rt_intersect_triangle(index, (*w).origin, (*w).tri_dir, (*w).ray.tmin, (*w).best.t);
            if h.hit && !(SCENE_HAS_ALPHA_TEST && (*w).alpha_tested && rt_alpha_cuts((*w).instance, index, h.barycentrics)) {
                (*w).best.t = h.t;
                (*w).best.instance = (*w).instance;
                (*w).best.barycentrics = h.barycentrics;
                (*w).best.front_face = h.front_face;
                (*w).best_triangle = index;
                if any_hit {
                    return true;
                }
            }
        }
    } else if (*w).prims.y != 0u {
        // TLAS entry bits are permuted by the octant (rt_xor_permute8).
        let bit = firstLeadingBit((*w).prims.y);
        (*w).prims.y &= ~(1u << bit);
        let entry = rt_tlas_entry((*w).prims.x + (bit ^ ((*w).oct_inv4 & 7u)));
        if RT_COUNT_WORK {
            rt_work.y += 1u;
        }
        // What is left of the TLAS walk waits on the stack; entries before nodes.
        if ((*w).group.y & 0xff000000u) != 0u {
            rt_walk_push(w, stack, (*w).group);
        }
        if (*w).prims.y != 0u {
            rt_walk_push(w, stack, (*w).prims);
        }
        (*w).tlas_sp = (*w).sp;
        (*w).in_blas = true;
        (*w).instance = entry.instance;
        (*w).alpha_tested = SCENE_HAS_ALPHA_TEST && rt_instance_alpha_tested(entry.instance);
        (*w).node_offset = entry.node_offset;
        (*w).triangle_offset = entry.triangle_offset;
        let local_from_world = instances[entry.instance].local_from_world;
        (*w).origin = (local_from_world * vec4<f32>((*w).ray.origin, 1.0)).xyz;
        (*w).tri_dir = (local_from_world * vec4<f32>((*w).ray.direction, 0.0)).xyz;
        (*w).dir = rt_safe_direction((*w).tri_dir);
        (*w).oct_inv4 = rt_octant_inv4((*w).dir);
        // The entry's start node (the BLAS root unless re-braided), as the only inner child of
        // a virtual parent (its one hit bit, no imask bits below it: the child index is the
        // base); the TLAS entries left wait on the stack.
        (*w).group = vec2<u32>(entry.start_node, 0x80000000u);
        (*w).prims = vec2<u32>(0u, 0u);
        return false;
    }
    if ((*w).group.y & 0xff000000u) == 0u && (*w).prims.y == 0u {
        if (*w).in_blas && (*w).sp == (*w).tlas_sp {
            (*w).in_blas = false;
            (*w).origin = (*w).ray.origin;
            (*w).dir = (*w).world_dir;
            (*w).oct_inv4 = (*w).world_oct;
        }
        if (*w).sp == 0u {
            return true;
        }
        let e = rt_walk_pop(w, stack);
        // Node groups have inner hit bits; TLAS entry groups do not.
        if (e.y & 0xff000000u) != 0u {
            (*w).group = e;
        } else {
            (*w).group = vec2<u32>(0u, 0u);
            (*w).prims = e;
        }
    }
    return false;
}

// The hit a finished walk found, its primitive (the mesh's triangle index) filled in.
fn rt_walk_hit(w: ptr<function, RtWalk>) -> RayHit {
    var best = (*w).best;
    if best.instance != RT_NO_HIT {
        best.primitive = bitcast<u32>(blas_triangles[(*w).best_triangle * 3u].w);
        // A static group's triangle names its member's instance (slot + 1; 0 in a mesh's BLAS).
        let member = bitcast<u32>(blas_triangles[(*w).best_triangle * 3u + 1u].w);
        if member != 0u {
            best.instance = member - 1u;
        }
    }
    return best;
}

// Closest hit (or any hit) of a ray: its walk (rt_walk_step) run to the end.
fn rt_trace(ray: Ray, any_hit: bool) -> RayHit {
    var walk = rt_walk_start(ray);
    var stack: array<vec2<u32>, RT_STACK_SIZE>;
    loop {
        if rt_walk_step(&walk, &stack, any_hit) {
            break;
        }
    }
    return rt_walk_hit(&walk);
}

fn trace_closest(ray: Ray) -> RayHit {
    return rt_trace(ray, false);
}

// True when anything lies on the ray within [tmin, tmax) (shadow rays).
fn trace_any(ray: Ray) -> bool {
    return rt_trace(ray, true).instance != RT_NO_HIT;
}

// Moves a ray origin off a surface along its geometric normal by a few float steps of the position's
// magnitude (Wächter and Binder, Ray Tracing Gems ch. 6), so shadow and bounce rays miss the surface
// they start on at any scene scale.
fn offset_ray_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let int_scale = 256.0;
    let float_scale = 1.0 / 65536.0;
    let origin = 1.0 / 32.0;
    let of_i = vec3<i32>(int_scale * n);
    let p_i = bitcast<vec3<f32>>(bitcast<vec3<i32>>(p) + select(of_i, -of_i, p < vec3<f32>(0.0)));
    return select(p_i, p + float_scale * n, abs(p) < vec3<f32>(origin));
}

// What a ray sees at a hit: position, normals facing the ray, and the material there.
struct HitSurface {
    position: vec3<f32>,
    // Shading normal (interpolated vertex normal, normal map applied), on the side the ray came from.
    normal: vec3<f32>,
    // Triangle normal, on the side the ray came from (for offsetting new rays).
    geometric_normal: vec3<f32>,
    uv: vec2<f32>,
    // Base colour.
    albedo: vec3<f32>,
    emissive: vec3<f32>,
    metallic: f32,
    roughness: f32,
    specular: f32,
}

fn hit_brdf_surface(s: HitSurface) -> BrdfSurface {
    return BrdfSurface(s.albedo, s.metallic, s.roughness, s.specular);
}

// Interpolates the hit triangle's attributes and evaluates its material (base colour and emission,
// textures included). Call only for hits (hit.instance != RT_NO_HIT).
fn hit_surface(ray: Ray, hit: RayHit) -> HitSurface {
    let instance = instances[hit.instance];
    let blas = blas_info[instance.mesh];
    let base = blas.first_index + 3u * hit.primitive;
    let a = vertices[indices[base] + blas.base_vertex];
    let b = vertices[indices[base + 1u] + blas.base_vertex];
    let c = vertices[indices[base + 2u] + blas.base_vertex];
    let w = vec3<f32>(1.0 - hit.barycentrics.x - hit.barycentrics.y, hit.barycentrics.x, hit.barycentrics.y);
    var out: HitSurface;
    out.position = ray.origin + ray.direction * hit.t;
    let facing = select(-1.0, 1.0, hit.front_face);
    let local_n = a.normal * w.x + b.normal * w.y + c.normal * w.z;
    let ng_local = cross(b.position - a.position, c.position - a.position);
    let fallback = -safe_normalize(ray.direction, vec3<f32>(0.0, 0.0, 1.0));
    out.geometric_normal = facing * safe_normalize(instance_normal_to_world(hit.instance, ng_local), fallback);
    out.normal = safe_normalize(instance_normal_to_world(hit.instance, local_n), out.geometric_normal);
    // Shade the side the ray sees: flip a vertex normal that points away from the ray.
    if dot(out.normal, out.geometric_normal) < 0.0 {
        out.normal = -out.normal;
    }
    out.uv = vec2<f32>(a.u, a.v) * w.x + vec2<f32>(b.u, b.v) * w.y + vec2<f32>(c.u, c.v) * w.z;
    let m = eval_material(instance.material, out.uv);
    if m.tangent_normal.x != 0.0 || m.tangent_normal.y != 0.0 {
        let tangent = instance_tangent_to_world(hit.instance, a.tangent * w.x + b.tangent * w.y + c.tangent * w.z);
        out.normal = apply_normal_map(out.normal, tangent, m.tangent_normal);
        // A bent normal never faces away from the side the ray sees.
        if dot(out.normal, out.geometric_normal) < 1e-3 {
            out.normal = safe_normalize(out.normal - out.geometric_normal * (dot(out.normal, out.geometric_normal) - 1e-3), out.geometric_normal);
        }
    }
    out.albedo = m.albedo;
    out.emissive = m.emissive;
    out.metallic = m.metallic;
    out.roughness = m.roughness;
    out.specular = m.specular;
    return out;
}
