//! hikage-bevy: hikage's baked shadowing data in Bevy 0.20, through Bevy's own assets and
//! materials.
//!
//! [`HikagePlugin`] loads a bundle's `bundle.ron` as a [`HikageBundle`] whose payloads are
//! labelled sub-assets (`bundle/bundle.ron#terrain.horizon` is an [`Image`], 3D kept;
//! `bundle/bundle.ron#sphere` a [`Mesh`] with its streams as attributes, [`attributes`]), and
//! draws each method with a `StandardMaterial` extension built when the bundle has loaded:
//!
//! - [`HorizonTerrain`]: a heightfield with baked horizon shadows and ambient occlusion;
//! - [`StreamedTerrain`]: a terrain of any size baked in tiles and levels of detail, streamed
//!   around the camera;
//! - [`ReliefSurface`]: relief mapping with self-shadowing on any mesh with tangents;
//! - [`CurvedSurface`]: a bump map's horizon shadows corrected for a mesh's curvature;
//! - [`TerrainReceiver`]: any mesh in the far shadow of a [`HorizonTerrain`] or a
//!   [`StreamedTerrain`] (its sun field in the render world), past Bevy's cascades;
//! - [`HairStrands`]: hair strips blended over the scene with deep opacity maps from the sun,
//!   shadowing [`HairReceiver`] meshes;
//! - [`FittedShadows`]: a directional light's shadow map fitted to the visible geometry.
//!
//! A whole terrain scene:
//!
//! ```no_run
//! use bevy::prelude::*;
//! use hikage_bevy::{HikagePlugin, HorizonTerrain};
//!
//! fn main() {
//!     App::new().add_plugins((DefaultPlugins, HikagePlugin)).add_systems(Startup, setup).run();
//! }
//!
//! fn setup(mut commands: Commands, assets: Res<AssetServer>) {
//!     let bundle = assets.load("bundle/bundle.ron");
//!     commands.spawn(HorizonTerrain::new(bundle, "terrain.horizon").with_ao("terrain.ao"));
//!     commands.spawn((
//!         DirectionalLight { illuminance: 6_000.0, shadow_maps_enabled: true, ..default() },
//!         Transform::default().looking_to(Vec3::new(-1.0, -0.25, -0.5), Vec3::Y),
//!     ));
//!     commands.spawn((
//!         Camera3d::default(),
//!         Projection::Perspective(PerspectiveProjection { far: 200_000.0, ..default() }),
//!         Transform::from_xyz(20_000.0, 16_000.0, 50_000.0).looking_at(Vec3::new(20_000.0, 0.0, 14_000.0), Vec3::Y),
//!     ));
//! }
//! ```

mod attach;
pub mod attributes;
pub mod curved;
mod diagnostics;
mod field;
mod grid;
pub mod hair;
pub mod light_fit;
mod loader;
pub mod receiver;
pub mod relief;
mod shaders;
pub mod stream;
pub mod terrain;

use bevy_app::{App, Plugin, PostUpdate, Update};
use bevy_asset::{Asset, AssetApp, Assets, Handle};
use bevy_ecs::schedule::IntoScheduleConfigs;
use bevy_image::Image;
use bevy_light::SimulationLightSystems;
use bevy_mesh::Mesh;
use bevy_pbr::MaterialPlugin;
use bevy_reflect::TypePath;

pub use curved::{CurvedExtension, CurvedMaterial, CurvedSurface};
pub use diagnostics::HikageError;
pub use field::{FieldReceiverExtension, FieldReceiverMaterial};
pub use grid::GRID_LABEL;
pub use hair::{HairDraw, HairReceiver, HairReceiverMaterial, HairShadowMaps, HairStrands, HairStyle};
pub use hikage_bundle::{Asset as ManifestAsset, Manifest, Settings};
pub use hikage_runtime::horizon::{StreamOptions, StreamStats};
pub use light_fit::FittedShadows;
pub use loader::{BundleLoadError, BundleLoader};
pub use receiver::{TerrainReceiver, TerrainReceiverExtension, TerrainReceiverMaterial};
pub use relief::{ReliefExtension, ReliefMaterial, ReliefSurface};
pub use stream::{StreamedTerrain, TerrainStreamStats, TerrainTile};
pub use terrain::{HorizonTerrain, TerrainExtension, TerrainMaterial};

