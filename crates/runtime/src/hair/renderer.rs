//! [`HairRenderer`]: the deep opacity maps from a light, the shading set blended at its opacity
//! (or opaque) from the camera, and `hair_visibility` for the game's shadow receivers.

use std::sync::atomic::{AtomicU32, Ordering};

use glam::{Mat4, Vec3};
use hikage_bundle::{MeshDesc, StrandsSettings};

use super::{HAIR_WGSL, HairLight, HairSet};
use crate::draw::DrawOptions;
use crate::error::RuntimeError;
use crate::gpu;
use crate::upload::GpuBundle;

/// The record's streams the shaders read, by their names in the one table of the kind
/// ([`hikage_bundle::STRANDS_STREAMS`]), with the vertex format each is read as.
const STREAMS: [(&str, wgpu::VertexFormat); 6] = {
    let s = hikage_bundle::STRANDS_STREAMS;
    [
        (s[0].name, wgpu::VertexFormat::Float32x3),
        (s[1].name, wgpu::VertexFormat::Unorm16x2),
        (s[2].name, wgpu::VertexFormat::Unorm16x2),
        (s[3].name, wgpu::VertexFormat::Unorm8x4),
        (s[4].name, wgpu::VertexFormat::Uint16x2),
        (s[5].name, wgpu::VertexFormat::Uint32),
    ]
};

/// Bytes of one strand record.
const RECORD: u64 = hikage_bundle::STRANDS_RECORD_BYTES as u64;

const DEPTH_MAP: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const LAYERS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const REVEALAGE: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

/// The `HairUniform` of the hair WGSL, as it is in the uniform buffer (480 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HairUniform {
    /// World → light clip, column-major.
    pub light: [[f32; 4]; 4],
    /// Light clip → world, column-major (for the per-texel layer step).
    pub light_inverse: [[f32; 4]; 4],
    /// The hair's bounding box, lower corner (world).
    pub bounds_min: [f32; 4],
    /// The hair's bounding box, upper corner (world).
    pub bounds_max: [f32; 4],
    /// World → camera clip, column-major.
    pub camera: [[f32; 4]; 4],
    /// Camera position.
    pub eye: [f32; 4],
    /// Unit vector toward the light.
    pub to_light: [f32; 4],
    /// Light RGB.
    pub light_color: [f32; 4],
    /// Ambient RGB.
    pub ambient: [f32; 4],
    /// Colour factor (rgb) and opacity factor (a) at the root.
    pub root_tint: [f32; 4],
    /// Colour factor (rgb) and opacity factor (a) at the tip.
    pub tip_tint: [f32; 4],
    /// Layer step `d` in light NDC depth.
    pub step: f32,
    /// The set drawn into the opacity maps: 0 shading, 1 opacity.
    pub opacity_set: u32,
    /// Opacity-map texels per side.
    pub resolution: u32,
    /// Kajiya-Kay exponent.
    pub specular_power: f32,
    /// Kajiya-Kay specular strength.
    pub specular: f32,
    /// 0: [`LayerRule::Box`](super::LayerRule::Box), 1: per texel.
    pub layer_rule: u32,
    /// [`Lookup::code`].
    pub lookup: u32,
    /// A record's width scale (the asset's `max_width`).
    pub max_width: f32,
    /// Opacity set width / shading set width.
    pub width_ratio: f32,
    /// Opacity set opacity / shading set opacity.
    pub alpha_ratio: f32,
    /// Share of the width lost at the tip.
    pub taper: f32,
    /// Narrowest camera strip in pixels (0: off).
    pub min_pixel_width: f32,
    /// The camera target's size in pixels.
    pub viewport: [f32; 2],
    /// Distance from the eye to the nearest and farthest point of the hair's box.
    pub depth_range: [f32; 2],
    /// Width factor of the camera passes' level of detail.
    pub camera_widen: f32,
    /// Width factor of the light passes' level of detail.
    pub light_widen: f32,
    /// Per-strand brightness spread.
    pub color_variation: f32,
    /// The blend's weight falloff: the hair's optical depth across its box.
    pub oit_falloff: f32,
    /// The hair's frame (its coordinates as baked) → world, column-major ([`HairFrame::model`]).
    pub model: [[f32; 4]; 4],
    /// Factor on strand widths from `model`: the cube root of its 3×3 determinant.
    pub model_width: f32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: [f32; 3],
}

/// How receivers read the opacity maps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lookup {
    /// The texel under the point (the seed's: its wide faint set does the anti-aliasing).
    #[default]
    Nearest,
    /// The visibility of the 2×2 texels around the point, each at the point's depth, weighted
    /// bilinearly: percentage-closer filtering, the usual filtered lookup of plain deep opacity
    /// maps.
    Bilinear,
}

impl Lookup {
    /// The value of the WGSL uniform's `lookup` field.
    pub fn code(self) -> u32 {
        match self {
            Lookup::Nearest => 0,
            Lookup::Bilinear => 1,
        }
    }
}

/// Which level of detail a pass draws: level `l` draws about `1 / 2^l` of the strands, each
/// widened so the hair's coverage is kept ([`hikage_bundle::StrandsSettings::levels`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lod {
    /// Chosen per frame from the hair's projected size ([`AUTO_LOD_PIXELS`]).
    #[default]
    Auto,
    /// This level (0: every strand), or the coarsest the asset has.
    Level(u32),
}

/// [`Lod::Auto`] drops strands while the widened strips stay at most this wide, in pixels of
/// the camera (or texels of the opacity maps), at the centre of the hair's box.
pub const AUTO_LOD_PIXELS: f32 = 0.1;

