// Hair strips with deep opacity maps (seed 004): hikage_runtime::hair::HairRenderer, mirrored
// by hikage_runtime::hair's CPU reference.
//
// Strips: one 32-byte record per strand point; each instance draws the segment from record i
// to record i + 1 as a 4-vertex triangle strip, pushed apart across the strand in the vertex
// shader so it faces the viewer (the light in the light passes, the camera in the camera
// passes). A record whose point is the last of its strand draws nothing. Levels of detail draw
// the first strands of the records (stored in a shuffled order) widened by strands / kept.
// In the camera passes a strip narrower than `min_pixel_width` pixels is widened to it with
// its opacity lowered by the same factor, so width x opacity (its coverage) is kept.
// Light passes, orthographic, depth range = the hair's bounding box:
//   1. depth map: the nearest hair depth z0 per texel (R32Float);
//   2. opacity layers: every fragment adds its opacity to each layer whose far boundary lies
//      beyond it (cumulative, additive blending into a float target). Boundaries from z0 at
//      integer multiples of d: z0 + d, z0 + 3d, z0 + 6d, z0 + 10d (layer k is k d deep); d is
//      the box's depth range / 10, or per texel the span from z0 to where the texel's light
//      ray leaves the box, / 10.
// Receivers read the light reaching a point with hair_visibility: the cumulative opacity at
// its depth, interpolated between boundaries; visibility = 1 - min(opacity, 1), at the nearest
// texel or filtered over the 2x2 texels around the point.
// Camera: the shading set blended at its own opacity, order-independently (weighted blended
// OIT: an accumulation and a revealage target, then a composite over the scene), or opaque;
// Kajiya-Kay shading with the highlight where T.E = -T.L. A fragment's weight is the light its
// pixel's hair in front of it lets through: exp(-opacity in front), read from 8 cumulative
// camera layers of view depth (a pass before the blend; boundaries at the box's nearest
// distance + its depth range x k(k+1)/72, k = 1..8), or, without that pass, falling with the
// fragment's depth across the hair's box by the hair's mean optical depth.

struct HairUniform {
    light: mat4x4<f32>,         // world -> light clip (orthographic, wgpu depth 0..1)
    light_inverse: mat4x4<f32>, // light clip -> world
    bounds_min: vec4<f32>,      // the hair's bounding box (world)
    bounds_max: vec4<f32>,
    camera: mat4x4<f32>,        // world -> camera clip
    eye: vec4<f32>,             // camera position (world)
    to_light: vec4<f32>,        // unit vector toward the light
    light_color: vec4<f32>,     // rgb
    ambient: vec4<f32>,         // rgb
    root_tint: vec4<f32>,       // rgb: colour factor at the root; a: opacity factor at the root
    tip_tint: vec4<f32>,        // the same at the tip (mixed by param)
    step: f32,                  // layer step d, light NDC depth
    opacity_set: u32,           // the set drawn into the opacity maps: 0 shading, 1 opacity
    resolution: u32,            // opacity-map texels per side
    specular_power: f32,        // Kajiya-Kay exponent
    specular: f32,              // Kajiya-Kay specular strength
    layer_rule: u32,            // layer step: 0 the box's range / 10, 1 per texel
    lookup: u32,                // receivers: 0 nearest texel, 1 bilinear over 2x2 texels
    max_width: f32,             // a record's shape.x scale (world units)
    width_ratio: f32,           // opacity set / shading set width
    alpha_ratio: f32,           // opacity set / shading set opacity
    taper: f32,                 // width x (1 - taper x param)
    min_pixel_width: f32,       // camera passes: narrowest strip in pixels (0: off)
    viewport: vec2<f32>,        // camera target size in pixels
    depth_range: vec2<f32>,     // view depth (clip w) of the hair's box: nearest, farthest
    camera_widen: f32,          // level of detail: width factor of the camera passes
    light_widen: f32,           // level of detail: width factor of the light passes
    color_variation: f32,       // per-strand brightness spread (0: none)
    oit_falloff: f32,           // the blend's weight: exp(-oit_falloff x depth across the box)
    model: mat4x4<f32>,         // the hair's frame (as baked) -> world: where the strands are drawn
    model_width: f32,           // factor on widths: cube root of the model's 3x3 determinant
}

