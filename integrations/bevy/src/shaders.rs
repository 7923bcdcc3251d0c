//! The WESL modules of the materials: hikage-runtime's WGSL functions registered as Bevy shader
//! libraries, and each material's fragment shader embedded in the crate.

use bevy_app::App;
use bevy_asset::{Assets, Handle};
use bevy_ecs::resource::Resource;
use bevy_shader::Shader;

/// The terrain material's fragment shader.
pub(crate) const TERRAIN: &str = "embedded://hikage_bevy/shaders/terrain.wesl";

/// Keeps the runtime's shader libraries alive for as long as the app runs.
#[derive(Resource)]
struct Libraries(#[expect(dead_code, reason = "held only to keep the shaders loaded")] Vec<Handle<Shader>>);

/// Registers `hikage_bevy::horizon` (hikage-runtime's horizon functions) and embeds the
/// materials' own shaders.
pub(crate) fn register(app: &mut App) {
    bevy_shader::load_shader_library!(app, "shaders/terrain.wesl");
    let mut shaders = app.world_mut().resource_mut::<Assets<Shader>>();
    let libraries = [("horizon", hikage_runtime::horizon::HORIZON_WGSL)]
        .map(|(name, source)| shaders.add(Shader::from_wesl(source, format!("embedded://hikage_bevy/{name}.wesl"))));
    app.insert_resource(Libraries(libraries.to_vec()));
}
