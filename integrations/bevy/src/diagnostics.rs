//! What hikage says on an entity it cannot draw as asked: [`HikageError`], gathered from every
//! check the plugin makes — the bundle's load, the assets the component names, the mesh it
//! draws on, the sun it is shadowed from — so that nothing fails silently.
//!
//! Each check owns one slot of the entity's [`Problems`] and clears only its own, so fixing
//! one mistake does not hide another. The slots are published as one [`HikageError`] (logged
//! once each time its text changes) and removed when every slot is clear.

use bevy_asset::{AssetLoadError, AssetServer, Assets, Handle, LoadState};
use bevy_ecs::prelude::*;
use bevy_light::DirectionalLight;

use crate::{BundleLoadError, HikageBundle};

/// Why hikage cannot draw an entity as its component asks: the bundle failed to load (the
/// entity keeps drawing the last bundle that loaded, if any), an asset id is missing or of
/// another kind, the mesh lacks what the method needs, or the sun has no shadow maps. Set on the
/// entity and logged once; removed when the cause is fixed (a later load succeeds, the
/// component or the light changes).
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::HikageError;
///
/// fn report(errors: Query<(Entity, &HikageError), Changed<HikageError>>) {
///     for (entity, error) in &errors {
///         eprintln!("{entity}: {}", error.0);
///     }
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq)]
pub struct HikageError(pub String);

/// The checks, each with its slot in [`Problems`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Check {
    /// The bundle's load (missing manifest, damaged payload, unknown format).
    Load,
    /// The assets the component names (ids, kinds, sizes that must agree).
    Build,
    /// The mesh the component draws on.
    Mesh,
    /// The directional light whose shadow factor the material sets.
    Sun,
    /// A streamed terrain's tiles (one that failed to read or is missing).
    Tiles,
    /// A streamed terrain's resident budget, too small for level 0 under the camera.
    Budget,
    /// The entity a receiver names (a terrain's receiver's terrain).
    Names,
}

/// Every check's finding on one entity (required by each hikage component).
#[derive(Component, Default, Debug)]
pub(crate) struct Problems([Option<String>; 7]);

impl Problems {
    /// Sets `check`'s finding, marking the component changed only when it differs.
    pub(crate) fn set(this: &mut Mut<Problems>, check: Check, problem: Option<String>) {
        if this.0[check as usize] != problem {
            this.0[check as usize] = problem;
        }
    }

    /// `check`'s finding.
    pub(crate) fn get(&self, check: Check) -> Option<&str> {
        self.0[check as usize].as_deref()
    }

    /// Every finding, in check order, as one message.
    fn message(&self) -> Option<String> {
        let found: Vec<&str> = self.0.iter().flatten().map(String::as_str).collect();
        (!found.is_empty()).then(|| found.join("; "))
    }
}

/// A component that draws assets of a bundle.
pub(crate) trait NamesBundle: Component {
    /// The bundle it names assets of.
    fn bundle(&self) -> &Handle<HikageBundle>;
}

/// A component whose material sets Bevy's directional shadow factor, which Bevy applies only to
/// a light with shadow maps.
pub(crate) trait SunShadowed: Component {
    /// Whether it uses the factor as it is now set up.
    fn shadowed_by_sun(&self) -> bool {
        true
    }
}

/// A receiver: a component that shades its entity's own `Mesh3d`.
pub(crate) trait ShadesOwnMesh: Component {
    /// What it says on an entity without a `Mesh3d`.
    const NO_MESH: &'static str;
}

/// Says on each `C` without a `Mesh3d` that there is nothing to shade.
pub(crate) fn check_mesh<C: ShadesOwnMesh>(mut entities: Query<(Has<bevy_mesh::Mesh3d>, &mut Problems), With<C>>) {
    for (has_mesh, mut problems) in &mut entities {
        // Every frame: the message is made only when the finding changes.
        if has_mesh == problems.get(Check::Mesh).is_some() {
            Problems::set(&mut problems, Check::Mesh, (!has_mesh).then(|| C::NO_MESH.to_string()));
        }
    }
}

/// Puts a failed load of each `C`'s bundle on the entity. A load in progress changes nothing (a
/// failed reload stays said until one succeeds); a loaded bundle clears it.
pub(crate) fn check_load<C: NamesBundle>(
    server: Res<AssetServer>,
    bundles: Res<Assets<HikageBundle>>,
    mut entities: Query<(&C, &mut Problems)>,
) {
    for (component, mut problems) in &mut entities {
        let handle = component.bundle();
        let problem = match server.get_load_state(handle.id()) {
            Some(LoadState::Failed(error)) => {
                // The loader's own message names the manifest, the asset and the payload (Bevy's
                // error around it may carry a backtrace: its first line is the message).
                let cause = match error.as_ref() {
                    AssetLoadError::AssetLoaderError(e) => match e.error().downcast_ref::<BundleLoadError>() {
                        Some(ours) => ours.to_string(),
                        None => e.error().to_string().lines().next().unwrap_or_default().to_string(),
                    },
                    other => other.to_string(),
                };
                Some(if bundles.contains(handle.id()) {
                    format!("the bundle failed to reload, so the last one that loaded is still drawn: {cause}")
                } else {
                    format!("the bundle failed to load: {cause}")
                })
            }
            Some(LoadState::Loaded) => None,
            _ => continue,
        };
        Problems::set(&mut problems, Check::Load, problem);
    }
}

/// Says on each `C` shadowed by the sun when the scene's directional lights all lack shadow
/// maps: Bevy applies a material's directional shadow factor only to a light with shadow maps,
/// so the baked shadows would be lost without a word.
pub(crate) fn check_sun<C: SunShadowed>(lights: Query<&DirectionalLight>, mut entities: Query<(&C, &mut Problems)>) {
    let unshadowed = !lights.is_empty() && lights.iter().all(|l| !l.shadow_maps_enabled);
    for (component, mut problems) in &mut entities {
        let said = unshadowed && component.shadowed_by_sun();
        // Every frame: the message is made only when the finding changes.
        if said != problems.get(Check::Sun).is_some() {
            Problems::set(&mut problems, Check::Sun, said.then(|| UNSHADOWED.to_string()));
        }
    }
}

/// What an entity shadowed through Bevy's shadow factor says under a sun without shadow maps.
const UNSHADOWED: &str = "the scene's DirectionalLight has `shadow_maps_enabled: false`, and Bevy applies a \
                          material's shadow factor only to a light with shadow maps: set it to true, or no baked \
                          shadow is drawn";

/// Publishes each entity's changed [`Problems`] as its [`HikageError`], logging each new text
/// once, and removes the error once every check is clear.
pub(crate) fn publish(
    mut commands: Commands,
    entities: Query<(Entity, &Problems, Option<&HikageError>), Changed<Problems>>,
) {
    for (entity, problems, shown) in &entities {
        match (problems.message(), shown) {
            (None, Some(_)) => {
                bevy_log::info!("hikage: entity {entity}: fixed");
                commands.entity(entity).remove::<HikageError>();
            }
            (Some(message), shown) if shown.is_none_or(|s| s.0 != message) => {
                bevy_log::error!("hikage: entity {entity}: {message}");
                commands.entity(entity).insert(HikageError(message));
            }
            _ => {}
        }
    }
}
