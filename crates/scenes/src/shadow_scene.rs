//! The reference scene of seed 001: a few hundred boxes over a large ground, drawn with a shadow
//! map from one light whose projection is fixed, fitted ([`hikage_runtime::shadow_fit`]) or fitted in
//! post-perspective space. [`render_frame`] draws one frame on the GPU and reads back, per
//! pixel, the shadow-map texel coordinates, the texel density σ, the lit flag and the world
//! position; [`sigma_cpu`] recomputes σ for a pixel from the camera and light matrices alone, so
//! the GPU figure can be checked. Used by the `shadow_fit` example and the GPU tests.

use glam::{Mat4, Vec3, Vec4};

use crate::headless::{Headless, clear_attachment, depth_attachment, depth_test, plain_target, render_pipeline};
use hikage_runtime::shadow_fit::{
    self, Camera, Fit, FitOptions, FitSpace, FitTarget, Light, MeshRef, PullBack, Scratch, Snap, Sphere,
};

/// WGSL of the two passes.
pub const SCENE_WGSL: &str = include_str!("shaders/shadow_scene.wgsl");

/// Face normals by the index stored per vertex: ±x, ±y, ±z.
pub const FACE_NORMALS: [Vec3; 6] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];

/// Boxes over a ground quad, as one triangle list in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// World positions.
    pub positions: Vec<Vec3>,
    /// Face index of each vertex (into [`FACE_NORMALS`]).
    pub faces: Vec<u32>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Each box's lower and upper corner.
    pub boxes: Vec<[Vec3; 2]>,
    /// Bounds of everything.
    pub bounds: Sphere,
}

impl Scene {
    /// `boxes` boxes (2–10 units wide, 2–24 tall) scattered over a ground `2·half` wide, from a
    /// fixed seed.
    pub fn boxes(boxes: u32, half: f32, seed: u64) -> Scene {
        let mut state = seed.wrapping_mul(0x9e3779b97f4a7c15) | 1;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut s = Scene {
            positions: Vec::new(),
            faces: Vec::new(),
            indices: Vec::new(),
            boxes: Vec::new(),
            bounds: Sphere { centre: Vec3::ZERO, radius: 0.0 },
        };
        s.add_quad(Vec3::new(-half, 0.0, -half), Vec3::new(0.0, 0.0, 2.0 * half), Vec3::new(2.0 * half, 0.0, 0.0), 2);
        let mut top: f32 = 0.0;
        for _ in 0..boxes {
            let (w, d, h) = (2.0 + 8.0 * next(), 2.0 + 8.0 * next(), 2.0 + 22.0 * next());
            let (x, z) = ((next() * 2.0 - 1.0) * (half - 10.0), (next() * 2.0 - 1.0) * (half - 10.0));
            s.add_box(Vec3::new(x - w / 2.0, 0.0, z - d / 2.0), Vec3::new(w, h, d));
            top = top.max(h);
        }
        let corner = Vec3::new(half, top, half);
        s.bounds = Sphere {
            centre: Vec3::new(0.0, top / 2.0, 0.0),
            radius: (corner - Vec3::new(0.0, top / 2.0, 0.0)).length(),
        };
        s
    }

