//! The mesh of a heightfield: a grid through its texel centres, in the terrain frame the
//! horizon maps use (x along +u, y up, z along +v, world units).

use bevy_asset::RenderAssetUsages;
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
    let (sx, sy) = settings.texel_size;
    let world = |i: usize, j: usize| settings.height_offset + settings.height_scale * samples[j * w + i];
    let mut positions = Vec::with_capacity(w * h);
    let mut normals = Vec::with_capacity(w * h);
    let mut uvs = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            positions.push([(i as f32 + 0.5) * sx, world(i, j), (j as f32 + 0.5) * sy]);
            let du = world((i + 1).min(w - 1), j) - world(i.saturating_sub(1), j);
            let dv = world(i, (j + 1).min(h - 1)) - world(i, j.saturating_sub(1));
            let n = [-du / (2.0 * sx), 1.0, -dv / (2.0 * sy)];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            normals.push(n.map(|c| c / len));
            uvs.push([(i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32]);
        }
    }
    let mut indices = Vec::with_capacity(6 * (w - 1) * (h - 1));
    for j in 0..h - 1 {
        for i in 0..w - 1 {
            let k = (j * w + i) as u32;
            let (right, down) = (k + 1, k + w as u32);
            // Counter-clockwise seen from above (+y): u runs along x, v along z.
            indices.extend_from_slice(&[k, down, right, right, down, down + 1]);
        }
    }
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default());
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs);
    mesh.insert_indices(Indices::U32(indices));
    Ok(mesh)
}
