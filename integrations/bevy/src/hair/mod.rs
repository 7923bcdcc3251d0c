//! Hair strips with deep opacity maps: [`HairStrands`] on an entity draws a bundle's `Strands`
//! asset through hikage-runtime's `HairRenderer` inside Bevy's camera schedule. Each frame, for
//! each 3D camera, the opacity maps are rendered from the scene's directional light before the
//! main pass (so [`HairReceiver`] meshes are shadowed by them in the same frame), and after
//! Bevy's transparent pass the strips, expanded to face the camera, are shaded with Kajiya-Kay
//! and blended over the scene order-independently (or drawn opaque).
//!
//! The strands' coordinates as baked are the hair's own frame, and its entity's
//! `GlobalTransform` carries it into the world: parent the hair to a head or a joint entity and
//! it moves with it, its opacity maps' light box and so its receivers' shadow too (strand
//! widths scale with the transform). The opacity maps and their uniform are ordinary Bevy assets
//! ([`HairShadowMaps`]), so a game's own materials can read them too.

mod receiver;
mod render;

use bevy_app::{App, Update};
use bevy_asset::{Assets, Handle, RenderAssetUsages};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
use bevy_render::storage::ShaderBuffer;
use hikage_runtime::glam;
use hikage_runtime::hair::{HairFrame, HairLight, HairUniform};
pub use hikage_runtime::hair::{HairLod, HairSet, Lod, Lookup};

pub use receiver::{HairReceiver, HairReceiverExtension, HairReceiverMaterial};

use crate::HikageBundle;
use crate::diagnostics::{Check, NamesBundle, Problems};

/// How a camera sees the hair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HairDraw {
    /// Each strip at its own opacity, blended order-independently over the scene (weighted
    /// blended transparency: no sorting), sub-pixel strips widened with their opacity lowered
    /// so they blend instead of speckling.
    #[default]
    Blended,
    /// Opaque strips at their own width, written to the depth buffer.
    Opaque,
    /// Not drawn: the hair only shadows its receivers (a first-person head, say).
    ShadowsOnly,
}

/// Draws a bundle's hair (a `Strands` asset, the strips `hikage bake` writes from a `.hair`
/// file) and renders its deep opacity maps each frame, lit by a directional light.
///
/// Any camera draws it, with MSAA (Bevy's default) or without: with MSAA the hair is tested
/// against the camera's depth resolved to one sample per pixel. The light is `light`, or else the
/// first directional light with shadow maps (else the first one); its colour × illuminance / π
/// lights the strips as Bevy lights a matte surface, and the scene's `GlobalAmbientLight` is
/// their ambient light, both scaled by the camera's exposure.
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::hair::{HairReceiver, HairStrands};
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
///     let bundle = assets.load("bundle/bundle.ron");
///     let hair = commands.spawn(HairStrands::new(bundle, "head.strips")).id();
///     // The head under the hair, shadowed by it.
///     commands.spawn((Mesh3d(meshes.add(Sphere::new(8.5))), HairReceiver::new(hair)));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(bevy_transform::components::Transform, bevy_camera::visibility::Visibility, Problems)]
pub struct HairStrands {
    /// The bundle holding the strips.
    pub bundle: Handle<HikageBundle>,
    /// The `Strands` asset's id.
    pub strips: String,
    /// Blended, opaque or shadows only.
    pub draw: HairDraw,
    /// The directional light entity lighting the hair, or `None` for the scene's first.
    pub light: Option<Entity>,
    /// Opacity-map texels per side.
    pub resolution: u32,
    /// The set drawn into the opacity maps: the wide faint opacity set (anti-aliased shadows)
    /// or the shading set itself (plain deep opacity maps).
    pub set: HairSet,
    /// How receivers and the hair read the opacity maps.
    pub lookup: Lookup,
    /// Kajiya-Kay specular strength.
    pub specular: f32,
    /// Kajiya-Kay specular exponent.
    pub specular_power: f32,
    /// The narrowest blended strip in pixels (0: drawn at its own width).
    pub min_pixel_width: f32,
    /// Levels of detail of the camera and light passes.
    pub lod: HairLod,
    /// Gradient, taper and per-strand variation.
    pub style: HairStyle,
    /// The entity holding the `SkinnedMesh` the strands were bound to (a strands job with
    /// `scalp`), or `None` for hair carried rigidly by this entity's transform. With a skin, each
    /// strand follows its scalp triangle as the skin's joints pose it (on the GPU, every frame),
    /// and this entity's transform is not used.
    pub skin: Option<Entity>,
}

