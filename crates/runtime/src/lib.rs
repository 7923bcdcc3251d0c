//! hikage-runtime: what a game links to draw with hikage bundles in wgpu.
//!
//! Loading is split in two so a game can load while it renders:
//! - [`CpuBundle::read`] (or [`CpuBundle::read_ids`], [`CpuBundle::read_prefix`] for one level's
//!   assets) opens a bundle, checks every payload's size and BLAKE3, and decodes textures
//!   (including zstd) and meshes. It needs no device and can run on a loader thread.
//! - [`GpuBundle::upload`] creates the wgpu textures (3D stays 3D, arrays stay arrays, every mip
//!   level uploaded) and mesh buffers. Anything the device cannot hold becomes a
//!   [`RuntimeError`], never a wgpu validation panic.
//!
//! One component per method draws with them. Each is built from a device, a queue, the
//! [`GpuBundle`] and asset ids; takes its per-frame inputs as a plain struct; records into the
//! game's render pass or command encoder; and exposes its bind group layout, bind group and WGSL
//! with the bindings at the group index the game chose, for the game's own shaders:
//!
//! - [`horizon::TerrainShadows`]: a heightfield under a sun, horizon shadows and ambient
//!   occlusion (seed 000 on terrain); [`horizon::TerrainStream`]: the same for a map of any
//!   size, baked in tiles with levels of detail and streamed around the camera (its residency,
//!   [`horizon::TileResidency`], is what another engine's stream runs too);
//! - [`horizon::SunField`]: the terrain's sun visibility at any world point, for the game's own
//!   shaders — houses, trees and water in a mountain's shadow kilometres away;
//! - [`horizon::SurfaceShadows`]: a bump map on a curved mesh with the curvature-corrected
//!   horizon test (seed 000 §3);
//! - [`relief::ReliefMaterial`]: relief mapping with depth-map shadows and ambient occlusion on
//!   any mesh with tangents (seed 003);
//! - [`hair::HairRenderer`]: deep opacity maps and hair blended at its opacity (seed 004), and
//!   [`hair::HairSkin`]: hair following a skinned scalp;
//! - [`shadow_fit`]: the per-frame light projection fitted to what the camera sees (seed 001,
//!   CPU).
//!
//! Every shader has a CPU reference of the same name, which the tests compare with the GPU.
//! The runtime never links the baker, and leaves wgpu's backends to the game.
//!
//! A terrain, set up once and drawn every frame:
//!
//! ```no_run
//! use hikage_runtime::glam::camera::rh::{proj::directx, view::look_at_mat4};
//! use hikage_runtime::horizon::{Sun, TerrainFrame, TerrainShadows};
//! use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, RuntimeError, glam::{Mat4, Vec3}, wgpu};
//!
//! const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
//! const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
//!
//! struct Game {
//!     terrain: TerrainShadows,
//!     view_proj: Mat4,
//! }
//!
//! impl Game {
//!     /// Once: load (a loader thread could do the first line), upload, build the component, and
//!     /// place a camera from the terrain's extent.
//!     fn new(device: &wgpu::Device, queue: &wgpu::Queue, aspect: f32) -> Result<Game, RuntimeError> {
//!         let cpu = CpuBundle::read_prefix("bundle".as_ref(), "terrain.")?;
//!         let gpu = GpuBundle::upload(device, queue, &cpu)?;
//!         let options = DrawOptions { depth_format: Some(DEPTH), ..DrawOptions::new(COLOR) };
//!         let terrain = TerrainShadows::new(device, queue, &gpu, "terrain.horizon", Some("terrain.ao"), &options)?;
//!         let (centre, radius) = (terrain.extent().centre(), terrain.extent().radius());
//!         let eye = centre + Vec3::new(0.0, 0.8, 1.2) * radius;
//!         let view = look_at_mat4(eye, centre, Vec3::Y);
//!         let view_proj = directx::perspective(0.8, aspect, 0.01 * radius, 4.0 * radius) * view;
//!         Ok(Game { terrain, view_proj })
//!     }
//!
//!     /// Every frame: the sun, then the terrain drawn into the game's pass.
//!     fn frame(&self, device: &wgpu::Device, queue: &wgpu::Queue, color: &wgpu::TextureView, depth: &wgpu::TextureView) {
//!         let sun = Sun { direction: Vec3::new(-0.9, 0.2, 0.1).normalize(), ..Sun::default() };
//!         self.terrain.update(queue, &TerrainFrame { view_proj: self.view_proj, sun, ..TerrainFrame::default() });
//!         let mut encoder = device.create_command_encoder(&Default::default());
//!         {
//!             let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
//!                 color_attachments: &[Some(wgpu::RenderPassColorAttachment {
//!                     view: color,
//!                     depth_slice: None,
//!                     resolve_target: None,
//!                     ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
//!                 })],
//!                 depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
//!                     view: depth,
//!                     depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
//!                     stencil_ops: None,
//!                 }),
//!                 ..Default::default()
//!             });
//!             self.terrain.draw(&mut pass);
//!         }
//!         queue.submit([encoder.finish()]);
//!     }
//! }
//! ```
//!
//! After an artist rebakes, [`CpuBundle::reload`] reads what changed, [`GpuBundle::apply`]
//! uploads it, and [`Changes::touches`] says which components to build again (each lists its
//! `asset_ids`).