/// The levels of detail of the camera passes and of the light passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HairLod {
    /// The camera's (blended or opaque hair).
    pub camera: Lod,
    /// The opacity maps'.
    pub light: Lod,
}

/// How strands look beyond what the asset holds: a gradient from root to tip, a taper, and a
/// per-strand variation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairStyle {
    /// Factor on the strand colour at the root (linear RGB).
    pub root_tint: Vec3,
    /// Factor on the strand colour at the tip; mixed with `root_tint` by `param`.
    pub tip_tint: Vec3,
    /// Factor on the opacity at the root.
    pub root_alpha: f32,
    /// Factor on the opacity at the tip (a fade toward the tips below 1).
    pub tip_alpha: f32,
    /// Share of the width lost at the tip, or `None` for the asset's.
    pub taper: Option<f32>,
    /// Spread of a per-strand brightness factor, hashed from the strand's id (0: none; 0.2:
    /// ±10%).
    pub color_variation: f32,
}

impl Default for HairStyle {
    fn default() -> HairStyle {
        HairStyle {
            root_tint: Vec3::ONE,
            tip_tint: Vec3::ONE,
            root_alpha: 1.0,
            tip_alpha: 1.0,
            taper: None,
            color_variation: 0.0,
        }
    }
}

/// What changes from frame to frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairFrame {
    /// The hair's frame (the strands' coordinates as baked) → world: where the hair is drawn,
    /// as the model matrix of the head or bone it sits on. Widths scale with it (by the cube
    /// root of its determinant); the light ([`HairRenderer::light_at`]) must be fitted with the
    /// same matrix. `Mat4::IDENTITY` draws the hair where it was baked.
    pub model: Mat4,
    /// World → camera clip (wgpu: depth 0..1).
    pub camera: Mat4,
    /// The camera's position, world space (strips face it).
    pub eye: Vec3,
    /// The light and its opacity-map projection ([`HairRenderer::light`]).
    pub light: HairLight,
    /// The set drawn into the opacity maps: the wide faint opacity set (the seed's) or the
    /// shading set itself (plain deep opacity maps).
    pub set: HairSet,
    /// Linear RGB of the light.
    pub light_color: Vec3,
    /// Linear RGB of the ambient light.
    pub ambient: Vec3,
    /// Kajiya-Kay specular strength.
    pub specular: f32,
    /// Kajiya-Kay specular exponent.
    pub specular_power: f32,
    /// How receivers (and the hair itself) read the opacity maps.
    pub lookup: Lookup,
    /// The narrowest strip the camera draws, in pixels: a thinner one is widened to it with
    /// its opacity lowered by the same factor (its coverage kept), so sub-pixel strands blend
    /// instead of speckling. 0 draws them at their own width.
    pub min_pixel_width: f32,
    /// Levels of detail.
    pub lod: HairLod,
    /// Gradient, taper and variation.
    pub style: HairStyle,
    /// The part of the frame the camera draws, `[x, y, width, height]` in pixels of the target
    /// (a split screen's half, a picture in picture); `None` for the whole frame. The camera
    /// passes, the composite and the opaque draw keep to it, and strip widths in pixels are
    /// the viewport's.
    pub viewport: Option<[u32; 4]>,
    /// The box the strands lie in this frame, in the hair's frame (before `model`), when they
    /// move within it: skinned hair's [`super::HairSkin::update`]. `None`: the asset's baked
    /// bounds. Levels of detail and the blend's depth range are measured on it.
    pub bounds: Option<(Vec3, Vec3)>,
}

impl HairFrame {
    /// A frame for `camera` at `eye` lit by `light` through the opacity set, with white light,
    /// a little ambient light, a specular highlight, strips at least 1 pixel wide and automatic
    /// levels of detail.
    pub fn new(camera: Mat4, eye: Vec3, light: HairLight) -> HairFrame {
        HairFrame {
            model: Mat4::IDENTITY,
            camera,
            eye,
            light,
            set: HairSet::Opacity,
            light_color: Vec3::ONE,
            ambient: Vec3::splat(0.15),
            specular: 0.25,
            specular_power: 40.0,
            lookup: Lookup::Nearest,
            min_pixel_width: 1.0,
            lod: HairLod::default(),
            style: HairStyle::default(),
            viewport: None,
            bounds: None,
        }
    }
}

/// How the renderer's pipelines are built.
#[derive(Clone, Debug, PartialEq)]
pub struct HairOptions {
    /// The game's targets, as every component takes them: the colour target
    /// [`HairRenderer::composite`] and [`HairRenderer::draw_opaque`] draw into (its format;
    /// blending is the renderer's), the depth format the camera passes test so hair hides
    /// behind geometry (`None` without depth), and the bind group index of the renderer's group
    /// in every pipeline and of the receivers' group in the game's own shaders. Culling and the
    /// visibility target do not apply to hair.
    pub draw: DrawOptions,
    /// Opacity-map texels per side.
    pub resolution: u32,
    /// The frame's size in pixels (the order-independent blend keeps two targets of it, four
    /// with [`BlendWeight::Layers`]; [`HairRenderer::resize`] changes it).
    pub size: (u32, u32),
    /// How the camera's order-independent blend weighs each fragment.
    pub blend: BlendWeight,
}

impl HairOptions {
    /// 256² opacity maps, a `size` frame drawn into `color_format` with no depth, group 0, the
    /// blend weighted by the hair in front of each fragment ([`BlendWeight::Layers`]).
    pub fn new(color_format: wgpu::TextureFormat, size: (u32, u32)) -> HairOptions {
        HairOptions { draw: DrawOptions::new(color_format), resolution: 256, size, blend: BlendWeight::default() }
    }
}

