//! hikage-runtime: loads hikage bundles into wgpu and provides the WGSL that uses them.
//!
//! Loading is split in two so a game can load while it renders:
//! - [`CpuBundle::read`] opens a bundle, checks every payload's size and BLAKE3, and decodes
//!   textures (including zstd) and meshes. It needs no device and can run on a worker thread.
//! - [`GpuBundle::upload`] creates the wgpu textures (3D stays 3D, arrays stay arrays, every mip
//!   level uploaded) and mesh buffers. Anything the device cannot hold becomes a
//!   [`RuntimeError`], never a wgpu validation panic.
//!
//! [`horizon`] holds the WGSL of curvature-corrected horizon shadows and its CPU reference;
//! [`relief`] the relief-mapping tracers (seed 003), shadows and ambient occlusion, with theirs;
//! [`shadow_fit`] the per-frame light-projection fit of seed 001 (CPU, glam).
//!
//! The runtime never links the baker: a game needs only this crate and `hikage-bundle`.

mod error;
mod gpu;
pub mod hair;
pub mod horizon;
mod load;
pub mod relief;
pub mod shadow_fit;
mod upload;

pub use error::RuntimeError;
pub use glam;
pub use load::{CpuAsset, CpuBundle, CpuPayload};
pub use upload::{GpuBundle, GpuMesh, GpuTexture, wgpu_format};
pub use wgpu;

/// Every WGSL source the crate builds, as a component builds it, parses and validates (naga,
/// no device): a typo in a shader fails here, not in a game's first frame.
#[cfg(test)]
mod wgsl_tests {
    #[test]
    fn every_shader_validates() {
        let sources = [
            ("horizon", crate::horizon::HORIZON_WGSL.to_string()),
            ("terrain", format!("{}\n{}", crate::horizon::HORIZON_WGSL, include_str!("shaders/terrain.wgsl"))),
            ("surface", format!("{}\n{}", crate::horizon::HORIZON_WGSL, include_str!("shaders/surface.wgsl"))),
        ];
        for (name, source) in sources {
            for group in [0, 3] {
                let source = crate::gpu::at_group(&source, group);
                let module = naga::front::wgsl::parse_str(&source)
                    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&source)));
                naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                    .validate(&module)
                    .unwrap_or_else(|e| panic!("{name} at group {group}: {}", e.emit_to_string(&source)));
            }
        }
    }
}
