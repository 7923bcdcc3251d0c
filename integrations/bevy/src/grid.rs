//! The mesh of a heightfield: a grid through its texel centres, in the terrain frame the
//! horizon maps use (x along +u, y up, z along +v, world units).

use bevy_asset::RenderAssetUsages;
use bevy_camera::primitives::Aabb;
use bevy_math::Vec3;
use bevy_mesh::{Indices, Mesh, PrimitiveTopology};
use hikage_bundle::{HeightfieldSettings, TextureData};

/// The label suffix of a heightfield's grid mesh: `bundle.ron#terrain.height/grid`.
pub const GRID_LABEL: &str = "grid";

/// The grid of `heights` (level 0, channel 0): texel (i, j) at ((i + ½) sx, h, (j + ½) sy),
/// normals from central differences clamped at the edges, UV at the texel centre — the same
/// surface `hikage-runtime`'s terrain draws, so a texel's horizon sits under its vertex.
pub fn grid_mesh(heights: &TextureData, settings: &HeightfieldSettings) -> Result<Mesh, String> {
    let (w, h) = (heights.desc.width as usize, heights.desc.height as usize);
    if w < 2 || h < 2 {
        return Err(format!("a terrain grid needs at least 2×2 texels, the heightfield is {w}×{h}"));
    }
    let samples = heights.channel_f32(0, 0);
    let world = |i: isize, j: isize| {
        let (i, j) = (i.clamp(0, w as isize - 1) as usize, j.clamp(0, h as isize - 1) as usize);
        settings.world_height(samples[j * w + i])
    };
    Ok(surface((w, h), settings.texel_size, world, 0.0, RenderAssetUsages::default()))
}

/// The grid of one tile of a map baked in tiles, from its heights with a one-texel apron of its
/// neighbours' (`hikage_runtime::horizon::heights_with_apron`), so that its edge normals are
/// the whole map's; with a skirt `skirt` world units deep under its edges, which hides the
/// cracks where it meets a tile of another level. Held on the GPU only, so its bounds (tile
/// frame) come with it.
pub fn tile_mesh(apron: &TextureData, settings: &HeightfieldSettings, skirt: f32) -> Result<(Mesh, Aabb), String> {
    let (aw, ah) = (apron.desc.width as usize, apron.desc.height as usize);
    if aw < 4 || ah < 4 {
        return Err(format!("a terrain tile needs at least 2×2 texels, this one is {}×{}", aw - 2, ah - 2));
    }
    let samples = apron.channel_f32(0, 0);
    let world = |i: isize, j: isize| settings.world_height(samples[(j + 1) as usize * aw + (i + 1) as usize]);
    let (w, h) = (aw - 2, ah - 2);
    let (low, high) = (0..h as isize)
        .flat_map(|j| (0..w as isize).map(move |i| (i, j)))
        .map(|(i, j)| world(i, j))
        .fold((f32::MAX, f32::MIN), |(lo, hi), y| (lo.min(y), hi.max(y)));
    let (sx, sy) = settings.texel_size;
    let bounds = Aabb::from_min_max(
        Vec3::new(0.5 * sx, low - skirt, 0.5 * sy),
        Vec3::new((w as f32 - 0.5) * sx, high, (h as f32 - 0.5) * sy),
    );
    Ok((surface((w, h), settings.texel_size, world, skirt, RenderAssetUsages::RENDER_WORLD), bounds))
}

/// The grid of `w`×`h` nodes whose world height is `world(i, j)` (defined one node past each
/// edge, for the normals), with a skirt `skirt` deep when above 0.
fn surface(
    (w, h): (usize, usize),
    (sx, sy): (f32, f32),
    world: impl Fn(isize, isize) -> f32,
    skirt: f32,
    usage: RenderAssetUsages,
) -> Mesh {
    let perimeter = if skirt > 0.0 { 2 * (w + h) - 4 } else { 0 };
    let mut positions = Vec::with_capacity(w * h + perimeter);
    let mut normals = Vec::with_capacity(w * h + perimeter);
    let mut uvs = Vec::with_capacity(w * h + perimeter);
    for j in 0..h as isize {
        for i in 0..w as isize {
            positions.push([(i as f32 + 0.5) * sx, world(i, j), (j as f32 + 0.5) * sy]);
            let du = world(i + 1, j) - world(i - 1, j);
            let dv = world(i, j + 1) - world(i, j - 1);
            let n = [-du / (2.0 * sx), 1.0, -dv / (2.0 * sy)];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            normals.push(n.map(|c| c / len));
            uvs.push([(i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32]);
        }
    }
    let mut indices = Vec::with_capacity(6 * ((w - 1) * (h - 1) + perimeter));
    for j in 0..h - 1 {
        for i in 0..w - 1 {
            let k = (j * w + i) as u32;
            let (right, down) = (k + 1, k + w as u32);
            // Counter-clockwise seen from above (+y): u runs along x, v along z.
            indices.extend_from_slice(&[k, down, right, right, down, down + 1]);
        }
    }
    if skirt > 0.0 {
        // The edge nodes once round (the −z edge along +x, then the +x, +z and −x edges): each
        // segment (a, b) and its copies (a', b') `skirt` lower make a quad facing outward.
        let ring: Vec<usize> = (0..w)
            .chain((1..h).map(|j| j * w + w - 1))
            .chain((0..w - 1).rev().map(|i| (h - 1) * w + i))
            .chain((1..h - 1).rev().map(|j| j * w))
            .collect();
        let first = positions.len() as u32;
        for &k in &ring {
            let [x, y, z] = positions[k];
            positions.push([x, y - skirt, z]);
            normals.push(normals[k]);
            uvs.push(uvs[k]);
        }
        for s in 0..ring.len() {
            let t = (s + 1) % ring.len();
            let (a, b) = (ring[s] as u32, ring[t] as u32);
            let (a2, b2) = (first + s as u32, first + t as u32);
            indices.extend_from_slice(&[a, b, a2, b, b2, a2]);
        }
    }
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, usage);
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs);
    mesh.insert_indices(Indices::U32(indices));
    mesh
}
