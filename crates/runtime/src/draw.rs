//! How a component's draw pipeline fits the game's render pass.

/// The targets and bind group index a component draws with: what its pipeline is built for.
/// The game's render pass must have the same attachments.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawOptions {
    /// The colour target at location 0 (format, blending).
    pub color: wgpu::ColorTargetState,
    /// The depth attachment's format, if the pass has one (tested with `depth_compare` and
    /// written).
    pub depth_format: Option<wgpu::TextureFormat>,
    /// How a fragment's depth passes the test: `Less` for a 0-near, 1-far depth buffer,
    /// `Greater` for a reversed one (1 near, 0 far, as Bevy and many engines keep it).
    pub depth_compare: wgpu::CompareFunction,
    /// A second colour target at location 1 receiving each component's visibility per pixel
    /// (of the light and of the sky; see the component), for shadow masks, debugging and tests.
    pub visibility_format: Option<wgpu::TextureFormat>,
    /// Faces culled: `Some(Face::Back)` for closed meshes seen from outside.
    pub cull_mode: Option<wgpu::Face>,
    /// The bind group index of the component's group in its pipeline and its WGSL; the game's
    /// own groups keep the other indices.
    pub group: u32,
}

impl DrawOptions {
    /// An unblended `color_format` target, no depth (`Less` once one is set), no visibility
    /// target, no culling, group 0.
    pub fn new(color_format: wgpu::TextureFormat) -> DrawOptions {
        DrawOptions {
            color: wgpu::ColorTargetState { format: color_format, blend: None, write_mask: wgpu::ColorWrites::ALL },
            depth_format: None,
            depth_compare: wgpu::CompareFunction::Less,
            visibility_format: None,
            cull_mode: None,
            group: 0,
        }
    }
}