    /// A parallelogram `o + a·s + b·t` facing `face`, wound counter-clockwise seen from it.
    fn add_quad(&mut self, o: Vec3, a: Vec3, b: Vec3, face: u32) {
        let base = self.positions.len() as u32;
        self.positions.extend([o, o + a, o + a + b, o + b]);
        self.faces.extend([face; 4]);
        self.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    fn add_box(&mut self, lo: Vec3, size: Vec3) {
        self.boxes.push([lo, lo + size]);
        let (x, y, z) = (Vec3::X * size.x, Vec3::Y * size.y, Vec3::Z * size.z);
        self.add_quad(lo + x, y, z, 0);
        self.add_quad(lo, z, y, 1);
        self.add_quad(lo + y, z, x, 2);
        self.add_quad(lo, x, z, 3);
        self.add_quad(lo + z, x, y, 4);
        self.add_quad(lo, y, x, 5);
    }

    /// Whether `p` sees `light`, by casting the ray to it against every box (the ground casts
    /// no shadow on what stands on it): the exact answer shadow maps approximate.
    pub fn lit_exact(&self, light: Light, p: Vec3) -> bool {
        let (dir, reach) = match light {
            Light::Point(l) => ((l - p).normalize_or_zero(), (l - p).length()),
            Light::Directional(d) => (-d.normalize_or_zero(), f32::INFINITY),
        };
        !self.boxes.iter().any(|&[lo, hi]| {
            let (mut t0, mut t1) = (1e-3f32, reach);
            for axis in 0..3 {
                if dir[axis].abs() < 1e-12 {
                    if p[axis] <= lo[axis] || p[axis] >= hi[axis] {
                        return false;
                    }
                    continue;
                }
                let (a, b) = ((lo[axis] - p[axis]) / dir[axis], (hi[axis] - p[axis]) / dir[axis]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
            t0 < t1
        })
    }

    /// The scene as one mesh for the fit.
    pub fn mesh(&self) -> MeshRef<'_> {
        MeshRef { world: Mat4::IDENTITY, positions: &self.positions, indices: &self.indices }
    }
}

/// The light projections compared: seed 001's Table 1 (SM, PSM, SM + fit, PSM + fit) and the
/// snapped fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// A fixed frustum around the whole scene.
    Sm,
    /// Perspective shadow maps over the whole view frustum (Stamminger & Drettakis).
    Psm,
    /// The seed's fit to the visible geometry.
    SmFit,
    /// The fit snapped to the texel grid.
    SmFitSnapped,
    /// The fit in post-perspective space, the virtual camera pulled back only for casters
    /// (Stamminger & Drettakis).
    PsmFitCasters,
    /// The fit in post-perspective space, the virtual camera pulled back at least
    /// `√(z_near · z_far)` (the default).
    PsmFit,
}

impl Projection {
    /// Every projection, in table order.
    pub const ALL: [Projection; 6] = [
        Projection::Sm,
        Projection::Psm,
        Projection::SmFit,
        Projection::SmFitSnapped,
        Projection::PsmFitCasters,
        Projection::PsmFit,
    ];

    /// Name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Projection::Sm => "SM: fixed frustum (whole scene)",
            Projection::Psm => "PSM (whole view frustum)",
            Projection::SmFit => "SM + fit (the seed)",
            Projection::SmFitSnapped => "SM + fit + snapping",
            Projection::PsmFitCasters => "PSM + fit, pulled back for casters only",
            Projection::PsmFit => "PSM + fit, balanced (default)",
        }
    }

    /// The light matrix for `camera`, with the fit it came from (none for the fixed frustum).
    pub fn light_matrix(
        self,
        light: Light,
        camera: &Camera,
        meshes: &[MeshRef],
        base: &FitOptions,
        scratch: &mut Scratch,
    ) -> (Mat4, Option<Fit>) {
        let options = match self {
            Projection::Sm => return (shadow_fit::fixed(light, base), None),
            Projection::Psm => FitOptions {
                space: FitSpace::PostPerspective(PullBack::Balanced),
                target: FitTarget::ViewFrustum,
                ..*base
            },
            Projection::SmFit => *base,
            Projection::SmFitSnapped => FitOptions { snap: Snap::TexelGrid, ..*base },
            Projection::PsmFitCasters => {
                FitOptions { space: FitSpace::PostPerspective(PullBack::CastersOnly), ..*base }
            }
            Projection::PsmFit => FitOptions { space: FitSpace::PostPerspective(PullBack::Balanced), ..*base },
        };
        let f = shadow_fit::fit(light, camera, meshes, &options, scratch);
        (f.view_proj, Some(f))
    }
}

/// The light of the timing scene, and fit options for it: the spot light of the `shadow_fit`
/// example, its near plane just before the scene.
pub fn spot_light(scene: &Scene, resolution: u32) -> (Light, FitOptions) {
    let position = Vec3::new(-260.0, 380.0, 160.0);
    let options = FitOptions {
        // Every caster lies in the scene sphere: a near plane just before it keeps them all and
        // spends the depth range on the scene.
        near: ((position - scene.bounds.centre).length() - scene.bounds.radius).max(1.0) * 0.95,
        resolution,
        ..FitOptions::new(scene.bounds)
    };
    (Light::Point(position), options)
}