impl HairStrands {
    /// The hair of strips asset `strips` in `bundle`: blended, 256² opacity maps of the
    /// opacity set, and hikage-runtime's default look (`HairFrame::new`).
    pub fn new(bundle: Handle<HikageBundle>, strips: impl Into<String>) -> HairStrands {
        let defaults = HairFrame::new(glam::Mat4::IDENTITY, glam::Vec3::ZERO, unit_light());
        HairStrands {
            bundle,
            strips: strips.into(),
            draw: HairDraw::default(),
            light: None,
            resolution: 256,
            set: defaults.set,
            lookup: defaults.lookup,
            specular: defaults.specular,
            specular_power: defaults.specular_power,
            min_pixel_width: defaults.min_pixel_width,
            lod: defaults.lod,
            style: HairStyle::default(),
            skin: None,
        }
    }

    /// The same, following the skinned mesh of entity `skin` (the character's mesh entity with
    /// a `SkinnedMesh`, as a glTF scene spawns it), whose scalp the strands were bound to.
    ///
    /// ```no_run
    /// use bevy::prelude::*;
    /// use hikage_bevy::hair::HairStrands;
    ///
    /// // `body` is the entity of the character's skinned mesh (a glTF scene's mesh node).
    /// fn attach(mut commands: Commands, assets: Res<AssetServer>, body: Entity) {
    ///     commands.spawn(HairStrands::new(assets.load("bundle/bundle.ron"), "head.strips").with_skin(body));
    /// }
    /// ```
    pub fn with_skin(mut self, skin: Entity) -> HairStrands {
        self.skin = Some(skin);
        self
    }

    /// The same, drawn as `draw` says.
    pub fn with_draw(mut self, draw: HairDraw) -> HairStrands {
        self.draw = draw;
        self
    }

    /// The same, lit by directional light `light`.
    pub fn with_light(mut self, light: Entity) -> HairStrands {
        self.light = Some(light);
        self
    }
}

impl NamesBundle for HairStrands {
    fn bundle(&self) -> &Handle<HikageBundle> {
        &self.bundle
    }
}

/// How strands look beyond what the asset holds, in Bevy's types: a gradient from root to tip,
/// a taper, and a per-strand variation (hikage-runtime's `HairStyle`).
///
/// ```
/// use bevy::math::Vec3;
/// use hikage_bevy::HairStyle;
///
/// let auburn = HairStyle {
///     root_tint: Vec3::new(0.3, 0.2, 0.14),
///     tip_tint: Vec3::new(0.7, 0.55, 0.4),
///     ..HairStyle::default()
/// };
/// assert_eq!(auburn.root_alpha, 1.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairStyle {
    /// Factor on the strand colour at the root (linear RGB).
    pub root_tint: bevy_math::Vec3,
    /// Factor on the strand colour at the tip; mixed with `root_tint` along the strand.
    pub tip_tint: bevy_math::Vec3,
    /// Factor on the opacity at the root.
    pub root_alpha: f32,
    /// Factor on the opacity at the tip (a fade toward the tips below 1).
    pub tip_alpha: f32,
    /// Share of the width lost at the tip, or `None` for the asset's.
    pub taper: Option<f32>,
    /// Spread of a per-strand brightness factor, hashed from the strand's id (0: none; 0.2:
    /// ±10%).
    pub color_variation: f32,
}

impl Default for HairStyle {
    /// hikage-runtime's default: untinted, opaque to the tips, the asset's taper, no variation.
    fn default() -> HairStyle {
        let d = hikage_runtime::hair::HairStyle::default();
        HairStyle {
            root_tint: bevy_math::Vec3::from_array(d.root_tint.to_array()),
            tip_tint: bevy_math::Vec3::from_array(d.tip_tint.to_array()),
            root_alpha: d.root_alpha,
            tip_alpha: d.tip_alpha,
            taper: d.taper,
            color_variation: d.color_variation,
        }
    }
}

