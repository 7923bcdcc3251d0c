//! The hair scene of seed 004 (demo code): a ground quad receiving the hair's shadow through
//! the renderer's `hair_visibility`, whole frames of hair over the ground, read-back of the
//! opacity maps, and the aliasing figure of the ground's shadow. Used by the `hair_shadow`
//! example and the GPU tests.

use glam::{Mat4, Vec3};
use hikage_runtime::hair::HairRenderer;

use crate::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, clear_attachment};

const GROUND_WGSL: &str = include_str!("shaders/hair_ground.wgsl");

/// How the camera draws the hair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairBlend {
    /// Blended at its opacity, order-independently (the renderer's default).
    OrderIndependent,
    /// Opaque.
    Opaque,
}

/// A ground quad that receives the hair's shadow.
pub struct Ground {
    vertices: wgpu::Buffer,
    uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
    color: wgpu::RenderPipeline,
    visibility: wgpu::RenderPipeline,
}

impl Ground {
    /// The quad `corners` (counter-clockwise seen from above) for `renderer`, whose receiver
    /// group must be at index 0.
    pub fn new(g: &Headless, renderer: &HairRenderer, corners: [Vec3; 4]) -> Ground {
        let device = &g.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("ground"),
            source: wgpu::ShaderSource::Wgsl(format!("{}\n{GROUND_WGSL}", renderer.wgsl()).into()),
        });
        let own = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ground"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ground"),
            bind_group_layouts: &[Some(renderer.receiver_layout()), Some(&own)],
            immediate_size: 0,
        });
        let uniform = g.buffer(80, wgpu::BufferUsages::UNIFORM, None);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ground"),
            layout: &own,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }],
        });
        let quad: Vec<u8> =
            [0usize, 1, 2, 0, 2, 3].iter().flat_map(|&i| corners[i].to_array()).flat_map(f32::to_le_bytes).collect();
        let vertices = g.buffer(quad.len() as u64, wgpu::BufferUsages::VERTEX, Some(&quad));
        let pipeline = |fs: &str, format, depth: Option<wgpu::DepthStencilState>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(fs),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("ground_vs"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: 12,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                    })],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                depth_stencil: depth,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[crate::headless::plain_target(format)],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let mut depth = crate::headless::depth_test();
        depth.format = DEPTH_FORMAT;
        Ground {
            vertices,
            uniform,
            group,
            color: pipeline("ground_fs", COLOR_FORMAT, Some(depth)),
            visibility: pipeline("ground_fs_visibility", wgpu::TextureFormat::R32Float, None),
        }
    }

    fn draw(
        &self,
        g: &Headless,
        pass: &mut wgpu::RenderPass<'_>,
        renderer: &HairRenderer,
        pipeline: &wgpu::RenderPipeline,
        view_proj: Mat4,
    ) {
        let mut u: Vec<f32> = view_proj.to_cols_array().to_vec();
        u.extend([0.75, 0.72, 0.66, 1.0]);
        g.queue.write_buffer(&self.uniform, 0, &u.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, renderer.receiver_bind_group(), &[]);
        pass.set_bind_group(1, &self.group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.draw(0..6, 0..1);
    }

    /// The ground's visibility seen by `view_proj` into a `size` image (1 where no hair
    /// shadows it, 1 off the quad), from the opacity maps the renderer holds.
    pub fn visibility(&self, g: &Headless, renderer: &HairRenderer, view_proj: Mat4, size: (u32, u32)) -> Vec<f32> {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let target = g.texture(size, wgpu::TextureFormat::R32Float, usage);
        let view = target.create_view(&Default::default());
        let mut encoder = g.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ground visibility"),
                color_attachments: &[clear_attachment(&view, wgpu::Color::WHITE)],
                ..Default::default()
            });
            self.draw(g, &mut pass, renderer, &self.visibility, view_proj);
        }
        g.queue.submit([encoder.finish()]);
        g.read_texture(&target).chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    }
}

