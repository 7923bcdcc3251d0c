//! The `Curvature` job: an OBJ or glTF mesh with UVs → a `curvature` mesh asset.

use std::path::{Path, PathBuf};

use hikage_bundle::{CURVATURE_STREAMS, CurvatureSettings, MeshData, Settings};
use serde::{Deserialize, Serialize};

use super::{BakedAsset, Baker, JobContext};
use crate::curvature;
use crate::error::BakeError;
use crate::mesh;

/// Version of the curvature job; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 2;

/// Settings of a curvature bake.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurvatureJob {
    /// Asset id.
    pub id: String,
    /// Wavefront OBJ with texture coordinates on every face corner, or glTF 2.0 (`.gltf`,
    /// `.glb`) whose first mesh has `POSITION` and `TEXCOORD_0` (see [`crate::mesh::gltf`]).
    pub input: PathBuf,
    /// Payload compression: `Auto` (the default: a zstd level per kind of payload), `Zstd(level)`
    /// (1–22), or `None`.
    #[serde(default)]
    pub compression: crate::Compression,
}

impl CurvatureJob {
    /// Loads and checks the mesh, and computes its curvature.
    pub(crate) fn compute(
        &self,
        ctx: &JobContext,
    ) -> Result<(crate::mesh::Mesh, Vec<curvature::VertexCurvature>), BakeError> {
        let path = ctx.base_dir.join(&self.input);
        let mesh = mesh::load(&path, mesh::MeshLimits::default())?;
        let c = curvature::compute(&mesh).map_err(|e| BakeError::input(&path, None, e.to_string()))?;
        Ok((mesh, c))
    }
}

impl Baker for CurvatureJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "curvature"
    }

    fn algorithm_version(&self) -> u32 {
        ALGORITHM_VERSION
    }

    /// The mesh, and for a `.gltf` the buffer files beside it.
    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        let input = base_dir.join(&self.input);
        let buffers = mesh::gltf::external_files(&input);
        std::iter::once(input).chain(buffers).collect()
    }

    fn outputs(&self) -> Vec<String> {
        vec![self.id.clone()]
    }

    fn canonical_settings(&self) -> String {
        "rings=2".to_string()
    }

    fn check(&self) -> Result<(), String> {
        Ok(())
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        self.compute(ctx).map(|_| ())
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 1);
        let (mesh, c) = self.compute(ctx)?;
        let n = mesh.vertex_uv.len();
        let mut data = MeshData::new(n as u32);
        let flat = |f: &dyn Fn(usize) -> Vec<f32>| (0..n).flat_map(f).collect::<Vec<f32>>();
        let v3 = |v: glam::DVec3| v.as_vec3().to_array().to_vec();
        let v2 = |v: glam::DVec2| v.as_vec2().to_array().to_vec();
        for stream in CURVATURE_STREAMS {
            let values = match stream.name {
                "position" => flat(&|v| v3(mesh.positions[mesh.vertex_position[v] as usize])),
                "uv" => flat(&|v| v2(mesh.vertex_uv[v])),
                "normal" => flat(&|v| v3(c[v].normal)),
                "curvature" => flat(&|v| vec![c[v].k1 as f32, c[v].k2 as f32]),
                "principal1" => flat(&|v| v2(c[v].dir1_uv)),
                "principal2" => flat(&|v| v2(c[v].dir2_uv)),
                "tangent_u" => flat(&|v| v3(c[v].pu)),
                _ => flat(&|v| v3(c[v].pv)),
            };
            data.push_f32(stream.name, stream.components, &values)?;
        }
        let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        data.set_indices(&indices)?;
        (ctx.progress)(1, 1);
        Ok(vec![BakedAsset {
            id: self.id.clone(),
            settings: Settings::Curvature(CurvatureSettings { positions: mesh.positions.len() as u32, rings: 2 }),
            payload: data.into(),
        }])
    }
}
