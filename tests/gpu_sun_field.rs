//! The terrain's far shadows on what stands on it (`SunField`), on lavapipe: boxes 2 to 100 m
//! tall scattered 0.5 to 40 km from the camera over a generated 41 km terrain, drawn as a
//! game's receivers draw (`sun_field_visibility` in their fragment shader), each pixel's lit
//! state against an exact march from that pixel's world point over the heights
//! (`hikage_devkit::brute_force`); the one-mesh and the streamed terrain's fields against each
//! other; the terrain's own pixels with and without a field.

use std::path::PathBuf;

use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::glam::{Vec2, Vec3};
use hikage_runtime::hikage_bundle::tile_index::TileIndex;
use hikage_runtime::horizon::reference::{HorizonMap, horizon_raised_sun_visible, horizon_sun_visible};
use hikage_runtime::horizon::{
    FieldMap, FieldTileTextures, HorizonEncoding, StreamOptions, Sun, SunField, SunFieldOptions, SunFieldSource,
    SunFieldTiles, TerrainFrame, TerrainShadows, TerrainStream, TerrainUniform, TileLayout, apron_neighbours,
    heights_with_apron,
};
use hikage_runtime::{CpuAsset, CpuBundle, DrawOptions, GpuBundle, PayloadData, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, VISIBILITY_FORMAT, depth_test, plain_target};

use hikage_devkit::brute_force::{bilinear_height, raised_shadow_height, sun_shadow_height};

use crate::util::{Dir, gpu};

/// Map side (texels), texel size (m), relief (m), the bake's reach (m) and tile side.
const N: usize = 512;
const TEXEL: f32 = 80.0;
const RELIEF: f32 = 1800.0;
const REACH: f32 = 15_000.0;
const TILE: u32 = 64;

/// Boxes, and the pixels a side of each one's cell of the frame.
const BOXES: usize = 576;
const CELL: u32 = 16;

/// The camera, near the map's corner.
const EYE: (f32, f32) = (1000.0, 1000.0);

/// Low suns: elevation and azimuth (degrees, from +u toward +v).
const SUNS: [(f32, f32); 3] = [(3.0, 60.0), (8.0, 200.0), (20.0, 300.0)];

/// The generated terrain, baked whole (`whole.*`) and in 64² tiles with every level (`dem.*`),
/// and its world heights.
fn baked() -> &'static (PathBuf, Vec<f32>) {
    use std::sync::OnceLock;
    static BAKED: OnceLock<(PathBuf, Vec<f32>)> = OnceLock::new();
    BAKED.get_or_init(|| {
        let dir = Dir::new("gpu_sun_field");
        let samples = hikage_devkit::synth::terrain(N as u32);
        dir.write("dem.r32", samples.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
        let job = |id: &str, tiles: &str| {
            format!(
                r#"Horizon(id: "{id}", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}), height_scale: {RELIEF},
                   directions: 32, edge: Clamp, max_distance: {REACH}{tiles}),"#
            )
        };
        let tiled = format!(", tile: {TILE}, levels: 16");
        dir.write(
            "pipeline.ron",
            format!(r#"(output: "bundle", jobs: [{} {}])"#, job("whole", ""), job("dem", &tiled)),
        );
        dir.run(&["bake"]);
        (dir.path("bundle"), samples.iter().map(|v| v * RELIEF).collect())
    })
}

fn draw_options() -> DrawOptions {
    DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    }
}

/// A sun at `elevation` and `azimuth` (degrees) with the real sun's disc.
fn sun((elevation, azimuth): (f32, f32)) -> Sun {
    let (e, a) = (elevation.to_radians(), azimuth.to_radians());
    Sun { direction: Vec3::new(e.cos() * a.cos(), e.sin(), e.cos() * a.sin()), ..Sun::default() }
}

/// A box standing on the terrain: its footprint's centre (map frame), half width, height, and
/// the lowest ground under it.
#[derive(Clone, Copy, Debug)]
struct Receiver {
    centre: Vec2,
    half: f32,
    height: f32,
    base: f32,
}

