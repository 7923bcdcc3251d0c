// Terrain under a sun with horizon shadows and ambient occlusion: hikage_runtime::horizon::
// TerrainShadows. Needs SCENE_WGSL and HORIZON_WGSL before it. The heightfield is drawn as a grid through its
// texel centres, generated from the vertex index (no vertex buffer).
//
// Terrain frame: x along +u (columns), y up, z along +v (rows), world units; the model matrix
// places it in the world. Texel (i, j) has its centre at ((i + 0.5) sx, h, (j + 0.5) sy).

struct TerrainUniform {
    // model: terrain frame -> world; light: unit direction toward the sun in the terrain frame,
    // w its angular radius (radians); light_color: the sun's; ambient: the sky's, scaled by sky
    // visibility (1 - ao).
    scene: Scene,
    texel_size: vec2<f32>,      // world units per texel along u and v
    height_scale: f32,          // world height = height_offset + height_scale * sample
    height_offset: f32,
    size: vec2<u32>,            // heightfield width, height
    has_ao: u32,                // 1 when terrain_ao holds the baked occlusion
    skirt: f32,                 // depth of the skirt under the edges (world units), 0: none
    encoding: HorizonEncoding,
    apron: u32,                 // heights texels around the terrain's own (a streamed tile's neighbours')
}

@group(0) @binding(0) var<uniform> terrain: TerrainUniform;
@group(0) @binding(1) var terrain_horizon: texture_3d<f32>;
@group(0) @binding(2) var terrain_sampler: sampler;
@group(0) @binding(3) var terrain_heights: texture_2d<f32>;
@group(0) @binding(4) var terrain_ao: texture_2d<f32>;

// World height at texel (i, j), clamped to the heights held (the map, and a tile's apron).
fn terrain_height(texel: vec2<i32>) -> f32 {
    let apron = i32(terrain.apron);
    let t = clamp(texel, vec2<i32>(-apron), vec2<i32>(terrain.size) - 1 + apron) + apron;
    return terrain.height_offset + terrain.height_scale * textureLoad(terrain_heights, t, 0).r;
}

// The terrain-frame position of texel (i, j)'s centre.
fn terrain_position(texel: vec2<i32>) -> vec3<f32> {
    let c = (vec2<f32>(texel) + 0.5) * terrain.texel_size;
    return vec3<f32>(c.x, terrain_height(texel), c.y);
}

// The unit normal at texel (i, j) from central differences, terrain frame.
fn terrain_normal(texel: vec2<i32>) -> vec3<f32> {
    let du = terrain_height(texel + vec2<i32>(1, 0)) - terrain_height(texel - vec2<i32>(1, 0));
    let dv = terrain_height(texel + vec2<i32>(0, 1)) - terrain_height(texel - vec2<i32>(0, 1));
    return normalize(vec3<f32>(-du / (2.0 * terrain.texel_size.x), 1.0, -dv / (2.0 * terrain.texel_size.y)));
}

// Share of the sun disc above the horizon at texture coordinate uv.
fn terrain_sun_visibility(uv: vec2<f32>) -> f32 {
    // The bump frame of the horizon map: x along +u, y along +v, z up.
    let sun = vec3<f32>(terrain.scene.light.x, terrain.scene.light.z, terrain.scene.light.y);
    return horizon_sun_visible(terrain_horizon, terrain_sampler, terrain.encoding, uv, sun, terrain.texel_size, terrain.scene.light.w);
}

// Sky visibility (1 - the baked occlusion) at texture coordinate uv; 1 without a map.
fn terrain_sky_visibility(uv: vec2<f32>) -> f32 {
    if (terrain.has_ao == 0u) {
        return 1.0;
    }
    let dims = vec2<i32>(textureDimensions(terrain_ao));
    let t = clamp(vec2<i32>(floor(uv * vec2<f32>(dims))), vec2<i32>(0), dims - 1);
    return 1.0 - textureLoad(terrain_ao, t, 0).r;
}

