// Relief mapping with depth maps (seed 003): four tracers, shadows and ambient occlusion.
// Mirrors hikage_runtime::relief (CPU reference) and hikage_bundle::relief (geometry) line by
// line. Space: u, v in texels of the heightfield (the map repeats), depth z in [0, 1] from the
// top plane down, the relief `thickness` texels deep. A ray is (origin on the top plane, unit
// direction with z > 0 going down), parameterised by its length s in texels.

struct ReliefUniform {
    size: vec2<u32>,        // heightfield width, height (powers of two)
    depth_size: vec2<u32>,  // depth-map width, height
    levels: u32,            // max-mip levels
    theta_rows: u32,        // zenith rows of the direction table
    phi_cols: u32,          // azimuths per row
    tracer: u32,            // 0 linear, 1 depth map, 2 max-mip, 3 depth map + max-mip
    thickness: f32,         // relief depth in texels
    steps: u32,             // linear / search steps over the full depth
    binary: u32,            // binary-search halvings
    start_level: u32,       // max-mip start level
    stop_level: u32,        // max-mip stop level
    margin: f32,            // share of the depth-map estimate stepped back (tracer 3)
    direction_rule: u32,    // 0 nearest row, 1 nearest row at or above the ray (toward the zenith)
    visibility: u32,        // shadows and AO: 0 stored depth then max-mip, 1 the seed's search
    visibility_steps: u32,  // seed visibility: search steps over the full depth
    visibility_binary: u32, // seed visibility: binary-search halvings
    _pad: vec2<u32>,
}

@group(0) @binding(0) var relief_heights: texture_2d<f32>;
@group(0) @binding(1) var relief_depths: texture_2d_array<f32>;
@group(0) @binding(2) var<uniform> relief: ReliefUniform;

const RELIEF_HALF_PI: f32 = 1.5707963267948966;
const RELIEF_TAU: f32 = 6.283185307179586;
const RELIEF_NUDGE: f32 = 1e-3;
const RELIEF_MAX_STEPS: u32 = 65536u;

struct ReliefRay {
    origin: vec2<f32>,
    dir: vec3<f32>,
}

// Reads made by the current invocation.
var<private> reads_height: u32;
var<private> reads_depth: u32;

fn relief_max_height(level: u32, i: i32, j: i32) -> f32 {
    let w = i32(relief.size.x >> level);
    let h = i32(relief.size.y >> level);
    return textureLoad(relief_heights, vec2<i32>(i & (w - 1), j & (h - 1)), i32(level)).r;
}

fn relief_dz(r: ReliefRay) -> f32 {
    return r.dir.z / relief.thickness;
}

fn relief_bottom(r: ReliefRay) -> f32 {
    return relief.thickness / r.dir.z;
}

fn relief_inside(r: ReliefRay, s: f32) -> bool {
    reads_height += 1u;
    let u = r.origin.x + s * r.dir.x;
    let v = r.origin.y + s * r.dir.y;
    let z = s * relief_dz(r);
    return z >= 1.0 - relief_max_height(0u, i32(floor(u)), i32(floor(v)));
}

