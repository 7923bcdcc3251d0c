//! [`HairRenderer`]: the deep opacity maps from a light, the shading set blended at its opacity
//! (or opaque) from the camera, and `hair_visibility` for the game's shadow receivers.

use std::sync::atomic::{AtomicU32, Ordering};

use glam::{Mat4, Vec3};
use hikage_bundle::{MeshDesc, StrandsSettings};

use super::frame::{AUTO_LOD_PIXELS, BlendWeight, HairFrame, HairOptions, HairUniform, Lod};
use super::targets::{
    DEPTH_MAP, FrameTargets, LAYERS_FORMAT, Layouts, Pipelines, RECORD, color_attachment, frame_targets, pipelines,
    texture, view_entry,
};
use super::{HAIR_WGSL, HairLight, HairSet};
use crate::error::RuntimeError;
use crate::gpu;
use crate::upload::GpuBundle;

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