/// One whole frame of `size`: the opacity maps, the ground (if any) and the hair by `blend`,
/// over `clear`. The renderer's uniform must be set and its frame targets `size`. Returns the
/// sRGB RGBA8 pixels.
pub fn render_frame(
    g: &Headless,
    renderer: &HairRenderer,
    ground: Option<(&Ground, Mat4)>,
    blend: HairBlend,
    size: (u32, u32),
    clear: wgpu::Color,
) -> Vec<u8> {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let color = g.texture(size, COLOR_FORMAT, usage);
    let depth = g.texture(size, DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let (cv, dv) = (color.create_view(&Default::default()), depth.create_view(&Default::default()));
    let mut encoder = g.device.create_command_encoder(&Default::default());
    renderer.render_opacity_maps(&mut encoder);
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("scene"),
            color_attachments: &[clear_attachment(&cv, clear)],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &dv,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        if let Some((ground, view_proj)) = ground {
            ground.draw(g, &mut pass, renderer, &ground.color, view_proj);
        }
        if blend == HairBlend::Opaque {
            renderer.draw_opaque(&mut pass);
        }
    }
    if blend == HairBlend::OrderIndependent {
        renderer.render_hair(&mut encoder, Some(&dv));
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("composite"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &cv,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            ..Default::default()
        });
        renderer.composite(&mut pass);
    }
    g.queue.submit([encoder.finish()]);
    g.read_texture(&color)
}

/// The renderer's opacity maps read back: the nearest depth per texel and the four layers.
pub fn read_opacity_maps(g: &Headless, renderer: &HairRenderer) -> (Vec<f32>, Vec<[f32; 4]>) {
    let (depth, layers) = renderer.opacity_maps();
    let d = g.read_texture(depth);
    let l = g.read_texture(layers);
    let depth = d.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let layers = l
        .chunks_exact(8)
        .map(|c| std::array::from_fn(|k| half::f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f32()))
        .collect();
    (depth, layers)
}

/// Box-filters a `(w·factor) × (h·factor)` image down to `w × h`: the mean of each block.
pub fn box_filter(v: &[f32], (w, h): (u32, u32), factor: u32) -> Vec<f32> {
    let (w, h, f) = (w as usize, h as usize, factor as usize);
    let mut out = vec![0.0f32; w * h];
    for (y, row) in v.chunks_exact(w * f).enumerate() {
        for (x, &value) in row.iter().enumerate() {
            out[(y / f) * w + x / f] += value;
        }
    }
    out.iter_mut().for_each(|o| *o /= (f * f) as f32);
    out
}

/// The reference ground shadow seen by `view_proj` in a `size` image: the shading set's
/// opacity maps at `factor` × `resolution` texels a side, the ground's visibility rendered at
/// `factor` × `size` and box-filtered down to `size` — what anti-aliased opacity maps of
/// `resolution`² should converge to.
#[expect(clippy::too_many_arguments, reason = "a test scene's knobs, each set by the examples and tests")]
pub fn reference_shadow(
    g: &Headless,
    gpu: &hikage_runtime::GpuBundle,
    strips: &str,
    to_light: Vec3,
    corners: [Vec3; 4],
    view_proj: Mat4,
    (resolution, size): (u32, (u32, u32)),
    factor: u32,
) -> Result<Vec<f32>, hikage_runtime::RuntimeError> {
    use hikage_runtime::hair::{HairFrame, HairLod, HairOptions, HairSet, Lod};
    let options = HairOptions { resolution: resolution * factor, ..HairOptions::new(COLOR_FORMAT, (8, 8)) };
    let renderer = HairRenderer::new(&g.device, &g.queue, gpu, strips, &options)?;
    let lod = HairLod { camera: Lod::Level(0), light: Lod::Level(0) };
    let frame = HairFrame {
        set: HairSet::Shading,
        lod,
        ..HairFrame::new(Mat4::IDENTITY, Vec3::ZERO, renderer.light(to_light))
    };
    renderer.update(&g.queue, &frame);
    let mut encoder = g.device.create_command_encoder(&Default::default());
    renderer.render_opacity_maps(&mut encoder);
    g.queue.submit([encoder.finish()]);
    let ground = Ground::new(g, &renderer, corners);
    let fine = ground.visibility(g, &renderer, view_proj, (size.0 * factor, size.1 * factor));
    Ok(box_filter(&fine, size, factor))
}

