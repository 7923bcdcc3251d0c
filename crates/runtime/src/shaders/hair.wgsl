// Hair strips with deep opacity maps (seed 004): hikage_runtime::hair::HairRenderer, mirrored
// by hikage_runtime::hair's CPU reference.
//
// Strips: two vertices per strand point, pushed apart across the strand in the vertex shader so
// the strip faces the viewer (the light in the light passes, the camera in the camera passes).
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
// Kajiya-Kay shading with the highlight where T.E = -T.L.

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
    step: f32,                  // layer step d, light NDC depth
    opacity_set: u32,           // the set drawn into the opacity maps: 0 shading, 1 opacity
    resolution: u32,            // opacity-map texels per side
    specular_power: f32,        // Kajiya-Kay exponent
    specular: f32,              // Kajiya-Kay specular strength
    layer_rule: u32,            // layer step: 0 the box's range / 10, 1 per texel
    lookup: u32,                // receivers: 0 nearest texel, 1 bilinear over 2x2 texels
    _pad: u32,
}

@group(0) @binding(0) var<uniform> hair: HairUniform;
@group(0) @binding(1) var hair_depth: texture_2d<f32>;
@group(0) @binding(2) var hair_layers: texture_2d<f32>;
@group(0) @binding(3) var hair_accum: texture_2d<f32>;
@group(0) @binding(4) var hair_revealage: texture_2d<f32>;

struct StripIn {
    @location(0) position: vec3<f32>,
    @location(1) side: f32,
    @location(2) tangent: vec3<f32>,
    @location(3) width: vec2<f32>,
    @location(4) opacity: vec2<f32>,
    @location(5) color: vec3<f32>,
}

// The strip vertex: the centre pushed half the width across the strand, facing `toward`.
fn hair_expand(p: vec3<f32>, side: f32, t: vec3<f32>, width: f32, toward: vec3<f32>) -> vec3<f32> {
    var across = cross(t, toward);
    if (length(across) < 1e-6) {
        across = cross(t, vec3<f32>(0.0, 0.0, 1.0));
        if (length(across) < 1e-6) {
            across = vec3<f32>(1.0, 0.0, 0.0);
        }
    }
    return p + normalize(across) * (side * 0.5 * width);
}

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
fn hair_kajiya_kay(t: vec3<f32>, to_light: vec3<f32>, to_eye: vec3<f32>, base: vec3<f32>, visibility: f32) -> vec3<f32> {
    let sin_l = sqrt(max(1.0 - dot(t, to_light) * dot(t, to_light), 0.0));
    let direct = hair.light_color.rgb * visibility;
    let spec = hair.specular * hair_specular(t, to_light, to_eye, hair.specular_power);
    return base * (hair.ambient.rgb + direct * sin_l) + direct * spec;
}

fn hair_set_width(v: StripIn) -> f32 {
    return select(v.width.x, v.width.y, hair.opacity_set == 1u);
}

fn hair_set_alpha(v: StripIn) -> f32 {
    return select(v.opacity.x, v.opacity.y, hair.opacity_set == 1u);
}

struct LightOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) alpha: f32,
}

@vertex
fn hair_vs_light(v: StripIn) -> LightOut {
    var out: LightOut;
    let w = hair_expand(v.position, v.side, v.tangent, hair_set_width(v), hair.to_light.xyz);
    out.clip = hair.light * vec4<f32>(w, 1.0);
    out.alpha = hair_set_alpha(v);
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
}

// The shading set, facing the camera.
@vertex
fn hair_vs_camera(v: StripIn) -> CameraOut {
    var out: CameraOut;
    let toward = normalize(hair.eye.xyz - v.position);
    let w = hair_expand(v.position, v.side, v.tangent, v.width.x, toward);
    out.clip = hair.camera * vec4<f32>(w, 1.0);
    out.world = w;
    out.tangent = v.tangent;
    out.color = v.color;
    out.alpha = v.opacity.x;
    return out;
}

// The lit colour of a camera fragment.
fn hair_shade(in: CameraOut) -> vec3<f32> {
    let t = normalize(in.tangent);
    let vis = hair_visibility(in.world);
    return hair_kajiya_kay(t, hair.to_light.xyz, normalize(hair.eye.xyz - in.world), in.color, vis);
}

// The weight of a fragment at view depth `z` with opacity `a` (McGuire & Bavoil 2013, eq. 10):
// nearer fragments weigh more where several overlap.
fn hair_oit_weight(z: f32, a: f32) -> f32 {
    return a * clamp(0.03 / (1e-5 + pow(z / 200.0, 4.0)), 1e-2, 3e3);
}

struct OitOut {
    @location(0) accum: vec4<f32>,
    @location(1) revealage: vec4<f32>,
}

@fragment
fn hair_fs_oit(in: CameraOut) -> OitOut {
    let c = hair_shade(in);
    let w = hair_oit_weight(in.clip.w, in.alpha);
    return OitOut(vec4<f32>(c * in.alpha * w, in.alpha * w), vec4<f32>(in.alpha));
}

@fragment
fn hair_fs_opaque(in: CameraOut) -> @location(0) vec4<f32> {
    return vec4<f32>(hair_shade(in), 1.0);
}

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