/// How the camera's order-independent blend weighs a fragment against the others in its pixel.
/// Sorted front to back, a fragment counts by the light its pixel's hair in front of it lets
/// through; the blend has no order, so it estimates that.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BlendWeight {
    /// From the hair in front of the fragment in its own pixel: a camera pass first adds every
    /// fragment's opacity into 8 cumulative layers of view depth across the hair's box (two
    /// `Rgba16Float` targets of the frame's size), and each fragment's weight is
    /// `exp(−opacity in front)`, interpolated between the layers' boundaries. One more draw of
    /// the strips, 16 bytes a pixel; it follows dense hair whose front strands hide the rest,
    /// where one falloff per hair cannot.
    #[default]
    Layers,
    /// From the fragment's depth across the hair's box alone, falling off by the hair's mean
    /// optical depth: no extra pass and no extra targets, close on sparse or evenly dense hair.
    Depth,
}

/// Hair strips with anti-aliased shadows (seed 004): deep opacity maps from a light, drawn from
/// either set of a `Strands` asset, and the shading set seen by the camera, shaded with
/// Kajiya-Kay and shadowed through the maps.
///
/// The camera draws the shading set blended at each strand's own opacity with weighted blended
/// order-independent transparency (McGuire & Bavoil 2013): no sorting, frame-sized targets and
/// a composite over the scene, each fragment weighted by the light the hair in front of it in
/// its pixel lets through ([`BlendWeight`]); [`draw_opaque`](HairRenderer::draw_opaque) draws
/// it opaque instead. A frame records, into the game's encoder:
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, gpu: &hikage_runtime::GpuBundle, color: &wgpu::TextureView, depth: &wgpu::TextureView, camera: hikage_runtime::glam::Mat4, eye: hikage_runtime::glam::Vec3) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::hair::{HairFrame, HairOptions, HairRenderer};
/// use hikage_runtime::{glam::Vec3, wgpu};
///
/// let mut options = HairOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb, (1280, 720));
/// options.draw.depth_format = Some(wgpu::TextureFormat::Depth32Float);
/// let hair = HairRenderer::new(device, queue, gpu, "head.strips", &options)?;
/// let light = hair.light(Vec3::new(0.45, 1.0, 0.3));
/// hair.update(queue, &HairFrame::new(camera, eye, light));
/// let mut encoder = device.create_command_encoder(&Default::default());
/// hair.render_opacity_maps(&mut encoder);
/// // … the game draws its scene into `color` and `depth`, its receivers reading
/// // `hair_visibility` through `hair.receiver_bind_group()` …
/// hair.render_hair(&mut encoder, Some(depth));
/// {
///     let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
///         color_attachments: &[Some(wgpu::RenderPassColorAttachment {
///             view: color,
///             depth_slice: None,
///             resolve_target: None,
///             ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
///         })],
///         ..Default::default()
///     });
///     hair.composite(&mut pass);
/// }
/// queue.submit([encoder.finish()]);
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct HairRenderer {
    assets: Vec<String>,
    wgsl: String,
    group: u32,
    resolution: u32,
    settings: StrandsSettings,
    buffer: wgpu::Buffer,
    desc: MeshDesc,
    uniform: wgpu::Buffer,
    depth_map: wgpu::Texture,
    layers: wgpu::Texture,
    zbuffer: wgpu::TextureView,
    layouts: Layouts,
    light_group: wgpu::BindGroup,
    opacity_group: wgpu::BindGroup,
    receiver_group: wgpu::BindGroup,
    targets: FrameTargets,
    pipelines: Pipelines,
    has_depth: bool,
    size: (u32, u32),
    accum_format: wgpu::TextureFormat,
    blend: BlendWeight,
    /// The levels [`update`](HairRenderer::update) chose: camera, light.
    drawn: [AtomicU32; 2],
    /// The viewport of the last [`update`](Self::update): x, y, width, height (width 0: the
    /// whole frame).
    viewport: [AtomicU32; 4],
}

#[derive(Debug)]
struct Layouts {
    light: wgpu::BindGroupLayout,
    opacity: wgpu::BindGroupLayout,
    receiver: wgpu::BindGroupLayout,
    /// The blended pass weighted by the camera's layers: the receivers' entries and the layers.
    camera: wgpu::BindGroupLayout,
    composite: wgpu::BindGroupLayout,
}

/// The frame-sized targets of the camera's blend and the groups that read them.
#[derive(Debug)]
struct FrameTargets {
    accum: wgpu::TextureView,
    revealage: wgpu::TextureView,
    /// With [`BlendWeight::Layers`]: the camera's 8 cumulative opacity layers (the nearer four,
    /// the farther four) and the blended pass's group reading them with the opacity maps.
    layers: Option<([wgpu::Texture; 2], wgpu::BindGroup)>,
    composite_group: wgpu::BindGroup,
}

#[derive(Debug)]
struct Pipelines {
    depth: wgpu::RenderPipeline,
    opacity: wgpu::RenderPipeline,
    /// With [`BlendWeight::Layers`]: the camera's opacity layers, drawn before the blend.
    camera_layers: Option<wgpu::RenderPipeline>,
    oit: wgpu::RenderPipeline,
    opaque: wgpu::RenderPipeline,
    composite: wgpu::RenderPipeline,
}

