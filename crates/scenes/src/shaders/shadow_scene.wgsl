// The shadow-fit scene: a depth pass from the light into an R32Float map, then the camera pass
// writing per pixel the shadow-map texel coordinates, the texel density sigma (shadow-map
// texels per screen pixel, R * sqrt|det d(s,t)/d(x,y)|), the lit flag, the world position and
// the face. Read back by hikage_runtime::shadow_scene.

struct Frame {
    camera: mat4x4<f32>,   // world -> camera clip
    light: mat4x4<f32>,    // world -> light clip
    resolution: f32,       // shadow-map texels per side
    bias: f32,             // constant bias of the shadow test (world units)
    _pad: vec2<f32>,
    source: vec4<f32>,     // w = 1: the light's position; w = 0: the direction its light travels
}

// Distance to the light along its ray (world units): what the map stores and the test compares,
// the same quantity for every projection.
fn light_distance(world: vec3<f32>) -> f32 {
    if (frame.source.w > 0.5) {
        return length(world - frame.source.xyz);
    }
    return dot(world, frame.source.xyz);
}

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var shadow_map: texture_2d<f32>;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) face: f32,
}

struct LightOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

@vertex
fn vs_light(v: VertexIn) -> LightOut {
    var out: LightOut;
    out.clip = frame.light * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    return out;
}

// The depth test keeps the surface nearest the light by the map's own depth order (inverted for
// an inverted perspective shadow map); the map stores its distance to the light.
@fragment
fn fs_light(in: LightOut) -> @location(0) vec4<f32> {
    return vec4<f32>(light_distance(in.world), 0.0, 0.0, 1.0);
}

struct CameraOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) face: f32,  // the same at every vertex of a face
}

@vertex
fn vs_camera(v: VertexIn) -> CameraOut {
    var out: CameraOut;
    out.clip = frame.camera * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.face = v.face;
    return out;
}

struct CameraTargets {
    @location(0) shadow: vec4<f32>,  // s * R, t * R, sigma, lit (1) / shadowed (0) / outside the map (-1)
    @location(1) world: vec4<f32>,   // world position, face index (background: -1)
}

@fragment
fn fs_camera(in: CameraOut) -> CameraTargets {
    var out: CameraTargets;
    let lc = frame.light * vec4<f32>(in.world, 1.0);
    let ndc = lc.xyz / lc.w;
    let texel = vec2<f32>((ndc.x * 0.5 + 0.5) * frame.resolution, (0.5 - ndc.y * 0.5) * frame.resolution);
    let dx = dpdx(texel);
    let dy = dpdy(texel);
    let det = dx.x * dy.y - dx.y * dy.x;
    let sigma = sqrt(abs(det));
    // Receiver-plane bias: the change of light distance per shadow-map texel across this
    // surface (its gradient per pixel through the inverse of the texel Jacobian), so a sloped
    // receiver does not shadow itself between texel centres.
    let distance = light_distance(in.world);
    let dz = vec2<f32>(dpdx(distance), dpdy(distance));
    var slope = 0.0;
    if abs(det) > 1e-12 {
        let gs = (dy.y * dz.x - dx.y * dz.y) / det;
        let gt = (-dy.x * dz.x + dx.x * dz.y) / det;
        slope = min(abs(gs) + abs(gt), 1000.0);
    }
    var lit = -1.0;
    let r = i32(frame.resolution);
    let ij = vec2<i32>(floor(texel));
    if lc.w > 0.0 && ij.x >= 0 && ij.y >= 0 && ij.x < r && ij.y < r && ndc.z >= 0.0 && ndc.z <= 1.0 {
        let stored = textureLoad(shadow_map, ij, 0).r;
        lit = select(0.0, 1.0, distance <= stored + frame.bias + 1.5 * slope);
    }
    out.shadow = vec4<f32>(texel, sigma, lit);
    out.world = vec4<f32>(in.world, in.face);
    return out;
}