mod draw;
mod error;
mod gpu;
pub mod hair;
pub mod horizon;
mod load;
pub mod relief;
mod scene;
pub mod shadow_fit;
mod upload;

pub use bytemuck;
pub use draw::DrawOptions;
pub use error::RuntimeError;
pub use glam;
pub use hikage_bundle;
pub use hikage_bundle::PayloadData;
pub use load::{Changes, CpuAsset, CpuBundle};
pub use scene::{SCENE_WGSL, SceneUniform};
pub use upload::{GpuBundle, GpuMesh, GpuTexture, OPTIONAL_FEATURES, device_format, wgpu_format};
pub use wgpu;

/// The WGSL sources the components build, as each builds them: a typo in a shader or a
/// uniform whose Rust layout differs from its WGSL struct fails here, not in a game's first
/// frame.
#[cfg(test)]
mod wgsl_tests {
    use crate::hair::HairUniform;
    use crate::horizon::sun_field::{COMMON_WGSL, FILL_WGSL, SUN_FIELD_WGSL, SunFieldPass, SunFieldUniform, WALK_WGSL};
    use crate::horizon::{HorizonEncoding, SurfaceUniform, TerrainUniform};
    use crate::relief::{ReliefMaterialUniform, ReliefUniform};
    use crate::scene::{SCENE_WGSL, SceneUniform};

    fn sources() -> Vec<(&'static str, String)> {
        let horizon = crate::horizon::HORIZON_WGSL;
        let relief = crate::relief::RELIEF_WGSL;
        vec![
            ("horizon", horizon.to_string()),
            ("terrain", format!("{SCENE_WGSL}\n{horizon}\n{}", include_str!("shaders/terrain.wgsl"))),
            ("surface", format!("{SCENE_WGSL}\n{horizon}\n{}", include_str!("shaders/surface.wgsl"))),
            ("relief", relief.to_string()),
            ("hair", crate::hair::HAIR_WGSL.to_string()),
            ("hair skin", crate::hair::HAIR_SKIN_WGSL.to_string()),
            ("relief material", format!("{SCENE_WGSL}\n{relief}\n{}", include_str!("shaders/relief_material.wgsl"))),
            ("sun field", SUN_FIELD_WGSL.to_string()),
            (
                "sun field fill",
                format!(
                    "{SCENE_WGSL}\n{horizon}\n{}\n{COMMON_WGSL}\n{FILL_WGSL}",
                    include_str!("shaders/terrain.wgsl")
                ),
            ),
            ("sun field walk", format!("{COMMON_WGSL}\n{WALK_WGSL}")),
        ]
    }

