//! The hair in Bevy's render world: each [`HairStrands`](super::HairStrands) is extracted with its
//! light, gets one hikage-runtime `HairRenderer` per camera (its blend targets are the camera's
//! size and its composite the camera's format), and is drawn by two systems of Bevy's `Core3d`
//! camera schedule: the opacity maps before the main pass, the strips after the transparent pass.

use std::collections::HashMap;
use std::sync::Arc;

use bevy_app::App;
use bevy_camera::Camera3d;
use bevy_color::{ColorToComponents, LinearRgba};
use bevy_core_pipeline::{Core3d, Core3dSystems};
use bevy_ecs::prelude::*;
use bevy_light::{DirectionalLight, GlobalAmbientLight};
use bevy_render::camera::ExtractedCamera;
use bevy_render::render_asset::RenderAssets;
use bevy_render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy_render::storage::GpuShaderBuffer;
use bevy_render::texture::GpuImage;
use bevy_render::view::{ExtractedView, Msaa, ViewDepthStencilTexture, ViewTarget};
use bevy_render::{Extract, ExtractSchedule, Render, RenderApp, RenderSystems};
use bevy_transform::components::GlobalTransform;
use hikage_runtime::hair::{HairFrame, HairLight, HairOptions, HairRenderer, HairSkin};
use hikage_runtime::{CpuAsset, GpuBundle, glam, wgpu};

use super::{HairDraw, HairShadowMaps, HairStrands};
use crate::HikageBundle;

/// A hair as the render world sees it this frame.
struct ExtractedHair {
    /// The main world's entity.
    entity: Entity,
    /// The strips' records as loaded (a new `Arc` after a reload).
    strips: Arc<CpuAsset>,
    hair: HairStrands,
    maps: HairShadowMaps,
    /// The hair's frame → world: its entity's `GlobalTransform`.
    model: glam::Mat4,
    /// Unit vector toward the light (world).
    to_light: glam::Vec3,
    /// The light's colour × illuminance / π, before the camera's exposure.
    light_color: glam::Vec3,
    /// The ambient light, before the camera's exposure.
    ambient: glam::Vec3,
    /// The skin the hair follows: its binding and scalp, and this frame's joint matrices.
    skin: Option<ExtractedSkin>,
}

/// A skinned hair's binding and scalp as loaded, and its skin's joint matrices this frame
/// (each joint's world matrix × its inverse bind pose).
struct ExtractedSkin {
    binding: Arc<CpuAsset>,
    scalp: Arc<CpuAsset>,
    joints: Vec<glam::Mat4>,
}

/// The hairs of this frame.
#[derive(Resource, Default)]
struct ExtractedHairs(Vec<ExtractedHair>);

/// One hair's renderer for one camera, and what it was built for.
struct ViewHair {
    renderer: HairRenderer,
    /// The records, opacity-map size, colour format and skin (binding, records; none: 0, 0) it
    /// was built for.
    built_for: (usize, u32, wgpu::TextureFormat, (usize, usize)),
    /// The camera's size its blend targets have.
    size: (u32, u32),
}

/// The renderers by (hair, camera), the strips uploaded by hair, the hairs (with their
/// records) that failed to build, said once, and for cameras with MSAA the depth the hair tests
/// against.
#[derive(Resource, Default)]
struct HairRenderers {
    views: HashMap<(Entity, Entity), ViewHair>,
    uploads: HashMap<Entity, (usize, GpuBundle)>,
    /// Each skinned hair's skin.
    skins: HashMap<Entity, PosedHair>,
    failed: Vec<(Entity, usize)>,
    resolve: Option<DepthResolve>,
    resolved: HashMap<Entity, wgpu::Texture>,
}

/// A skinned hair's skin, what it was built for (binding, records) and the box its hair lies in
/// this frame.
struct PosedHair {
    built_for: (usize, usize),
    skin: HairSkin,
    bounds: (glam::Vec3, glam::Vec3),
}