@group(0) @binding(0) var<uniform> hair: HairUniform;
@group(0) @binding(1) var hair_depth: texture_2d<f32>;
@group(0) @binding(2) var hair_layers: texture_2d<f32>;

// One instance: the records of a segment's two points (the same buffer bound twice, one record
// apart).
struct SegmentIn {
    @builtin(vertex_index) corner: u32,
    @location(0) a_position: vec3<f32>,
    @location(1) a_tangent: vec2<f32>,
    @location(2) a_shape: vec2<f32>,
    @location(3) a_color: vec4<f32>,
    @location(4) a_strand: vec2<u32>,
    @location(5) a_id: u32,
    @location(6) b_position: vec3<f32>,
    @location(7) b_tangent: vec2<f32>,
    @location(8) b_shape: vec2<f32>,
    @location(9) b_color: vec4<f32>,
    @location(10) b_strand: vec2<u32>,
    @location(11) b_id: u32,
}

// A strand point as the passes use it.
struct HairPoint {
    position: vec3<f32>,
    tangent: vec3<f32>,
    width: f32,   // full width of the drawn set, tapered, widened by the level of detail
    alpha: f32,   // opacity of the drawn set
    color: vec3<f32>,
    drawn: bool,  // false: the segment from this point does not exist (last point of a strand)
}

fn hair_srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

// A strand's brightness factor from its id: 1 +- color_variation / 2, the same for every point.
fn hair_strand_variation(id: u32) -> f32 {
    var h = id * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return 1.0 + hair.color_variation * (f32(h) / 4294967295.0 - 0.5);
}

// A record's point in world space (through the model matrix), in the set the pass draws
// (`opacity_set`), at the pass's widening.
fn hair_point(position: vec3<f32>, tangent: vec2<f32>, shape: vec2<f32>, color: vec4<f32>, strand: vec2<u32>,
    id: u32, opacity_set: bool, widen: f32) -> HairPoint {
    let param = select(f32(strand.x) / f32(strand.y), 0.0, strand.y == 0u);
    var width = shape.x * hair.max_width * (1.0 - hair.taper * param) * widen;
    var alpha = shape.y * mix(hair.root_tint.a, hair.tip_tint.a, param);
    if (opacity_set) {
        width = width * hair.width_ratio;
        alpha = min(alpha * hair.alpha_ratio, 1.0);
    }
    let tint = mix(hair.root_tint.rgb, hair.tip_tint.rgb, param) * hair_strand_variation(id);
    let linear = hair_srgb_to_linear(color.rgb) * tint;
    let world = (hair.model * vec4<f32>(position, 1.0)).xyz;
    let t = normalize((hair.model * vec4<f32>(hair_oct_decode(tangent), 0.0)).xyz);
    return HairPoint(world, t, width * hair.model_width, alpha, linear, strand.x < strand.y);
}

// The segment's end this corner belongs to (corners 0, 1 at a; 2, 3 at b), and its side.
fn hair_end(v: SegmentIn, opacity_set: bool, widen: f32) -> HairPoint {
    let a = hair_point(v.a_position, v.a_tangent, v.a_shape, v.a_color, v.a_strand, v.a_id, opacity_set, widen);
    if (v.corner < 2u) {
        return a;
    }
    var b = hair_point(v.b_position, v.b_tangent, v.b_shape, v.b_color, v.b_strand, v.b_id, opacity_set, widen);
    b.drawn = a.drawn;
    return b;
}

fn hair_side(corner: u32) -> f32 {
    return select(-1.0, 1.0, (corner & 1u) == 1u);
}

// The unit vector across a strand of tangent t, facing `toward`.
fn hair_across(t: vec3<f32>, toward: vec3<f32>) -> vec3<f32> {
    var across = cross(t, toward);
    if (length(across) < 1e-6) {
        across = cross(t, vec3<f32>(0.0, 0.0, 1.0));
        if (length(across) < 1e-6) {
            across = vec3<f32>(1.0, 0.0, 0.0);
        }
    }
    return normalize(across);
}

