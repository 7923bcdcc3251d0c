//! Components that name assets of a bundle get their mesh and material once the bundle has
//! loaded — and again when the component changes or the bundle is reloaded.

use bevy_asset::{AssetEvent, Assets, Handle};
use bevy_ecs::prelude::*;
use bevy_mesh::{Mesh, Mesh3d};
use bevy_pbr::{Material, MeshMaterial3d};

use crate::HikageBundle;
use crate::diagnostics::{Check, NamesBundle, Problems};

/// A component built from a bundle's assets into a material (and a mesh, when the bundle
/// supplies the geometry too).
pub(crate) trait FromBundle: NamesBundle + Sized {
    /// The material the component draws with.
    type Material: Material;
    /// Its material and, where the bundle has the geometry, its mesh; or why not.
    fn build(&self, bundle: &HikageBundle) -> Result<(Self::Material, Option<Handle<Mesh>>), String>;
}

/// An entity as [`attach`] sees it: its component, whether it has been built, what is wrong.
type State<'a, C, M> = (Entity, Ref<'a, C>, Has<MeshMaterial3d<M>>, Mut<'a, Problems>);

/// Builds each `C` whose bundle has loaded and that is new, changed or has a reloaded bundle;
/// a failure goes to the entity's [`Problems`] and leaves the last material it had.
pub(crate) fn attach<C: FromBundle>(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<HikageBundle>>,
    bundles: Res<Assets<HikageBundle>>,
    mut materials: ResMut<Assets<C::Material>>,
    mut entities: Query<State<C, C::Material>>,
) {
    // A reload is `Modified`. (A bundle that loads after a failed first load needs no event:
    // its entities were never built.)
    let reloaded: Vec<_> =
        events.read().filter_map(|e| if let AssetEvent::Modified { id } = e { Some(*id) } else { None }).collect();
    for (entity, component, built, mut problems) in &mut entities {
        let stale = component.is_changed() || reloaded.contains(&component.bundle().id());
        if (built || problems.get(Check::Build).is_some()) && !stale {
            continue;
        }
        let Some(bundle) = bundles.get(component.bundle()) else {
            continue;
        };
        match component.build(bundle) {
            Ok((material, mesh)) => {
                let mut e = commands.entity(entity);
                e.insert(MeshMaterial3d(materials.add(material)));
                if let Some(mesh) = mesh {
                    e.insert(Mesh3d(mesh));
                }
                Problems::set(&mut problems, Check::Build, None);
            }
            Err(message) => Problems::set(&mut problems, Check::Build, Some(message)),
        }
    }
}
