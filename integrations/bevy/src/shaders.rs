//! The WESL modules of the materials: hikage-runtime's WGSL functions registered as Bevy shader
//! libraries, and each material's fragment shader embedded in the crate.

use bevy_app::App;
use bevy_asset::{Assets, Handle};
use bevy_ecs::resource::Resource;
use bevy_shader::Shader;

/// The terrain material's fragment shader.
pub(crate) const TERRAIN: &str = "embedded://hikage_bevy/shaders/terrain.wesl";
/// The curved-surface material's vertex and fragment shader.
pub(crate) const CURVED: &str = "embedded://hikage_bevy/shaders/curved.wesl";
/// The relief material's fragment shader.
pub(crate) const RELIEF: &str = "embedded://hikage_bevy/shaders/relief.wesl";

/// The relief tracer's bindings in hikage-runtime's WGSL, and where a Bevy material extension
/// binds them (the base material holds 0–99; the extension's own uniform is 100).
const RELIEF_BINDINGS: [(&str, &str); 3] = [
    (
        "@group(0) @binding(0) var relief_heights",
        "@group(constants::MATERIAL_BIND_GROUP) @binding(101) var relief_heights",
    ),
    (
        "@group(0) @binding(1) var relief_depths",
        "@group(constants::MATERIAL_BIND_GROUP) @binding(102) var relief_depths",
    ),
    (
        "@group(0) @binding(2) var<uniform> relief:",
        "@group(constants::MATERIAL_BIND_GROUP) @binding(103) var<uniform> relief:",
    ),
];

/// hikage-runtime's relief WGSL with its bindings moved into Bevy's material group.
fn relief_library() -> String {
    let mut source = hikage_runtime::relief::RELIEF_WGSL.to_string();
    for (from, to) in RELIEF_BINDINGS {
        assert_eq!(source.matches(from).count(), 1, "hikage-runtime's relief WGSL no longer declares `{from}` once");
        source = source.replace(from, to);
    }
    source
}

/// Keeps the runtime's shader libraries alive for as long as the app runs.
#[derive(Resource)]
struct Libraries(#[expect(dead_code, reason = "held only to keep the shaders loaded")] Vec<Handle<Shader>>);

/// Registers `hikage_bevy::horizon` (hikage-runtime's horizon functions) and embeds the
/// materials' own shaders.
pub(crate) fn register(app: &mut App) {
    bevy_shader::load_shader_library!(app, "shaders/output.wesl");
    bevy_shader::load_shader_library!(app, "shaders/terrain.wesl");
    bevy_shader::load_shader_library!(app, "shaders/relief.wesl");
    bevy_shader::load_shader_library!(app, "shaders/curved.wesl");
    let mut shaders = app.world_mut().resource_mut::<Assets<Shader>>();
    let libraries = [("horizon", hikage_runtime::horizon::HORIZON_WGSL.to_string()), ("relief", relief_library())]
        .map(|(name, source)| shaders.add(Shader::from_wesl(source, format!("embedded://hikage_bevy/{name}.wesl"))));
    app.insert_resource(Libraries(libraries.to_vec()));
}
