//! Writing a mesh asset as binary glTF 2.0 (`.glb`) for engines and viewers.
//!
//! Streams map to glTF attributes: `position` → `POSITION` (with the min/max glTF requires),
//! `normal` → `NORMAL`, a 4-component `tangent` → `TANGENT`, `color` → `COLOR_0`, `uv` →
//! `TEXCOORD_0`; every other stream becomes a custom attribute named `_` + its upper-cased name
//! (`_CURVATURE`, `_STRAND_ID`, …). Indices are `UNSIGNED_INT` triangles. One buffer, one buffer
//! view per stream, all 4-byte aligned.
//!
//! A strands asset is written as its ribbons ([`crate::strands::ribbons`]): flat, non-degenerate
//! strips with tangents, for tools that do not widen strips in a shader.

use std::path::Path;

use hikage_bundle::{Bundle, ComponentType, MeshData};
use serde_json::json;

use crate::error::BakeError;

fn attribute_name(stream: &str, components: u8) -> String {
    match stream {
        "position" => "POSITION".into(),
        "tangent" if components == 4 => "TANGENT".into(),
        "normal" => "NORMAL".into(),
        "color" => "COLOR_0".into(),
        "uv" => "TEXCOORD_0".into(),
        other => format!("_{}", other.to_uppercase()),
    }
}

fn accessor_type(components: u8) -> &'static str {
    match components {
        1 => "SCALAR",
        2 => "VEC2",
        3 => "VEC3",
        _ => "VEC4",
    }
}

/// The GLB bytes of a mesh.
pub fn glb(mesh: &MeshData, generator: &str) -> Result<Vec<u8>, String> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut attributes) = (Vec::new(), Vec::new(), serde_json::Map::new());
    for a in &mesh.desc.attributes {
        if a.component != ComponentType::F32 {
            return Err(format!("stream `{}`: only f32 streams are exported", a.name));
        }
        let start = a.offset as usize;
        let len = a.count as usize * a.stride as usize;
        let data =
            mesh.bytes.get(start..start + len).ok_or_else(|| format!("stream `{}` runs past the payload", a.name))?;
        let mut acc = json!({
            "bufferView": views.len(),
            "componentType": 5126,
            "count": a.count,
            "type": accessor_type(a.components),
        });
        if a.name == "position" {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for v in data.chunks_exact(12) {
                for k in 0..3 {
                    let x = f32::from_le_bytes([v[4 * k], v[4 * k + 1], v[4 * k + 2], v[4 * k + 3]]);
                    lo[k] = lo[k].min(x);
                    hi[k] = hi[k].max(x);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": len, "target": 34962 }));
        attributes.insert(attribute_name(&a.name, a.components), json!(accessors.len()));
        accessors.push(acc);
        bin.extend_from_slice(data);
    }
    let mut primitive = json!({ "attributes": attributes, "mode": 4 });
    if let Some(ix) = &mesh.desc.indices {
        let start = ix.offset as usize;
        let len = ix.count as usize * 4;
        let data = mesh.bytes.get(start..start + len).ok_or("the index stream runs past the payload")?;
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": len, "target": 34963 }));
        primitive["indices"] = json!(accessors.len());
        accessors
            .push(json!({ "bufferView": views.len() - 1, "componentType": 5125, "count": ix.count, "type": "SCALAR" }));
        bin.extend_from_slice(data);
    }
    let doc = json!({
        "asset": { "version": "2.0", "generator": generator },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [primitive] }],
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": accessors,
    });
    let mut text = serde_json::to_vec(&doc).map_err(|e| e.to_string())?;
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}

/// Writes mesh asset `id` of `bundle` to `out` as GLB; returns (vertices, indices).
pub fn export_gltf(bundle: &Bundle, id: &str, out: &Path) -> Result<(u32, u32), BakeError> {
    let mut mesh = bundle.read_mesh(id)?;
    if let Some(settings) = bundle.asset(id)?.settings.strands() {
        let points = hikage_bundle::read_strand_points(&mesh, settings).ok_or_else(|| {
            BakeError::input(out, Some(format!("asset `{id}`")), "strand records of an unknown layout")
        })?;
        mesh = crate::strands::ribbons::build(&points, settings.taper);
    }
    let bytes =
        glb(&mesh, hikage_bundle::GENERATOR).map_err(|m| BakeError::input(out, Some(format!("asset `{id}`")), m))?;
    super::write_via_temp(out, &bytes)?;
    Ok((mesh.desc.vertex_count, mesh.desc.indices.as_ref().map_or(0, |i| i.count)))
}