// Where a segment that does not exist goes: outside every clip volume.
const HAIR_CULLED: vec4<f32> = vec4<f32>(0.0, 0.0, -2.0, 1.0);

// Light NDC depth where the light's ray through NDC (x, y) leaves the hair's box; 1 on a miss.
fn hair_box_exit(xy: vec2<f32>) -> f32 {
    let a = hair.light_inverse * vec4<f32>(xy, 0.0, 1.0);
    let b = hair.light_inverse * vec4<f32>(xy, 1.0, 1.0);
    let p0 = a.xyz / a.w;
    let dp = b.xyz / b.w - p0;
    var enter = 0.0;
    var exit = 1.0;
    for (var axis = 0; axis < 3; axis = axis + 1) {
        if (abs(dp[axis]) < 1e-9) {
            continue;
        }
        let t1 = (hair.bounds_min[axis] - p0[axis]) / dp[axis];
        let t2 = (hair.bounds_max[axis] - p0[axis]) / dp[axis];
        enter = max(enter, min(t1, t2));
        exit = min(exit, max(t1, t2));
    }
    if (enter > exit) {
        return 1.0;
    }
    return exit;
}

// Layer step d of the texel whose centre is at light NDC (x, y), above its nearest hair z0.
fn hair_step(xy: vec2<f32>, z0: f32) -> f32 {
    if (hair.layer_rule == 0u) {
        return hair.step;
    }
    return max(hair_box_exit(xy) - z0, 1e-6) / 10.0;
}

// Light NDC (x, y) of the centre of texel `ij`.
fn hair_texel_ndc(ij: vec2<i32>) -> vec2<f32> {
    let r = f32(hair.resolution);
    return vec2<f32>((f32(ij.x) + 0.5) / r * 2.0 - 1.0, 1.0 - (f32(ij.y) + 0.5) / r * 2.0);
}

// Far boundary of layer k (1-based) above the nearest hair depth z0, layer step d.
fn hair_boundary(z0: f32, d: f32, k: u32) -> f32 {
    return z0 + d * f32(k * (k + 1u) / 2u);
}

// Light reaching depth z (light NDC) through texel ij: 1 - the cumulative opacity in front.
fn hair_texel_visibility(ij: vec2<i32>, z: f32) -> f32 {
    let r = i32(hair.resolution);
    if (ij.x < 0 || ij.y < 0 || ij.x >= r || ij.y >= r) {
        return 1.0;
    }
    let z0 = textureLoad(hair_depth, ij, 0).r;
    if (z <= z0) {
        return 1.0;
    }
    let d = hair_step(hair_texel_ndc(ij), z0);
    let layers = textureLoad(hair_layers, ij, 0);
    var opacity = layers.w;
    var lo = z0;
    var before = 0.0;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let hi = hair_boundary(z0, d, k + 1u);
        if (z < hi) {
            opacity = mix(before, layers[k], (z - lo) / max(hi - lo, 1e-9));
            break;
        }
        lo = hi;
        before = layers[k];
    }
    return 1.0 - min(opacity, 1.0);
}

// Light reaching a world point through the opacity maps, at the nearest texel or filtered over
// the 2x2 texels around it.
fn hair_visibility(world: vec3<f32>) -> f32 {
    let c = hair.light * vec4<f32>(world, 1.0);
    let ndc = c.xyz / c.w;
    let r = f32(hair.resolution);
    let texel = vec2<f32>((ndc.x * 0.5 + 0.5) * r, (0.5 - ndc.y * 0.5) * r);
    if (hair.lookup == 0u) {
        return hair_texel_visibility(vec2<i32>(floor(texel)), ndc.z);
    }
    let base = floor(texel - 0.5);
    let f = texel - 0.5 - base;
    let ij = vec2<i32>(base);
    let top = mix(hair_texel_visibility(ij, ndc.z), hair_texel_visibility(ij + vec2<i32>(1, 0), ndc.z), f.x);
    let bottom = mix(hair_texel_visibility(ij + vec2<i32>(0, 1), ndc.z), hair_texel_visibility(ij + vec2<i32>(1, 1), ndc.z), f.x);
    return mix(top, bottom, f.y);
}