/// The whole integration: [`HikageAssetsPlugin`], the materials and the systems that build
/// [`HorizonTerrain`]s. Add it after Bevy's `DefaultPlugins` (it needs the render and PBR
/// plugins).
pub struct HikagePlugin;

impl Plugin for HikagePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            HikageAssetsPlugin,
            MaterialPlugin::<TerrainMaterial>::default(),
            MaterialPlugin::<ReliefMaterial>::default(),
            MaterialPlugin::<CurvedMaterial>::default(),
            MaterialPlugin::<TerrainReceiverMaterial>::default(),
            MaterialPlugin::<FieldReceiverMaterial>::default(),
        ));
        shaders::register(app);
        hair::build(app);
        field::build(app);
        app.add_systems(
            Update,
            (
                (attach::attach::<HorizonTerrain>, attach::attach::<ReliefSurface>, attach::attach::<CurvedSurface>),
                (diagnostics::check_load::<HorizonTerrain>, diagnostics::check_sun::<HorizonTerrain>),
                (diagnostics::check_load::<ReliefSurface>, diagnostics::check_sun::<ReliefSurface>),
                (diagnostics::check_load::<CurvedSurface>, diagnostics::check_sun::<CurvedSurface>),
                (diagnostics::check_load::<HairStrands>, relief::check_mesh),
                (stream::stream_terrain, diagnostics::check_load::<StreamedTerrain>),
                diagnostics::check_sun::<StreamedTerrain>,
                (
                    receiver::attach,
                    diagnostics::check_mesh::<TerrainReceiver>,
                    diagnostics::check_sun::<TerrainReceiver>,
                ),
            ),
        );
        app.add_systems(PostUpdate, diagnostics::publish);
        app.add_systems(
            PostUpdate,
            light_fit::fit_shadows
                .after(SimulationLightSystems::UpdateDirectionalLightCascades)
                .before(SimulationLightSystems::UpdateLightFrusta),
        );
    }
}

/// Bundles as assets only: the [`HikageBundle`] asset and its loader (`.ron` manifests named
/// `bundle.ron`), and Bevy's [`Image`] and [`Mesh`] assets if no other plugin has. For apps
/// without a renderer (asset processing, servers); [`HikagePlugin`] includes it. With a render
/// device, BC4/BC5 textures stay blocks where the device samples them (see [`BundleLoader`]).
pub struct HikageAssetsPlugin;

/// The registered loader, kept to tell it the render device once the device exists.
#[derive(bevy_ecs::prelude::Resource)]
pub(crate) struct RegisteredLoader(BundleLoader);

impl Plugin for HikageAssetsPlugin {
    fn build(&self, app: &mut App) {
        // `init_asset` replaces the storage: only where no other plugin (Bevy's image or mesh
        // plugin) has made one, or the images and meshes it holds would be lost.
        if !app.world().contains_resource::<Assets<Image>>() {
            app.init_asset::<Image>();
        }
        if !app.world().contains_resource::<Assets<Mesh>>() {
            app.init_asset::<Mesh>();
        }
        let loader = BundleLoader::default();
        app.insert_resource(RegisteredLoader(loader.clone()));
        app.init_asset::<HikageBundle>().register_asset_loader(loader);
    }

    fn finish(&self, app: &mut App) {
        // The render plugin has made its device by now (its `finish` runs first).
        if let Some(device) = app.world().get_resource::<bevy_render::renderer::RenderDevice>() {
            app.world().resource::<RegisteredLoader>().0.set_device(device.features());
        }
    }
}

