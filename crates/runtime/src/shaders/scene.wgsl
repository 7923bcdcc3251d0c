// What every drawing component's uniform starts with (hikage_runtime::SceneUniform): where the
// component is drawn and how it is lit. The component's own fields follow it.
struct Scene {
    view_proj: mat4x4<f32>,     // world -> clip
    model: mat4x4<f32>,         // the component's frame -> world
    light: vec4<f32>,           // xyz: unit direction toward the light (in the frame the component states); w: the component's
    light_color: vec4<f32>,     // rgb
    ambient: vec4<f32>,         // rgb
    albedo: vec4<f32>,          // rgb
}

// A component's shading of one pixel: its colour, and the visibility terms it writes to the
// optional second target (each component says which).
struct Shade {
    color: vec4<f32>,
    visibility: vec4<f32>,
}

// The fragment outputs with the visibility target.
struct ShadeTargets {
    @location(0) color: vec4<f32>,
    @location(1) visibility: vec4<f32>,
}