/// Seed 001's Table 1 on the CPU side: the per-frame time of each projection's light matrix
/// (visibility test, fit, PSM's casters and pull-back) for boxes over a 400 × 400 ground with
/// about `polygons` triangles, seen from inside the field of boxes; best of `runs`, seconds.
pub fn cpu_times(polygons: u32, runs: usize) -> Vec<(Projection, f64)> {
    let scene = Scene::boxes(polygons.saturating_sub(2) / 12, 200.0, 1);
    let (light, options) = spot_light(&scene, 1024);
    let camera = Camera {
        view: glam::camera::rh::view::look_at_mat4(Vec3::new(90.0, 4.0, 0.0), Vec3::new(86.0, 1.0, 20.0), Vec3::Y),
        projection: glam::camera::rh::proj::directx::perspective(60f32.to_radians(), 4.0 / 3.0, 0.5, 150.0),
    };
    let mesh = [scene.mesh()];
    let mut scratch = Scratch::default();
    Projection::ALL
        .iter()
        .map(|&p| {
            let mut best = f64::INFINITY;
            for _ in 0..runs {
                let t = std::time::Instant::now();
                std::hint::black_box(p.light_matrix(light, &camera, &mesh, &options, &mut scratch));
                best = best.min(t.elapsed().as_secs_f64());
            }
            (p, best)
        })
        .collect()
}

/// Per-frame readback.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameData {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Per pixel: shadow-map texel coordinates `(s·R, t·R)`, σ, lit (1), shadowed (0), outside
    /// the shadow map (−1).
    pub shadow: Vec<[f32; 4]>,
    /// Per pixel: world position and face index (−1: background).
    pub world: Vec<[f32; 4]>,
    /// The shadow map: per texel the nearest surface's distance to the light (world units;
    /// [`EMPTY`] where nothing was drawn), `R × R`.
    pub map: Vec<f32>,
}

/// The shadow map's value where nothing was drawn.
pub const EMPTY: f32 = 1e30;

/// The matrices and sizes of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSetup {
    /// World → camera clip.
    pub camera: Mat4,
    /// World → light clip.
    pub light: Mat4,
    /// The light itself: the shadow map stores, and the test compares, distances to it.
    pub source: Light,
    /// Shadow-map texels per side.
    pub resolution: u32,
    /// Image width and height.
    pub size: (u32, u32),
}

/// Constant bias of the shadow test, world units; the shader adds 1.5× the receiver plane's
/// change of light distance per shadow-map texel.
///
/// The test compares world distances to the light rather than the map's clip depth: a
/// perspective shadow map's depth is so uneven across the scene that no one depth bias suits
/// both the near and the far receivers, while a distance is the same quantity for every
/// projection, so all of them are compared on equal terms.
pub const DEPTH_BIAS: f32 = 0.02;

