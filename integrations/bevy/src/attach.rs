//! Components that name assets of a bundle get their mesh and material once the bundle has
//! loaded — and again when the component changes or the bundle is reloaded.

use bevy_asset::{AssetEvent, Assets, Handle};
use bevy_ecs::prelude::*;
use bevy_mesh::{Mesh, Mesh3d};
use bevy_pbr::{Material, MeshMaterial3d};

use crate::{HikageBundle, HikageError};

/// A component built from a bundle's assets into a material (and a mesh, when the bundle
/// supplies the geometry too).
pub(crate) trait FromBundle: Component + Sized {
    /// The material the component draws with.
    type Material: Material;
    /// The bundle it names assets of.
    fn bundle(&self) -> &Handle<HikageBundle>;
    /// Its material and, where the bundle has the geometry, its mesh; or why not.
    fn build(&self, bundle: &HikageBundle) -> Result<(Self::Material, Option<Handle<Mesh>>), String>;
}

/// An entity as [`attach`] sees it: its component, whether it has been built or has failed.
type State<'a, C, M> = (Entity, Ref<'a, C>, Has<MeshMaterial3d<M>>, Has<HikageError>);

/// Builds each `C` whose bundle has loaded and that is new, changed or has a reloaded bundle;
/// a failure is logged once and left on the entity as [`HikageError`].
pub(crate) fn attach<C: FromBundle>(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<HikageBundle>>,
    bundles: Res<Assets<HikageBundle>>,
    mut materials: ResMut<Assets<C::Material>>,
    entities: Query<State<C, C::Material>>,
) {
    let reloaded: Vec<_> =
        events.read().filter_map(|e| if let AssetEvent::Modified { id } = e { Some(*id) } else { None }).collect();
    for (entity, component, built, failed) in &entities {
        let stale = component.is_changed() || reloaded.contains(&component.bundle().id());
        if (built || failed) && !stale {
            continue;
        }
        let Some(bundle) = bundles.get(component.bundle()) else {
            continue;
        };
        let mut e = commands.entity(entity);
        match component.build(bundle) {
            Ok((material, mesh)) => {
                e.remove::<HikageError>().insert(MeshMaterial3d(materials.add(material)));
                if let Some(mesh) = mesh {
                    e.insert(Mesh3d(mesh));
                }
            }
            Err(message) => {
                bevy_log::error!("hikage: {message}");
                e.insert(HikageError(message));
            }
        }
    }
}