/// Boxes 2 to 100 m tall (houses, trees, towers) from 0.5 to 40 km from the camera, log-spaced,
/// fanned over the quarter of the map in front of it.
fn receivers(heights: &[f32]) -> Vec<Receiver> {
    let tall = [2.0f32, 5.0, 10.0, 30.0, 60.0, 100.0];
    (0..BOXES)
        .map(|i| {
            let r = 500.0 * 80f32.powf(i as f32 / (BOXES - 1) as f32);
            let a = (5.0 + 80.0 * ((i as f32 * 0.618_034).fract())).to_radians();
            let centre = Vec2::new(EYE.0 + r * a.cos(), EYE.1 + r * a.sin());
            let height = tall[i % tall.len()];
            let half = (0.3 * height).max(2.0);
            let ground = |d: Vec2| bilinear_height(heights, (N, N), (TEXEL, TEXEL), (centre + d).into()).unwrap();
            let corners = [
                Vec2::ZERO,
                Vec2::new(-half, -half),
                Vec2::new(half, -half),
                Vec2::new(-half, half),
                Vec2::splat(half),
            ];
            let base = corners.iter().map(|&d| ground(d)).fold(f32::MAX, f32::min) - 0.5;
            Receiver { centre, half, height, base }
        })
        .collect()
}

/// A game's receiver: boxes whose fragments ask the field for the sun (at group 1), writing
/// `(visibility, world x, y, z)` to the visibility target.
const RECEIVER_WGSL: &str = r#"
struct Box {
    view_proj: mat4x4<f32>,
    lo: vec4<f32>,
    hi: vec4<f32>,
    cell: vec4<f32>,
}
@group(0) @binding(0) var<storage, read> boxes: array<Box>;

struct Out {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

const FACES = array<u32, 36>(0u, 2u, 6u, 0u, 6u, 4u, 1u, 5u, 7u, 1u, 7u, 3u, 0u, 4u, 5u, 0u, 5u, 1u,
    2u, 3u, 7u, 2u, 7u, 6u, 0u, 1u, 3u, 0u, 3u, 2u, 4u, 6u, 7u, 4u, 7u, 5u);

@vertex
fn vs(@builtin(vertex_index) v: u32, @builtin(instance_index) i: u32) -> Out {
    let b = boxes[i];
    let c = FACES[v];
    let corner = vec3<f32>(f32(c & 1u), f32((c >> 1u) & 1u), f32((c >> 2u) & 1u));
    let world = mix(b.lo.xyz, b.hi.xyz, corner);
    let clip = b.view_proj * vec4<f32>(world, 1.0);
    var out: Out;
    out.clip = vec4<f32>(clip.xy * b.cell.z + b.cell.xy * clip.w, clip.zw);
    out.world = world;
    return out;
}

struct Targets {
    @location(0) color: vec4<f32>,
    @location(1) visibility: vec4<f32>,
}

@fragment
fn fs(in: Out) -> Targets {
    let sun = sun_field_visibility(in.world);
    return Targets(vec4<f32>(vec3<f32>(0.1 + 0.9 * sun), 1.0), vec4<f32>(sun, in.world));
}
"#;

/// The boxes drawn with `field`, each in its own cell seen from the sun's side and above; per
/// covered pixel: the box, the field's visibility and the pixel's world point.
fn draw_receivers(g: &Headless, field: &SunField, boxes: &[Receiver], sun_dir: Vec3) -> Vec<(usize, f32, Vec3)> {
    let cells = (BOXES as f32).sqrt().ceil() as u32;
    // Per box, as the shader's `Box`: its camera, its corners, and its cell of the frame.
    let data: Vec<f32> = boxes
        .iter()
        .enumerate()
        .flat_map(|(i, b)| {
            let lo = Vec3::new(b.centre.x - b.half, b.base, b.centre.y - b.half);
            let hi = Vec3::new(b.centre.x + b.half, b.base + 0.5 + b.height, b.centre.y + b.half);
            let (mid, r) = (0.5 * (lo + hi), 0.5 * (hi - lo).length() * 1.05);
            let toward = (Vec3::new(sun_dir.x, 0.0, sun_dir.z).normalize() + Vec3::Y * 0.6).normalize();
            let view = look_at_mat4(mid + toward * 4.0 * r, mid, Vec3::Y);
            let view_proj = directx::orthographic(-r, r, -r, r, 0.5 * r, 8.0 * r) * view;
            let (col, row) = (i as u32 % cells, i as u32 / cells);
            let scale = 1.0 / cells as f32;
            let cell = [-1.0 + (2 * col + 1) as f32 * scale, 1.0 - (2 * row + 1) as f32 * scale, scale, 0.0];
            let mut v = view_proj.to_cols_array().to_vec();
            v.extend(lo.extend(0.0).to_array());
            v.extend(hi.extend(0.0).to_array());
            v.extend(cell);
            v
        })
        .collect();
    let buffer = g.buffer(
        std::mem::size_of_val(data.as_slice()) as u64,
        wgpu::BufferUsages::STORAGE,
        Some(&data.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()),
    );
    let boxes_layout = g.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("boxes"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let boxes_group = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("boxes"),
        layout: &boxes_layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    });
    let layout = g.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("receivers"),
        bind_group_layouts: &[Some(&boxes_layout), Some(field.layout())],
        immediate_size: 0,
    });
    let module = g.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("receivers"),
        source: wgpu::ShaderSource::Wgsl(format!("{}\n{RECEIVER_WGSL}", field.wgsl()).into()),
    });
    let pipeline = g.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("receivers"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: Some(depth_test()),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[plain_target(COLOR_FORMAT), plain_target(VISIBILITY_FORMAT)],
        }),
        multiview_mask: None,
        cache: None,
    });
    let side = cells * CELL;
    let frame = g.render((side, side), wgpu::Color::BLACK, |pass| {
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &boxes_group, &[]);
        pass.set_bind_group(1, field.bind_group(), &[]);
        pass.draw(0..36, 0..BOXES as u32);
    });
    let mut out = Vec::new();
    for (p, v) in frame.visibility.iter().enumerate() {
        if v[1] == 0.0 && v[3] == 0.0 {
            continue;
        }
        let (col, row) = (p as u32 % side / CELL, p as u32 / side / CELL);
        out.push(((row * cells + col) as usize, v[0], Vec3::new(v[1], v[2], v[3])));
    }
    out
}

