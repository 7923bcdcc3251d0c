//! The `Curvature` job: an OBJ or glTF mesh with UVs → a `curvature` mesh asset.

use std::path::{Path, PathBuf};

use hikage_bundle::{CurvatureSettings, MeshData, Settings};
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
        let position = flat(&|v| mesh.positions[mesh.vertex_position[v] as usize].as_vec3().to_array().to_vec());
        data.push_f32("position", 3, &position)?;
        data.push_f32("uv", 2, &flat(&|v| mesh.vertex_uv[v].as_vec2().to_array().to_vec()))?;
        data.push_f32("normal", 3, &flat(&|v| c[v].normal.as_vec3().to_array().to_vec()))?;
        data.push_f32("curvature", 2, &flat(&|v| vec![c[v].k1 as f32, c[v].k2 as f32]))?;
        data.push_f32("principal1", 2, &flat(&|v| c[v].dir1_uv.as_vec2().to_array().to_vec()))?;
        data.push_f32("principal2", 2, &flat(&|v| c[v].dir2_uv.as_vec2().to_array().to_vec()))?;
        data.push_f32("tangent_u", 3, &flat(&|v| c[v].pu.as_vec3().to_array().to_vec()))?;
        data.push_f32("tangent_v", 3, &flat(&|v| c[v].pv.as_vec3().to_array().to_vec()))?;
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
