//! Bump maps on curved meshes: [`CurvedSurface`] draws a bundle's `Curvature` mesh with a
//! `Horizon` asset's bump map tiled over it, shadowed by the horizon test corrected for the
//! mesh's curvature ([`CurvedMaterial`]).

use bevy_asset::{Asset, Handle};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_math::{UVec2, Vec2};
use bevy_mesh::{Mesh, MeshVertexBufferLayoutRef};
use bevy_pbr::{
    ExtendedMaterial, MaterialExtension, MaterialExtensionKey, MaterialExtensionPipeline, StandardMaterial,
};
use bevy_reflect::Reflect;
use bevy_render::render_resource::{AsBindGroup, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError};
use bevy_shader::ShaderRef;
use hikage_bundle::{AssetKind, Settings};

use crate::HikageBundle;
use crate::attach::FromBundle;
use crate::attributes;
use crate::diagnostics::{NamesBundle, Problems, SunShadowed};

/// Bevy's `StandardMaterial` on a curved mesh with a bump map and curvature-corrected horizon
/// shadows.
pub type CurvedMaterial = ExtendedMaterial<StandardMaterial, CurvedExtension>;

/// Draws `Curvature` asset `curvature` of `bundle` (the mesh, with κ1, κ2, the principal
/// directions and `P_u`, `P_v` per vertex) carrying the bump map of `Horizon` asset `horizon`,
/// tiled once per unit of UV. The sun is the scene's first `DirectionalLight`, with
/// `shadow_maps_enabled` as for [`crate::HorizonTerrain`].
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::CurvedSurface;
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>) {
///     let bundle = assets.load("bundle/bundle.ron");
///     commands.spawn(CurvedSurface::new(bundle, "sphere", "cylinders.horizon"));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(bevy_transform::components::Transform, bevy_camera::visibility::Visibility, Problems)]
pub struct CurvedSurface {
    /// The bundle holding the assets.
    pub bundle: Handle<HikageBundle>,
    /// The `Curvature` asset: the mesh drawn.
    pub curvature: String,
    /// The `Horizon` asset of the bump map (and, through its settings, its heightfield).
    pub horizon: String,
    /// The surface under the shadows.
    pub base: StandardMaterial,
    /// The curvature-corrected test; `false` gives the flat horizon test, for comparison.
    pub corrected: bool,
}

impl CurvedSurface {
    /// Mesh `curvature` with bump map `horizon`, corrected for curvature.
    pub fn new(bundle: Handle<HikageBundle>, curvature: impl Into<String>, horizon: impl Into<String>) -> Self {
        CurvedSurface {
            bundle,
            curvature: curvature.into(),
            horizon: horizon.into(),
            base: StandardMaterial { perceptual_roughness: 0.8, ..StandardMaterial::default() },
            corrected: true,
        }
    }

    /// The same over `base` (colour, textures, roughness).
    pub fn with_base(mut self, base: StandardMaterial) -> CurvedSurface {
        self.base = base;
        self
    }
}

/// The bump half of [`CurvedMaterial`].
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
pub struct CurvedExtension {
    /// The bump map's size, heights and encoding, and the test.
    #[uniform(100)]
    pub uniform: CurvedUniform,
    /// The bump map's horizon map.
    #[texture(101, dimension = "3d")]
    #[sampler(102)]
    pub horizon: Handle<Image>,
    /// The bump map's heights.
    #[texture(103, sample_type = "float", filterable = false)]
    pub heights: Handle<Image>,
}

/// The uniform of [`CurvedExtension`] (WGSL `HikageCurved`).
#[derive(ShaderType, Reflect, Debug, Clone, Copy, Default)]
pub struct CurvedUniform {
    /// One tile of the bump map in its world units, `(W·sx, H·sy)`.
    pub tile: Vec2,
    /// The bump map's texel size.
    pub texel_size: Vec2,
    /// The heightfield's width and height.
    pub size: UVec2,
    /// Bump height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// 0: float texels; 1: `Rg8Unorm`.
    pub format: u32,
    /// World units of distance per unit of the distance channel (`Rg8Unorm`).
    pub distance_scale: f32,
    /// `tan β` of open sky (`Rg8Unorm`'s code 0).
    pub open_sky_slope: f32,
    /// 1: the curvature-corrected test; 0: the flat one; 2: no horizon test (Bevy's light as
    /// it is).
    pub test: u32,
}

impl MaterialExtension for CurvedExtension {
    fn vertex_shader() -> ShaderRef {
        crate::shaders::CURVED.into()
    }

    fn fragment_shader() -> ShaderRef {
        crate::shaders::CURVED.into()
    }

    /// The main pass reads the Curvature streams; prepasses and shadows keep Bevy's layout.
    fn specialize(
        _: &MaterialExtensionPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        layout: &MeshVertexBufferLayoutRef,
        _: MaterialExtensionKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        if descriptor.vertex.shader_defs.contains(&"PREPASS_PIPELINE".into()) {
            return Ok(());
        }
        descriptor.vertex.buffers = vec![layout.0.get_layout(&[
            Mesh::ATTRIBUTE_POSITION.at_shader_location(0),
            Mesh::ATTRIBUTE_NORMAL.at_shader_location(1),
            Mesh::ATTRIBUTE_UV_0.at_shader_location(2),
            attributes::CURVATURE.at_shader_location(8),
            attributes::PRINCIPAL1.at_shader_location(9),
            attributes::PRINCIPAL2.at_shader_location(10),
            attributes::TANGENT_U.at_shader_location(11),
            attributes::TANGENT_V.at_shader_location(12),
        ])?];
        Ok(())
    }
}

impl NamesBundle for CurvedSurface {
    fn bundle(&self) -> &Handle<HikageBundle> {
        &self.bundle
    }
}

impl SunShadowed for CurvedSurface {}

impl FromBundle for CurvedSurface {
    type Material = CurvedMaterial;

    fn build(&self, bundle: &HikageBundle) -> Result<(CurvedMaterial, Option<Handle<Mesh>>), String> {
        let curvature =
            bundle.asset(&self.curvature).ok_or_else(|| format!("no asset `{}` in the bundle", self.curvature))?;
        if curvature.kind != AssetKind::Curvature {
            return Err(format!("asset `{}` is a {:?}, expected a Curvature", self.curvature, curvature.kind));
        }
        let mesh =
            bundle.mesh(&self.curvature).cloned().ok_or_else(|| format!("asset `{}` has no mesh", self.curvature))?;
        let (settings, horizon, encoding) = bundle.horizon(&self.horizon)?;
        let heights = bundle.image_of_kind(&settings.heightfield, AssetKind::Heightfield)?;
        let height_asset =
            bundle.asset(&settings.heightfield).ok_or_else(|| format!("no asset `{}`", settings.heightfield))?;
        let (Settings::Heightfield(hf), Some(desc)) = (&height_asset.settings, height_asset.payload.texture()) else {
            return Err(format!("asset `{}` is not a heightfield texture", settings.heightfield));
        };
        let (sx, sy) = settings.texel_size;
        let uniform = CurvedUniform {
            tile: Vec2::new(desc.width as f32 * sx, desc.height as f32 * sy),
            texel_size: Vec2::new(sx, sy),
            size: UVec2::new(desc.width, desc.height),
            height_scale: hf.height_scale,
            height_offset: hf.height_offset,
            format: encoding.format,
            distance_scale: encoding.distance_scale,
            open_sky_slope: encoding.open_sky_slope,
            test: u32::from(self.corrected),
        };
        let extension = CurvedExtension { uniform, horizon, heights };
        Ok((ExtendedMaterial { base: self.base.clone(), extension }, Some(mesh)))
    }
}