/// Agreement of receivers' lit states with the exact march, by box height.
#[derive(Default)]
struct Tally {
    /// Per height: pixels, pixels that agree.
    by_height: std::collections::BTreeMap<u32, (usize, usize)>,
}

impl Tally {
    fn add(&mut self, height: f32, agrees: bool) {
        let e = self.by_height.entry(height as u32).or_default();
        e.0 += 1;
        e.1 += agrees as usize;
    }

    fn share(&self, keep: impl Fn(u32) -> bool) -> f64 {
        let (n, ok) = self.by_height.iter().filter(|(h, _)| keep(**h)).fold((0, 0), |a, (_, v)| (a.0 + v.0, a.1 + v.1));
        ok as f64 / n.max(1) as f64
    }
}

/// The field of `terrain` for `sun`, built for a camera at [`EYE`], and the boxes drawn with
/// it: per covered pixel, the box, the field's visibility and the world point.
fn field_pixels(g: &Headless, terrain: &impl SunFieldSource, boxes: &[Receiver], s: Sun) -> Vec<(usize, f32, Vec3)> {
    let options = SunFieldOptions { side: 256, levels: 4, group: 1, ..SunFieldOptions::default() };
    let mut field = SunField::new(&g.device, terrain, options).unwrap();
    let frame = TerrainFrame { sun: s, ..TerrainFrame::default() };
    let eye = Vec3::new(EYE.0, 3000.0, EYE.1);
    let stats = field.update(&g.device, &g.queue, terrain, &frame, eye).unwrap();
    assert_eq!(stats.levels_built, 4, "the first update builds every level");
    draw_receivers(g, &field, boxes, s.direction)
}

/// Per pixel of `pixels`: lit by the exact march from its world point at `sun_angles` (degrees),
/// or `None` under the terrain's surface (hidden in a game's frame).
fn marched(heights: &[f32], pixels: &[(usize, f32, Vec3)], sun_angles: (f32, f32)) -> Vec<Option<bool>> {
    use rayon::prelude::*;
    let (e, a) = (sun_angles.0.to_radians(), sun_angles.1.to_radians());
    pixels
        .par_iter()
        .map(|&(_, _, p)| {
            let ground = bilinear_height(heights, (N, N), (TEXEL, TEXEL), (p.x, p.z))?;
            (p.y >= ground + 0.05)
                .then(|| p.y > sun_shadow_height(heights, (N, N), (TEXEL, TEXEL), (p.x, p.z), (e, a), REACH))
        })
        .collect()
}