/// The depth a camera with MSAA gives the hair: its multisampled depth resolved to one sample
/// per pixel, the nearest of the pixel's samples, so the single-sampled blend (and the opaque
/// draw) test against it and composite onto the resolved main texture. Hair is then hidden
/// wherever any sample of a pixel is covered by nearer geometry (never drawn over a nearer
/// edge).
struct DepthResolve {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

/// The resolve: a full-screen triangle writing each pixel's nearest sample as its depth.
const RESOLVE_WGSL: &str = r#"
@group(0) @binding(0) var scene_depth: texture_depth_multisampled_2d;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// Bevy's depth is reversed (1 near, 0 far): the nearest sample is the largest.
@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @builtin(frag_depth) f32 {
    let ij = vec2<i32>(p.xy);
    var d = 0.0;
    for (var s = 0u; s < textureNumSamples(scene_depth); s = s + 1u) {
        d = max(d, textureLoad(scene_depth, ij, i32(s)));
    }
    return d;
}
"#;

impl DepthResolve {
    fn new(device: &wgpu::Device) -> DepthResolve {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hikage hair depth resolve"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: true,
                },
                count: None,
            }],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hikage hair depth resolve"),
            source: wgpu::ShaderSource::Wgsl(RESOLVE_WGSL.into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hikage hair depth resolve"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("hikage hair depth resolve"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[],
            }),
            multiview_mask: None,
            cache: None,
        });
        DepthResolve { pipeline, layout }
    }

    /// Records the resolve of `msaa_depth` into `resolved`.
    fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        msaa_depth: &wgpu::TextureView,
        resolved: &wgpu::TextureView,
    ) {
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hikage hair depth resolve"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(msaa_depth) }],
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hikage hair depth resolve"),
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: resolved,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// Bevy's depth format, which the hair's camera passes test against.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Makes the depth of every camera with MSAA readable while hair is drawn (the resolve samples
/// it), on the render world's copy of its `Camera3d`: the game's camera is left as it is.
fn readable_msaa_depth(hairs: Res<ExtractedHairs>, mut cameras: Query<(&mut Camera3d, &Msaa)>) {
    if hairs.0.is_empty() {
        return;
    }
    for (mut camera, msaa) in &mut cameras {
        let usage = wgpu::TextureUsages::from(camera.depth_texture_usages);
        if msaa.samples() > 1 && !usage.contains(wgpu::TextureUsages::TEXTURE_BINDING) {
            camera.depth_texture_usages = (usage | wgpu::TextureUsages::TEXTURE_BINDING).into();
        }
    }
}

pub(super) fn build(app: &mut App) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .init_resource::<ExtractedHairs>()
        .init_resource::<HairRenderers>()
        .add_systems(ExtractSchedule, extract)
        .add_systems(Render, readable_msaa_depth.in_set(RenderSystems::PrepareViews))
        .add_systems(Render, prepare.in_set(RenderSystems::PrepareResources))
        .add_systems(
            Core3d,
            (
                opacity_maps.after(Core3dSystems::Prepass).before(Core3dSystems::MainPass),
                strips.after(Core3dSystems::MainPass).before(Core3dSystems::EarlyPostProcess),
            ),
        );
}

/// The records' identity: a reload gives a new allocation.
fn key(strips: &Arc<CpuAsset>) -> usize {
    Arc::as_ptr(strips) as usize
}

fn to_glam(c: LinearRgba) -> glam::Vec3 {
    glam::Vec3::from_array(c.to_f32_array_no_alpha())
}

/// What extraction reads of the skins hair follows: their meshes' joints, the joints' transforms
/// and the inverse bind poses.
type Skinning = (
    Query<'static, 'static, &'static bevy_mesh::skinning::SkinnedMesh>,
    Query<'static, 'static, &'static GlobalTransform>,
    Res<'static, bevy_asset::Assets<bevy_mesh::skinning::SkinnedMeshInverseBindposes>>,
);