fn texture(device: &wgpu::Device, size: (u32, u32), format: wgpu::TextureFormat, label: &str) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

fn view_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) }
}

impl HairRenderer {
    /// Builds the renderer of `strips` (a `Strands` asset of `gpu`).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        gpu: &GpuBundle,
        strips: &str,
        options: &HairOptions,
    ) -> Result<HairRenderer, RuntimeError> {
        let mesh = gpu.mesh(strips)?;
        let bad = |message: String| RuntimeError::Asset { asset: strips.to_string(), message };
        let settings = mesh
            .asset
            .settings
            .strands()
            .ok_or_else(|| bad(format!("expected a strands asset, found a {}", mesh.asset.kind.name())))?
            .clone();
        if mesh.desc != hikage_bundle::strands_desc(mesh.desc.vertex_count) {
            return Err(bad("strand records must be the interleaved 32-byte layout of format 1.5".into()));
        }
        if let Some(l) = settings.levels.iter().find(|l| l[1] > mesh.desc.vertex_count || l[0] > settings.strands) {
            return Err(bad(format!("level of detail {l:?} names more than the asset's strands and points")));
        }
        if options.resolution == 0 || options.resolution > device.limits().max_texture_dimension_2d {
            return Err(bad(format!("opacity maps of {} texels a side do not fit this device", options.resolution)));
        }
        let resolution = options.resolution;
        let wgsl = gpu::at_group(HAIR_WGSL, options.draw.group);
        let uniform = gpu::uniform_buffer(device, queue, "hikage hair", &HairUniform::zeroed_for(resolution));
        let maps = (resolution, resolution);
        let depth_map = texture(device, maps, DEPTH_MAP, "hikage hair depth map");
        let layers = texture(device, maps, LAYERS_FORMAT, "hikage hair opacity layers");
        let zbuffer = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("hikage hair light depth"),
                size: wgpu::Extent3d { width: resolution, height: resolution, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Depth32Float,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default());
        let sampled = |b| gpu::texture_entry(b, wgpu::TextureViewDimension::D2, false);
        let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
        };
        let layouts = Layouts {
            light: layout("hikage hair light", &[gpu::uniform_entry::<HairUniform>(0)]),
            opacity: layout("hikage hair opacity", &[gpu::uniform_entry::<HairUniform>(0), sampled(1)]),
            receiver: layout("hikage hair receivers", &[gpu::uniform_entry::<HairUniform>(0), sampled(1), sampled(2)]),
            camera: layout(
                "hikage hair camera",
                &[gpu::uniform_entry::<HairUniform>(0), sampled(1), sampled(2), sampled(5), sampled(6)],
            ),
            composite: layout("hikage hair composite", &[sampled(3), sampled(4)]),
        };
        let (depth_view, layers_view) =
            (depth_map.create_view(&Default::default()), layers.create_view(&Default::default()));
        let ubind = wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() };
        let group = |layout: &wgpu::BindGroupLayout, entries: &[wgpu::BindGroupEntry]| {
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("hikage hair"), layout, entries })
        };
        let light_group = group(&layouts.light, std::slice::from_ref(&ubind));
        let opacity_group = group(&layouts.opacity, &[ubind.clone(), view_entry(1, &depth_view)]);
        let receiver_group =
            group(&layouts.receiver, &[ubind.clone(), view_entry(1, &depth_view), view_entry(2, &layers_view)]);
        // Accumulate in f32 where the device blends it; the weights are bounded so half floats
        // do not overflow either.
        let accum_format = if device.features().contains(wgpu::Features::FLOAT32_BLENDABLE) {
            wgpu::TextureFormat::Rgba32Float
        } else {
            wgpu::TextureFormat::Rgba16Float
        };
        let targets = frame_targets(
            device,
            &layouts,
            options.size,
            accum_format,
            options.blend,
            (&uniform, &depth_view, &layers_view),
        );
        let pipelines = gpu::checked(device, strips, || pipelines(device, &wgsl, &layouts, options, accum_format))?;
        Ok(HairRenderer {
            assets: vec![strips.to_string()],
            wgsl,
            group: options.draw.group,
            resolution,
            settings,
            buffer: mesh.buffer.clone(),
            desc: mesh.desc.clone(),
            uniform,
            depth_map,
            layers,
            zbuffer,
            layouts,
            light_group,
            opacity_group,
            receiver_group,
            targets,
            pipelines,
            has_depth: options.draw.depth_format.is_some(),
            size: options.size,
            accum_format,
            blend: options.blend,
            drawn: [AtomicU32::new(0), AtomicU32::new(0)],
            viewport: Default::default(),
        })
    }

    /// An orthographic light along `to_light` fitted to the hair's bounding box (from the
    /// asset's settings) where it was baked: nothing outside the box is drawn into the maps.
    pub fn light(&self, to_light: Vec3) -> HairLight {
        self.light_at(Mat4::IDENTITY, to_light)
    }

    /// The light along `to_light` (world) fitted to the hair's box carried by `model` (the
    /// [`HairFrame::model`] the frame draws with): the maps and their receivers follow the hair.
    ///
    /// ```no_run
    /// # fn f(hair: &hikage_runtime::hair::HairRenderer, head: hikage_runtime::glam::Mat4, camera: hikage_runtime::glam::Mat4, eye: hikage_runtime::glam::Vec3) {
    /// use hikage_runtime::glam::Vec3;
    /// use hikage_runtime::hair::HairFrame;
    ///
    /// // The head's world matrix this frame, from the game's animation.
    /// let light = hair.light_at(head, Vec3::new(0.3, 1.0, 0.2));
    /// let frame = HairFrame { model: head, ..HairFrame::new(camera, eye, light) };
    /// # }
    /// ```
    pub fn light_at(&self, model: Mat4, to_light: Vec3) -> HairLight {
        let (lo, hi) = self.bounds_at(model);
        HairLight::for_bounds(lo, hi, to_light)
    }

    /// The world box around the hair drawn with `model`: the box of the asset's bounds carried
    /// by it.
    pub fn bounds_at(&self, model: Mat4) -> (Vec3, Vec3) {
        box_through(model, (Vec3::from(self.settings.bounds_min), Vec3::from(self.settings.bounds_max)))
    }

    /// The world box around the hair `frame` draws: its `bounds` (or the asset's) carried by
    /// its model matrix.
    fn frame_bounds(&self, frame: &HairFrame) -> (Vec3, Vec3) {
        match frame.bounds {
            Some(b) => box_through(frame.model, b),
            None => self.bounds_at(frame.model),
        }
    }

    /// Draws the records `skin` poses instead of the asset's own: the hair follows the
    /// skinned scalp from then on (record the skin's pass before the hair's each frame, and
    /// give each frame the skin's bounds). The skin must pose this renderer's strands.
    pub fn follow(&mut self, skin: &super::HairSkin) -> Result<(), RuntimeError> {
        if skin.points() != self.desc.vertex_count || !skin.asset_ids().contains(&self.assets[0]) {
            return Err(RuntimeError::Asset {
                asset: self.assets[0].clone(),
                message: format!("the skin poses {:?}, not these strands", skin.asset_ids().last()),
            });
        }
        self.buffer = skin.posed_records().clone();
        for id in skin.asset_ids() {
            if !self.assets.contains(id) {
                self.assets.push(id.clone());
            }
        }
        Ok(())
    }

    /// The ids of the assets the renderer was built from (the strips): after a reload whose
    /// [`crate::Changes::touches`] them, build it again.
    pub fn asset_ids(&self) -> &[String] {
        &self.assets
    }

    /// The strands asset's settings (both sets, bounds).
    pub fn settings(&self) -> &StrandsSettings {
        &self.settings
    }

    /// The levels of detail the asset has: `[strands, points]` per level, finest first.
    pub fn levels(&self) -> Vec<[u32; 2]> {
        if self.settings.levels.is_empty() {
            vec![[self.settings.strands, self.desc.vertex_count]]
        } else {
            self.settings.levels.clone()
        }
    }

    /// The levels of detail `frame` draws: (camera, light).
    pub fn chosen_levels(&self, frame: &HairFrame) -> (u32, u32) {
        let levels = self.levels().len() as u32;
        let (lo, hi) = self.frame_bounds(frame);
        let model_width = model_width(frame.model);
        let centre = 0.5 * (lo + hi);
        // The widest a world length at the box's centre appears, in pixels, along the axes.
        let camera_pixels = {
            let c0 = frame.camera * centre.extend(1.0);
            let [_, _, w, h] = self.viewport_of(frame);
            let size = Vec3::new(w as f32, h as f32, 0.0);
            [Vec3::X, Vec3::Y, Vec3::Z]
                .into_iter()
                .map(|axis| {
                    let c1 = frame.camera * (centre + axis).extend(1.0);
                    if c0.w <= 0.0 || c1.w <= 0.0 {
                        return 0.0;
                    }
                    ((c1.truncate() / c1.w - c0.truncate() / c0.w) * 0.5 * size).truncate().length()
                })
                .fold(0.0f32, f32::max)
        };
        let texels = self.resolution as f32 / (hi - lo).max_element().max(1e-12);
        let width = |set: HairSet| {
            model_width
                * match set {
                    HairSet::Shading => self.settings.shading.0,
                    HairSet::Opacity => self.settings.opacity.0,
                }
        };
        let pick = |lod: Lod, strip_pixels: f32| match lod {
            Lod::Level(l) => l.min(levels - 1),
            Lod::Auto => {
                let mut l = 0;
                while l + 1 < levels && strip_pixels * self.widen(l + 1) <= AUTO_LOD_PIXELS {
                    l += 1;
                }
                l
            }
        };
        (
            pick(frame.lod.camera, width(HairSet::Shading) * camera_pixels),
            pick(frame.lod.light, width(frame.set) * texels),
        )
    }

    /// The width factor of level `level`: all strands / the strands it draws.
    fn widen(&self, level: u32) -> f32 {
        let levels = self.levels();
        let l = levels[(level as usize).min(levels.len() - 1)];
        self.settings.strands.max(1) as f32 / l[0].max(1) as f32
    }

    /// The uniform for `frame`.
    pub fn uniform(&self, frame: &HairFrame) -> HairUniform {
        let (lo, hi) = frame.light.bounds;
        let (camera_level, light_level) = self.chosen_levels(frame);
        let s = &self.settings;
        let ratio = |a: f32, b: f32| if b > 0.0 { a / b } else { 1.0 };
        // Distances from the eye to the hair's box: the nearest point and the farthest corner.
        let (blo, bhi) = self.frame_bounds(frame);
        let model_width = model_width(frame.model);
        let near = (frame.eye.clamp(blo, bhi) - frame.eye).length();
        let far = (0..8)
            .map(|k| {
                let c = Vec3::new(
                    if k & 1 == 0 { blo.x } else { bhi.x },
                    if k & 2 == 0 { blo.y } else { bhi.y },
                    if k & 4 == 0 { blo.z } else { bhi.z },
                );
                (c - frame.eye).length()
            })
            .fold(0.0f32, f32::max);
        let style = &frame.style;
        HairUniform {
            light: frame.light.view_proj.to_cols_array_2d(),
            light_inverse: frame.light.view_proj.inverse().to_cols_array_2d(),
            bounds_min: lo.extend(0.0).to_array(),
            bounds_max: hi.extend(0.0).to_array(),
            camera: frame.camera.to_cols_array_2d(),
            eye: frame.eye.extend(1.0).to_array(),
            to_light: frame.light.to_light.normalize().extend(0.0).to_array(),
            light_color: frame.light_color.extend(0.0).to_array(),
            ambient: frame.ambient.extend(0.0).to_array(),
            root_tint: style.root_tint.extend(style.root_alpha).to_array(),
            tip_tint: style.tip_tint.extend(style.tip_alpha).to_array(),
            step: frame.light.step,
            opacity_set: u32::from(frame.set == HairSet::Opacity),
            resolution: self.resolution,
            specular_power: frame.specular_power,
            specular: frame.specular,
            layer_rule: match frame.light.rule {
                super::LayerRule::Box => 0,
                super::LayerRule::PerTexel => 1,
            },
            lookup: frame.lookup.code(),
            max_width: s.max_width,
            width_ratio: ratio(s.opacity.0, s.shading.0),
            alpha_ratio: ratio(s.opacity.1, s.shading.1),
            taper: style.taper.unwrap_or(s.taper),
            min_pixel_width: frame.min_pixel_width,
            viewport: {
                let [_, _, w, h] = self.viewport_of(frame);
                [w as f32, h as f32]
            },
            depth_range: [near, far],
            camera_widen: self.widen(camera_level),
            light_widen: self.widen(light_level),
            color_variation: style.color_variation,
            // The optical depth across the box is the hair's own: measured in its frame.
            oit_falloff: oit_falloff(s, (far - near) / model_width.max(1e-12)),
            model: frame.model.to_cols_array_2d(),
            model_width,
            _pad: [0.0; 3],
        }
    }

    /// Writes the uniform for `frame` and takes its levels of detail; the next submitted passes
    /// use them.
    pub fn update(&self, queue: &wgpu::Queue, frame: &HairFrame) {
        let (camera, light) = self.chosen_levels(frame);
        self.drawn[0].store(camera, Ordering::Relaxed);
        self.drawn[1].store(light, Ordering::Relaxed);
        for (slot, v) in self.viewport.iter().zip(self.viewport_of(frame)) {
            slot.store(v, Ordering::Relaxed);
        }
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.uniform(frame)));
    }

    /// The hair's WGSL with its bindings at the chosen group, for a game's own receivers:
    /// `hair_visibility(world)` with [`receiver_layout`](Self::receiver_layout).
    pub fn wgsl(&self) -> &str {
        &self.wgsl
    }

    /// The layout of the receivers' bind group: 0 the uniform, 1 the depth map, 2 the layers.
    pub fn receiver_layout(&self) -> &wgpu::BindGroupLayout {
        &self.layouts.receiver
    }

    /// The receivers' bind group, valid once [`render_opacity_maps`](Self::render_opacity_maps)
    /// has run in the same frame.
    pub fn receiver_bind_group(&self) -> &wgpu::BindGroup {
        &self.receiver_group
    }

    /// The opacity maps: the nearest hair depth per texel (R32Float, light NDC; 1 where there is
    /// none) and the four cumulative layers (Rgba16Float).
    pub fn opacity_maps(&self) -> (&wgpu::Texture, &wgpu::Texture) {
        (&self.depth_map, &self.layers)
    }

    /// Records the two light passes into `encoder`: the depth map, then the opacity layers.
    pub fn render_opacity_maps(&self, encoder: &mut wgpu::CommandEncoder) {
        let (depth_view, layers_view) =
            (self.depth_map.create_view(&Default::default()), self.layers.create_view(&Default::default()));
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("hikage hair depth map"),
                color_attachments: &[color_attachment(&depth_view, wgpu::Color::WHITE)],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.zbuffer,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            self.draw_strips(&mut pass, &self.pipelines.depth, &self.light_group, LIGHT);
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hikage hair opacity layers"),
            color_attachments: &[color_attachment(&layers_view, wgpu::Color::TRANSPARENT)],
            ..Default::default()
        });
        self.draw_strips(&mut pass, &self.pipelines.opacity, &self.opacity_group, LIGHT);
    }

    /// Records the camera passes of the order-independent blend into `encoder`: the shading set
    /// accumulated into the renderer's frame targets (after its opacity layers, with
    /// [`BlendWeight::Layers`]), depth-tested against `scene_depth` (the game's depth
    /// attachment, read only; give it exactly when the options had a depth format).
    /// [`composite`](Self::composite) then blends the result over the scene.
    pub fn render_hair(&self, encoder: &mut wgpu::CommandEncoder, scene_depth: Option<&wgpu::TextureView>) {
        debug_assert_eq!(scene_depth.is_some(), self.has_depth, "scene_depth must match HairOptions::depth_format");
        let depth = || {
            scene_depth.map(|view| wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            })
        };
        if let (Some(pipeline), Some((textures, _))) = (&self.pipelines.camera_layers, &self.targets.layers) {
            let [near, far] = textures.each_ref().map(|t| t.create_view(&Default::default()));
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("hikage hair camera layers"),
                color_attachments: &[
                    color_attachment(&near, wgpu::Color::TRANSPARENT),
                    color_attachment(&far, wgpu::Color::TRANSPARENT),
                ],
                depth_stencil_attachment: depth(),
                ..Default::default()
            });
            self.keep_to_viewport(&mut pass);
            self.draw_strips(&mut pass, pipeline, &self.light_group, CAMERA);
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hikage hair"),
            color_attachments: &[
                color_attachment(&self.targets.accum, wgpu::Color::TRANSPARENT),
                color_attachment(&self.targets.revealage, wgpu::Color::WHITE),
            ],
            depth_stencil_attachment: depth(),
            ..Default::default()
        });
        self.keep_to_viewport(&mut pass);
        let group = self.targets.layers.as_ref().map_or(&self.receiver_group, |(_, group)| group);
        self.draw_strips(&mut pass, &self.pipelines.oit, group, CAMERA);
    }

    /// `frame`'s viewport within the frame targets (the whole frame when it has none).
    fn viewport_of(&self, frame: &HairFrame) -> [u32; 4] {
        let (w, h) = self.size;
        match frame.viewport {
            Some([x, y, vw, vh]) => {
                let (x, y) = (x.min(w.saturating_sub(1)), y.min(h.saturating_sub(1)));
                [x, y, vw.clamp(1, w - x), vh.clamp(1, h - y)]
            }
            None => [0, 0, w, h],
        }
    }

    /// Sets the last update's viewport on `pass`.
    fn keep_to_viewport(&self, pass: &mut wgpu::RenderPass<'_>) {
        let [x, y, w, h] = self.viewport.each_ref().map(|v| v.load(Ordering::Relaxed) as f32);
        if w > 0.0 && h > 0.0 {
            pass.set_viewport(x, y, w, h, 0.0, 1.0);
        }
    }

    /// Blends the hair accumulated by [`render_hair`](Self::render_hair) over the game's colour
    /// target in `pass`, a pass with that one colour attachment and no depth attachment (it sets
    /// the frame's viewport on the pass).
    pub fn composite(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.keep_to_viewport(pass);
        pass.set_pipeline(&self.pipelines.composite);
        pass.set_bind_group(self.group, &self.targets.composite_group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// Draws the shading set opaque into `pass` (the game's colour target and depth), the
    /// alternative to the order-independent blend (it sets the frame's viewport on the pass).
    pub fn draw_opaque(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.keep_to_viewport(pass);
        self.draw_strips(pass, &self.pipelines.opaque, &self.receiver_group, CAMERA);
    }

    /// Makes the frame targets `size` pixels (after the game's window is resized).
    pub fn resize(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        let (depth_view, layers_view) =
            (self.depth_map.create_view(&Default::default()), self.layers.create_view(&Default::default()));
        self.targets = frame_targets(
            device,
            &self.layouts,
            size,
            self.accum_format,
            self.blend,
            (&self.uniform, &depth_view, &layers_view),
        );
        self.size = size;
    }

    /// One instance per segment of the chosen level: the records bound twice, one apart.
    fn draw_strips(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipeline: &wgpu::RenderPipeline,
        group: &wgpu::BindGroup,
        which: usize,
    ) {
        let levels = self.levels();
        let level = (self.drawn[which].load(Ordering::Relaxed) as usize).min(levels.len() - 1);
        let points = levels[level][1] as u64;
        if points < 2 {
            return;
        }
        let records = RECORD * self.desc.vertex_count as u64;
        pass.set_pipeline(pipeline);
        pass.set_bind_group(self.group, group, &[]);
        pass.set_vertex_buffer(0, self.buffer.slice(0..records - RECORD));
        pass.set_vertex_buffer(1, self.buffer.slice(RECORD..records));
        pass.draw(0..4, 0..(points - 1) as u32);
    }
}

/// The factor `model` puts on lengths across a strand: the cube root of its 3×3 determinant
/// (a uniform scale's own factor).
fn model_width(model: Mat4) -> f32 {
    glam::Mat3::from_mat4(model).determinant().abs().cbrt()
}

/// The box of `(lo, hi)` carried by `model`.
fn box_through(model: Mat4, (lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
    if model == Mat4::IDENTITY {
        return (lo, hi);
    }
    (0..8).fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), k| {
        let corner = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let p = model.transform_point3(corner);
        (a.min(p), b.max(p))
    })
}

