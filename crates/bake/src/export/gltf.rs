//! Writing a mesh asset as binary glTF 2.0 (`.glb`) for engines and viewers.
//!
//! Streams map to glTF attributes: `position` → `POSITION` (with the min/max glTF requires),
//! `normal` → `NORMAL`, a 4-component `tangent` → `TANGENT`, `color` → `COLOR_0`, `uv` →
//! `TEXCOORD_0`; every other stream becomes a custom attribute named `_` + its upper-cased name
//! (`_CURVATURE`, `_STRAND_ID`, …); a scalp's `joints` and `weights` are `JOINTS_0` (integers,
//! not normalized) and `WEIGHTS_0`, under a skin naming its joints. Indices are triangles, as stored (U32 or U16). One buffer, one buffer
//! view per stream, all 4-byte aligned. 8- and 16-bit streams are written as they are stored,
//! `normalized`; where core glTF does not allow their type (8-bit normals and tangents) the file
//! lists KHR_mesh_quantization as used and required.
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
        // A scalp's skin: joint indices (integers) and their weights.
        "joints" if components == 4 => "JOINTS_0".into(),
        "weights" if components == 4 => "WEIGHTS_0".into(),
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

/// glTF's `componentType` of a stream, and whether it is `normalized`; `None` for U32, which
/// glTF allows only for indices.
fn component_type(c: ComponentType) -> Option<(u32, bool)> {
    Some(match c {
        ComponentType::I8 => (5120, true),
        ComponentType::U8 => (5121, true),
        ComponentType::I16 => (5122, true),
        ComponentType::U16 => (5123, true),
        ComponentType::F32 => (5126, false),
        ComponentType::U32 => return None,
    })
}

/// Whether core glTF 2.0 allows `component` for attribute `gltf`; where it does not (normals and
/// tangents in 8 or 16 bits, signed texture coordinates) the file requires KHR_mesh_quantization.
fn core_allows(gltf: &str, component: ComponentType) -> bool {
    match gltf {
        _ if component == ComponentType::F32 => true,
        "NORMAL" | "TANGENT" | "POSITION" => false,
        "TEXCOORD_0" | "COLOR_0" | "JOINTS_0" | "WEIGHTS_0" => {
            matches!(component, ComponentType::U8 | ComponentType::U16)
        }
        _ => true, // application-specific attributes take any type
    }
}

/// The GLB bytes of a mesh.
pub fn glb(mesh: &MeshData, generator: &str) -> Result<Vec<u8>, String> {
    glb_skinned(mesh, generator, &[])
}

/// The GLB bytes of a mesh skinned by `joints` (a scalp's joint names, in the order its `joints`
/// stream indexes them): a node per joint at the scene's root and a skin naming them, with the
/// identity for every inverse bind matrix (the mesh as stored is the bind pose); no joints, no
/// skin.
pub fn glb_skinned(mesh: &MeshData, generator: &str, joints: &[String]) -> Result<Vec<u8>, String> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut attributes) = (Vec::new(), Vec::new(), serde_json::Map::new());
    let mut quantized = false;
    for a in &mesh.desc.attributes {
        let (code, normalized) = component_type(a.component)
            .ok_or_else(|| format!("stream `{}`: glTF takes U32 only for indices", a.name))?;
        let gltf = attribute_name(&a.name, a.components);
        // Joint indices are integers, never normalized.
        let normalized = normalized && gltf != "JOINTS_0";
        if a.name == "position" && a.component != ComponentType::F32 {
            return Err("stream `position`: only f32 positions are exported".into());
        }
        quantized |= !core_allows(&gltf, a.component);
        let start = a.offset as usize;
        let len = a.count as usize * a.stride as usize;
        let data =
            mesh.bytes.get(start..start + len).ok_or_else(|| format!("stream `{}` runs past the payload", a.name))?;
        let mut acc = json!({
            "bufferView": views.len(),
            "componentType": code,
            "count": a.count,
            "type": accessor_type(a.components),
        });
        if normalized {
            acc["normalized"] = json!(true);
        }
        if a.name == "position" {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for v in mesh.elements(a) {
                for k in 0..3 {
                    let x = a.component.normalized(v, k);
                    lo[k] = lo[k].min(x);
                    hi[k] = hi[k].max(x);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let mut view = json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": len, "target": 34962 });
        if a.stride as usize != a.element_bytes() {
            view["byteStride"] = json!(a.stride);
        }
        views.push(view);
        attributes.insert(gltf, json!(accessors.len()));
        accessors.push(acc);
        bin.extend_from_slice(data);
    }
    let mut primitive = json!({ "attributes": attributes, "mode": 4 });
    if let Some(ix) = &mesh.desc.indices {
        let start = ix.offset as usize;
        let (code, size) = if ix.component == ComponentType::U16 { (5123, 2) } else { (5125, 4) };
        let len = ix.count as usize * size;
        let data = mesh.bytes.get(start..start + len).ok_or("the index stream runs past the payload")?;
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": len, "target": 34963 }));
        primitive["indices"] = json!(accessors.len());
        accessors
            .push(json!({ "bufferView": views.len() - 1, "componentType": code, "count": ix.count, "type": "SCALAR" }));
        bin.extend_from_slice(data);
    }
    let mut nodes = vec![json!({ "mesh": 0 })];
    if !joints.is_empty() {
        nodes[0]["skin"] = json!(0);
        nodes.extend(joints.iter().map(|name| json!({ "name": name })));
    }
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": generator },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": [{ "primitives": [primitive] }],
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": accessors,
    });
    if !joints.is_empty() {
        doc["skins"] = json!([{ "joints": (1..=joints.len()).collect::<Vec<_>>() }]);
    }
    if quantized {
        doc["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
        doc["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    }
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
    let joints = match &bundle.asset(id)?.settings {
        hikage_bundle::Settings::Scalp(scalp) => scalp.joints.clone(),
        _ => Vec::new(),
    };
    let bytes = glb_skinned(&mesh, hikage_bundle::GENERATOR, &joints)
        .map_err(|m| BakeError::input(out, Some(format!("asset `{id}`")), m))?;
    super::write_via_temp(out, &bytes)?;
    Ok((mesh.desc.vertex_count, mesh.desc.indices.as_ref().map_or(0, |i| i.count)))
}
