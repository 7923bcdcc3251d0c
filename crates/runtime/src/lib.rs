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