struct TerrainVertex {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) normal: vec3<f32>,
}

// The vertex of texel (i, j)'s centre, `drop` world units below the surface.
fn terrain_vertex(texel: vec2<i32>, drop: f32) -> TerrainVertex {
    var out: TerrainVertex;
    let p = terrain_position(texel) - vec3<f32>(0.0, drop, 0.0);
    out.clip = terrain.scene.view_proj * (terrain.scene.model * vec4<f32>(p, 1.0));
    out.uv = (vec2<f32>(texel) + 0.5) / vec2<f32>(terrain.size);
    out.normal = terrain_normal(texel);
    return out;
}

// The grid: two triangles per quad of texel centres. With a skirt, then a wall hanging `skirt`
// below each edge segment (both windings, 12 vertices a segment): tiles of different levels of
// detail meet without a visible crack.
@vertex
fn terrain_vs(@builtin(vertex_index) index: u32) -> TerrainVertex {
    let columns = terrain.size.x - 1u;
    let rows = terrain.size.y - 1u;
    let grid = 6u * columns * rows;
    if (index < grid) {
        let quad = index / 6u;
        var corners = array<vec2<u32>, 6>(vec2<u32>(0u, 0u), vec2<u32>(1u, 0u), vec2<u32>(0u, 1u), vec2<u32>(0u, 1u), vec2<u32>(1u, 0u), vec2<u32>(1u, 1u));
        return terrain_vertex(vec2<i32>(vec2<u32>(quad % columns, quad / columns) + corners[index % 6u]), 0.0);
    }
    // Segments: the first row, the last row, the first column, the last column.
    let k = index - grid;
    var segment = k / 12u;
    var a: vec2<u32>;
    var step: vec2<u32>;
    if (segment < columns) {
        a = vec2<u32>(segment, 0u);
        step = vec2<u32>(1u, 0u);
    } else if (segment < 2u * columns) {
        a = vec2<u32>(segment - columns, rows);
        step = vec2<u32>(1u, 0u);
    } else if (segment < 2u * columns + rows) {
        a = vec2<u32>(0u, segment - 2u * columns);
        step = vec2<u32>(0u, 1u);
    } else {
        a = vec2<u32>(columns, segment - 2u * columns - rows);
        step = vec2<u32>(0u, 1u);
    }
    // (along the segment, down): two triangles, then the same two wound the other way.
    var corners = array<vec2<u32>, 12>(
        vec2<u32>(0u, 0u), vec2<u32>(1u, 0u), vec2<u32>(0u, 1u), vec2<u32>(0u, 1u), vec2<u32>(1u, 0u), vec2<u32>(1u, 1u),
        vec2<u32>(0u, 0u), vec2<u32>(0u, 1u), vec2<u32>(1u, 0u), vec2<u32>(0u, 1u), vec2<u32>(1u, 1u), vec2<u32>(1u, 0u));
    let c = corners[k % 12u];
    return terrain_vertex(vec2<i32>(a + step * c.x), f32(c.y) * terrain.skirt);
}

// The terrain's shading; visibility x: sun visibility, y: 1 (covered), z: sky visibility.
fn terrain_shade(in: TerrainVertex) -> Shade {
    let sun = terrain_sun_visibility(in.uv);
    let sky = terrain_sky_visibility(in.uv);
    let lambert = max(dot(normalize(in.normal), terrain.scene.light.xyz), 0.0);
    let light = terrain.scene.light_color.rgb * (lambert * sun) + terrain.scene.ambient.rgb * sky;
    return Shade(vec4<f32>(terrain.scene.albedo.rgb * light, 1.0), vec4<f32>(sun, 1.0, sky, 1.0));
}

@fragment
fn terrain_fs(in: TerrainVertex) -> @location(0) vec4<f32> {
    return terrain_shade(in).color;
}

@fragment
fn terrain_fs_visibility(in: TerrainVertex) -> ShadeTargets {
    let s = terrain_shade(in);
    return ShadeTargets(s.color, s.visibility);
}
