// Relief mapping as a material for any mesh with tangents (seed 003): the view ray taken into
// the relief's texel space at each pixel, traced with the tracer chosen in `relief`, shaded with
// depth-map shadows and ambient occlusion: hikage_runtime::relief::ReliefMaterial. Needs
// SCENE_WGSL and RELIEF_WGSL before it. The mesh's surface is the relief's top plane (depth 0); the relief
// lies below it, one tile per unit of uv.

struct ReliefMaterialUniform {
    // model: mesh space -> world (rotation, translation, uniform scale); light: unit direction
    // toward the light (world); ambient: scaled by the ambient occlusion's open share.
    scene: Scene,
    eye: vec4<f32>,             // w = 1: the camera's position (world); w = 0: an orthographic camera's unit view direction
    tile: vec2<f32>,            // world size of one relief tile along the tangent and the bitangent
    ao_stride: u32,             // ambient occlusion over every n-th direction; 0: off
    shadows: u32,               // 1: depth-map shadows
    bias: f32,                  // depth a stored hit may lie above a point that still counts as lit
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(3) var<uniform> material: ReliefMaterialUniform;

struct ReliefVertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tangent: vec4<f32>,    // xyz: along +u; w: ±1, the bitangent is w · cross(normal, tangent)
    @location(3) uv: vec2<f32>,
}

struct ReliefVertex {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tangent: vec4<f32>,
    @location(3) uv: vec2<f32>,
}

@vertex
fn relief_vs(v: ReliefVertexIn) -> ReliefVertex {
    var out: ReliefVertex;
    let world = material.scene.model * vec4<f32>(v.position, 1.0);
    out.clip = material.scene.view_proj * world;
    out.world = world.xyz;
    out.normal = (material.scene.model * vec4<f32>(v.normal, 0.0)).xyz;
    out.tangent = vec4<f32>((material.scene.model * vec4<f32>(v.tangent.xyz, 0.0)).xyz, v.tangent.w);
    out.uv = v.uv;
    return out;
}

// The whole material at a point of the mesh (world position, interpolated normal, tangent, uv);
// visibility x: 1 lit, 0 shadowed; y: 1 (covered); z: ambient occlusion's open share; w: hit
// depth.
fn relief_material_shade(world: vec3<f32>, normal: vec3<f32>, tangent: vec4<f32>, uv: vec2<f32>) -> Shade {
    let n = normalize(normal);
    let t = normalize(tangent.xyz - n * dot(tangent.xyz, n));
    let b = tangent.w * cross(n, t);
    var d = material.eye.xyz;
    if (material.eye.w > 0.5) {
        d = normalize(world - material.eye.xyz);
    }
    // Tangent space to texel space: texels per world unit along each axis (the relief's depth
    // is measured in texels of its width).
    let size = vec2<f32>(relief.size);
    let scale = vec3<f32>(size.x / material.tile.x, size.y / material.tile.y, size.x / material.tile.x);
    let dir = normalize(vec3<f32>(dot(d, t), dot(d, b), -dot(d, n)) * scale);
    let l = material.scene.light.xyz;
    if (dir.z <= 1e-4) {
        return Shade(vec4<f32>(material.scene.albedo.rgb * material.scene.ambient.rgb, 1.0), vec4<f32>(0.0, 1.0, 1.0, 0.0));
    }
    let origin = uv * size;
    let r = ReliefRay(origin, dir);
    reads_height = 0u;
    reads_depth = 0u;
    let s = relief_trace(r);
    let p = vec3<f32>(origin + s * dir.xy, s * relief_dz(r));
    let lt = normalize(vec3<f32>(dot(l, t), dot(l, b), dot(l, n)) * scale);
    var lit = lt.z > 0.0;
    if (material.shadows == 1u && lit) {
        lit = relief_lit(p, lt, material.bias);
    }
    var ao = 1.0;
    if (material.ao_stride > 0u) {
        ao = relief_ambient_occlusion(p, material.ao_stride, material.bias);
    }
    let nt = relief_normal(p);
    let shading = normalize(t * nt.x + b * nt.y + n * nt.z);
    let direct = max(dot(shading, l), 0.0) * select(0.0, 1.0, lit);
    let light = material.scene.light_color.rgb * direct + material.scene.ambient.rgb * ao;
    return Shade(vec4<f32>(material.scene.albedo.rgb * light, 1.0), vec4<f32>(select(0.0, 1.0, lit), 1.0, ao, p.z));
}

@fragment
fn relief_fs(in: ReliefVertex) -> @location(0) vec4<f32> {
    return relief_material_shade(in.world, in.normal, in.tangent, in.uv).color;
}

@fragment
fn relief_fs_visibility(in: ReliefVertex) -> ShadeTargets {
    let s = relief_material_shade(in.world, in.normal, in.tangent, in.uv);
    return ShadeTargets(s.color, s.visibility);
}