/// Copies each hair whose bundle and maps are ready, with its light, into the render world.
fn extract(
    mut out: ResMut<ExtractedHairs>,
    hairs: Extract<Query<(Entity, &HairStrands, &HairShadowMaps, &GlobalTransform)>>,
    bundles: Extract<Res<bevy_asset::Assets<HikageBundle>>>,
    lights: Extract<Query<(Entity, &DirectionalLight, &GlobalTransform)>>,
    ambient: Extract<Option<Res<GlobalAmbientLight>>>,
    skinning: Extract<Skinning>,
) {
    let (skins, joints, bindposes) = &*skinning;
    out.0.clear();
    let ambient = ambient.as_ref().map_or(glam::Vec3::ZERO, |a| to_glam(a.color.to_linear()) * a.brightness);
    // The scene's light for hairs that name none: the first with shadow maps, else the first.
    let first = lights.iter().min_by_key(|(e, l, _)| (!l.shadow_maps_enabled, *e));
    for (entity, hair, maps, transform) in &hairs {
        let Some(bundle) = bundles.get(&hair.bundle) else { continue };
        let Some(strips) = bundle.strands(&hair.strips) else { continue };
        // A skinned hair waits for its skin, its joints and its binding (said on the entity
        // while one is missing).
        let skin = match hair.skin {
            None => None,
            Some(entity) => {
                let Ok(skin) = skins.get(entity) else { continue };
                let Some(inverse) = bindposes.get(&skin.inverse_bindposes) else { continue };
                let Ok((binding, scalp)) = super::binding_of(bundle, &hair.strips) else { continue };
                let matrices: Option<Vec<glam::Mat4>> = skin
                    .joints
                    .iter()
                    .zip(inverse.iter())
                    .map(|(&j, ibm)| {
                        let world = joints.get(j).ok()?.to_matrix() * *ibm;
                        Some(glam::Mat4::from_cols_array(&world.to_cols_array()))
                    })
                    .collect();
                // A skin of other joints than the scalp's is said on the entity (`check_skin`).
                let baked = scalp.asset.settings.scalp().map_or(0, |s| s.joints.len());
                let Some(matrices) = matrices.filter(|m| m.len() == skin.joints.len() && m.len() == baked) else {
                    continue;
                };
                Some(ExtractedSkin { binding: binding.clone(), scalp: scalp.clone(), joints: matrices })
            }
        };
        let light = match hair.light {
            Some(e) => lights.get(e).ok(),
            None => first,
        };
        let (to_light, light_color) = match light {
            Some((_, l, t)) => (
                glam::Vec3::from_array(t.back().to_array()),
                to_glam(l.color.to_linear()) * l.illuminance / std::f32::consts::PI,
            ),
            None => (glam::Vec3::Y, glam::Vec3::ZERO),
        };
        // A skin's joint matrices pose the hair in the world.
        let model = match skin {
            Some(_) => glam::Mat4::IDENTITY,
            None => glam::Mat4::from_cols_array(&transform.to_matrix().to_cols_array()),
        };
        out.0.push(ExtractedHair {
            entity,
            strips: strips.clone(),
            hair: hair.clone(),
            maps: maps.clone(),
            model,
            to_light,
            light_color,
            ambient,
            skin,
        });
    }
}

