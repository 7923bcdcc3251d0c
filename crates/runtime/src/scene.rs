//! What every drawing component's uniform starts with, in Rust and in WGSL: the scene's
//! matrices and light ([`SceneUniform`], WGSL `Scene`), and the shading a component's fragment
//! stage returns (WGSL `Shade`, written to `ShadeTargets` with the visibility target).

use glam::{Mat4, Vec3, Vec4};

/// WGSL of `Scene`, `Shade` and `ShadeTargets`, which every component's WGSL starts with.
pub const SCENE_WGSL: &str = include_str!("shaders/scene.wgsl");

/// The `Scene` at the head of every component's uniform (192 bytes): where the component is
/// drawn and how it is lit.
///
/// ```
/// use hikage_runtime::SceneUniform;
/// use hikage_runtime::glam::{Mat4, Vec3, Vec4};
/// // A camera 10 units south of the origin and 5 up, looking at it (right-handed, y up), with
/// // wgpu's depth range 0..1: glam's `camera::rh` view and `proj::directx` projection.
/// let view = hikage_runtime::glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 5.0, 10.0), Vec3::ZERO, Vec3::Y);
/// let projection = hikage_runtime::glam::camera::rh::proj::directx::perspective(1.0, 16.0 / 9.0, 0.1, 100.0);
/// let scene = SceneUniform::new(projection * view, Mat4::IDENTITY, Vec3::Y.extend(0.0), Vec3::ONE, Vec3::splat(0.2), Vec3::splat(0.6));
/// assert_eq!(scene.albedo, [0.6, 0.6, 0.6, 1.0]);
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SceneUniform {
    /// World → clip, column-major.
    pub view_proj: [[f32; 4]; 4],
    /// The component's frame → world, column-major.
    pub model: [[f32; 4]; 4],
    /// `xyz`: unit direction toward the light, in the frame the component states; `w`: the
    /// component's (a sun's angular radius, the curvature switch).
    pub light: [f32; 4],
    /// Light RGB.
    pub light_color: [f32; 4],
    /// Ambient RGB.
    pub ambient: [f32; 4],
    /// Albedo RGB (alpha 1).
    pub albedo: [f32; 4],
}

impl SceneUniform {
    /// The head of a component's uniform.
    pub fn new(view_proj: Mat4, model: Mat4, light: Vec4, light_color: Vec3, ambient: Vec3, albedo: Vec3) -> Self {
        SceneUniform {
            view_proj: view_proj.to_cols_array_2d(),
            model: model.to_cols_array_2d(),
            light: light.to_array(),
            light_color: light_color.extend(0.0).to_array(),
            ambient: ambient.extend(0.0).to_array(),
            albedo: albedo.extend(1.0).to_array(),
        }
    }
}
