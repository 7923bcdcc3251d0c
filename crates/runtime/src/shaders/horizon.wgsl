// Horizon shadows (Onoue, Max & Nishita, "Bumpmap shadows on curved surfaces"), eq. (1)-(3);
// the equations and conventions are stated in docs/conventions.md. Each function has a CPU
// reference of the same name and argument order in hikage_runtime::horizon.
//
// Frames. The horizon map lives in the bump frame: x along +u, y along +v (texel space), z up,
// all in the heightfield's world units. A light given in a mesh's space is taken into that
// frame by horizon_surface_light; on terrain the bump frame is the terrain's own.
// The map is a W x H x D 3D texture, azimuth phi_k = 2 pi k / D on the depth axis, measured in
// texel space from +u toward +v; channel x = tan(beta), y = d (world units).

const HORIZON_TAU: f32 = 6.283185307179586;
const HORIZON_PI: f32 = 3.141592653589793;

// How the horizon texture stores a texel: format 0 float (as it is), 1 rg8 (x = beta/pi + 0.5,
// 0 = open sky; y = d / distance_scale).
struct HorizonEncoding {
    format: u32,
    distance_scale: f32,
    open_sky_slope: f32,
    _pad: f32,
}

// Eq. (1): the normal curvature along v, from the principal curvatures k1, k2 and the principal
// directions v1, v2 (any lengths, orthogonal on the surface). Both directions are used, so the
// result holds when the texture axes are not orthogonal; no square root is needed.
fn horizon_local_curvature(k1: f32, k2: f32, v: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> f32 {
    let vv = dot(v, v);
    if (vv <= 0.0) {
        return 0.0;
    }
    let c = dot(v, v1);
    let s = dot(v, v2);
    return k1 * c * c / (vv * max(dot(v1, v1), 1e-30)) + k2 * s * s / (vv * max(dot(v2, v2), 1e-30));
}

// Eq. (2)-(3): the horizon slope seen from height h above a base surface of curvature kappa
// (all in one unit of length). Convex: the larger of the bump horizon lowered by the curvature
// (eq. 2) and the curved base surface's own horizon (eq. 3, a negative slope). Concave: as is.
fn horizon_corrected_slope(tan_beta: f32, d: f32, kappa: f32, h: f32) -> f32 {
    if (kappa <= 0.0) {
        return tan_beta;
    }
    let kh = kappa * h;
    let bump = tan_beta * (1.0 - kh) - 0.5 * kappa * d;
    let base = -sqrt(max(kh * (2.0 + kh), 0.0));
    return max(bump, base);
}

// Lit when the light (bump frame) rises above the horizon slope. Light from below the tangent
// plane is not culled: a bump top can still be lit.
fn horizon_is_lit(light: vec3<f32>, tan_beta: f32) -> bool {
    return light.z > tan_beta * length(light.xy);
}

// The texel-space azimuth of a bump-frame direction: x and y are world units along u and v, so
// a heightfield of non-square texels (sx, sy) turns them before the angle is taken.
fn horizon_texel_azimuth(light: vec3<f32>, texel_size: vec2<f32>) -> f32 {
    return atan2(light.y / texel_size.y, light.x / texel_size.x);
}

// (tan beta, d) at texture coordinate uv for texel-space azimuth phi (radians), decoded.
fn horizon_fetch(map: texture_3d<f32>, samp: sampler, enc: HorizonEncoding, uv: vec2<f32>, phi: f32) -> vec2<f32> {
    let directions = f32(textureDimensions(map).z);
    let w = phi / HORIZON_TAU + 0.5 / directions;
    return horizon_decode(enc, textureSampleLevel(map, samp, vec3<f32>(uv, w), 0.0).xy);
}

// Stored channels `t` as (tan beta, d).
fn horizon_decode(enc: HorizonEncoding, t: vec2<f32>) -> vec2<f32> {
    if (enc.format == 1u) {
        var slope = enc.open_sky_slope;
        if (t.x > 0.0) {
            slope = tan((t.x - 0.5) * HORIZON_PI);
        }
        return vec2<f32>(slope, t.y * enc.distance_scale);
    }
    return t;
}

// The share of a light disc of angular radius `radius` (radians) above a horizon when its centre
// stands `above` radians over it: the area of a circular segment, exact for small discs. A
// point light (radius 0) is all or nothing.
fn horizon_disc_visible(above: f32, radius: f32) -> f32 {
    if (radius <= 0.0) {
        return select(0.0, 1.0, above > 0.0);
    }
    let t = clamp(above / radius, -1.0, 1.0);
    return (acos(-t) + t * sqrt(1.0 - t * t)) / HORIZON_PI;
}

// The principal directions in mesh space (columns 0 and 1, not normalised), rebuilt from their
// dot products d1, d2 with the unit tangents of +u and +v (the Curvature asset's principal1 and
// principal2): the tangents are not orthogonal in general, so a dot product is not a component.
fn horizon_principal_directions(pu: vec3<f32>, pv: vec3<f32>, n: vec3<f32>, d1: vec2<f32>, d2: vec2<f32>) -> mat2x3<f32> {
    let eu = normalize(pu - n * dot(pu, n));
    let ev = normalize(pv - n * dot(pv, n));
    let c = dot(eu, ev);
    return mat2x3<f32>((d1.x - c * d1.y) * eu + (d1.y - c * d1.x) * ev, (d2.x - c * d2.y) * eu + (d2.y - c * d2.x) * ev);
}

// A light on a curved surface, in the bump frame, with what eq. (2)-(3) need there.
struct HorizonSurfaceLight {
    // The light direction in the bump frame (not normalised).
    light: vec3<f32>,
    // Eq. (1)'s curvature along the light, in 1/bump-world units.
    kappa: f32,
}

// Takes light `l` (mesh space, any length) into the bump frame of a surface point whose texture
// frame is pu = dP/du, pv = dP/dv (mesh units per texture unit) and unit normal n (outward),
// with principal curvatures k1 >= k2 (1/mesh units) and principal directions d1, d2 given as dot
// products with the unit tangents of +u and +v. One tile of the bump map spans `tile` =
// (W sx, H sy) bump-world units: the frame is (pu / tile.x, pv / tile.y, n |pu x pv|^(1/2) /
// (tile.x tile.y)^(1/2)), the seed's (P_u, P_v, N / |N|^(1/2)) scaled to the map's world size.
fn horizon_surface_light(
    l: vec3<f32>,
    pu: vec3<f32>,
    pv: vec3<f32>,
    n: vec3<f32>,
    k1: f32,
    k2: f32,
    d1: vec2<f32>,
    d2: vec2<f32>,
    tile: vec2<f32>,
) -> HorizonSurfaceLight {
    let hs = sqrt(length(cross(pu, pv)) / (tile.x * tile.y));
    let au = pu / tile.x;
    let av = pv / tile.y;
    let an = n * hs;
    // Cramer's rule: l = au x + av y + an z.
    let det = dot(au, cross(av, an));
    let lb = vec3<f32>(dot(l, cross(av, an)), dot(au, cross(l, an)), dot(au, cross(av, l))) / det;
    // Eq. (1) in mesh space.
    let v = horizon_principal_directions(pu, pv, n, d1, d2);
    let kappa = horizon_local_curvature(k1, k2, l - n * dot(l, n), v[0], v[1]);
    // Curvature along the light in bump units: lengths along it scale by g, heights by hs.
    let across = length(lb.xy);
    var g = 1.0;
    if (across > 0.0) {
        g = length(au * (lb.x / across) + av * (lb.y / across));
    }
    return HorizonSurfaceLight(lb, kappa * g * g / hs);
}

// The whole test at a surface point: `s` from horizon_surface_light, `h` the bump height there
// (bump-world units above the base surface), `corrected` false for the flat test of Forsyth.
fn horizon_surface_lit(
    map: texture_3d<f32>,
    samp: sampler,
    enc: HorizonEncoding,
    uv: vec2<f32>,
    s: HorizonSurfaceLight,
    h: f32,
    texel_size: vec2<f32>,
    corrected: bool,
) -> bool {
    let hd = horizon_fetch(map, samp, enc, uv, horizon_texel_azimuth(s.light, texel_size));
    var kappa = 0.0;
    if (corrected) {
        kappa = s.kappa;
    }
    return horizon_is_lit(s.light, horizon_corrected_slope(hd.x, hd.y, kappa, h));
}

// Sun visibility on a heightfield drawn as geometry (no curvature): the share of a sun disc of
// angular radius `radius` above the horizon, `sun` in the bump frame (x along +u, y along +v,
// z up).
fn horizon_sun_visible(
    map: texture_3d<f32>,
    samp: sampler,
    enc: HorizonEncoding,
    uv: vec2<f32>,
    sun: vec3<f32>,
    texel_size: vec2<f32>,
    radius: f32,
) -> f32 {
    let hd = horizon_fetch(map, samp, enc, uv, horizon_texel_azimuth(sun, texel_size));
    let elevation = atan2(sun.z, length(sun.xy));
    return horizon_disc_visible(elevation - atan(hd.x), radius);
}

// (tan beta, d) of texel `texel` in baked direction `k`, decoded.
fn horizon_load(map: texture_3d<f32>, enc: HorizonEncoding, texel: vec2<u32>, k: u32) -> vec2<f32> {
    return horizon_decode(enc, textureLoad(map, vec3<u32>(texel, k), 0).xy);
}

// The horizon angle (radians) of a point `height` above the heightfield at texel coordinates
// `at`, in baked direction `k`: its texel's horizon point, that point's own horizon point, and so
// on (the vertices of the upper convex hull of the profile), on stored texels, until the slope
// from the raised point stops rising; at most 8 points, none past `reach`, none off the map.
// -pi/2 with no occluder.
fn horizon_raised_angle(
    map: texture_3d<f32>,
    enc: HorizonEncoding,
    at: vec2<f32>,
    k: u32,
    texel_size: vec2<f32>,
    height: f32,
    reach: f32,
) -> f32 {
    let dims = textureDimensions(map);
    let phi = HORIZON_TAU * f32(k) / f32(dims.z);
    let along = vec2<f32>(cos(phi), sin(phi));
    let step = along / length(along * texel_size);
    var t = 0.0;
    var z = 0.0;
    var best = -1e30;
    for (var hop = 0u; hop < 8u; hop++) {
        let p = floor(at + step * t);
        if (p.x < 0.0 || p.y < 0.0 || p.x >= f32(dims.x) || p.y >= f32(dims.y)) {
            break;
        }
        let hd = horizon_load(map, enc, vec2<u32>(p), k);
        if (hd.y <= 0.0 || t + hd.y > reach) {
            break;
        }
        let t1 = t + hd.y;
        let z1 = z + hd.y * hd.x;
        let slope = (z1 - height) / t1;
        if (slope <= best) {
            break;
        }
        t = t1;
        z = z1;
        best = slope;
    }
    return atan(best);
}

// Sun visibility of a point `height` above the heightfield at `uv` (bump-world units), from the
// horizons alone: the raised point's horizon in the two baked directions either side of the sun
// (horizon_raised_angle), blended as the sampler blends the ground's, against the sun's disc.
// A farther ridge that the ground's near occluder hides still shadows a point above it. `reach`
// bounds the walk (the bake's max distance, or the map's extent); `height` 0 is the ground.
fn horizon_raised_sun_visible(
    map: texture_3d<f32>,
    enc: HorizonEncoding,
    uv: vec2<f32>,
    sun: vec3<f32>,
    texel_size: vec2<f32>,
    height: f32,
    reach: f32,
    radius: f32,
) -> f32 {
    let dims = textureDimensions(map);
    let directions = f32(dims.z);
    let turns = horizon_texel_azimuth(sun, texel_size) / HORIZON_TAU * directions;
    let f = turns - floor(turns / directions) * directions;
    let k0 = floor(f);
    let at = uv * vec2<f32>(dims.xy);
    let a0 = horizon_raised_angle(map, enc, at, u32(k0) % dims.z, texel_size, height, reach);
    let a1 = horizon_raised_angle(map, enc, at, (u32(k0) + 1u) % dims.z, texel_size, height, reach);
    let horizon = a0 + (a1 - a0) * (f - k0);
    let elevation = atan2(sun.z, length(sun.xy));
    return horizon_disc_visible(elevation - horizon, radius);
}
