// Hair strips with deep opacity maps (seed 004). Mirrors hikage_runtime::hair.
//
// Strips: two vertices per strand point, pushed apart across the strand in the vertex shader so
// the strip faces the viewer (the light in the light passes, the camera in the final pass).
// Light passes, orthographic, depth range = the hair's bounding box:
//   1. depth map: the nearest hair depth z0 per texel (R32Float);
//   2. opacity layers: every fragment adds its opacity to each layer whose far boundary lies
//      beyond it (cumulative, additive blending into a float target). Boundaries from z0 at
//      integer multiples of d: z0 + d, z0 + 3d, z0 + 6d, z0 + 10d (layer k is k·d deep, so far
//      layers are wider), d = (bounding box depth range) / 10.
// Shading: the cumulative opacity at a point's depth, interpolated between boundaries,
// visibility = 1 − min(opacity, 1) (the seed: a sum of 1 or more is full occlusion);
// Kajiya-Kay for the hair.

struct HairFrame {
    light: mat4x4<f32>,     // world -> light clip (orthographic, wgpu depth 0..1)
    camera: mat4x4<f32>,    // world -> camera clip
    eye: vec4<f32>,         // camera position
    to_light: vec4<f32>,    // unit vector toward the light
    depth_range: vec4<f32>, // x: bbox near depth, y: bbox far depth (light NDC), z: layer step d, w: set (0 shading, 1 opacity)
    params: vec4<f32>,      // x: opacity-map texels per side
}

@group(0) @binding(0) var<uniform> frame: HairFrame;

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
    let l = length(across);
    if l < 1e-6 {
        across = cross(t, vec3<f32>(0.0, 0.0, 1.0));
        if length(across) < 1e-6 {
            across = vec3<f32>(1.0, 0.0, 0.0);
        }
    }
    return p + normalize(across) * (side * 0.5 * width);
}

fn hair_set_width(v: StripIn) -> f32 {
    return select(v.width.x, v.width.y, frame.depth_range.w > 0.5);
}

fn hair_set_alpha(v: StripIn) -> f32 {
    return select(v.opacity.x, v.opacity.y, frame.depth_range.w > 0.5);
}

// Far boundary of layer k (1-based) above the nearest hair depth z0.
fn hair_boundary(z0: f32, k: u32) -> f32 {
    return z0 + frame.depth_range.z * f32(k * (k + 1u) / 2u);
}

struct LightOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) alpha: f32,
}

@vertex
fn vs_light(v: StripIn) -> LightOut {
    var out: LightOut;
    let w = hair_expand(v.position, v.side, v.tangent, hair_set_width(v), frame.to_light.xyz);
    out.clip = frame.light * vec4<f32>(w, 1.0);
    out.alpha = hair_set_alpha(v);
    return out;
}

@fragment
fn fs_depth(in: LightOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.clip.z, 0.0, 0.0, 1.0);
}

@group(0) @binding(1) var hair_depth: texture_2d<f32>;

@fragment
fn fs_opacity(in: LightOut) -> @location(0) vec4<f32> {
    let z0 = textureLoad(hair_depth, vec2<i32>(floor(in.clip.xy)), 0).r;
    let z = in.clip.z;
    var out = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k = k + 1u) {
        if z < hair_boundary(z0, k + 1u) {
            out[k] = in.alpha;
        }
    }
    return out;
}

@group(0) @binding(2) var hair_layers: texture_2d<f32>;

// Light reaching a world point: 1 − the cumulative opacity in front of it.
fn hair_visibility(world: vec3<f32>) -> f32 {
    let c = frame.light * vec4<f32>(world, 1.0);
    let ndc = c.xyz / c.w;
    let r = frame.params.x;
    let texel = vec2<f32>((ndc.x * 0.5 + 0.5) * r, (0.5 - ndc.y * 0.5) * r);
    let ij = vec2<i32>(floor(texel));
    if ij.x < 0 || ij.y < 0 || ij.x >= i32(r) || ij.y >= i32(r) {
        return 1.0;
    }
    let z0 = textureLoad(hair_depth, ij, 0).r;
    let z = ndc.z;
    if z <= z0 {
        return 1.0;
    }
    let layers = textureLoad(hair_layers, ij, 0);
    var opacity = layers.w;
    var lo = z0;
    var before = 0.0;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let hi = hair_boundary(z0, k + 1u);
        if z < hi {
            opacity = mix(before, layers[k], (z - lo) / max(hi - lo, 1e-9));
            break;
        }
        lo = hi;
        before = layers[k];
    }
    return 1.0 - min(opacity, 1.0);
}

// Kajiya-Kay: diffuse by the sine between tangent and light, specular by the cone of
// reflected directions around the tangent.
fn hair_kajiya_kay(t: vec3<f32>, to_light: vec3<f32>, to_eye: vec3<f32>, base: vec3<f32>, visibility: f32) -> vec3<f32> {
    let tl = dot(t, to_light);
    let te = dot(t, to_eye);
    let sin_l = sqrt(max(1.0 - tl * tl, 0.0));
    let sin_e = sqrt(max(1.0 - te * te, 0.0));
    let spec = pow(max(tl * te + sin_l * sin_e, 0.0), 40.0);
    return base * (0.15 + 0.85 * sin_l * visibility) + vec3<f32>(0.25) * spec * visibility;
}

struct CameraOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) tangent: vec3<f32>,
    @location(2) color: vec3<f32>,
}

@vertex
fn vs_hair(v: StripIn) -> CameraOut {
    var out: CameraOut;
    let toward = normalize(frame.eye.xyz - v.position);
    let w = hair_expand(v.position, v.side, v.tangent, v.width.x, toward);
    out.clip = frame.camera * vec4<f32>(w, 1.0);
    out.world = w;
    out.tangent = v.tangent;
    out.color = v.color;
    return out;
}

@fragment
fn fs_hair(in: CameraOut) -> @location(0) vec4<f32> {
    let t = normalize(in.tangent);
    let vis = hair_visibility(in.world);
    let c = hair_kajiya_kay(t, frame.to_light.xyz, normalize(frame.eye.xyz - in.world), in.color, vis);
    return vec4<f32>(pow(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)), vec3<f32>(1.0 / 2.2)), 1.0);
}

struct GroundOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

@vertex
fn vs_ground(@location(0) p: vec3<f32>) -> GroundOut {
    var out: GroundOut;
    out.clip = frame.camera * vec4<f32>(p, 1.0);
    out.world = p;
    return out;
}

@fragment
fn fs_ground(in: GroundOut) -> @location(0) vec4<f32> {
    let vis = hair_visibility(in.world);
    let lambert = max(frame.to_light.y, 0.0);
    let c = vec3<f32>(0.75, 0.72, 0.66) * (0.25 + 0.75 * lambert * vis);
    return vec4<f32>(pow(c, vec3<f32>(1.0 / 2.2)), 1.0);
}

// The ground's visibility seen straight down (for the aliasing figure): R32Float.
@fragment
fn fs_ground_visibility(in: GroundOut) -> @location(0) vec4<f32> {
    return vec4<f32>(hair_visibility(in.world), 0.0, 0.0, 1.0);
}
