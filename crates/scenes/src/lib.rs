//! hikage-scenes: the offscreen harness and the demo scenes shared by the runtime's examples,
//! the GPU tests and the bench, in the manner of the wgpu examples' framework. Nothing here is
//! part of what a game links (`publish = false`); the examples draw through
//! `hikage-runtime`'s public API and use this crate only for a device, read-back and PNGs.
//!
//! - [`headless`]: a device without a window, read-back of buffers and textures.
//! - [`png`]: PNG output for the pictures in `docs/images/`.
//! - [`raster`]: a CPU rasteriser, so a test can run a shader's CPU reference per pixel.
//! - [`horizon_sphere`], [`relief_plane`], [`shadow_scene`], [`hair_scene`]: analytic reference
//!   scenes whose every pixel a CPU function reproduces, for the GPU tests and the figures.
//! - [`hair_view`]: the hair in the camera against the same renderer supersampled.

pub mod hair_scene;
pub mod hair_view;
pub mod headless;
pub mod horizon_sphere;
pub mod png;
pub mod raster;
pub mod relief_plane;
pub mod shadow_scene;

use std::path::{Path, PathBuf};

use hikage_runtime::{CpuBundle, GpuBundle};

/// The command line every example takes, `[BUNDLE] [OUT]`: the bundle (default `bundle`) and
/// the directory the pictures go to (default `target/<name>`), created.
pub fn example_paths(name: &str) -> Result<(PathBuf, PathBuf), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let bundle = PathBuf::from(args.next().unwrap_or_else(|| "bundle".into()));
    let out = PathBuf::from(args.next().unwrap_or_else(|| format!("target/{name}")));
    std::fs::create_dir_all(&out)?;
    Ok((bundle, out))
}

/// What every example starts with: the assets `ids` (and the assets they name) read from the
/// bundle in `dir`, a headless device, and those assets uploaded to it. Prints the adapter.
pub fn open_bundle(
    dir: &Path,
    ids: &[&str],
) -> Result<(CpuBundle, headless::Headless, GpuBundle), Box<dyn std::error::Error>> {
    let cpu = CpuBundle::read_ids(dir, ids)?;
    let gpu = headless::Headless::new()?;
    println!("adapter: {}", gpu.describe());
    let uploaded = GpuBundle::upload(&gpu.device, &gpu.queue, &cpu)?;
    Ok((cpu, gpu, uploaded))
}

/// The vertices of a `Curvature` asset's mesh as a [`ReliefMaterial`] draws them: the tangent
/// along `P_u`, its sign from `P_v` (the bitangent is `w · cross(normal, tangent)`).
///
/// [`ReliefMaterial`]: hikage_runtime::relief::ReliefMaterial
pub fn relief_vertices(mesh: &hikage_bundle::MeshData) -> Vec<hikage_runtime::relief::ReliefVertex> {
    use glam::Vec3;
    let stream = |name: &str| mesh.read_f32(name).unwrap_or_else(|| panic!("a curvature mesh has `{name}`"));
    let (position, normal, uv) = (stream("position"), stream("normal"), stream("uv"));
    let (pu, pv) = (stream("tangent_u"), stream("tangent_v"));
    (0..mesh.desc.vertex_count as usize)
        .map(|v| {
            let n = Vec3::from_slice(&normal[3 * v..]);
            let t = Vec3::from_slice(&pu[3 * v..]).normalize();
            let w = if n.cross(t).dot(Vec3::from_slice(&pv[3 * v..])) < 0.0 { -1.0 } else { 1.0 };
            hikage_runtime::relief::ReliefVertex {
                position: [position[3 * v], position[3 * v + 1], position[3 * v + 2]],
                normal: n.to_array(),
                tangent: t.extend(w).to_array(),
                uv: [uv[2 * v], uv[2 * v + 1]],
            }
        })
        .collect()
}