/// The terrain's own pixels (its horizon, sampled as the GPU samples it) against the same march
/// at the same suns: the agreement receivers are held to.
fn ground_agreement(dir: &std::path::Path, heights: &[f32]) -> f64 {
    let cpu = CpuBundle::read_prefix(dir, "whole.").unwrap();
    let asset = cpu.asset("whole.horizon").unwrap();
    let map = HorizonMap::new(asset.texture().unwrap(), asset.asset.settings.horizon().unwrap(), true).unwrap();
    let (mut ok, mut total) = (0, 0);
    for &(e, a) in &SUNS {
        let (e, a) = (e.to_radians(), a.to_radians());
        let bump = Vec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin());
        for k in 0..3000 {
            let (i, j) = ((k * 37 + 11) % N, (k * 53 + k / N + 5) % N);
            let lit = 0.0 > raised_shadow_height(heights, (N, N), (TEXEL, TEXEL), (i, j), (e, a), REACH);
            let uv = Vec2::new((i as f32 + 0.5) / N as f32, (j as f32 + 0.5) / N as f32);
            let seen = horizon_sun_visible(&map, uv, bump, Vec2::splat(TEXEL), Sun::default().angular_radius) > 0.5;
            ok += (lit == seen) as usize;
            total += 1;
        }
    }
    ok as f64 / total as f64
}