/// Draws one frame: the shadow map from `light`, then the scene from `camera`.
pub fn render_frame(gpu: &Headless, scene: &Scene, setup: &FrameSetup) -> FrameData {
    let FrameSetup { camera, light, source, resolution, size: (width, height) } = *setup;
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("shadow scene"),
        source: wgpu::ShaderSource::Wgsl(SCENE_WGSL.into()),
    });
    let vertices: Vec<u8> = scene
        .positions
        .iter()
        .zip(&scene.faces)
        .flat_map(|(p, &f)| [p.x, p.y, p.z, f as f32])
        .flat_map(f32::to_le_bytes)
        .collect();
    let indices: Vec<u8> = scene.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let vbuf = gpu.buffer(vertices.len() as u64, wgpu::BufferUsages::VERTEX, Some(&vertices));
    let ibuf = gpu.buffer(indices.len() as u64, wgpu::BufferUsages::INDEX, Some(&indices));
    let mut uniform: Vec<f32> = Vec::new();
    uniform.extend(camera.to_cols_array());
    uniform.extend(light.to_cols_array());
    uniform.extend([resolution as f32, DEPTH_BIAS, 0.0, 0.0]);
    uniform.extend(
        match source {
            Light::Point(p) => p.extend(1.0),
            Light::Directional(d) => d.normalize_or(Vec3::NEG_Y).extend(0.0),
        }
        .to_array(),
    );
    let ubytes: Vec<u8> = uniform.iter().flat_map(|v| v.to_le_bytes()).collect();
    let ubuf = gpu.buffer(ubytes.len() as u64, wgpu::BufferUsages::UNIFORM, Some(&ubytes));
    let layout = wgpu::VertexBufferLayout {
        array_stride: 16,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32],
    };
    let target = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let depth_only = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let map_size = (resolution, resolution);
    let map = gpu.texture(map_size, wgpu::TextureFormat::R32Float, target | wgpu::TextureUsages::TEXTURE_BINDING);
    let map_depth = gpu.texture(map_size, wgpu::TextureFormat::Depth32Float, depth_only);
    let shadow = gpu.texture((width, height), wgpu::TextureFormat::Rgba32Float, target);
    let world = gpu.texture((width, height), wgpu::TextureFormat::Rgba32Float, target);
    let cam_depth = gpu.texture((width, height), wgpu::TextureFormat::Depth32Float, depth_only);
    // Both sides: boxes are closed, and the ground is seen from above only.
    let buffers = [Some(layout)];
    let pipeline = |vs, fs, formats: &[wgpu::TextureFormat]| {
        let targets: Vec<_> = formats.iter().map(|&f| plain_target(f)).collect();
        render_pipeline(device, &module, (vs, fs), &buffers, &targets, Some(depth_test()))
    };
    let light_pipe = pipeline("vs_light", "fs_light", &[wgpu::TextureFormat::R32Float]);
    let cam_pipe =
        pipeline("vs_camera", "fs_camera", &[wgpu::TextureFormat::Rgba32Float, wgpu::TextureFormat::Rgba32Float]);
    let light_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &light_pipe.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() }],
    });
    let map_view = map.create_view(&Default::default());
    let cam_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &cam_pipe.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&map_view) },
        ],
    });
    let color = |view, clear: f64| clear_attachment(view, wgpu::Color { r: clear, g: clear, b: clear, a: clear });
    let depth = depth_attachment;
    let (md, sv, wv, cd) = (
        map_depth.create_view(&Default::default()),
        shadow.create_view(&Default::default()),
        world.create_view(&Default::default()),
        cam_depth.create_view(&Default::default()),
    );
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("light"),
            color_attachments: &[color(&map_view, EMPTY as f64)],
            depth_stencil_attachment: depth(&md),
            ..Default::default()
        });
        pass.set_pipeline(&light_pipe);
        pass.set_bind_group(0, &light_bind, &[]);
        pass.set_vertex_buffer(0, vbuf.slice(..));
        pass.set_index_buffer(ibuf.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..scene.indices.len() as u32, 0, 0..1);
    }
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("camera"),
            color_attachments: &[color(&sv, -1.0), color(&wv, -1.0)],
            depth_stencil_attachment: depth(&cd),
            ..Default::default()
        });
        pass.set_pipeline(&cam_pipe);
        pass.set_bind_group(0, &cam_bind, &[]);
        pass.set_vertex_buffer(0, vbuf.slice(..));
        pass.set_index_buffer(ibuf.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..scene.indices.len() as u32, 0, 0..1);
    }
    gpu.queue.submit([enc.finish()]);
    let quads = |bytes: Vec<u8>| -> Vec<[f32; 4]> {
        bytes
            .chunks_exact(16)
            .map(|c| std::array::from_fn(|k| f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])))
            .collect()
    };
    let map_bytes = gpu.read_texture(&map);
    FrameData {
        width,
        height,
        shadow: quads(gpu.read_texture(&shadow)),
        world: quads(gpu.read_texture(&world)),
        map: map_bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect(),
    }
}

/// σ at pixel `(x, y)` from the matrices alone: the rays through this pixel's centre and its
/// right and lower neighbours' meet the plane of the surface there (point `world`, normal of
/// `face`); their shadow-map texel coordinates give the Jacobian.
pub fn sigma_cpu(setup: &FrameSetup, (x, y): (u32, u32), world: Vec3, face: u32) -> f32 {
    let FrameSetup { camera, light, resolution, size: (width, height), .. } = *setup;
    let inv = camera.inverse();
    let normal = FACE_NORMALS[face as usize % 6];
    let texel = |px: f32, py: f32| {
        let ndc_x = px / width as f32 * 2.0 - 1.0;
        let ndc_y = 1.0 - py / height as f32 * 2.0;
        let near = inv.project_point3(Vec3::new(ndc_x, ndc_y, 0.0));
        let far = inv.project_point3(Vec3::new(ndc_x, ndc_y, 1.0));
        let d = far - near;
        let t = (world - near).dot(normal) / d.dot(normal);
        let p = near + d * t;
        let c: Vec4 = light * p.extend(1.0);
        let (u, v) = (c.x / c.w, c.y / c.w);
        Vec3::new((u * 0.5 + 0.5) * resolution as f32, (0.5 - v * 0.5) * resolution as f32, 0.0)
    };
    let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
    let o = texel(cx, cy);
    let dx = texel(cx + 1.0, cy) - o;
    let dy = texel(cx, cy + 1.0) - o;
    (dx.x * dy.y - dx.y * dy.x).abs().sqrt()
}