fn relief_direction(layer: u32) -> vec3<f32> {
    let i = layer / relief.phi_cols;
    let j = layer % relief.phi_cols;
    let theta = (f32(i) + 0.5) * RELIEF_HALF_PI / f32(relief.theta_rows);
    let phi = RELIEF_TAU * f32(j) / f32(relief.phi_cols);
    return vec3<f32>(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

// The layer a ray's estimate is read from (hikage_bundle::relief::ReliefDirections::pick).
fn relief_pick(d: vec3<f32>) -> u32 {
    let horizontal = sqrt(d.x * d.x + d.y * d.y);
    let theta = atan2(horizontal, max(d.z, 0.0));
    let rows = theta / RELIEF_HALF_PI * f32(relief.theta_rows);
    var row = i32(ceil(rows)) - 1;
    if relief.direction_rule == 1u {
        row = i32(floor(rows - 0.5));
    }
    row = clamp(row, 0, i32(relief.theta_rows) - 1);
    var phi = atan2(d.y, d.x);
    if phi < 0.0 {
        phi = phi + RELIEF_TAU;
    }
    let col = u32(floor(phi / RELIEF_TAU * f32(relief.phi_cols) + 0.5)) % relief.phi_cols;
    return u32(row) * relief.phi_cols + col;
}

fn relief_depth_at(layer: u32, u: f32, v: f32) -> f32 {
    reads_depth += 1u;
    let dw = i32(relief.depth_size.x);
    let dh = i32(relief.depth_size.y);
    let i = i32(floor(u * f32(relief.depth_size.x) / f32(relief.size.x)));
    let j = i32(floor(v * f32(relief.depth_size.y) / f32(relief.size.y)));
    let ii = ((i % dw) + dw) % dw;
    let jj = ((j % dh) + dh) % dh;
    return textureLoad(relief_depths, vec2<i32>(ii, jj), i32(layer), 0).r;
}

// Seed's estimate: the picked direction's stored hit, projected onto the view ray.
fn relief_estimate(r: ReliefRay) -> f32 {
    let layer = relief_pick(r.dir);
    let k = relief_direction(layer);
    let d = relief_depth_at(layer, r.origin.x, r.origin.y);
    let along_sample = d * relief.thickness / k.z;
    let c = k.x * r.dir.x + k.y * r.dir.y + k.z * r.dir.z;
    return clamp(along_sample * c, 0.0, relief_bottom(r));
}

fn relief_bisect(r: ReliefRay, lo_in: f32, hi_in: f32, n: u32) -> f32 {
    var lo = lo_in;
    var hi = hi_in;
    for (var k = 0u; k < n; k = k + 1u) {
        let mid = 0.5 * (lo + hi);
        if relief_inside(r, mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    return 0.5 * (lo + hi);
}

fn relief_exit(o: f32, d: f32, inv: f32, c: f32, size: f32) -> f32 {
    if d == 0.0 {
        return 3.0e38;
    }
    var wall = c * size;
    if d > 0.0 {
        wall = (c + 1.0) * size;
    }
    return (wall - o) * inv;
}

// Max-mip traversal (hikage_bundle::relief::first_hit_maxmip).
fn relief_maxmip(r: ReliefRay, s_start: f32, s_stop: f32, start_level: u32, stop_level: u32) -> f32 {
    let top = relief.levels - 1u;
    let stop = min(stop_level, top);
    var level = clamp(start_level, stop, top);
    let dz = relief_dz(r);
    let s_end = min(s_stop, relief_bottom(r));
    var s = max(s_start, 0.0);
    var ix = 3.0e38;
    var iy = 3.0e38;
    if r.dir.x != 0.0 {
        ix = 1.0 / r.dir.x;
    }
    if r.dir.y != 0.0 {
        iy = 1.0 / r.dir.y;
    }
    for (var n = 0u; n < RELIEF_MAX_STEPS; n = n + 1u) {
        if s >= s_end {
            return s_end;
        }
        let size = f32(1u << level);
        let inv_size = 1.0 / size;
        let ahead = s + RELIEF_NUDGE;
        let ci = floor((r.origin.x + ahead * r.dir.x) * inv_size);
        let cj = floor((r.origin.y + ahead * r.dir.y) * inv_size);
        reads_height += 1u;
        let top_depth = 1.0 - relief_max_height(level, i32(ci), i32(cj));
        if s * dz >= top_depth {
            if level == stop {
                return s;
            }
            level = level - 1u;
            continue;
        }
        let s_top = top_depth / dz;
        let s_exit = min(relief_exit(r.origin.x, r.dir.x, ix, ci, size), relief_exit(r.origin.y, r.dir.y, iy, cj, size));
        if s_top <= s_exit {
            s = s_top;
            if level == stop {
                return min(s, s_end);
            }
            level = level - 1u;
        } else {
            s = max(s_exit, s);
            level = min(level + 1u, top);
        }
    }
    return min(s, s_end);
}

// The seed's search from an estimate: backward while inside, forward while outside, in steps of
// 1/steps of the depth, then binary halvings.
fn relief_search(r: ReliefRay, s0: f32, steps: u32, binary: u32) -> f32 {
    let bottom = relief_bottom(r);
    let ds = bottom / f32(max(steps, 1u));
    var lo = 0.0;
    var hi = bottom;
    if relief_inside(r, s0) {
        hi = s0;
        lo = 0.0;
        loop {
            if hi <= 0.0 {
                break;
            }
            let s = max(hi - ds, 0.0);
            if s <= 0.0 || !relief_inside(r, s) {
                lo = s;
                break;
            }
            hi = s;
        }
    } else {
        lo = s0;
        hi = bottom;
        loop {
            let s = lo + ds;
            if s >= bottom {
                break;
            }
            if relief_inside(r, s) {
                hi = s;
                break;
            }
            lo = s;
        }
    }
    return relief_bisect(r, lo, hi, binary);
}

// The hit length the tracer chosen in `relief` finds.
fn relief_trace(r: ReliefRay) -> f32 {
    let bottom = relief_bottom(r);
    let ds = bottom / f32(max(relief.steps, 1u));
    switch relief.tracer {
        case 0u: {
            var lo = 0.0;
            var hi = bottom;
            for (var k = 1u; k < relief.steps; k = k + 1u) {
                let s = f32(k) * ds;
                if relief_inside(r, s) {
                    hi = s;
                    break;
                }
                lo = s;
            }
            return relief_bisect(r, lo, hi, relief.binary);
        }
        case 1u: {
            return relief_search(r, relief_estimate(r), relief.steps, relief.binary);
        }
        case 2u: {
            return relief_maxmip(r, 0.0, 3.0e38, relief.start_level, relief.stop_level);
        }
        default: {
            let s0 = relief_estimate(r) * (1.0 - relief.margin);
            return relief_maxmip(r, s0, 3.0e38, relief.start_level, 0u);
        }
    }
}

// The shading normal at a point of the relief (texels, z up): central differences of the
// heights around its texel (hikage_runtime::relief::ReliefMaps::normal).
fn relief_normal(p: vec3<f32>) -> vec3<f32> {
    let i = i32(floor(p.x));
    let j = i32(floor(p.y));
    let k = 0.5 * relief.thickness;
    return normalize(vec3<f32>(
        (relief_max_height(0u, i - 1, j) - relief_max_height(0u, i + 1, j)) * k,
        (relief_max_height(0u, i, j - 1) - relief_max_height(0u, i, j + 1)) * k,
        1.0,
    ));
}

// Where the ray from the top plane toward -`toward` (unit, z up) reaching `uvz` enters.
fn relief_entry(uvz: vec3<f32>, toward: vec3<f32>) -> vec2<f32> {
    let back = uvz.z * relief.thickness / toward.z;
    return vec2<f32>(uvz.x + back * toward.x, uvz.y + back * toward.y);
}

// The max-mip path's decision for a ray whose stored hit is `stored`: open when the stored hit is
// not above `depth`; otherwise when a max-mip traversal from the stored depth (pulled back 10%)
// down to `depth` meets nothing.
fn relief_open_after(r: ReliefRay, stored: f32, depth: f32) -> bool {
    if stored >= depth {
        return true;
    }
    let dz = relief_dz(r);
    let s_point = max(depth, 0.0) / dz;
    let s_start = stored / dz * 0.9;
    return relief_maxmip(r, s_start, s_point, 2u, 0u) >= s_point;
}

// Is the point lit from `light` (unit, z up)? By the visibility path chosen in `relief`: the
// stored depth, then a max-mip traversal from it to the point; or the seed's search from the
// estimate. A hit within `bias` (depth) above the point counts as the point.
fn relief_lit(uvz: vec3<f32>, light: vec3<f32>, bias: f32) -> bool {
    if light.z <= 0.0 {
        return false;
    }
    let entry = relief_entry(uvz, light);
    let dir = vec3<f32>(-light.x, -light.y, light.z);
    let r = ReliefRay(entry, dir);
    if relief.visibility == 1u {
        let s0 = relief_estimate(r);
        return relief_search(r, s0, relief.visibility_steps, relief.visibility_binary) * relief_dz(r) >= uvz.z - bias;
    }
    let layer = relief_pick(dir);
    let stored = relief_depth_at(layer, entry.x, entry.y);
    return relief_open_after(r, stored, uvz.z - bias);
}

// Cosine-weighted open share of the hemisphere over every `stride`-th direction, each decided
// by the visibility path as relief_lit does (the layer's own direction: its stored hit is the
// estimate).
fn relief_ambient_occlusion(uvz: vec3<f32>, stride: u32, bias: f32) -> f32 {
    var open = 0.0;
    var total = 0.0;
    let layers = relief.theta_rows * relief.phi_cols;
    for (var layer = 0u; layer < layers; layer = layer + max(stride, 1u)) {
        let k = relief_direction(layer);
        let up = vec3<f32>(-k.x, -k.y, k.z);
        let w = k.z * sqrt(k.x * k.x + k.y * k.y);
        let entry = relief_entry(uvz, up);
        let stored = relief_depth_at(layer, entry.x, entry.y);
        let r = ReliefRay(entry, k);
        var seen = false;
        if relief.visibility == 1u {
            let dz = relief_dz(r);
            seen = relief_search(r, stored / dz, relief.visibility_steps, relief.visibility_binary) * dz >= uvz.z - bias;
        } else {
            seen = relief_open_after(r, stored, uvz.z - bias);
        }
        if seen {
            open = open + w;
        }
        total = total + w;
    }
    if total > 0.0 {
        return open / total;
    }
    return 1.0;
}
