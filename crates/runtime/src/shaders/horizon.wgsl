// Curvature-corrected horizon shadows: Onoue, Max & Nishita, "Bumpmap shadows on curved
// surfaces", eq. (1)-(3), as stated in docs/conventions.md.
//
// Conventions: the horizon map is a W x H x D 3D texture, azimuth phi_k = 2 pi k / D on the
// depth axis, phi measured in texel space from +u toward +v; channel x = tan(beta), y = d
// (world units). Sample it with linear filtering and Repeat on w so directions interpolate and
// wrap 2 pi -> 0. Vectors named `light` are in the surface frame (P_u, P_v, N): x along +u,
// y along +v, z along the normal. Each function has a CPU reference of the same name in
// hikage_runtime::horizon.

const HORIZON_TAU: f32 = 6.283185307179586;

// Eq. (1): normal curvature along the light's azimuth; (cos_phi, sin_phi) is the azimuth
// measured from the first principal direction.
fn horizon_local_curvature(k1: f32, k2: f32, cos_phi: f32, sin_phi: f32) -> f32 {
    return k1 * cos_phi * cos_phi + k2 * sin_phi * sin_phi;
}

// Eq. (2)-(3): the horizon slope seen from height h above a base surface of curvature kappa.
// Convex (kappa > 0): the larger of the bump horizon lowered by the curvature (eq. 2) and the
// curved base surface's own horizon (eq. 3, written as a negative slope). Concave: unchanged.
fn horizon_corrected_slope(tan_beta: f32, d: f32, kappa: f32, h: f32) -> f32 {
    if (kappa <= 0.0) {
        return tan_beta;
    }
    let kh = kappa * h;
    let bump = tan_beta * (1.0 - kh) - 0.5 * kappa * d;
    let base = -sqrt(max(kh * (2.0 + kh), 0.0));
    return max(bump, base);
}

// Lit when the light's elevation above the tangent plane exceeds the horizon. Light from
// behind the surface (z < 0) is not culled: a bump top can still be lit.
fn horizon_is_lit(light: vec3<f32>, tan_beta: f32) -> bool {
    return light.z > tan_beta * length(light.xy);
}

// (tan beta, d) at texture coordinate uv for texel-space azimuth phi (radians).
fn horizon_fetch(map: texture_3d<f32>, samp: sampler, uv: vec2<f32>, phi: f32) -> vec2<f32> {
    let directions = f32(textureDimensions(map).z);
    let w = phi / HORIZON_TAU + 0.5 / directions;
    return textureSampleLevel(map, samp, vec3<f32>(uv, w), 0.0).xy;
}

// The whole test: is the point at uv, at height h above the base surface, lit by `light`?
// k1, k2: principal curvatures; principal: the first principal direction in the (u, v) plane.
fn horizon_shadow_lit(
    map: texture_3d<f32>,
    samp: sampler,
    uv: vec2<f32>,
    light: vec3<f32>,
    k1: f32,
    k2: f32,
    principal: vec2<f32>,
    h: f32,
) -> bool {
    let flat_len = length(light.xy);
    if (flat_len <= 0.0) {
        return light.z > 0.0;
    }
    let dir = light.xy / flat_len;
    let p = normalize(principal);
    let kappa = horizon_local_curvature(k1, k2, dot(dir, p), dir.x * p.y - dir.y * p.x);
    let hd = horizon_fetch(map, samp, uv, atan2(light.y, light.x));
    return horizon_is_lit(light, horizon_corrected_slope(hd.x, hd.y, kappa, h));
}