impl From<HairStyle> for hikage_runtime::hair::HairStyle {
    fn from(s: HairStyle) -> hikage_runtime::hair::HairStyle {
        hikage_runtime::hair::HairStyle {
            root_tint: glam::Vec3::from_array(s.root_tint.to_array()),
            tip_tint: glam::Vec3::from_array(s.tip_tint.to_array()),
            root_alpha: s.root_alpha,
            tip_alpha: s.tip_alpha,
            taper: s.taper,
            color_variation: s.color_variation,
        }
    }
}

/// A light over a unit box, only for reading `HairFrame`'s defaults.
fn unit_light() -> HairLight {
    HairLight::for_bounds(glam::Vec3::ZERO, glam::Vec3::ONE, glam::Vec3::Y)
}

/// The opacity maps of a [`HairStrands`] entity, set on it by the plugin: what its receivers
/// bind. Rewritten on the GPU every frame a camera draws; their contents are hikage-runtime's
/// `HairRenderer::opacity_maps` and `HairUniform`.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct HairShadowMaps {
    /// The hair's `HairUniform` (the light's projection, the box, the layer rule), as bytes.
    pub uniform: Handle<ShaderBuffer>,
    /// The nearest hair depth per texel (`R32Float`, light NDC; 1 where there is none).
    pub depth: Handle<Image>,
    /// The four cumulative opacity layers (`Rgba16Float`).
    pub layers: Handle<Image>,
    /// Texels per side.
    pub resolution: u32,
    /// Set by the render world once it has drawn the maps into `depth` and `layers`.
    drawn: MapsDrawn,
}

impl HairShadowMaps {
    /// True once the render world has drawn these maps (it then draws them every frame, before
    /// the main pass). Receivers are given their material only then, so no receiver is drawn
    /// with maps that hold nothing yet.
    ///
    /// ```no_run
    /// use bevy::prelude::*;
    /// use hikage_bevy::HairShadowMaps;
    ///
    /// fn ready(hairs: Query<&HairShadowMaps>) -> bool {
    ///     hairs.iter().all(HairShadowMaps::drawn)
    /// }
    /// ```
    pub fn drawn(&self) -> bool {
        self.drawn.0.load(std::sync::atomic::Ordering::Acquire)
    }

    /// Says that the render world has drawn the maps.
    pub(crate) fn set_drawn(&self) {
        self.drawn.0.store(true, std::sync::atomic::Ordering::Release);
    }
}

/// Whether a [`HairShadowMaps`] has been drawn, shared by its copies in both worlds.
#[derive(Clone, Debug, Default)]
struct MapsDrawn(std::sync::Arc<std::sync::atomic::AtomicBool>);

impl PartialEq for MapsDrawn {
    fn eq(&self, other: &MapsDrawn) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Registers the hair's systems: the maps' assets in the main world, the renderer in the
/// render world, and the receivers' material.
pub(crate) fn build(app: &mut App) {
    app.add_plugins(bevy_pbr::MaterialPlugin::<HairReceiverMaterial>::default());
    app.add_systems(
        Update,
        (
            give_maps,
            check_strips,
            check_skin,
            receiver::attach.after(give_maps),
            crate::diagnostics::check_mesh::<HairReceiver>,
            crate::diagnostics::check_sun::<HairReceiver>,
        ),
    );
    render::build(app);
}

/// Says on each [`HairStrands`] whose loaded bundle has no such `Strands` asset what is there
/// instead, or whose opacity maps the render device cannot hold (the render world could only
/// log it), and clears it once fixed.
fn check_strips(
    mut hairs: Query<(&HairStrands, &mut Problems)>,
    bundles: Res<Assets<HikageBundle>>,
    device: Option<Res<bevy_render::renderer::RenderDevice>>,
) {
    let largest = device.map(|d| d.limits().max_texture_dimension_2d);
    for (hair, mut problems) in &mut hairs {
        let Some(bundle) = bundles.get(&hair.bundle) else { continue };
        let problem = match (bundle.strands(&hair.strips), bundle.asset(&hair.strips)) {
            (None, Some(a)) => Some(format!("asset `{}` is a {:?}, expected Strands", hair.strips, a.kind)),
            (None, None) => Some(format!("no asset `{}` in the bundle", hair.strips)),
            (Some(_), _) => match largest {
                Some(max) if hair.resolution == 0 || hair.resolution > max => Some(format!(
                    "opacity maps of {0}×{0} texels: the render device holds 1 to {max} a side",
                    hair.resolution
                )),
                _ => None,
            },
        };
        Problems::set(&mut problems, Check::Build, problem);
    }
}

/// The hair binding of strips `strips` in `bundle` and the scalp it names: the assets a skin
/// needs; or why there are none.
pub(crate) fn binding_of<'a>(
    bundle: &'a HikageBundle,
    strips: &str,
) -> Result<(&'a std::sync::Arc<hikage_runtime::CpuAsset>, &'a std::sync::Arc<hikage_runtime::CpuAsset>), String> {
    let binding = bundle
        .manifest
        .assets
        .iter()
        .find(|a| a.settings.hair_binding().is_some_and(|b| b.strands == strips))
        .and_then(|a| bundle.hair_binding(&a.id))
        .ok_or_else(|| {
            format!("the bundle binds no scalp to `{strips}`: bake the strands with `scalp` (a skinned glTF)")
        })?;
    let scalp_id = &binding.asset.settings.hair_binding().expect("found by it").scalp;
    let scalp = bundle.hair_binding(scalp_id).ok_or_else(|| format!("the bundle has no scalp `{scalp_id}`"))?;
    Ok((binding, scalp))
}

