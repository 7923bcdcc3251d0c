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

/// The terrain receivers' fragment shader.
pub(crate) const TERRAIN_RECEIVER: &str = "embedded://hikage_bevy/shaders/terrain_receiver.wesl";

/// The fragment shader of a streamed terrain's receivers.
pub(crate) const FIELD_RECEIVER: &str = "embedded://hikage_bevy/shaders/field_receiver.wesl";

/// The hair receivers' fragment shader.
pub(crate) const HAIR_RECEIVER: &str = "embedded://hikage_bevy/shaders/hair_receiver.wesl";

/// The hair's bindings in hikage-runtime's WGSL, and where the receivers' material extension
/// binds them (the uniform as a read-only storage buffer: Bevy's `ShaderBuffer` holds its bytes).
const HAIR_BINDINGS: [(&str, &str); 3] = [
    (
        "@group(0) @binding(0) var<uniform> hair:",
        "@group(constants::MATERIAL_BIND_GROUP) @binding(110) var<storage, read> hair:",
    ),
    ("@group(0) @binding(1) var hair_depth", "@group(constants::MATERIAL_BIND_GROUP) @binding(111) var hair_depth"),
    ("@group(0) @binding(2) var hair_layers", "@group(constants::MATERIAL_BIND_GROUP) @binding(112) var hair_layers"),
];

/// Where the receivers' half of the hair WGSL ends: the passes' entry points and the blend's
/// targets follow.
const HAIR_PASSES: &str = "\nstruct LightOut {";

/// hikage-runtime's hair WGSL up to its passes (the uniform, the maps, `hair_visibility` and the
/// shading functions), its bindings moved into Bevy's material group.
fn hair_library() -> String {
    let source = hikage_runtime::hair::HAIR_WGSL;
    assert_eq!(source.matches(HAIR_PASSES).count(), 1, "hikage-runtime's hair WGSL no longer has its passes last");
    moved(&source[..source.find(HAIR_PASSES).expect("counted above")], &HAIR_BINDINGS)
}

/// `source` with each binding declaration `from` replaced by `to` (each must occur once).
fn moved(source: &str, bindings: &[(&str, &str)]) -> String {
    let mut source = source.to_string();
    for (from, to) in bindings {
        assert_eq!(source.matches(from).count(), 1, "hikage-runtime's WGSL no longer declares `{from}` once");
        source = source.replace(from, to);
    }
    source
}

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
    moved(hikage_runtime::relief::RELIEF_WGSL, &RELIEF_BINDINGS)
}

/// The sun field's receiver bindings in hikage-runtime's WGSL, and where
/// [`crate::field::FieldReceiverExtension`] binds them.
const FIELD_BINDINGS: [(&str, &str); 2] = [
    (
        "@group(0) @binding(0) var<uniform> sun_field:",
        "@group(constants::MATERIAL_BIND_GROUP) @binding(120) var<uniform> sun_field:",
    ),
    (
        "@group(0) @binding(1) var sun_field_thresholds",
        "@group(constants::MATERIAL_BIND_GROUP) @binding(121) var sun_field_thresholds",
    ),
];

/// Keeps the runtime's shader libraries alive for as long as the app runs.
#[derive(Resource)]
struct Libraries(#[expect(dead_code, reason = "held only to keep the shaders loaded")] Vec<Handle<Shader>>);

/// Registers `hikage_bevy::horizon`, `::relief`, `::hair` and `::sun_field` (hikage-runtime's
/// functions) and embeds the materials' own shaders.
pub(crate) fn register(app: &mut App) {
    bevy_shader::load_shader_library!(app, "shaders/output.wesl");
    bevy_shader::load_shader_library!(app, "shaders/terrain.wesl");
    bevy_shader::load_shader_library!(app, "shaders/relief.wesl");
    bevy_shader::load_shader_library!(app, "shaders/curved.wesl");
    bevy_shader::load_shader_library!(app, "shaders/hair_receiver.wesl");
    bevy_shader::load_shader_library!(app, "shaders/terrain_receiver.wesl");
    bevy_shader::load_shader_library!(app, "shaders/cascades.wesl");
    bevy_shader::load_shader_library!(app, "shaders/field_receiver.wesl");
    let mut shaders = app.world_mut().resource_mut::<Assets<Shader>>();
    let libraries = [
        ("horizon", hikage_runtime::horizon::HORIZON_WGSL.to_string()),
        ("relief", relief_library()),
        ("hair", hair_library()),
        ("sun_field", moved(hikage_runtime::horizon::SUN_FIELD_WGSL, &FIELD_BINDINGS)),
    ]
    .map(|(name, source)| shaders.add(Shader::from_wesl(source, format!("embedded://hikage_bevy/{name}.wesl"))));
    app.insert_resource(Libraries(libraries.to_vec()));
}