/// σ recomputed on the CPU ([`sigma_cpu`]) at every `step`-th visible pixel whose 3×3
/// neighbourhood lies on one face (derivatives there come from one plane): (pixels checked,
/// pixels within 5% of the GPU's σ).
pub fn check_sigma(data: &FrameData, setup: &FrameSetup, step: usize) -> (usize, usize) {
    let (w, h) = setup.size;
    let (mut checked, mut agree) = (0, 0);
    for i in (0..data.world.len()).step_by(step.max(1)) {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let p = data.world[i];
        if p[3] < 0.0 || data.shadow[i][3] < 0.0 || x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            continue;
        }
        let one_face =
            (y - 1..=y + 1).all(|yy| (x - 1..=x + 1).all(|xx| data.world[(yy * w + xx) as usize][3] == p[3]));
        if !one_face {
            continue;
        }
        let cpu = sigma_cpu(setup, (x, y), Vec3::new(p[0], p[1], p[2]), p[3] as u32);
        checked += 1;
        agree += ((cpu - data.shadow[i][2]).abs() <= 0.05 * cpu.max(1e-6)) as usize;
    }
    (checked, agree)
}

/// Figures of one frame: σ over visible pixels inside the shadow map (median, 10th
/// percentile), the share of shadow-map texels some visible pixel samples, and the lit flags.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameStats {
    /// Median σ.
    pub sigma_median: f32,
    /// 10th percentile of σ.
    pub sigma_p10: f32,
    /// Share of the `R²` texels used by visible pixels.
    pub texels_used: f64,
    /// Share of visible pixels outside the shadow map (no shadow information).
    pub outside: f64,
}

/// The figures of a frame.
pub fn frame_stats(data: &FrameData, resolution: u32) -> FrameStats {
    let r = resolution as usize;
    let mut used = vec![false; r * r];
    let mut sigmas = Vec::new();
    let (mut visible, mut outside) = (0usize, 0usize);
    for (s, w) in data.shadow.iter().zip(&data.world) {
        if w[3] < 0.0 {
            continue;
        }
        visible += 1;
        if s[3] < 0.0 {
            outside += 1;
            continue;
        }
        sigmas.push(s[2]);
        let (i, j) = (s[0].floor() as usize, s[1].floor() as usize);
        if i < r && j < r {
            used[j * r + i] = true;
        }
    }
    sigmas.sort_by(f32::total_cmp);
    let pick = |q: f64| sigmas.get(((sigmas.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(0.0);
    FrameStats {
        sigma_median: pick(0.5),
        sigma_p10: pick(0.1),
        texels_used: used.iter().filter(|&&u| u).count() as f64 / (r * r) as f64,
        outside: outside as f64 / visible.max(1) as f64,
    }
}

/// Share of the pixels of `data` on surfaces facing `light` and inside its shadow map whose
/// lit state differs from the exact one ([`Scene::lit_exact`]).
pub fn errors_exact(scene: &Scene, data: &FrameData, light: Light) -> f64 {
    let (mut counted, mut wrong) = (0usize, 0usize);
    for (s, w) in data.shadow.iter().zip(&data.world) {
        if s[3] < 0.0 || w[3] < 0.0 {
            continue;
        }
        let p = Vec3::new(w[0], w[1], w[2]);
        if !faces(light, p, w[3]) {
            continue;
        }
        counted += 1;
        wrong += ((s[3] > 0.5) != scene.lit_exact(light, p)) as usize;
    }
    wrong as f64 / counted.max(1) as f64
}

/// Whether the face of index `face` at `p` is turned toward `light`.
fn faces(light: Light, p: Vec3, face: f32) -> bool {
    let toward = match light {
        Light::Point(l) => l - p,
        Light::Directional(d) => -d,
    };
    FACE_NORMALS[face as usize % 6].dot(toward) > 0.0
}

/// Share of pixels inside both shadow maps whose lit/shadowed state differs (between frames:
/// shimmer; against a reference render of the same frame: error), over the surfaces facing
/// `light` (a face turned away from the light is dark whatever its shadow test says, and its
/// test is the bias's choice).
pub fn flips(a: &FrameData, b: &FrameData, light: Light) -> f64 {
    let (mut both, mut flipped) = (0usize, 0usize);
    for ((sa, sb), w) in a.shadow.iter().zip(&b.shadow).zip(&a.world) {
        if sa[3] < 0.0 || sb[3] < 0.0 || w[3] < 0.0 {
            continue;
        }
        if !faces(light, Vec3::new(w[0], w[1], w[2]), w[3]) {
            continue;
        }
        both += 1;
        flipped += (sa[3] != sb[3]) as usize;
    }
    flipped as f64 / both.max(1) as f64
}