// The Kajiya-Kay specular lobe: 1 on the cone of mirror directions around the tangent, where
// T.E = -T.L (sin_l sin_e - tl te is the cosine of the angle to that cone).
fn hair_specular(t: vec3<f32>, to_light: vec3<f32>, to_eye: vec3<f32>, power: f32) -> f32 {
    let tl = dot(t, to_light);
    let te = dot(t, to_eye);
    let sin_l = sqrt(max(1.0 - tl * tl, 0.0));
    let sin_e = sqrt(max(1.0 - te * te, 0.0));
    return pow(max(sin_l * sin_e - tl * te, 0.0), power);
}

// Kajiya-Kay shading of a strand of colour `base`: diffuse by the sine between tangent and
// light, the specular lobe, both scaled by the light's visibility; ambient light unshadowed.
// Each channel saturates at 1, so the blend's weighted mean of fragments never resolves above 1.
fn hair_kajiya_kay(t: vec3<f32>, to_light: vec3<f32>, to_eye: vec3<f32>, base: vec3<f32>, visibility: f32) -> vec3<f32> {
    let sin_l = sqrt(max(1.0 - dot(t, to_light) * dot(t, to_light), 0.0));
    let direct = hair.light_color.rgb * visibility;
    let spec = hair.specular * hair_specular(t, to_light, to_eye, hair.specular_power);
    return min(base * (hair.ambient.rgb + direct * sin_l) + direct * spec, vec3<f32>(1.0));
}

struct LightOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) alpha: f32,
}

@vertex
fn hair_vs_light(v: SegmentIn) -> LightOut {
    var out: LightOut;
    let p = hair_end(v, hair.opacity_set == 1u, hair.light_widen);
    let w = p.position + hair_across(p.tangent, hair.to_light.xyz) * (hair_side(v.corner) * 0.5 * p.width);
    out.clip = select(HAIR_CULLED, hair.light * vec4<f32>(w, 1.0), p.drawn);
    out.alpha = p.alpha;
    return out;
}

@fragment
fn hair_fs_depth(in: LightOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.clip.z, 0.0, 0.0, 1.0);
}

@fragment
fn hair_fs_opacity(in: LightOut) -> @location(0) vec4<f32> {
    let ij = vec2<i32>(floor(in.clip.xy));
    let z0 = textureLoad(hair_depth, ij, 0).r;
    let d = hair_step(hair_texel_ndc(ij), z0);
    let z = in.clip.z;
    var out = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k = k + 1u) {
        if (z < hair_boundary(z0, d, k + 1u)) {
            out[k] = in.alpha;
        }
    }
    return out;
}

struct CameraOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) tangent: vec3<f32>,
    @location(2) color: vec3<f32>,
    @location(3) alpha: f32,
    @location(4) view_depth: f32,
    @location(5) across_px: f32, // pixels from the strip's centre line, signed
    @location(6) footprint: f32, // the strip's width in pixels (0: drawn as it is)
}

// Pixels across a strip `width` wide at `p`, along `across`, seen by the camera.
fn hair_pixel_width(p: vec3<f32>, across: vec3<f32>, width: f32) -> f32 {
    let c0 = hair.camera * vec4<f32>(p, 1.0);
    let c1 = hair.camera * vec4<f32>(p + across * width, 1.0);
    if (c0.w <= 0.0 || c1.w <= 0.0) {
        return 0.0;
    }
    return length((c1.xy / c1.w - c0.xy / c0.w) * 0.5 * hair.viewport);
}