/// Says on each [`HairStrands`] following a skin what keeps it from following: no
/// `SkinnedMesh` on the entity, no binding of its strips in the bundle, or a skin whose joints
/// are not the ones the scalp was bound with.
fn check_skin(
    mut hairs: Query<(&HairStrands, &mut Problems)>,
    skins: Query<&bevy_mesh::skinning::SkinnedMesh>,
    bundles: Res<Assets<HikageBundle>>,
) {
    for (hair, mut problems) in &mut hairs {
        let Some(entity) = hair.skin else {
            Problems::set(&mut problems, Check::Mesh, None);
            continue;
        };
        let Some(bundle) = bundles.get(&hair.bundle) else { continue };
        let problem = match (skins.get(entity), binding_of(bundle, &hair.strips)) {
            (Err(_), _) => Some(format!("the skin entity {entity} has no SkinnedMesh")),
            (_, Err(e)) => Some(e),
            (Ok(skin), Ok((_, scalp))) => {
                let joints = &scalp.asset.settings.scalp().expect("a scalp").joints;
                (skin.joints.len() != joints.len()).then(|| {
                    format!(
                        "the skin of entity {entity} has {} joints; the scalp was bound to a skin of {} ({})",
                        skin.joints.len(),
                        joints.len(),
                        joints.join(", ")
                    )
                })
            }
        };
        Problems::set(&mut problems, Check::Mesh, problem);
    }
}

/// Gives each [`HairStrands`] its [`HairShadowMaps`] (new ones when its resolution changes).
fn give_maps(
    mut commands: Commands,
    hairs: Query<(Entity, &HairStrands, Option<&HairShadowMaps>), Changed<HairStrands>>,
    mut images: ResMut<Assets<Image>>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    device: Option<Res<bevy_render::renderer::RenderDevice>>,
) {
    let largest = device.map_or(u32::MAX, |d| d.limits().max_texture_dimension_2d);
    for (entity, hair, maps) in &hairs {
        if maps.is_some_and(|m| m.resolution == hair.resolution) {
            continue;
        }
        // A size the device cannot hold would end the app with a validation error: it is said
        // on the entity instead (`check_strips`), and the maps it has are kept.
        if hair.resolution == 0 || hair.resolution > largest {
            continue;
        }
        let r = hair.resolution;
        let mut map = |format: TextureFormat| {
            let mut image = Image::new_uninit(
                Extent3d { width: r, height: r, depth_or_array_layers: 1 },
                TextureDimension::D2,
                format,
                RenderAssetUsages::RENDER_WORLD,
            );
            image.texture_descriptor.usage =
                TextureUsages::TEXTURE_BINDING | TextureUsages::COPY_DST | TextureUsages::COPY_SRC;
            images.add(image)
        };
        let (depth, layers) = (map(TextureFormat::R32Float), map(TextureFormat::Rgba16Float));
        let size = std::mem::size_of::<HairUniform>() as u64;
        let uniform = buffers.add(ShaderBuffer::with_size(size, RenderAssetUsages::RENDER_WORLD));
        let drawn = MapsDrawn::default();
        commands.entity(entity).insert(HairShadowMaps { uniform, depth, layers, resolution: r, drawn });
    }
}