/// A loaded bundle: its manifest, and a handle to each payload as a labelled sub-asset.
#[derive(Asset, TypePath, Debug)]
pub struct HikageBundle {
    /// The manifest: every asset's kind, settings and payload description.
    pub manifest: Manifest,
    /// The texture assets' images, in manifest order (their ids in `image_ids`).
    #[dependency]
    pub images: Vec<Handle<Image>>,
    /// The ids of `images`.
    pub image_ids: Vec<String>,
    /// The mesh assets' meshes, in manifest order (their ids in `mesh_ids`).
    #[dependency]
    pub meshes: Vec<Handle<Mesh>>,
    /// The ids of `meshes`.
    pub mesh_ids: Vec<String>,
    /// Each heightfield's grid mesh (labelled `<id>/grid`), in manifest order.
    #[dependency]
    pub grids: Vec<Handle<Mesh>>,
    /// The heightfield ids of `grids`.
    pub grid_ids: Vec<String>,
    /// Each `Strands` asset's records as read, by id (hair draws them with its own passes), and
    /// each `HairBinding` and `Scalp` asset (read by hikage-runtime's `HairSkin`; not meshes).
    pub strands: Vec<std::sync::Arc<hikage_runtime::CpuAsset>>,
}

impl HikageBundle {
    /// The image of texture asset `id`.
    pub fn image(&self, id: &str) -> Option<&Handle<Image>> {
        self.image_ids.iter().position(|i| i == id).map(|k| &self.images[k])
    }

    /// The mesh of mesh asset `id`.
    pub fn mesh(&self, id: &str) -> Option<&Handle<Mesh>> {
        self.mesh_ids.iter().position(|i| i == id).map(|k| &self.meshes[k])
    }

    /// The grid mesh of heightfield asset `id`: texel centres in the terrain frame (x along
    /// +u, y up, z along +v), normals, UVs.
    pub fn grid(&self, id: &str) -> Option<&Handle<Mesh>> {
        self.grid_ids.iter().position(|i| i == id).map(|k| &self.grids[k])
    }

    /// The image of texture asset `id`, which must be of `kind`; or why not.
    pub fn image_of_kind(&self, id: &str, kind: hikage_bundle::AssetKind) -> Result<Handle<Image>, String> {
        let asset = self.asset(id).ok_or_else(|| format!("no asset `{id}` in the bundle"))?;
        if asset.kind != kind {
            return Err(format!("asset `{id}` is a {:?}, expected a {kind:?}", asset.kind));
        }
        if let Some(tile) = asset.settings.tile() {
            return Err(format!(
                "asset `{id}` is a tile of map `{}`, which is streamed: draw it with `StreamedTerrain`",
                tile.map
            ));
        }
        self.image(id).cloned().ok_or_else(|| format!("asset `{id}` has no image"))
    }

    /// Horizon asset `id`: its settings, its image and how its texels are encoded; or why not.
    pub fn horizon(
        &self,
        id: &str,
    ) -> Result<(&hikage_bundle::HorizonSettings, Handle<Image>, hikage_runtime::horizon::HorizonEncoding), String>
    {
        let image = self.image_of_kind(id, hikage_bundle::AssetKind::Horizon)?;
        let asset = self.asset(id).ok_or_else(|| format!("no asset `{id}` in the bundle"))?;
        match (&asset.settings, asset.payload.texture()) {
            (hikage_bundle::Settings::Horizon(settings), Some(desc)) => {
                Ok((settings, image, hikage_runtime::horizon::HorizonEncoding::new(desc.format, settings)))
            }
            _ => Err(format!("asset `{id}` has no horizon settings or texture")),
        }
    }

    /// The records of `Strands` asset `id`, as hikage-runtime's hair renderer reads them.
    pub fn strands(&self, id: &str) -> Option<&std::sync::Arc<hikage_runtime::CpuAsset>> {
        self.strands.iter().find(|s| s.asset.id == id && s.asset.kind == hikage_bundle::AssetKind::Strands)
    }

    /// `HairBinding` or `Scalp` asset `id` as read, for hikage-runtime's `HairSkin`.
    pub fn hair_binding(&self, id: &str) -> Option<&std::sync::Arc<hikage_runtime::CpuAsset>> {
        self.strands.iter().find(|s| {
            s.asset.id == id
                && matches!(s.asset.kind, hikage_bundle::AssetKind::HairBinding | hikage_bundle::AssetKind::Scalp)
        })
    }

    /// The manifest entry of asset `id`: kind, settings, payload description.
    pub fn asset(&self, id: &str) -> Option<&ManifestAsset> {
        self.manifest.asset(id)
    }
}