// A camera vertex of the shading set. With `filtered`, the strip is at least `min_pixel_width`
// pixels wide — a thinner one widened with its opacity lowered by the same factor, so its
// coverage (width x opacity) is kept — and drawn a pixel wider, the fragment shader weighting
// each pixel by how much of it the strip covers across (a box-filtered edge).
fn hair_camera_vertex(v: SegmentIn, filtered: bool) -> CameraOut {
    var out: CameraOut;
    let p = hair_end(v, false, hair.camera_widen);
    let across = hair_across(p.tangent, normalize(hair.eye.xyz - p.position));
    var width = p.width;
    var alpha = p.alpha;
    var footprint = 0.0;
    let pixels = hair_pixel_width(p.position, across, width);
    if (filtered && hair.min_pixel_width > 0.0 && pixels > 0.0) {
        footprint = max(pixels, hair.min_pixel_width);
        alpha = alpha * pixels / footprint;
        width = width * (footprint + 1.0) / pixels;
    }
    let side = hair_side(v.corner);
    let w = p.position + across * (side * 0.5 * width);
    let clip = hair.camera * vec4<f32>(w, 1.0);
    out.clip = select(HAIR_CULLED, clip, p.drawn);
    out.world = w;
    out.tangent = p.tangent;
    out.color = p.color;
    out.alpha = alpha;
    out.view_depth = length(w - hair.eye.xyz);
    out.across_px = side * 0.5 * (footprint + 1.0) * f32(footprint > 0.0);
    out.footprint = footprint;
    return out;
}

// The shading set facing the camera, filtered (the blended pass).
@vertex
fn hair_vs_camera(v: SegmentIn) -> CameraOut {
    return hair_camera_vertex(v, true);
}

// The shading set facing the camera at its own width (the opaque draw).
@vertex
fn hair_vs_camera_opaque(v: SegmentIn) -> CameraOut {
    return hair_camera_vertex(v, false);
}

// The share of a pixel a filtered strip covers across: the overlap of the pixel's span with
// the strip's; 1 for a strip drawn as it is.
fn hair_coverage(in: CameraOut) -> f32 {
    if (in.footprint <= 0.0) {
        return 1.0;
    }
    let d = abs(in.across_px);
    return clamp(min(d + 0.5, 0.5 * in.footprint) - max(d - 0.5, -0.5 * in.footprint), 0.0, 1.0);
}

// The lit colour of a camera fragment.
fn hair_shade(in: CameraOut) -> vec3<f32> {
    let t = normalize(in.tangent);
    let vis = hair_visibility(in.world);
    return hair_kajiya_kay(t, hair.to_light.xyz, normalize(hair.eye.xyz - in.world), in.color, vis);
}

// The weight of a fragment at view depth `z` with opacity `a` in the order-independent blend:
// the light a ray keeps after crossing the hair in front of it, exp(-oit_falloff x t) at the
// share t of the hair box's depth, `oit_falloff` being the hair's optical depth across the box
// (twice its opacity-weighted area over the box's volume, times the box's depth); so dense hair's
// outer layer outweighs its self-shadowed inner ones as sorting would, and sparse hair blends
// evenly. Bounded in [1e-4, 1]: no realistic fragment count overflows a half-float
// accumulator.
fn hair_oit_weight(z: f32, a: f32) -> f32 {
    let t = clamp((z - hair.depth_range.x) / max(hair.depth_range.y - hair.depth_range.x, 1e-6), 0.0, 1.0);
    return a * max(exp(-hair.oit_falloff * t), 1e-4);
}

// The camera's opacity layers (the blend weighted by them): the cumulative opacity of the hair
// in each pixel up to the far boundaries of layers 1-4 and 5-8.
@group(0) @binding(5) var hair_camera_near: texture_2d<f32>;
@group(0) @binding(6) var hair_camera_far: texture_2d<f32>;

// Far boundary of camera layer k (1-based, 1..8), view depth: the box's depth range in 36 parts
// from its nearest point, layer k being k parts deep so near layers are thin.
fn hair_camera_boundary(k: u32) -> f32 {
    let range = max(hair.depth_range.y - hair.depth_range.x, 1e-6);
    return hair.depth_range.x + range * f32(k * (k + 1u) / 2u) / 36.0;
}

struct CameraLayersOut {
    @location(0) near: vec4<f32>,
    @location(1) far: vec4<f32>,
}