/// A shadow image against its reference, over the pixels in or beside shadow in either (below
/// 0.98): RMS and largest difference of visibility, and the difference of mean darkness
/// (1 − visibility; positive: darker than the reference).
pub fn shadow_errors(v: &[f32], reference: &[f32]) -> (f64, f64, f64) {
    let (mut sq, mut max, mut dark, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for (&a, &b) in v.iter().zip(reference) {
        if a >= 0.98 && b >= 0.98 {
            continue;
        }
        let d = (a - b) as f64;
        sq += d * d;
        max = max.max(d.abs());
        dark += -d;
        n += 1;
    }
    if n == 0 {
        return (0.0, 0.0, 0.0);
    }
    ((sq / n as f64).sqrt(), max, dark / n as f64)
}

/// The error the layers put into the hair's own shadow: at every strand point, the visibility
/// through the layered maps of the light passes `uniform` sets up (its set, its level's first
/// `points` records) against the exact cumulative opacity of every fragment in front of it in
/// the same texel (the maps without layering), on the CPU. RMS and largest.
pub fn layer_errors(
    strips: &hikage_runtime::hair::reference::StripArrays,
    uniform: &hikage_runtime::hair::HairUniform,
    light: &hikage_runtime::hair::HairLight,
    points: u32,
) -> (f64, f64) {
    use hikage_runtime::hair::reference::{Facing, accumulate_cpu, expand, for_each_light_fragment, texel_visibility};
    let resolution = uniform.resolution;
    let r = resolution as usize;
    let expanded = expand(strips, uniform, Facing::Light, points);
    let mut fragments: Vec<Vec<(f32, f32)>> = vec![Vec::new(); r * r];
    for_each_light_fragment(&expanded, light, resolution, |i, z, a| fragments[i].push((z, a)));
    let (z0, layers) = accumulate_cpu(&expanded, light, resolution);
    let (mut sq, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
    for point in &strips.points {
        let c = light.view_proj * Vec3::from(point.position).extend(1.0);
        let ndc = c.truncate() / c.w;
        let (x, y) = (((ndc.x * 0.5 + 0.5) * r as f32).floor(), ((0.5 - ndc.y * 0.5) * r as f32).floor());
        if x < 0.0 || y < 0.0 || x >= r as f32 || y >= r as f32 {
            continue;
        }
        let i = y as usize * r + x as usize;
        let in_front: f32 = fragments[i].iter().filter(|(z, _)| *z < ndc.z).map(|(_, a)| a).sum();
        let exact = 1.0 - in_front.min(1.0);
        let layered = texel_visibility(light, &z0, &layers, resolution, (x as i64, y as i64), ndc.z);
        let d = (layered - exact) as f64;
        sq += d * d;
        max = max.max(d.abs());
        n += 1;
    }
    ((sq / n.max(1) as f64).sqrt(), max)
}

/// Aliasing of a shadow image: the mean squared difference between each pixel and the mean of
/// its 3×3 neighbourhood (high-frequency energy), over pixels in shadow (visibility < 0.98) or
/// next to one, relative to the squared mean darkness there. Holes and stripes in a shadow raise
/// it; a smooth shadow of the same darkness keeps it low.
pub fn high_frequency_energy(v: &[f32], (w, h): (u32, u32)) -> f64 {
    let (w, h) = (w as usize, h as usize);
    let (mut energy, mut dark, mut n) = (0.0f64, 0.0f64, 0usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let mut sum = 0.0f64;
            let mut any = false;
            for dy in 0..3 {
                for dx in 0..3 {
                    let s = v[(y + dy - 1) * w + x + dx - 1] as f64;
                    sum += s;
                    any |= s < 0.98;
                }
            }
            if !any {
                continue;
            }
            let c = v[y * w + x] as f64;
            energy += (c - sum / 9.0).powi(2);
            dark += 1.0 - c;
            n += 1;
        }
    }
    if n == 0 || dark == 0.0 {
        return 0.0;
    }
    (energy / n as f64) / (dark / n as f64).powi(2)
}

/// How [`camera_reference`] composites the fragments of a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Composite {
    /// Sorted by depth, blended front to back: the exact answer.
    Sorted,
    /// The renderer's weighted blended order-independent transparency, each fragment weighted
    /// by the pixel's camera layers (`BlendWeight::Layers`, the default).
    OrderIndependent,
    /// The same blend weighted by depth across the hair's box (`BlendWeight::Depth`).
    DepthWeighted,
    /// The nearest fragment, opaque.
    Opaque,
}