/// The hair's optical depth across a depth of `depth` through its box: its opacity-weighted area
/// over the box's volume, times the depth, doubled because hair fills about half its box (a
/// shell around the head; the factor that brought the blend nearest the sorted composite on the
/// four layouts of the `hair_view` example), capped where the weight floor takes over.
fn oit_falloff(s: &StrandsSettings, depth: f32) -> f32 {
    let size = Vec3::from(s.bounds_max) - Vec3::from(s.bounds_min);
    let volume = size.x * size.y * size.z;
    if volume.is_nan() || volume <= 0.0 {
        return 0.0;
    }
    (2.0 * s.opacity_area / volume * depth).clamp(0.0, 30.0)
}

/// The `drawn` slot of the camera passes' level.
const CAMERA: usize = 0;
/// The `drawn` slot of the light passes' level.
const LIGHT: usize = 1;

impl HairUniform {
    /// A uniform with nothing set but the opacity maps' resolution (before the first frame).
    fn zeroed_for(resolution: u32) -> HairUniform {
        HairUniform { resolution, ..bytemuck::Zeroable::zeroed() }
    }
}

fn color_attachment(view: &wgpu::TextureView, clear: wgpu::Color) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
    })
}

/// The order-independent blend's targets of `size` and the groups over them; `maps` are the
/// uniform and the opacity maps the blended pass also reads.
fn frame_targets(
    device: &wgpu::Device,
    layouts: &Layouts,
    size: (u32, u32),
    accum_format: wgpu::TextureFormat,
    blend: BlendWeight,
    (uniform, depth_map, layers): (&wgpu::Buffer, &wgpu::TextureView, &wgpu::TextureView),
) -> FrameTargets {
    let accum = texture(device, size, accum_format, "hikage hair accumulation").create_view(&Default::default());
    let revealage = texture(device, size, REVEALAGE, "hikage hair revealage").create_view(&Default::default());
    let composite_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hikage hair composite"),
        layout: &layouts.composite,
        entries: &[view_entry(3, &accum), view_entry(4, &revealage)],
    });
    let layers = (blend == BlendWeight::Layers).then(|| {
        let textures = ["hikage hair camera layers 1-4", "hikage hair camera layers 5-8"]
            .map(|label| texture(device, size, LAYERS_FORMAT, label));
        let [near, far] = textures.each_ref().map(|t| t.create_view(&Default::default()));
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hikage hair camera"),
            layout: &layouts.camera,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                view_entry(1, depth_map),
                view_entry(2, layers),
                view_entry(5, &near),
                view_entry(6, &far),
            ],
        });
        (textures, group)
    });
    FrameTargets { accum, revealage, layers, composite_group }
}

