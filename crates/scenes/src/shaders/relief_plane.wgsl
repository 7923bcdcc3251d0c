// A relief quad: one tile of the heightfield as the top plane z = 0 of world space (x = u,
// y = v in texels, z up), seen by a pinhole camera, traced per pixel with the tracer chosen in
// `relief`, shaded with depth-map shadows and ambient occlusion. The camera ray of each pixel is
// reproduced on the CPU by hikage_runtime::relief_plane::camera_ray.

struct PlaneScene {
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,     // scaled by tan(fov / 2) · aspect
    up: vec4<f32>,        // scaled by tan(fov / 2)
    light: vec4<f32>,     // xyz: unit vector toward the light; w > 0: shadows on
    image: vec2<f32>,     // pixels
    ao_stride: u32,       // 0: no ambient occlusion
    _pad: u32,
}

@group(1) @binding(0) var<uniform> scene: PlaneScene;

// Depth a stored hit may lie above a point that still counts as lit (hikage_runtime::relief_plane::SHADOW_BIAS).
const SHADOW_BIAS: f32 = 0.02;

struct PlaneOut {
    @location(0) color: vec4<f32>,
    @location(1) data: vec4<f32>,  // hit length, height reads, depth reads, 1 (0: background)
    @location(2) shade: vec4<f32>, // lit (0/1), ambient occlusion (open share), 0, 0
}

@fragment
fn fs(@builtin(position) pos: vec4<f32>) -> PlaneOut {
    var out: PlaneOut;
    out.color = vec4<f32>(0.55, 0.65, 0.8, 1.0);
    out.data = vec4<f32>(0.0);
    out.shade = vec4<f32>(0.0);
    let ndc = vec2<f32>(pos.x / scene.image.x * 2.0 - 1.0, 1.0 - pos.y / scene.image.y * 2.0);
    let d = normalize(scene.forward.xyz + scene.right.xyz * ndc.x + scene.up.xyz * ndc.y);
    if d.z >= 0.0 {
        return out;
    }
    let t = -scene.eye.z / d.z;
    let uv = scene.eye.xy + t * d.xy;
    if uv.x < 0.0 || uv.y < 0.0 || uv.x >= f32(relief.size.x) || uv.y >= f32(relief.size.y) {
        return out;
    }
    let r = ReliefRay(uv, vec3<f32>(d.x, d.y, -d.z));
    reads_height = 0u;
    reads_depth = 0u;
    let s = relief_trace(r);
    out.data = vec4<f32>(s, f32(reads_height), f32(reads_depth), 1.0);

    let p = vec3<f32>(r.origin + s * r.dir.xy, s * relief_dz(r));
    let i = i32(floor(p.x));
    let j = i32(floor(p.y));
    let k = 0.5 * relief.thickness;
    let n = normalize(vec3<f32>(
        (relief_max_height(0u, i - 1, j) - relief_max_height(0u, i + 1, j)) * k,
        (relief_max_height(0u, i, j - 1) - relief_max_height(0u, i, j + 1)) * k,
        1.0,
    ));
    let l = scene.light.xyz;
    var lit = 1.0;
    if scene.light.w > 0.0 && !relief_lit(p, l, SHADOW_BIAS) {
        lit = 0.0;
    }
    var ao = 1.0;
    if scene.ao_stride > 0u {
        ao = relief_ambient_occlusion(p, scene.ao_stride, SHADOW_BIAS);
    }
    out.shade = vec4<f32>(lit, ao, 0.0, 0.0);
    let albedo = vec3<f32>(0.85, 0.78, 0.68) * (0.75 + 0.25 * (1.0 - p.z));
    let c = albedo * (0.3 * ao + 0.8 * max(dot(n, l), 0.0) * lit);
    out.color = vec4<f32>(pow(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)), vec3<f32>(1.0 / 2.2)), 1.0);
    return out;
}