/// The hair seen by the camera of `uniform`, on the CPU: every fragment of the first `points`
/// records' strips (expanded toward the eye, widened as the vertex shader widens them), shaded
/// by the CPU reference with the opacity maps `maps` (read back from the GPU, or from
/// `accumulate_cpu`), composited by `how` over black. Per pixel: linear RGB (premultiplied)
/// and coverage.
pub fn camera_reference(
    strips: &hikage_runtime::hair::reference::StripArrays,
    uniform: &hikage_runtime::hair::HairUniform,
    light: &hikage_runtime::hair::HairLight,
    maps: &(Vec<f32>, Vec<[f32; 4]>),
    (size, points): ((u32, u32), u32),
    how: Composite,
) -> Vec<[f32; 4]> {
    use hikage_runtime::hair::Lookup;
    use hikage_runtime::hair::reference::{
        Facing, coverage, expand, hair_camera_layers, hair_kajiya_kay, hair_layered_weight, hair_oit_weight,
        hair_visibility,
    };
    let lookup = if uniform.lookup == Lookup::Bilinear.code() { Lookup::Bilinear } else { Lookup::Nearest };
    let facing = if how == Composite::Opaque { Facing::CameraOpaque } else { Facing::Camera };
    let e = expand(strips, uniform, facing, points);
    let camera = Mat4::from_cols_array_2d(&uniform.camera);
    let eye = Vec3::from_slice(&uniform.eye[..3]);
    let clip: Vec<glam::Vec4> = e.world.iter().map(|w| camera * w.extend(1.0)).collect();
    let to_light = Vec3::from_slice(&uniform.to_light[..3]);
    // (depth, premultiplied colour, opacity, weight, view depth) per fragment, per pixel.
    type Fragment = (f32, Vec3, f32, f32, f32);
    let mut pixels: Vec<Vec<Fragment>> = vec![Vec::new(); (size.0 * size.1) as usize];
    crate::raster::for_each_fragment(&clip, &e.indices, size, false, |i, t, q, z| {
        let v = |k: usize| e.indices[3 * t + k] as usize;
        let mix3 = |f: &dyn Fn(usize) -> Vec3| f(v(0)) * q[0] + f(v(1)) * q[1] + f(v(2)) * q[2];
        let mix1 = |f: &dyn Fn(usize) -> f32| f(v(0)) * q[0] + f(v(1)) * q[1] + f(v(2)) * q[2];
        let p = mix3(&|k| e.world[k]);
        let tangent = mix3(&|k| e.tangent[k]).normalize();
        let base = mix3(&|k| e.color[k]);
        let alpha = mix1(&|k| e.alpha[k]) * coverage(mix1(&|k| e.across_px[k]), mix1(&|k| e.footprint[k]));
        let view_depth = mix1(&|k| e.view_depth[k]);
        let vis = hair_visibility(light, (&maps.0, &maps.1), uniform.resolution, lookup, p);
        let c = hair_kajiya_kay(uniform, tangent, to_light, (eye - p).normalize(), base, vis);
        pixels[i].push((z, c, alpha, hair_oit_weight(uniform, view_depth, alpha), view_depth));
    });
    pixels
        .into_iter()
        .map(|mut f| {
            if f.is_empty() {
                return [0.0; 4];
            }
            match how {
                Composite::Sorted => {
                    f.sort_by(|a, b| a.0.total_cmp(&b.0));
                    let (mut c, mut a) = (Vec3::ZERO, 0.0f32);
                    for (_, color, alpha, ..) in f {
                        c += color * alpha * (1.0 - a);
                        a += alpha * (1.0 - a);
                    }
                    [c.x, c.y, c.z, a]
                }
                Composite::OrderIndependent | Composite::DepthWeighted => {
                    let layers = (how == Composite::OrderIndependent)
                        .then(|| hair_camera_layers(uniform, f.iter().map(|x| (x.4, x.2))));
                    let (mut sum, mut weight, mut revealage) = (Vec3::ZERO, 0.0f32, 1.0f32);
                    for (_, color, alpha, w, view_depth) in f {
                        let w = layers.as_ref().map_or(w, |l| hair_layered_weight(uniform, l, view_depth, alpha));
                        sum += color * alpha * w;
                        weight += alpha * w;
                        revealage *= 1.0 - alpha;
                    }
                    let c = sum / weight.max(1e-5) * (1.0 - revealage);
                    [c.x, c.y, c.z, 1.0 - revealage]
                }
                Composite::Opaque => {
                    let (_, c, ..) = f.into_iter().min_by(|a, b| a.0.total_cmp(&b.0)).expect("not empty");
                    [c.x, c.y, c.z, 1.0]
                }
            }
        })
        .collect()
}

/// Linear RGB of an sRGB byte.
pub fn srgb_to_linear(b: u8) -> f32 {
    let c = b as f32 / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}
