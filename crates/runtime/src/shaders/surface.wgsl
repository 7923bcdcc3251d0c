// A bump-mapped curved mesh with horizon shadows corrected for its curvature (seed 000 §3):
// hikage_runtime::horizon::SurfaceShadows. Needs SCENE_WGSL and HORIZON_WGSL before it. Vertex streams come
// from a Curvature asset: position, uv, normal, curvature (k1, k2), principal1, principal2
// (dot products with the unit tangents of +u and +v), tangent_u = dP/du, tangent_v = dP/dv.

struct SurfaceUniform {
    // model: mesh space -> world; light: unit direction toward the light in mesh space, w 1 for
    // the curvature-corrected test, 0 for the flat one.
    scene: Scene,
    tile: vec2<f32>,            // one tile of the bump map in its world units: (W sx, H sy)
    texel_size: vec2<f32>,      // (sx, sy)
    height_scale: f32,          // bump height = height_offset + height_scale * sample
    height_offset: f32,
    size: vec2<u32>,            // heightfield width, height
    encoding: HorizonEncoding,
}

@group(0) @binding(0) var<uniform> surface: SurfaceUniform;
@group(0) @binding(1) var surface_horizon: texture_3d<f32>;
@group(0) @binding(2) var surface_sampler: sampler;
@group(0) @binding(3) var surface_heights: texture_2d<f32>;

// Bump height at texel (i, j) of the tiling map, bump-world units.
fn surface_height_at(texel: vec2<i32>) -> f32 {
    let dims = vec2<i32>(surface.size);
    let t = ((texel % dims) + dims) % dims;
    return surface.height_offset + surface.height_scale * textureLoad(surface_heights, t, 0).r;
}

// The texel of the tiling map under texture coordinate uv.
fn surface_texel(uv: vec2<f32>) -> vec2<i32> {
    return vec2<i32>(floor(fract(uv) * vec2<f32>(surface.size)));
}

// Is the surface point lit? Inputs as interpolated from the Curvature asset's streams.
fn surface_lit(uv: vec2<f32>, normal: vec3<f32>, k: vec2<f32>, d1: vec2<f32>, d2: vec2<f32>, pu: vec3<f32>, pv: vec3<f32>) -> bool {
    let s = horizon_surface_light(surface.scene.light.xyz, pu, pv, normal, k.x, k.y, d1, d2, surface.tile);
    let h = surface_height_at(surface_texel(uv));
    return horizon_surface_lit(surface_horizon, surface_sampler, surface.encoding, uv, s, h, surface.texel_size, surface.scene.light.w > 0.5);
}

// The bumped normal in mesh space: the surface P + n hs h(X, Y) over the bump frame.
fn surface_bumped_normal(uv: vec2<f32>, normal: vec3<f32>, pu: vec3<f32>, pv: vec3<f32>) -> vec3<f32> {
    let t = surface_texel(uv);
    let gx = (surface_height_at(t + vec2<i32>(1, 0)) - surface_height_at(t - vec2<i32>(1, 0))) / (2.0 * surface.texel_size.x);
    let gy = (surface_height_at(t + vec2<i32>(0, 1)) - surface_height_at(t - vec2<i32>(0, 1))) / (2.0 * surface.texel_size.y);
    let hs = sqrt(length(cross(pu, pv)) / (surface.tile.x * surface.tile.y));
    let su = pu / surface.tile.x + normal * (hs * gx);
    let sv = pv / surface.tile.y + normal * (hs * gy);
    let b = cross(su, sv);
    return normalize(b * sign(dot(b, normal)));
}

struct SurfaceVertexIn {
    @location(0) position: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) normal: vec3<f32>,
    @location(3) curvature: vec2<f32>,
    @location(4) principal1: vec2<f32>,
    @location(5) principal2: vec2<f32>,
    @location(6) tangent_u: vec3<f32>,
    @location(7) tangent_v: vec3<f32>,
}

struct SurfaceVertex {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) curvature: vec2<f32>,
    @location(3) principal1: vec2<f32>,
    @location(4) principal2: vec2<f32>,
    @location(5) tangent_u: vec3<f32>,
    @location(6) tangent_v: vec3<f32>,
}

@vertex
fn surface_vs(v: SurfaceVertexIn) -> SurfaceVertex {
    var out: SurfaceVertex;
    out.clip = surface.scene.view_proj * (surface.scene.model * vec4<f32>(v.position, 1.0));
    out.uv = v.uv;
    out.normal = v.normal;
    out.curvature = v.curvature;
    out.principal1 = v.principal1;
    out.principal2 = v.principal2;
    out.tangent_u = v.tangent_u;
    out.tangent_v = v.tangent_v;
    return out;
}

// The surface's shading; visibility x: 1 lit, 0 shadowed; y: 1 (covered).
fn surface_shade(in: SurfaceVertex) -> Shade {
    let n = normalize(in.normal);
    let lit = surface_lit(in.uv, n, in.curvature, in.principal1, in.principal2, in.tangent_u, in.tangent_v);
    let bumped = surface_bumped_normal(in.uv, n, in.tangent_u, in.tangent_v);
    let direct = max(dot(bumped, surface.scene.light.xyz), 0.0) * select(0.0, 1.0, lit);
    let light = surface.scene.light_color.rgb * direct + surface.scene.ambient.rgb;
    return Shade(vec4<f32>(surface.scene.albedo.rgb * light, 1.0), vec4<f32>(select(0.0, 1.0, lit), 1.0, 0.0, 1.0));
}

@fragment
fn surface_fs(in: SurfaceVertex) -> @location(0) vec4<f32> {
    return surface_shade(in).color;
}

@fragment
fn surface_fs_visibility(in: SurfaceVertex) -> ShadeTargets {
    let s = surface_shade(in);
    return ShadeTargets(s.color, s.visibility);
}