fn pipelines(
    device: &wgpu::Device,
    wgsl: &str,
    layouts: &Layouts,
    options: &HairOptions,
    accum_format: wgpu::TextureFormat,
) -> Pipelines {
    let module = gpu::module(device, "hikage hair", wgsl);
    // Both ends of a segment: the same record layout at locations 0–5 and 6–11.
    let attributes: Vec<Vec<wgpu::VertexAttribute>> = (0..2u32)
        .map(|end| {
            let mut offset = 0;
            STREAMS
                .iter()
                .enumerate()
                .map(|(k, &(_, format))| {
                    let a = wgpu::VertexAttribute { format, offset, shader_location: 6 * end + k as u32 };
                    offset += format.size();
                    a
                })
                .collect()
        })
        .collect();
    let buffers: Vec<Option<wgpu::VertexBufferLayout>> = attributes
        .iter()
        .map(|a| {
            Some(wgpu::VertexBufferLayout {
                array_stride: RECORD,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: a,
            })
        })
        .collect();
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let keep_inverse = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrc,
        operation: wgpu::BlendOperation::Add,
    };
    let target = |format, blend| Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL });
    let depth = |format, write, compare| wgpu::DepthStencilState {
        depth_write_enabled: Some(write),
        ..gpu::depth_state(format, compare)
    };
    let scene_depth = |write| options.draw.depth_format.map(|f| depth(f, write, options.draw.depth_compare));
    let color = options.draw.color.format;
    let pipeline = |layout: &wgpu::BindGroupLayout,
                    (vs, fs): (&str, &str),
                    strips: bool,
                    targets: &[Option<wgpu::ColorTargetState>],
                    depth: Option<wgpu::DepthStencilState>| {
        let desc = gpu::PipelineDesc {
            label: fs,
            vs,
            fs,
            buffers: if strips { &buffers } else { &[] },
            targets,
            depth,
            cull_mode: None,
            topology: if strips {
                wgpu::PrimitiveTopology::TriangleStrip
            } else {
                wgpu::PrimitiveTopology::TriangleList
            },
        };
        gpu::render_pipeline(device, &module, (options.draw.group, layout), desc)
    };
    let oit_targets = [
        target(accum_format, Some(wgpu::BlendState { color: add, alpha: add })),
        target(REVEALAGE, Some(wgpu::BlendState { color: keep_inverse, alpha: keep_inverse })),
    ];
    Pipelines {
        depth: pipeline(
            &layouts.light,
            ("hair_vs_light", "hair_fs_depth"),
            true,
            &[target(DEPTH_MAP, None)],
            Some(depth(wgpu::TextureFormat::Depth32Float, true, wgpu::CompareFunction::Less)),
        ),
        opacity: pipeline(
            &layouts.opacity,
            ("hair_vs_light", "hair_fs_opacity"),
            true,
            &[target(LAYERS_FORMAT, Some(wgpu::BlendState { color: add, alpha: add }))],
            None,
        ),
        camera_layers: (options.blend == BlendWeight::Layers).then(|| {
            pipeline(
                &layouts.light,
                ("hair_vs_camera", "hair_fs_camera_layers"),
                true,
                &[
                    target(LAYERS_FORMAT, Some(wgpu::BlendState { color: add, alpha: add })),
                    target(LAYERS_FORMAT, Some(wgpu::BlendState { color: add, alpha: add })),
                ],
                scene_depth(false),
            )
        }),
        oit: match options.blend {
            BlendWeight::Layers => pipeline(
                &layouts.camera,
                ("hair_vs_camera", "hair_fs_oit_layered"),
                true,
                &oit_targets,
                scene_depth(false),
            ),
            BlendWeight::Depth => {
                pipeline(&layouts.receiver, ("hair_vs_camera", "hair_fs_oit"), true, &oit_targets, scene_depth(false))
            }
        },
        opaque: pipeline(
            &layouts.receiver,
            ("hair_vs_camera_opaque", "hair_fs_opaque"),
            true,
            &[target(color, None)],
            scene_depth(true),
        ),
        composite: pipeline(
            &layouts.composite,
            ("hair_vs_composite", "hair_fs_composite"),
            false,
            &[target(color, Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING))],
            None,
        ),
    }
}