/// Builds, resizes and updates each (hair, camera) renderer and writes each hair's uniform into
/// its receivers' buffer.
fn prepare(
    hairs: Res<ExtractedHairs>,
    mut renderers: ResMut<HairRenderers>,
    views: Query<(Entity, &ExtractedView, &ExtractedCamera, &ViewTarget, &Msaa)>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    buffers: Res<RenderAssets<GpuShaderBuffer>>,
) {
    let (device, queue): (&wgpu::Device, &wgpu::Queue) = (device.wgpu_device(), &queue);
    let renderers = &mut *renderers;
    let (mut live, mut live_views) = (Vec::new(), Vec::new());
    for h in &hairs.0 {
        let strips_id = h.hair.strips.as_str();
        if renderers.failed.contains(&(h.entity, key(&h.strips))) {
            continue;
        }
        let upload = renderers.uploads.entry(h.entity).or_insert_with(|| (0, GpuBundle::default()));
        if upload.0 != key(&h.strips) {
            if let Err(e) = upload.1.insert(device, queue, &h.strips) {
                bevy_log::error!("hikage: hair `{strips_id}`: {e}");
                renderers.failed.push((h.entity, key(&h.strips)));
                continue;
            }
            upload.0 = key(&h.strips);
        }
        // The skin, built for this binding and this upload, takes this frame's joints.
        let skin_key = match &h.skin {
            None => {
                renderers.skins.remove(&h.entity);
                (0, 0)
            }
            Some(skin) => {
                let wanted = (key(&skin.binding), key(&h.strips));
                if renderers.skins.get(&h.entity).is_none_or(|s| s.built_for != wanted) {
                    let gpu = &renderers.uploads[&h.entity].1;
                    match HairSkin::new(device, queue, gpu, &skin.binding, &skin.scalp) {
                        Ok(built) => {
                            let bounds = (glam::Vec3::ZERO, glam::Vec3::ZERO);
                            renderers.skins.insert(h.entity, PosedHair { built_for: wanted, skin: built, bounds });
                        }
                        Err(e) => {
                            bevy_log::error!("hikage: hair `{strips_id}`: {e}");
                            renderers.failed.push((h.entity, key(&h.strips)));
                            continue;
                        }
                    }
                }
                let entry = renderers.skins.get_mut(&h.entity).expect("built above");
                match entry.skin.update(queue, &skin.joints) {
                    Ok(bounds) => entry.bounds = bounds,
                    Err(e) => {
                        bevy_log::error!("hikage: hair `{strips_id}`: {e}");
                        continue;
                    }
                }
                wanted
            }
        };
        let mut uniform_written = false;
        for (view, extracted, camera, target, msaa) in &views {
            let Some(size) = camera.physical_target_size else { continue };
            if msaa.samples() > 1 {
                renderers.resolve.get_or_insert_with(|| DepthResolve::new(device));
                let fits = renderers.resolved.get(&view).is_some_and(|t| (t.width(), t.height()) == (size.x, size.y));
                if !fits {
                    let texture = device.create_texture(&wgpu::TextureDescriptor {
                        label: Some("hikage hair resolved depth"),
                        size: wgpu::Extent3d { width: size.x, height: size.y, depth_or_array_layers: 1 },
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format: DEPTH_FORMAT,
                        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                        view_formats: &[],
                    });
                    renderers.resolved.insert(view, texture);
                }
                live_views.push(view);
            }
            let format = target.main_texture_format();
            let built_for = (key(&h.strips), h.maps.resolution, format, skin_key);
            let slot = (h.entity, view);
            if renderers.views.get(&slot).is_none_or(|v| v.built_for != built_for) {
                let mut options = HairOptions::new(format, (size.x, size.y));
                options.resolution = h.maps.resolution;
                options.draw.depth_format = Some(DEPTH_FORMAT);
                options.draw.depth_compare = wgpu::CompareFunction::GreaterEqual;
                let built = HairRenderer::new(device, queue, &renderers.uploads[&h.entity].1, strips_id, &options)
                    .and_then(|mut renderer| {
                        if let Some(posed) = renderers.skins.get(&h.entity) {
                            renderer.follow(&posed.skin)?;
                        }
                        Ok(renderer)
                    });
                match built {
                    Ok(renderer) => {
                        renderers.views.insert(slot, ViewHair { renderer, built_for, size: (size.x, size.y) });
                    }
                    Err(e) => {
                        renderers.views.remove(&slot);
                        bevy_log::error!("hikage: hair `{strips_id}`: {e}");
                        renderers.failed.push((h.entity, key(&h.strips)));
                        break;
                    }
                }
            }
            let bounds = renderers.skins.get(&h.entity).map(|s| s.bounds);
            let v = renderers.views.get_mut(&slot).expect("built above");
            if v.size != (size.x, size.y) {
                v.size = (size.x, size.y);
                v.renderer.resize(device, v.size);
            }
            let frame = frame(h, extracted, camera, &v.renderer, bounds);
            v.renderer.update(queue, &frame);
            // The receivers read the light's half of the uniform, the same for every camera.
            if !uniform_written && let Some(buffer) = buffers.get(&h.maps.uniform) {
                queue.write_buffer(&buffer.buffer, 0, hikage_runtime::bytemuck::bytes_of(&v.renderer.uniform(&frame)));
                uniform_written = true;
            }
            live.push(slot);
        }
    }
    renderers.views.retain(|slot, _| live.contains(slot));
    renderers.resolved.retain(|view, _| live_views.contains(view));
    let hair_entities: Vec<Entity> = hairs.0.iter().map(|h| h.entity).collect();
    renderers.uploads.retain(|e, _| hair_entities.contains(e));
    renderers.skins.retain(|e, _| hair_entities.contains(e));
    renderers.failed.retain(|(e, _)| hair_entities.contains(e));
}

/// The runtime's frame for hair `h` seen by a camera; `bounds` is a skinned hair's box this
/// frame.
fn frame(
    h: &ExtractedHair,
    view: &ExtractedView,
    camera: &ExtractedCamera,
    renderer: &HairRenderer,
    bounds: Option<(glam::Vec3, glam::Vec3)>,
) -> HairFrame {
    let world_from_view = view.world_from_view.to_matrix();
    let clip_from_world = view.clip_from_world.unwrap_or(view.clip_from_view * world_from_view.inverse());
    let camera_matrix = glam::Mat4::from_cols_array(&clip_from_world.to_cols_array());
    let eye = glam::Vec3::from_array(view.world_from_view.translation().to_array());
    let hair = &h.hair;
    HairFrame {
        set: hair.set,
        light_color: h.light_color * camera.exposure,
        ambient: h.ambient * camera.exposure,
        specular: hair.specular,
        specular_power: hair.specular_power,
        lookup: hair.lookup,
        min_pixel_width: hair.min_pixel_width,
        lod: hair.lod,
        style: hair.style.into(),
        model: h.model,
        viewport: camera.viewport.as_ref().map(|v| {
            let (p, s) = (v.physical_position, v.physical_size);
            [p.x, p.y, s.x, s.y]
        }),
        bounds,
        ..HairFrame::new(
            camera_matrix,
            eye,
            match bounds {
                Some((lo, hi)) => HairLight::for_bounds(lo, hi, h.to_light),
                None => renderer.light_at(h.model, h.to_light),
            },
        )
    }
}