    fn parse(name: &str, source: &str) -> naga::Module {
        naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)))
    }

    #[test]
    fn every_shader_validates() {
        for (name, source) in sources() {
            for group in [0, 3] {
                let source = crate::gpu::at_group(&source, group);
                naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                    .validate(&parse(name, &source))
                    .unwrap_or_else(|e| panic!("{name} at group {group}: {}", e.emit_to_string(&source)));
            }
        }
    }

    /// Byte offsets of a Rust uniform's fields by name, and its size.
    macro_rules! layout {
        ($t:ty; $($field:ident),*) => {
            (std::mem::size_of::<$t>(), vec![$((stringify!($field), std::mem::offset_of!($t, $field))),*])
        };
    }

    /// Every uniform's size and field offsets equal naga's layout of its WGSL struct (padding
    /// members, named `_…`, aside).
    #[test]
    fn every_uniform_matches_its_wgsl_struct() {
        let uniforms = [
            ("terrain", "Scene", layout!(SceneUniform; view_proj, model, light, light_color, ambient, albedo)),
            ("terrain", "HorizonEncoding", layout!(HorizonEncoding; format, distance_scale, open_sky_slope)),
            (
                "terrain",
                "TerrainUniform",
                layout!(TerrainUniform; scene, texel_size, height_scale, height_offset, size, has_ao, skirt, encoding, apron),
            ),
            (
                "surface",
                "SurfaceUniform",
                layout!(SurfaceUniform; scene, tile, texel_size, height_scale, height_offset, size, encoding),
            ),
            (
                "sun field",
                "SunFieldUniform",
                layout!(SunFieldUniform; to_map, levels, walk, slopes, map_size, side, count),
            ),
            ("sun field fill", "SunFieldPass", layout!(SunFieldPass; offset, first, level, edges)),
            ("sun field walk", "SunFieldPass", layout!(SunFieldPass; offset, first, level, edges)),
            (
                "relief",
                "ReliefUniform",
                layout!(ReliefUniform; size, depth_size, levels, theta_rows, phi_cols, tracer, thickness, steps, binary,
                    start_level, stop_level, margin, direction_rule, visibility, visibility_steps, visibility_binary),
            ),
            (
                "relief material",
                "ReliefMaterialUniform",
                layout!(ReliefMaterialUniform; scene, eye, tile, ao_stride, shadows, bias),
            ),
            (
                "hair",
                "HairUniform",
                layout!(HairUniform; light, light_inverse, bounds_min, bounds_max, camera, eye, to_light, light_color,
                    ambient, root_tint, tip_tint, step, opacity_set, resolution, specular_power, specular, layer_rule,
                    lookup, max_width, width_ratio, alpha_ratio, taper, min_pixel_width, viewport, depth_range,
                    camera_widen, light_widen, color_variation, oit_falloff, model, model_width),
            ),
        ];
        let sources = sources();
        for (module, name, (size, fields)) in uniforms {
            let source = &sources.iter().find(|s| s.0 == module).unwrap().1;
            let naga = parse(module, source);
            let (members, span) = naga
                .types
                .iter()
                .find_map(|(_, ty)| match &ty.inner {
                    naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some(name) => {
                        Some((members.clone(), *span))
                    }
                    _ => None,
                })
                .unwrap_or_else(|| panic!("no struct {name} in {module}"));
            assert_eq!(span as usize, size, "{name}: WGSL size {span}, Rust {size}");
            let wgsl: Vec<(String, usize)> = members
                .iter()
                .filter_map(|m| m.name.clone().map(|n| (n, m.offset as usize)))
                .filter(|(n, _)| !n.starts_with('_'))
                .collect();
            let rust: Vec<(String, usize)> = fields.into_iter().map(|(n, o)| (n.to_string(), o)).collect();
            assert_eq!(wgsl, rust, "{name}: WGSL members and offsets against Rust's");
        }
    }
}
