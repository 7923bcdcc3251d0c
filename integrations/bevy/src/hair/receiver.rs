//! Meshes shadowed by hair: [`HairReceiver`] draws its mesh with [`HairReceiverMaterial`], Bevy's
//! `StandardMaterial` whose directional light is dimmed by the light the hair's opacity maps let
//! through.

use bevy_asset::{Asset, Assets, Handle};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_pbr::{ExtendedMaterial, MaterialExtension, MeshMaterial3d, StandardMaterial};
use bevy_reflect::Reflect;
use bevy_render::render_resource::AsBindGroup;
use bevy_render::storage::ShaderBuffer;
use bevy_shader::ShaderRef;

use super::HairShadowMaps;
use crate::diagnostics::{Check, Problems, ShadesOwnMesh, SunShadowed};

/// Bevy's `StandardMaterial` shadowed by a hair's deep opacity maps.
pub type HairReceiverMaterial = ExtendedMaterial<StandardMaterial, HairReceiverExtension>;

/// Shades its entity's mesh with the shadow of the hair on entity `hair` (a
/// [`HairStrands`](super::HairStrands)): the light reaching each point through the hair's
/// opacity maps dims Bevy's directional lights there, as Bevy's shadow maps do. Put it on an
/// entity with a `Mesh3d`; it gets a [`HairReceiverMaterial`] over `base` once the hair's maps
/// have been drawn ([`HairShadowMaps::drawn`]), so it is never drawn with maps that hold nothing
/// yet.
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::hair::{HairReceiver, HairStrands};
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
///     let hair = commands.spawn(HairStrands::new(assets.load("bundle/bundle.ron"), "head.strips")).id();
///     let skin = StandardMaterial { base_color: Color::srgb(0.8, 0.6, 0.5), ..default() };
///     commands.spawn((Mesh3d(meshes.add(Sphere::new(8.5))), HairReceiver::new(hair).with_base(skin)));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(bevy_transform::components::Transform, bevy_camera::visibility::Visibility, Problems)]
pub struct HairReceiver {
    /// The entity with the `HairStrands` whose shadow this mesh receives.
    pub hair: Entity,
    /// The surface under the shadow.
    pub base: StandardMaterial,
}

impl HairReceiver {
    /// A white surface receiving the shadow of the hair on `hair`.
    pub fn new(hair: Entity) -> HairReceiver {
        HairReceiver { hair, base: StandardMaterial::default() }
    }

    /// The same over `base` (colour, textures, roughness).
    pub fn with_base(mut self, base: StandardMaterial) -> HairReceiver {
        self.base = base;
        self
    }
}

/// The hair half of [`HairReceiverMaterial`]: a hair's [`HairShadowMaps`].
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
pub struct HairReceiverExtension {
    /// The hair's uniform (hikage-runtime's `HairUniform`).
    #[storage(110, read_only)]
    pub hair: Handle<ShaderBuffer>,
    /// The nearest hair depth per texel.
    #[texture(111, sample_type = "float", filterable = false)]
    pub depth: Handle<Image>,
    /// The cumulative opacity layers.
    #[texture(112, sample_type = "float", filterable = false)]
    pub layers: Handle<Image>,
}

impl HairReceiverExtension {
    /// The extension reading `maps`.
    pub fn new(maps: &HairShadowMaps) -> HairReceiverExtension {
        HairReceiverExtension { hair: maps.uniform.clone(), depth: maps.depth.clone(), layers: maps.layers.clone() }
    }
}

impl MaterialExtension for HairReceiverExtension {
    fn fragment_shader() -> ShaderRef {
        crate::shaders::HAIR_RECEIVER.into()
    }
}

/// A receiver as [`attach`] sees it: its material, what is wrong.
type Receiver<'a> =
    (Entity, Ref<'a, HairReceiver>, Option<&'a MeshMaterial3d<HairReceiverMaterial>>, Mut<'a, Problems>);

/// Builds each receiver whose hair's maps have been drawn and that is new, changed, or reads
/// other maps than its hair's; a receiver naming an entity without `HairStrands` says so.
pub(crate) fn attach(
    mut commands: Commands,
    mut receivers: Query<Receiver>,
    hairs: Query<(Has<super::HairStrands>, Option<&HairShadowMaps>)>,
    mut materials: ResMut<Assets<HairReceiverMaterial>>,
) {
    for (entity, receiver, material, mut problems) in &mut receivers {
        let (is_hair, maps) = hairs.get(receiver.hair).map_or((false, None), |(h, m)| (h, m));
        let Some(maps) = maps else {
            if !is_hair {
                let message = format!("hair receiver {entity}: entity {} has no HairStrands", receiver.hair);
                Problems::set(&mut problems, Check::Build, Some(message));
            }
            continue; // else the hair gets its maps this frame
        };
        Problems::set(&mut problems, Check::Build, None);
        let current = material.and_then(|m| materials.get(&m.0)).is_some_and(|m| m.extension.depth == maps.depth);
        // Maps not drawn yet hold nothing: the receiver waits for them (a frame).
        if (current && !receiver.is_changed()) || !maps.drawn() {
            continue;
        }
        let material = ExtendedMaterial { base: receiver.base.clone(), extension: HairReceiverExtension::new(maps) };
        commands.entity(entity).insert(MeshMaterial3d(materials.add(material)));
    }
}

impl SunShadowed for HairReceiver {}

impl ShadesOwnMesh for HairReceiver {
    const NO_MESH: &'static str = "a HairReceiver shades the entity's own mesh, and this entity has no Mesh3d";
}
