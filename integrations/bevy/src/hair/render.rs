//! The hair in Bevy's render world: each [`HairStrands`](super::HairStrands) is extracted with its
//! light, gets one hikage-runtime `HairRenderer` per camera (its blend targets are the camera's
//! size and its composite the camera's format), and is drawn by two systems of Bevy's `Core3d`
//! camera schedule: the opacity maps before the main pass, the strips after the transparent pass.

use std::collections::HashMap;
use std::sync::Arc;

use bevy_app::App;
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
use hikage_runtime::hair::{HairFrame, HairOptions, HairRenderer};
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
}

/// The hairs of this frame.
#[derive(Resource, Default)]
struct ExtractedHairs(Vec<ExtractedHair>);

/// One hair's renderer for one camera, and what it was built for.
struct ViewHair {
    renderer: HairRenderer,
    /// The records, opacity-map size and colour format it was built for.
    built_for: (usize, u32, wgpu::TextureFormat),
    /// The camera's size its blend targets have.
    size: (u32, u32),
}

/// The renderers by (hair, camera), the strips uploaded by hair, the cameras told once that
/// MSAA hides the hair, and the hairs (with their records) that failed to build, said once.
#[derive(Resource, Default)]
struct HairRenderers {
    views: HashMap<(Entity, Entity), ViewHair>,
    uploads: HashMap<Entity, (usize, GpuBundle)>,
    warned: Vec<Entity>,
    failed: Vec<(Entity, usize)>,
}

pub(super) fn build(app: &mut App) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .init_resource::<ExtractedHairs>()
        .init_resource::<HairRenderers>()
        .add_systems(ExtractSchedule, extract)
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

/// Copies each hair whose bundle and maps are ready, with its light, into the render world.
fn extract(
    mut out: ResMut<ExtractedHairs>,
    hairs: Extract<Query<(Entity, &HairStrands, &HairShadowMaps, &GlobalTransform)>>,
    bundles: Extract<Res<bevy_asset::Assets<HikageBundle>>>,
    lights: Extract<Query<(Entity, &DirectionalLight, &GlobalTransform)>>,
    ambient: Extract<Option<Res<GlobalAmbientLight>>>,
) {
    out.0.clear();
    let ambient = ambient.as_ref().map_or(glam::Vec3::ZERO, |a| to_glam(a.color.to_linear()) * a.brightness);
    // The scene's light for hairs that name none: the first with shadow maps, else the first.
    let first = lights.iter().min_by_key(|(e, l, _)| (!l.shadow_maps_enabled, *e));
    for (entity, hair, maps, transform) in &hairs {
        let Some(strips) = bundles.get(&hair.bundle).and_then(|b| b.strands(&hair.strips)) else {
            continue;
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
        let model = glam::Mat4::from_cols_array(&transform.to_matrix().to_cols_array());
        out.0.push(ExtractedHair {
            entity,
            strips: strips.clone(),
            hair: hair.clone(),
            maps: maps.clone(),
            model,
            to_light,
            light_color,
            ambient,
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
    let mut live = Vec::new();
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
        let mut uniform_written = false;
        for (view, extracted, camera, target, msaa) in &views {
            if msaa.samples() != 1 {
                if !renderers.warned.contains(&view) {
                    renderers.warned.push(view);
                    bevy_log::warn!("hikage: hair `{strips_id}` is not drawn by a camera with MSAA on: use Msaa::Off");
                }
                continue;
            }
            let Some(size) = camera.physical_target_size else { continue };
            let format = target.main_texture_format();
            let built_for = (key(&h.strips), h.maps.resolution, format);
            let slot = (h.entity, view);
            if renderers.views.get(&slot).is_none_or(|v| v.built_for != built_for) {
                let mut options = HairOptions::new(format, (size.x, size.y));
                options.resolution = h.maps.resolution;
                options.draw.depth_format = Some(wgpu::TextureFormat::Depth32Float);
                options.draw.depth_compare = wgpu::CompareFunction::GreaterEqual;
                match HairRenderer::new(device, queue, &renderers.uploads[&h.entity].1, strips_id, &options) {
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
            let v = renderers.views.get_mut(&slot).expect("built above");
            if v.size != (size.x, size.y) {
                v.size = (size.x, size.y);
                v.renderer.resize(device, v.size);
            }
            let frame = frame(h, extracted, camera, &v.renderer);
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
    let hair_entities: Vec<Entity> = hairs.0.iter().map(|h| h.entity).collect();
    renderers.uploads.retain(|e, _| hair_entities.contains(e));
    renderers.failed.retain(|(e, _)| hair_entities.contains(e));
}

/// The runtime's frame for hair `h` seen by a camera.
fn frame(h: &ExtractedHair, view: &ExtractedView, camera: &ExtractedCamera, renderer: &HairRenderer) -> HairFrame {
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
        ..HairFrame::new(camera_matrix, eye, renderer.light_at(h.model, h.to_light))
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
        renderer.render_opacity_maps(encoder);
        let (depth, layers) = renderer.opacity_maps();
        for (from, to) in [(depth, &h.maps.depth), (layers, &h.maps.layers)] {
            if let Some(image) = images.get(to) {
                encoder.copy_texture_to_texture(from.as_image_copy(), image.texture.as_image_copy(), from.size());
            }
        }
    }
}

/// Draws each hair over the camera's scene: blended (the accumulation pass, then the composite
/// onto the main texture) or opaque (into the main texture and its depth).
fn strips(
    view: ViewQuery<(Entity, &ViewTarget, &ViewDepthStencilTexture)>,
    hairs: Res<ExtractedHairs>,
    renderers: Res<HairRenderers>,
    mut ctx: RenderContext,
) {
    let (entity, target, depth) = view.into_inner();
    let depth_view: &wgpu::TextureView = &depth.attachment.texture.default_view;
    let color_view: &wgpu::TextureView = target.main_texture_view();
    let encoder = ctx.command_encoder();
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