// The camera layers pass: a fragment adds its opacity to every layer whose far boundary lies
// beyond it (additive blending).
@fragment
fn hair_fs_camera_layers(in: CameraOut) -> CameraLayersOut {
    let alpha = in.alpha * hair_coverage(in);
    var out = CameraLayersOut(vec4<f32>(0.0), vec4<f32>(0.0));
    for (var k = 0u; k < 4u; k = k + 1u) {
        if (in.view_depth < hair_camera_boundary(k + 1u)) {
            out.near[k] = alpha;
        }
        if (in.view_depth < hair_camera_boundary(k + 5u)) {
            out.far[k] = alpha;
        }
    }
    return out;
}

// The opacity of the hair in front of view depth z in pixel p: the camera layers interpolated
// between their boundaries (0 at the box's nearest point).
fn hair_opacity_in_front(p: vec2<i32>, z: f32) -> f32 {
    let a = textureLoad(hair_camera_near, p, 0);
    let b = textureLoad(hair_camera_far, p, 0);
    var layers = array<f32, 8>(a.x, a.y, a.z, a.w, b.x, b.y, b.z, b.w);
    var lo = hair.depth_range.x;
    var before = 0.0;
    for (var k = 0u; k < 8u; k = k + 1u) {
        let hi = hair_camera_boundary(k + 1u);
        if (z < hi) {
            return mix(before, layers[k], clamp((z - lo) / max(hi - lo, 1e-9), 0.0, 1.0));
        }
        lo = hi;
        before = layers[k];
    }
    return layers[7];
}

// The weight of a fragment of opacity `a` at view depth `z` in pixel p, from the camera layers:
// the light the hair in front of it lets through, exp(-opacity), bounded in [1e-4, 1] like
// hair_oit_weight.
fn hair_layered_weight(p: vec2<i32>, z: f32, a: f32) -> f32 {
    return a * max(exp(-hair_opacity_in_front(p, z)), 1e-4);
}

struct OitOut {
    @location(0) accum: vec4<f32>,
    @location(1) revealage: vec4<f32>,
}

@fragment
fn hair_fs_oit(in: CameraOut) -> OitOut {
    let c = hair_shade(in);
    let alpha = in.alpha * hair_coverage(in);
    let w = hair_oit_weight(in.view_depth, alpha);
    return OitOut(vec4<f32>(c * alpha * w, alpha * w), vec4<f32>(alpha));
}

@fragment
fn hair_fs_oit_layered(in: CameraOut) -> OitOut {
    let c = hair_shade(in);
    let alpha = in.alpha * hair_coverage(in);
    let w = hair_layered_weight(vec2<i32>(floor(in.clip.xy)), in.view_depth, alpha);
    return OitOut(vec4<f32>(c * alpha * w, alpha * w), vec4<f32>(alpha));
}

@fragment
fn hair_fs_opaque(in: CameraOut) -> @location(0) vec4<f32> {
    return vec4<f32>(hair_shade(in), 1.0);
}

// The order-independent blend's targets, read by the composite.
@group(0) @binding(3) var hair_accum: texture_2d<f32>;
@group(0) @binding(4) var hair_revealage: texture_2d<f32>;

struct CompositeOut {
    @builtin(position) clip: vec4<f32>,
}

@vertex
fn hair_vs_composite(@builtin(vertex_index) i: u32) -> CompositeOut {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return CompositeOut(vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0));
}

// The accumulated hair over the scene: the weighted mean colour at coverage 1 - revealage,
// premultiplied (so a highlight above 1 is not clamped before it is scaled by the coverage).
@fragment
fn hair_fs_composite(in: CompositeOut) -> @location(0) vec4<f32> {
    let p = vec2<i32>(floor(in.clip.xy));
    let revealage = textureLoad(hair_revealage, p, 0).r;
    if (revealage >= 1.0) {
        discard;
    }
    let accum = textureLoad(hair_accum, p, 0);
    let coverage = 1.0 - revealage;
    return vec4<f32>(accum.rgb / max(accum.a, 1e-5) * coverage, coverage);
}