/// A stream of the tiled map settled for a camera at [`EYE`]: every tile it wants resident.
fn settled_stream(g: &Headless, dir: &std::path::Path, options: StreamOptions) -> TerrainStream {
    let mut stream = TerrainStream::open(&g.device, &g.queue, dir, "dem", &draw_options(), options).unwrap();
    let eye = Vec3::new(EYE.0, 3000.0, EYE.1);
    let frame = TerrainFrame::default();
    for _ in 0..20_000 {
        let stats = stream.update(&g.device, &g.queue, &frame, eye).unwrap();
        if stats.missing == 0 && stats.uploaded_bytes == 0 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    stream
}

/// Receivers 0.5–40 km away agree with the exact march as well as the terrain's own pixels do
/// (within a point at 2–30 m, two at 60–100 m), on the one-mesh terrain and on the stream as it
/// streams (coarser tiles far away); with level 0 everywhere the stream's receivers are the
/// one-mesh terrain's. 20 to 40 km out, where the field's texels are twice the terrain's (and
/// the stream's tiles four to eight times), within three points (four streamed).
#[test]
fn receivers_agree_with_an_exact_march_at_any_distance() {
    let Some(g) = gpu("receivers_agree_with_an_exact_march_at_any_distance") else { return };
    let (dir, heights) = baked();
    let boxes = receivers(heights);
    let cpu = CpuBundle::read_prefix(dir, "whole.").unwrap();
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let whole = TerrainShadows::new(&g.device, &g.queue, &gb, "whole.horizon", None, &draw_options()).unwrap();
    let streamed = settled_stream(&g, dir, StreamOptions::default());
    let all_level_0 =
        StreamOptions { detail: 1e9, resident_bytes: 8 << 30, upload_bytes: 8 << 30, ..StreamOptions::default() };
    let level_0 = settled_stream(&g, dir, all_level_0);
    assert!(level_0.drawn().all(|(k, _)| k.0 == 0));
    assert!(streamed.drawn().any(|(k, _)| k.0 > 0), "the stream draws coarser tiles far away");

    let ground = ground_agreement(dir, heights);
    let cpu_map = {
        let asset = cpu.asset("whole.horizon").unwrap();
        HorizonMap::new(asset.texture().unwrap(), asset.asset.settings.horizon().unwrap(), true).unwrap()
    };
    let (mut one, mut stream, mut walk) = (Tally::default(), Tally::default(), Tally::default());
    let (mut same, mut compared) = (0usize, 0usize);
    let mut far = (0usize, 0usize, 0usize, 0usize, 0usize);
    for &angles in &SUNS {
        let s = sun(angles);
        let a = field_pixels(&g, &whole, &boxes, s);
        let b = field_pixels(&g, &streamed, &boxes, s);
        let c = field_pixels(&g, &level_0, &boxes, s);
        assert!(a.len() == b.len() && a.len() == c.len(), "the same boxes drawn");
        let (e, az) = (angles.0.to_radians(), angles.1.to_radians());
        let bump = Vec3::new(e.cos() * az.cos(), e.cos() * az.sin(), e.sin());
        for (k, lit) in marched(heights, &a, angles).into_iter().enumerate() {
            let Some(lit) = lit else { continue };
            let (i, p) = (a[k].0, a[k].2);
            let height = boxes[i].height;
            one.add(height, lit == (a[k].1 > 0.5));
            stream.add(height, lit == (b[k].1 > 0.5));
            // The rule the field walks, on the CPU from the same point: what it can reach.
            let uv = Vec2::new(p.x, p.z) / (TEXEL * N as f32);
            let over = p.y - bilinear_height(heights, (N, N), (TEXEL, TEXEL), (p.x, p.z)).unwrap();
            let rule = horizon_raised_sun_visible(&cpu_map, uv, bump, Vec2::splat(TEXEL), over, REACH, 0.0) > 0.5;
            walk.add(height, lit == rule);
            compared += 1;
            same += ((a[k].1 > 0.5) == (c[k].1 > 0.5)) as usize;
            if (Vec2::new(p.x, p.z) - Vec2::from(EYE)).length() > 20_000.0 {
                far.0 += 1;
                far.1 += !lit as usize;
                far.2 += (lit == (a[k].1 > 0.5)) as usize;
                far.3 += (lit == (b[k].1 > 0.5)) as usize;
                far.4 += (lit == rule) as usize;
            }
        }
    }
    let report = |name: &str, t: &Tally| {
        for (h, (n, ok)) in &t.by_height {
            eprintln!("{name}: {h} m boxes, {n} pixels: {:.2}% agree with the march", 100.0 * *ok as f64 / *n as f64);
        }
    };
    report("one mesh", &one);
    report("stream", &stream);
    report("the rule on the CPU", &walk);
    eprintln!(
        "the terrain's own pixels: {:.2}%; level-0 stream against one mesh: {same} of {compared} alike",
        100.0 * ground
    );
    for (name, t) in [("one mesh", &one), ("stream", &stream)] {
        for &h in t.by_height.keys() {
            let share = t.share(|k| k == h);
            let allowed = if h <= 30 { 0.01 } else { 0.02 };
            assert!(share >= ground - allowed, "{name}: {share} at {h} m against the ground's {ground}");
        }
    }
    // Far away the field still shadows, and rightly: boxes 20 to 40 km out.
    let (far_pixels, far_shadowed, far_agree, far_streamed, far_rule) = far;
    let far_share = |n: usize| n as f64 / far_pixels as f64;
    eprintln!(
        "boxes 20–40 km away: {far_pixels} pixels, {far_shadowed} in the terrain's shadow by the march; {:.2}% agree \
         (one mesh), {:.2}% (stream, tiles 2 to 3 levels coarser there), {:.2}% (the rule on the CPU)",
        100.0 * far_share(far_agree),
        100.0 * far_share(far_streamed),
        100.0 * far_share(far_rule)
    );
    assert!(far_shadowed * 10 > far_pixels, "{far_shadowed} of {far_pixels} shadowed: too few to test");
    assert!(far_share(far_agree) >= ground - 0.03, "{} far away (one mesh)", far_share(far_agree));
    assert!(far_share(far_streamed) >= ground - 0.04, "{} far away (stream)", far_share(far_streamed));
    assert!(same as f64 >= 0.999 * compared as f64, "{same} of {compared}");
}

/// A field changes nothing of the terrain's own drawing: the stream's pixels are the same before
/// a field exists and after one is built from it.
#[test]
fn the_terrains_own_pixels_are_unchanged_by_a_field() {
    let Some(g) = gpu("the_terrains_own_pixels_are_unchanged_by_a_field") else { return };
    let (dir, _) = baked();
    let mut stream = settled_stream(&g, dir, StreamOptions::default());
    let eye = Vec3::new(EYE.0, 3000.0, EYE.1);
    let view_proj = directx::perspective(1.0, 1.0, 10.0, 100_000.0)
        * look_at_mat4(eye, Vec3::new(20_000.0, 0.0, 20_000.0), Vec3::Y);
    let frame = TerrainFrame { view_proj, sun: sun(SUNS[0]), ..TerrainFrame::default() };
    stream.update(&g.device, &g.queue, &frame, eye).unwrap();
    let before = g.render((256, 256), wgpu::Color::BLACK, |pass| stream.draw(pass));
    let mut field = SunField::new(&g.device, &stream, SunFieldOptions::default()).unwrap();
    field.update(&g.device, &g.queue, &stream, &frame, eye).unwrap();
    stream.update(&g.device, &g.queue, &frame, eye).unwrap();
    let after = g.render((256, 256), wgpu::Color::BLACK, |pass| stream.draw(pass));
    assert!(before.visibility.iter().filter(|v| v[1] > 0.5).count() > 1000, "the terrain is in view");
    assert!(before == after, "the terrain's pixels changed");
}

/// An engine that keeps a stream's tiles itself (hikage-bevy) and hands their textures to a
/// field through `SunFieldTiles` gets the field of the runtime's own stream: level 0 everywhere,
/// each tile's horizon uploaded as baked and its heights (with the neighbours' apron) as 32-bit
/// floats, the receivers' pixels equal to those of the stream's field at every sun.
#[test]
fn an_engines_own_tiles_give_the_streams_field() {
    let Some(g) = gpu("an_engines_own_tiles_give_the_streams_field") else { return };
    let (dir, heights) = baked();
    let boxes = receivers(heights);
    let all_level_0 =
        StreamOptions { detail: 1e9, resident_bytes: 8 << 30, upload_bytes: 8 << 30, ..StreamOptions::default() };
    let stream = settled_stream(&g, dir, all_level_0);
    let index = TileIndex::open(dir).unwrap();
    let layout = TileLayout::new("dem", |part, level, xy| index.tile(part, level, xy)).unwrap();
    let level = &layout.levels[0];
    let read = |part: &str, (x, y): (u32, u32)| {
        let asset = index.tile(part, 0, (x, y))?;
        let texture = index.read_texture(&asset).unwrap();
        Some((asset, texture))
    };
    let mut textures = GpuBundle::default();
    let mut views = Vec::new();
    for y in 0..level.grid.1 {
        for x in 0..level.grid.0 {
            let key = (0, x, y);
            let (height, own) = read(&layout.parts.height, (x, y)).unwrap();
            let sides = apron_neighbours(key).map(|n| n.and_then(|(_, nx, ny)| read(&layout.parts.height, (nx, ny))));
            let apron = heights_with_apron(&own, &sides.map(|s| s.map(|(_, t)| t)));
            let (w, h) = (apron.desc.width, apron.desc.height);
            let heights_view = float_texture(&g, (w, h), &apron.to_f32(0));
            let (horizon, map) = read(&layout.parts.horizon, (x, y)).unwrap();
            let settings = horizon.settings.horizon().unwrap().clone();
            let hf = height.settings.heightfield().unwrap();
            let constants = TerrainUniform {
                texel_size: [settings.texel_size.0, settings.texel_size.1],
                height_scale: hf.height_scale,
                height_offset: hf.height_offset,
                size: [w - 2, h - 2],
                encoding: HorizonEncoding::new(map.desc.format, &settings),
                apron: 1,
                ..hikage_runtime::bytemuck::Zeroable::zeroed()
            };
            textures
                .insert(&g.device, &g.queue, &CpuAsset { asset: horizon.clone(), payload: PayloadData::Texture(map) })
                .unwrap();
            views.push((key, horizon.id, heights_view, constants, Vec2::from(layout.offset(key))));
        }
    }
    let map = FieldMap { size: Vec2::splat(N as f32 * TEXEL), texel: Vec2::splat(TEXEL), directions: 32, reach: REACH };
    let mut tiles = SunFieldTiles::new(&g.device, &g.queue, map);
    let drawn = views.iter().map(|(key, id, heights, constants, offset)| FieldTileTextures {
        key: *key,
        offset: *offset,
        horizon: &textures.texture(id).unwrap().view,
        heights,
        constants: *constants,
    });
    tiles.set(&g.device, &g.queue, drawn);
    for &angles in &SUNS {
        let s = sun(angles);
        let a = field_pixels(&g, &stream, &boxes, s);
        let b = field_pixels(&g, &tiles, &boxes, s);
        assert_eq!(a.len(), b.len(), "the same boxes drawn");
        let differ = a.iter().zip(&b).filter(|(a, b)| (a.1 - b.1).abs() > 1e-6).count();
        eprintln!(
            "sun {angles:?}: {differ} of {} receiver pixels differ between the stream and the engine's tiles",
            a.len()
        );
        assert_eq!(differ, 0, "sun {angles:?}");
    }
}

/// A 2D `R32Float` texture of `values`, `w`×`h`, as an engine would upload heights.
fn float_texture(g: &Headless, (w, h): (u32, u32), values: &[f32]) -> wgpu::TextureView {
    let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
    let texture = g.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("engine heights"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let layout = wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: None };
    g.queue.write_texture(texture.as_image_copy(), &bytes, layout, size);
    texture.create_view(&Default::default())
}