/// The renderers of the current camera's hairs.
fn for_view<'a>(
    hairs: &'a ExtractedHairs,
    renderers: &'a HairRenderers,
    view: Entity,
) -> impl Iterator<Item = (&'a ExtractedHair, &'a HairRenderer)> {
    hairs.0.iter().filter_map(move |h| renderers.views.get(&(h.entity, view)).map(|v| (h, &v.renderer)))
}

/// Renders each hair's opacity maps and copies them into its [`HairShadowMaps`] images, before
/// the main pass draws the receivers.
fn opacity_maps(
    view: ViewQuery<Entity>,
    hairs: Res<ExtractedHairs>,
    renderers: Res<HairRenderers>,
    images: Res<RenderAssets<GpuImage>>,
    mut ctx: RenderContext,
) {
    let encoder = ctx.command_encoder();
    for (h, renderer) in for_view(&hairs, &renderers, view.entity()) {
        // Skinned hair is posed first (again for each camera: the joints are this frame's).
        if let Some(posed) = renderers.skins.get(&h.entity) {
            posed.skin.record(encoder);
        }
        renderer.render_opacity_maps(encoder);
        let (depth, layers) = renderer.opacity_maps();
        let mut copied = 0;
        for (from, to) in [(depth, &h.maps.depth), (layers, &h.maps.layers)] {
            if let Some(image) = images.get(to) {
                encoder.copy_texture_to_texture(from.as_image_copy(), image.texture.as_image_copy(), from.size());
                copied += 1;
            }
        }
        if copied == 2 {
            h.maps.set_drawn();
        }
    }
}

/// Draws each hair over the camera's scene: blended (the accumulation pass, then the composite
/// onto the main texture) or opaque (into the main texture and its depth).
fn strips(
    view: ViewQuery<(Entity, &ViewTarget, &ViewDepthStencilTexture, &Msaa)>,
    hairs: Res<ExtractedHairs>,
    renderers: Res<HairRenderers>,
    mut ctx: RenderContext,
) {
    let (entity, target, depth, msaa) = view.into_inner();
    if for_view(&hairs, &renderers, entity).next().is_none() {
        return;
    }
    let scene_depth: &wgpu::TextureView = &depth.attachment.texture.default_view;
    // The main texture is the resolved one once the main pass is over, MSAA or not.
    let color_view: &wgpu::TextureView = target.main_texture_view();
    let device = ctx.render_device().wgpu_device().clone();
    let encoder = ctx.command_encoder();
    let resolved = match (msaa.samples() > 1, &renderers.resolve, renderers.resolved.get(&entity)) {
        (false, ..) => None,
        (true, Some(resolve), Some(texture)) => {
            let resolved = texture.create_view(&Default::default());
            resolve.record(&device, encoder, scene_depth, &resolved);
            Some(resolved)
        }
        (true, ..) => return, // prepared next frame
    };
    let depth_view = resolved.as_ref().unwrap_or(scene_depth);
    for (h, renderer) in for_view(&hairs, &renderers, entity) {
        let load = wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store };
        let color = [Some(wgpu::RenderPassColorAttachment {
            view: color_view,
            depth_slice: None,
            resolve_target: None,
            ops: load,
        })];
        match h.hair.draw {
            HairDraw::Blended => {
                renderer.render_hair(encoder, Some(depth_view));
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("hikage hair composite"),
                    color_attachments: &color,
                    ..Default::default()
                });
                renderer.composite(&mut pass);
            }
            HairDraw::Opaque => {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("hikage hair"),
                    color_attachments: &color,
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: depth_view,
                        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
                        stencil_ops: None,
                    }),
                    ..Default::default()
                });
                renderer.draw_opaque(&mut pass);
            }
            HairDraw::ShadowsOnly => {}
        }
    }
}
