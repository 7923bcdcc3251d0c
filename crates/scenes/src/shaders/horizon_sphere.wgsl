// Seed 000 Fig. 4/5: a sphere of curvature kappa carrying a tiled bump map, lit by one
// directional light, shadowed by the horizon test (flat, or curvature-corrected). Drawn
// analytically per pixel (orthographic view along -z) so the CPU reference can reproduce every
// pixel: hikage_runtime::horizon_sphere::shade_cpu.

struct Scene {
    light: vec4<f32>,       // world direction toward the light (xyz)
    radius: f32,            // sphere radius = 1 / kappa
    kappa: f32,             // curvature used by the test (0: flat horizon test)
    tile_world: f32,        // world size of one bump-map tile
    height_scale: f32,      // world height = height_scale * sample
    size: vec2<f32>,        // image size in pixels
    _pad: vec2<f32>,
}

@group(0) @binding(0) var<uniform> scene: Scene;
@group(0) @binding(1) var horizon_map: texture_3d<f32>;
@group(0) @binding(2) var horizon_sampler: sampler;
@group(0) @binding(3) var heights: texture_2d<f32>;

struct Out {
    @location(0) color: vec4<f32>,
    @location(1) flag: u32,  // 0 shadowed, 1 lit, 2 background
}

@fragment
fn fs(@builtin(position) pos: vec4<f32>) -> Out {
    var out: Out;
    let r = scene.radius;
    let ndc = pos.xy / scene.size * 2.0 - 1.0;
    let x = ndc.x * r * 1.05;
    let y = -ndc.y * r * 1.05;
    let r2 = x * x + y * y;
    if (r2 >= r * r) {
        out.color = vec4<f32>(0.08, 0.08, 0.1, 1.0);
        out.flag = 2u;
        return out;
    }
    let z = sqrt(r * r - r2);
    let n = vec3<f32>(x, y, z) / r;
    let lam = atan2(x, z);
    let psi = asin(clamp(y / r, -1.0, 1.0));
    let east = vec3<f32>(cos(lam), 0.0, -sin(lam));
    let south = vec3<f32>(sin(psi) * sin(lam), -cos(psi), sin(psi) * cos(lam));
    let uv = vec2<f32>(lam * r / scene.tile_world, -psi * r / scene.tile_world);
    let dims = vec2<f32>(textureDimensions(heights));
    let texel = vec2<i32>(floor(fract(uv) * dims));
    let h = scene.height_scale * textureLoad(heights, texel, 0).r;
    let l = scene.light.xyz;
    let lf = vec3<f32>(dot(l, east), dot(l, south), dot(l, n));
    let lit = horizon_shadow_lit(horizon_map, horizon_sampler, uv, lf, scene.kappa, scene.kappa, vec2<f32>(1.0, 0.0), h);
    let base = vec3<f32>(0.85, 0.72, 0.55);
    if (lit) {
        out.color = vec4<f32>(base * (0.3 + 0.7 * max(dot(n, l), 0.0)), 1.0);
        out.flag = 1u;
    } else {
        out.color = vec4<f32>(base * 0.12, 1.0);
        out.flag = 0u;
    }
    return out;
}
