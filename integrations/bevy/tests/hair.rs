//! Hair rendered by Bevy on a GPU (lavapipe in CI) against hikage-runtime's CPU references:
//! the deep opacity maps the plugin renders before the main pass, the shadow they cast on a
//! receiver mesh, and the strips seen by the camera, blended over the scene.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::camera::Exposure;
use bevy::prelude::*;
use hikage_bake::strands::Strands;
use hikage_bake::strands::strips::{StripSets, build};
use hikage_bevy::hair::{HairDraw, HairReceiver, HairReceiverMaterial, HairShadowMaps, HairStrands, Lookup};
use hikage_bevy::{HikageBundle, HikageError};
use hikage_bundle::{BundleWriter, Settings, WriteMode};
use hikage_runtime::glam;
use hikage_runtime::hair::reference::{Facing, StripArrays, accumulate_cpu, expand, hair_visibility};
use hikage_runtime::hair::{HairFrame, HairOptions, HairRenderer};
use hikage_runtime::{CpuBundle, GpuBundle, wgpu};
use hikage_scenes::hair_scene::{Composite, camera_reference};

use common::{MaskScene, gpu_or_skip};

const SIZE: u32 = 256;
const RESOLUTION: u32 = 256;
const GROUND: f32 = -0.6;

/// Forty strands hanging from a ring and curling outward, crossing each other seen from the
/// light; a bundle of their strips in a fresh directory `name` (one per test: tests run side by
/// side), and their records for the references.
fn hair_bundle(name: &str) -> (std::path::PathBuf, StripArrays) {
    let (s, sets) = ring_strands();
    let strips = build(&s, &sets);
    let settings = strips.settings(&s, &sets, None);
    let dir = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, std::path::PathBuf::from).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    let mut writer = BundleWriter::open(&dir.join("bundle"), WriteMode::Replace).unwrap();
    writer.put_mesh("head.strips", Settings::Strands(settings.clone()), "test", &strips.mesh).unwrap();
    writer.commit().unwrap();
    (dir, StripArrays::from_mesh(&strips.mesh, &settings).unwrap())
}

/// The strands of [`hair_bundle`] and their sets.
fn ring_strands() -> (Strands, StripSets) {
    let (mut points, mut segments, mut color) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..40 {
        let a = k as f32 * std::f32::consts::TAU / 40.0;
        for i in 0..9 {
            let t = i as f32 / 8.0;
            let r = 0.35 + 0.55 * t;
            let twist = a + 0.9 * t;
            points.push([r * twist.cos(), 0.8 - 0.9 * t * t + 0.05 * (k % 3) as f32, r * twist.sin()]);
            color.push([0.55 + 0.3 * t, 0.35 + 0.01 * k as f32, 0.2]);
        }
        segments.push(8u16);
    }
    let s = Strands {
        segments,
        points,
        thickness: None,
        transparency: None,
        color: Some(color),
        default_thickness: 0.03,
        default_transparency: 0.5,
        default_color: [0.5; 3],
    };
    let sets = StripSets { shading: (0.03, 0.5), opacity: (0.12, 0.125), taper: 0.3 };
    (s, sets)
}

fn to_glam(m: Mat4) -> glam::Mat4 {
    glam::Mat4::from_cols_array(&m.to_cols_array())
}

/// The camera's world → clip matrix and position, as Bevy has them this frame.
fn camera_of(world: &mut World) -> (glam::Mat4, glam::Vec3) {
    let (camera, transform) = world.query::<(&Camera, &GlobalTransform)>().single(world).unwrap();
    let clip = camera.clip_from_view() * transform.to_matrix().inverse();
    (to_glam(clip), glam::Vec3::from_array(transform.translation().to_array()))
}

#[test]
fn hair_maps_shadows_and_view_match_the_cpu_references() {
    if !gpu_or_skip("hair_maps_shadows_and_view_match_the_cpu_references") {
        return;
    }
    let (dir, arrays) = hair_bundle("hair");
    let toward_sun = Vec3::new(0.3, 1.0, 0.4).normalize();
    let top = Transform::from_xyz(0.0, 5.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
    let MaskScene { mut app, target, .. } =
        MaskScene::new(&dir, SIZE, toward_sun, top, MaskScene::orthographic(3.0, 3.0, 20.0));

    // The same hair through hikage-runtime's renderer on its own device: the frame's uniform
    // (light, box, widths) for the CPU references.
    let g = hikage_scenes::headless::Headless::new().unwrap();
    let cpu = CpuBundle::read(&dir.join("bundle")).unwrap();
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let options =
        HairOptions { resolution: RESOLUTION, ..HairOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb, (SIZE, SIZE)) };
    let runtime = HairRenderer::new(&g.device, &g.queue, &gb, "head.strips", &options).unwrap();
    let light = runtime.light(glam::Vec3::from_array(toward_sun.to_array()));

    // 1. The opacity maps and the shadow on a receiving ground plane (the hair itself hidden).
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let hair = app.world().spawn(HairStrands::new(bundle.clone(), "head.strips").with_draw(HairDraw::ShadowsOnly)).id();
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(3.0, 3.0));
    let ground =
        app.world().spawn((Mesh3d(plane), Transform::from_xyz(0.0, GROUND, 0.0), HairReceiver::new(hair))).id();
    // A hair naming no strands asset, and a receiver naming an entity that is not hair.
    let wrong = app.world().spawn(HairStrands::new(bundle.clone(), "head.nothing")).id();
    let stray = app.world().spawn(HairReceiver::new(ground)).id();
    let built = app.update_until(600, |world| world.get::<MeshMaterial3d<HairReceiverMaterial>>(ground).is_some());
    assert!(built, "the receiver was not built");
    app.update_until(100, |world| world.get::<HikageError>(wrong).is_some());
    let error = |app: &mut common::Headless, e: Entity| app.world().get::<HikageError>(e).map(|e| e.0.clone());
    assert_eq!(error(&mut app, wrong).as_deref(), Some("no asset `head.nothing` in the bundle"));
    assert!(error(&mut app, stray).is_some_and(|m| m.contains("has no HairStrands")), "{:?}", error(&mut app, stray));
    app.world().despawn(wrong);
    app.world().despawn(stray);
    let shadowed = app.capture_settled(&target);
    let maps = app.world().get::<HairShadowMaps>(hair).unwrap().clone();
    let depth: Vec<f32> =
        app.read_image(&maps.depth).chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let layers: Vec<[f32; 4]> = app
        .read_image(&maps.layers)
        .chunks_exact(8)
        .map(|c| std::array::from_fn(|k| half::f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f32()))
        .collect();

    let frame = HairFrame::new(glam::Mat4::IDENTITY, glam::Vec3::ZERO, light);
    let uniform = runtime.uniform(&frame);
    let light_points = arrays.points_of_level(runtime.chosen_levels(&frame).1);
    let cpu_maps = accumulate_cpu(&expand(&arrays, &uniform, Facing::Light, light_points), &light, RESOLUTION);
    let n = (RESOLUTION * RESOLUTION) as usize;
    let (mut covered, mut depth_ok, mut layers_ok) = (0, 0, 0);
    for i in 0..n {
        covered += (cpu_maps.0[i] < 1.0) as usize;
        depth_ok += ((depth[i] - cpu_maps.0[i]).abs() < 1e-4) as usize;
        layers_ok += (0..4).all(|k| (layers[i][k] - cpu_maps.1[i][k]).abs() < 5e-3) as usize;
    }
    eprintln!(
        "bevy hair maps: {covered} of {n} texels covered; depth equal on {:.2}%, layers on {:.2}%",
        100.0 * depth_ok as f64 / n as f64,
        100.0 * layers_ok as f64 / n as f64
    );
    assert!(covered > n / 10, "the hair should cover part of the maps");
    assert!(depth_ok as f64 >= 0.99 * n as f64 && layers_ok as f64 >= 0.99 * n as f64);

    // The ground without the hair's shadow: the ratio of the two renders is the visibility.
    let open_material = app.world().resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    app.world()
        .entity_mut(ground)
        .remove::<(HairReceiver, MeshMaterial3d<HairReceiverMaterial>)>()
        .insert(MeshMaterial3d(open_material));
    let open = app.capture_settled(&target);
    let (mut checked, mut agree, mut shaded, mut error) = (0usize, 0usize, 0usize, 0.0f64);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let k = (row * SIZE + col) as usize;
            if open[k][1] < 0.05 {
                continue;
            }
            let ray = app.pixel_ray(col, row);
            let p = ray.origin + *ray.direction * ((GROUND - ray.origin.y) / ray.direction.y);
            let reference = hair_visibility(
                &light,
                (&cpu_maps.0, &cpu_maps.1),
                RESOLUTION,
                Lookup::Nearest,
                glam::Vec3::from_array(p.to_array()),
            );
            let bevy = (shadowed[k][1] / open[k][1]).min(1.0);
            checked += 1;
            shaded += (reference < 0.9) as usize;
            agree += ((reference < 0.5) == (bevy < 0.5)) as usize;
            error += ((reference - bevy) as f64).abs();
        }
    }
    let share = agree as f64 / checked as f64;
    eprintln!(
        "bevy hair shadow: {checked} ground pixels, {shaded} shaded; the shadow mask agrees on {:.2}%, mean |Δ visibility| {:.4}",
        100.0 * share,
        error / checked as f64
    );
    assert!(checked as u32 > SIZE * SIZE * 9 / 10, "the ground fills the view");
    assert!(shaded > checked / 10, "the hair shades the ground");
    assert!(share >= 0.98 && error / checked as f64 <= 0.02);

    // 2. The hair seen in perspective, blended over black, against the CPU composite.
    app.world().despawn(ground);
    app.world().insert_resource(ClearColor(Color::BLACK));
    app.world().entity_mut(hair).get_mut::<HairStrands>().unwrap().draw = HairDraw::Blended;
    let camera = app.world().query_filtered::<Entity, With<Camera>>().single(app.world()).unwrap();
    let eye = Vec3::new(0.4, 1.6, 2.8);
    app.world().entity_mut(camera).insert((
        Transform::from_translation(eye).looking_at(Vec3::new(0.0, 0.2, 0.0), Vec3::Y),
        Projection::Perspective(PerspectiveProjection { fov: 45f32.to_radians(), near: 0.1, ..default() }),
    ));
    app.update();
    let image = app.capture_bytes(&target);
    let (clip, eye) = camera_of(app.world());
    let exposure = Exposure::default().exposure();
    let frame = HairFrame {
        light_color: glam::Vec3::splat(2000.0 * exposure / std::f32::consts::PI),
        ambient: glam::Vec3::ZERO,
        ..HairFrame::new(clip, eye, light)
    };
    let uniform = runtime.uniform(&frame);
    let points = arrays.points_of_level(runtime.chosen_levels(&frame).0);
    let reference =
        camera_reference(&arrays, &uniform, &light, &cpu_maps, ((SIZE, SIZE), points), Composite::OrderIndependent);
    let (mut covered, mut close, mut lit, mut stray) = (0, 0, 0.0f32, 0);
    for (i, r) in reference.iter().enumerate() {
        let got = image[i].map(hikage_scenes::hair_scene::srgb_to_linear);
        if r[3] <= 0.0 {
            stray += (got[..3].iter().any(|&c| c > 0.02)) as u32;
            continue;
        }
        covered += 1;
        close += (0..3).all(|k| (got[k] - r[k].min(1.0)).abs() <= 0.02 + 0.02 * r[k]) as u32;
        lit += r[0] + r[1] + r[2];
    }
    eprintln!(
        "bevy hair view: {covered} pixels with hair, {:.2}% within 2% of the CPU composite; {stray} stray pixels",
        100.0 * close as f64 / covered as f64
    );
    assert!(covered > 2000, "the hair fills part of the view");
    assert!(lit / covered as f32 > 0.05, "lit hair");
    assert!(close as f64 >= 0.97 * covered as f64, "{close} of {covered}");
    assert!(stray < 50, "{stray} pixels drawn where the reference has no hair");

    // 3. Against the scene's depth: a wall behind the hair shows through it as the blend says
    // (the reference composite over the wall's own pixel), and a post in front of the hair
    // hides it.
    let unlit = |c: Color| StandardMaterial { base_color: c, unlit: true, ..default() };
    let (wall, post) = {
        let world = app.world();
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (meshes.add(Cuboid::new(4.0, 4.0, 0.1)), meshes.add(Cuboid::new(0.25, 4.0, 0.25)))
    };
    let (grey, red) = {
        let mut materials = app.world().resource_mut::<Assets<StandardMaterial>>();
        (materials.add(unlit(Color::srgb(0.4, 0.4, 0.4))), materials.add(unlit(Color::srgb(0.8, 0.1, 0.1))))
    };
    let toward_eye = (Vec3::from_array(eye.to_array()) - Vec3::new(0.0, 0.2, 0.0)).normalize();
    let facing = Transform::from_translation(-1.6 * toward_eye).looking_to(-toward_eye, Vec3::Y);
    app.world().spawn((Mesh3d(wall), MeshMaterial3d(grey), facing));
    app.world().spawn((Mesh3d(post), MeshMaterial3d(red), Transform::from_translation(1.4 * toward_eye)));
    let blended = app.capture(&target);
    app.world().entity_mut(hair).get_mut::<HairStrands>().unwrap().draw = HairDraw::ShadowsOnly;
    let bare = app.capture_settled(&target);
    let (mut behind, mut behind_ok, mut hidden, mut hidden_ok) = (0, 0, 0, 0);
    for (i, r) in reference.iter().enumerate() {
        if r[3] < 0.05 {
            continue;
        }
        let is_post = bare[i][0] > 0.3 && bare[i][1] < 0.1;
        let is_wall = (bare[i][0] - bare[i][1]).abs() < 0.01 && bare[i][1] > 0.05;
        if is_post {
            hidden += 1;
            hidden_ok += (0..3).all(|k| (blended[i][k] - bare[i][k]).abs() <= 0.01) as u32;
        } else if is_wall {
            behind += 1;
            let expected = |k: usize| r[k].min(1.0) + (1.0 - r[3]) * bare[i][k];
            behind_ok += (0..3).all(|k| (blended[i][k] - expected(k)).abs() <= 0.02 + 0.02 * expected(k)) as u32;
        }
    }
    eprintln!(
        "bevy hair depth: {behind_ok} of {behind} hair pixels over the wall composite as the reference says; \
         {hidden_ok} of {hidden} behind the post stay hidden"
    );
    assert!(behind > 1000 && hidden > 100, "{behind} pixels over the wall, {hidden} behind the post");
    assert!(behind_ok as f64 >= 0.97 * behind as f64 && hidden_ok as f64 >= 0.99 * hidden as f64);
}

/// Hair on a moved, turned and scaled entity (a child of a moved parent, as hair on a head
/// bone) draws as the same strands baked already there: the hair, blended, and its shadow on a
/// receiving ground agree within 1/255 on at least 99.9% of the pixels.
#[test]
fn hair_follows_its_entity_as_if_baked_there() {
    if !gpu_or_skip("hair_follows_its_entity_as_if_baked_there") {
        return;
    }
    let (s, sets) = ring_strands();
    // The parent's translation, then the child's quarter turn about y and 2× scale.
    let (offset, turn, scale) = (Vec3::new(3.0, -1.0, 0.5), Quat::from_rotation_y(std::f32::consts::FRAC_PI_2), 2.0);
    let model =
        Mat4::from_translation(offset) * Mat4::from_scale_rotation_translation(Vec3::splat(scale), turn, Vec3::ZERO);
    let (moved, doubled) = hikage_devkit::synth::carried(&s, &sets, model.to_cols_array_2d(), scale);
    let dir =
        option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, std::path::PathBuf::from).join("hair_moved");
    let _ = std::fs::remove_dir_all(&dir);
    let mut writer = BundleWriter::open(&dir.join("bundle"), WriteMode::Replace).unwrap();
    for (id, strands, sets) in [("here.strips", &s, &sets), ("there.strips", &moved, &doubled)] {
        let strips = build(strands, sets);
        writer.put_mesh(id, Settings::Strands(strips.settings(strands, sets, None)), "test", &strips.mesh).unwrap();
    }
    writer.commit().unwrap();

    let centre = offset + Vec3::new(0.0, 0.5, 0.0);
    let view = Transform::from_translation(centre + Vec3::new(1.0, 4.0, 3.0)).looking_at(centre, Vec3::Y);
    let projection = Projection::Perspective(PerspectiveProjection { fov: 50f32.to_radians(), near: 0.1, ..default() });
    let MaskScene { mut app, target, .. } =
        MaskScene::new(&dir, SIZE, Vec3::new(0.3, 1.0, 0.4).normalize(), view, projection);
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(8.0, 8.0));
    let draw = |app: &mut common::Headless, baked_there: bool| {
        let world = app.world();
        let hair = if baked_there {
            world.spawn(HairStrands::new(bundle.clone(), "there.strips")).id()
        } else {
            let head = world.spawn(Transform::from_translation(offset)).id();
            let hair = world
                .spawn((
                    HairStrands::new(bundle.clone(), "here.strips"),
                    Transform::from_rotation(turn).with_scale(Vec3::splat(scale)),
                ))
                .id();
            world.entity_mut(head).add_child(hair);
            hair
        };
        let ground = world
            .spawn((
                Mesh3d(plane.clone()),
                Transform::from_translation(offset - Vec3::new(0.0, 0.4, 0.0)),
                HairReceiver::new(hair),
            ))
            .id();
        let built = app.update_until(600, |w| w.get::<MeshMaterial3d<HairReceiverMaterial>>(ground).is_some());
        assert!(built, "the receiver was not built");
        // The first frames may still wait for the maps or the strips on the render side.
        let image = app.capture_bytes_settled(&target);
        let root = app.world().get::<ChildOf>(hair).map_or(hair, |c| c.parent());
        app.world().entity_mut(root).despawn();
        app.world().despawn(ground);
        image
    };
    let there = draw(&mut app, true);
    let here = draw(&mut app, false);
    // The ground alone, for what the hair and its shadow change.
    let white = app.world().resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    let ground = Transform::from_translation(offset - Vec3::new(0.0, 0.4, 0.0));
    app.world().spawn((Mesh3d(plane), MeshMaterial3d(white), ground));
    app.update();
    let bare = app.capture_bytes(&target);
    let agree = here.iter().zip(&there).filter(|(a, b)| (0..3).all(|k| a[k].abs_diff(b[k]) <= 1)).count();
    let n = here.len();
    let changed = there.iter().zip(&bare).filter(|(a, b)| (0..3).any(|k| a[k].abs_diff(b[k]) > 8)).count();
    eprintln!(
        "bevy hair moved by its entity: {agree} of {n} pixels within 1/255 of the hair baked there ({changed} pixels \
         show hair or its shadow)"
    );
    assert!(changed > 2000, "the hair and its shadow change part of the frame");
    assert!(agree as f64 >= 0.999 * n as f64, "{agree} of {n}");
}

/// The ring of [`hair_bundle`] (baked into `name`) in a scene seen obliquely in perspective, lit
/// from above.
fn oblique_scene(name: &str) -> MaskScene {
    let (dir, _) = hair_bundle(name);
    let view = Transform::from_xyz(0.4, 1.6, 2.8).looking_at(Vec3::new(0.0, 0.2, 0.0), Vec3::Y);
    let projection = Projection::Perspective(PerspectiveProjection { fov: 45f32.to_radians(), near: 0.1, ..default() });
    MaskScene::new(&dir, SIZE, Vec3::new(0.3, 1.0, 0.4).normalize(), view, projection)
}

/// Bevy's default camera has MSAA 4×: the hair (blended, against the scene's depth resolved to
/// one sample per pixel) and its shadow on a receiver draw there as with `Msaa::Off`, and a post
/// in front of the hair still hides it.
#[test]
fn hair_and_its_shadow_draw_in_a_camera_with_msaa() {
    use bevy::render::view::Msaa;
    if !gpu_or_skip("hair_and_its_shadow_draw_in_a_camera_with_msaa") {
        return;
    }
    let MaskScene { mut app, target, .. } = oblique_scene("hair_msaa");
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let world = app.world();
    let (plane, post) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (meshes.add(Plane3d::default().mesh().size(4.0, 4.0)), meshes.add(Cuboid::new(0.15, 4.0, 0.15)))
    };
    let red = world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial {
        base_color: Color::srgb(0.8, 0.1, 0.1),
        unlit: true,
        ..default()
    });
    let hair = world.spawn(HairStrands::new(bundle, "head.strips")).id();
    let ground = world.spawn((Mesh3d(plane), Transform::from_xyz(0.0, GROUND, 0.0), HairReceiver::new(hair))).id();
    world.spawn((Mesh3d(post), MeshMaterial3d(red), Transform::from_xyz(0.25, 0.0, 1.2)));
    let built = app.update_until(600, |w| w.get::<MeshMaterial3d<HairReceiverMaterial>>(ground).is_some());
    assert!(built, "the receiver was not built");
    let camera = app.world().query_filtered::<Entity, With<Camera>>().single(app.world()).unwrap();
    let frame = |app: &mut common::Headless, msaa: Msaa, draw: HairDraw| {
        app.world().entity_mut(camera).insert(msaa);
        app.world().get_mut::<HairStrands>(hair).unwrap().draw = draw;
        app.capture_bytes_settled(&target)
    };
    let off = frame(&mut app, Msaa::Off, HairDraw::Blended);
    let bare_off = frame(&mut app, Msaa::Off, HairDraw::ShadowsOnly);
    let msaa = frame(&mut app, Msaa::Sample4, HairDraw::Blended);
    let bare = frame(&mut app, Msaa::Sample4, HairDraw::ShadowsOnly);
    let n = off.len();
    let agree = off.iter().zip(&msaa).filter(|(a, b)| (0..3).all(|k| a[k].abs_diff(b[k]) <= 2)).count();
    let shown = |with: &[[u8; 4]], without: &[[u8; 4]]| {
        with.iter().zip(without).filter(|(a, b)| (0..3).any(|k| a[k].abs_diff(b[k]) > 8)).count()
    };
    let (hair_shown, hair_off) = (shown(&msaa, &bare), shown(&off, &bare_off));
    // The post's pixels (unlit red) are the same with and without the hair: it hides the hair.
    let post_pixels = bare.iter().filter(|p| p[0] > 180 && p[1] < 60).count();
    let post_kept = bare.iter().zip(&msaa).filter(|(b, m)| b[0] > 180 && b[1] < 60 && b == m).count();
    eprintln!(
        "bevy hair with MSAA 4x: {agree} of {n} pixels within 2/255 of Msaa::Off; hair shown on {hair_shown} pixels \
         ({hair_off} without MSAA); the post keeps {post_kept} of {post_pixels} pixels"
    );
    assert!(hair_shown > 2000 && hair_shown as f64 >= 0.97 * hair_off as f64, "the hair is drawn with MSAA");
    assert!(agree as f64 >= 0.98 * n as f64, "{agree} of {n}");
    assert!(post_pixels > 500 && post_kept as f64 >= 0.97 * post_pixels as f64, "the post hides the hair");
}

/// A camera drawing into part of its target (a split screen's right half) gets its hair there
/// only: the half equals the same camera drawing a target of the half's size, and the other
/// half keeps the clear colour.
#[test]
fn hair_keeps_to_a_cameras_viewport() {
    use bevy::camera::{RenderTarget, Viewport};
    if !gpu_or_skip("hair_keeps_to_a_cameras_viewport") {
        return;
    }
    let MaskScene { mut app, target, .. } = oblique_scene("hair_viewport");
    app.world().insert_resource(ClearColor(Color::srgb(0.0, 0.0, 1.0)));
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(4.0, 4.0));
    let hair = app.world().spawn(HairStrands::new(bundle, "head.strips")).id();
    let ground =
        app.world().spawn((Mesh3d(plane), Transform::from_xyz(0.0, GROUND, 0.0), HairReceiver::new(hair))).id();
    let built = app.update_until(600, |w| w.get::<MeshMaterial3d<HairReceiverMaterial>>(ground).is_some());
    assert!(built, "the receiver was not built");
    let camera = app.world().query_filtered::<Entity, With<Camera>>().single(app.world()).unwrap();
    let half = SIZE / 2;
    let viewport =
        Viewport { physical_position: UVec2::new(half, 0), physical_size: UVec2::new(half, SIZE), ..default() };
    app.world().get_mut::<Camera>(camera).unwrap().viewport = Some(viewport);
    let split = app.capture_bytes_settled(&target);
    let narrow = app.target(half, SIZE);
    app.world().get_mut::<Camera>(camera).unwrap().viewport = None;
    app.world().entity_mut(camera).insert(RenderTarget::from(narrow.clone()));
    let alone = app.capture_bytes_settled(&narrow);
    let (mut agree, mut hair_pixels) = (0, 0);
    for row in 0..SIZE as usize {
        for col in 0..half as usize {
            let (a, b) = (split[row * SIZE as usize + half as usize + col], alone[row * half as usize + col]);
            agree += (0..3).all(|k| a[k].abs_diff(b[k]) <= 2) as usize;
            hair_pixels += (b[0] > 40 && b[2] < 200) as usize;
        }
    }
    let outside = (0..SIZE as usize)
        .flat_map(|row| (0..half as usize).map(move |col| row * SIZE as usize + col))
        .filter(|&i| split[i][..3] != [0, 0, 255])
        .count();
    let n = (half * SIZE) as usize;
    eprintln!(
        "bevy hair in a viewport: {agree} of {n} pixels within 2/255 of the camera alone ({hair_pixels} not sky); \
         {outside} pixels drawn outside it"
    );
    assert!(hair_pixels > 2000, "the hair and ground fill part of the viewport");
    assert!(agree as f64 >= 0.995 * n as f64, "{agree} of {n}");
    assert_eq!(outside, 0, "nothing is drawn outside the viewport");
}

/// The hair's mistakes are said on the entity, and cleared when fixed: opacity maps larger than
/// the device holds, a receiver without a mesh, a sun without shadow maps (receivers are
/// shadowed through Bevy's shadow factor).
#[test]
fn hair_mistakes_are_said_on_the_entity() {
    if !gpu_or_skip("hair_mistakes_are_said_on_the_entity") {
        return;
    }
    let (dir, _) = hair_bundle("hair_mistakes");
    let MaskScene { mut app, light, .. } = MaskScene::new(
        &dir,
        32,
        Vec3::Y,
        Transform::from_xyz(0.0, 5.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z),
        default(),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let mut huge = HairStrands::new(bundle, "head.strips");
    huge.resolution = 1 << 20;
    let hair = app.world().spawn(huge).id();
    let receiver = app.world().spawn(HairReceiver::new(hair)).id();
    let error = |app: &mut common::Headless, e: Entity| app.world().get::<HikageError>(e).map(|e| e.0.clone());
    let said = app.update_until(600, |w| w.get::<HikageError>(hair).is_some_and(|e| e.0.contains("render device")));
    assert!(said, "{:?}", error(&mut app, hair));
    assert!(error(&mut app, receiver).is_some_and(|m| m.contains("no Mesh3d")), "{:?}", error(&mut app, receiver));
    app.world().get_mut::<DirectionalLight>(light).unwrap().shadow_maps_enabled = false;
    app.update();
    assert!(
        error(&mut app, receiver).is_some_and(|m| m.contains("shadow_maps_enabled")),
        "{:?}",
        error(&mut app, receiver)
    );
    // Fixed, one by one.
    app.world().get_mut::<HairStrands>(hair).unwrap().resolution = 128;
    app.world().get_mut::<DirectionalLight>(light).unwrap().shadow_maps_enabled = true;
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(2.0, 2.0));
    app.world().entity_mut(receiver).insert(Mesh3d(plane));
    let cleared =
        app.update_until(100, |w| w.get::<HikageError>(hair).is_none() && w.get::<HikageError>(receiver).is_none());
    assert!(cleared, "{:?} {:?}", error(&mut app, hair), error(&mut app, receiver));
    app.update_until(10, |_| false);
    // None of it asked the app to quit (a render validation error does).
    assert!(app.world().resource::<bevy::ecs::message::Messages<AppExit>>().is_empty(), "the app was asked to quit");
}

/// A receiver is drawn only once its hair's maps have been: in every frame in which it has its
/// material, the render world has drawn the maps it reads (the first frames, before the hair's
/// renderer exists, would otherwise draw it with empty maps).
#[test]
fn a_receiver_waits_for_its_hairs_maps() {
    if !gpu_or_skip("a_receiver_waits_for_its_hairs_maps") {
        return;
    }
    let (dir, _) = hair_bundle("hair_first_frame");
    let MaskScene { mut app, .. } = MaskScene::new(
        &dir,
        32,
        Vec3::Y,
        Transform::from_xyz(0.0, 40.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z),
        default(),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let hair = app.world().spawn(HairStrands::new(bundle, "head.strips")).id();
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(20.0, 20.0));
    let receiver = app.world().spawn((Mesh3d(plane), HairReceiver::new(hair))).id();
    let mut frames_without = 0;
    for _ in 0..600 {
        app.update();
        let world = app.world();
        let Some(maps) = world.get::<HairShadowMaps>(hair) else { continue };
        if world.get::<MeshMaterial3d<HairReceiverMaterial>>(receiver).is_none() {
            frames_without += 1;
            continue;
        }
        assert!(maps.drawn(), "the receiver has its material before its hair's maps were drawn");
        eprintln!("the receiver got its material {frames_without} frames after its hair got maps");
        assert!(world.get::<HikageError>(receiver).is_none(), "{:?}", world.get::<HikageError>(receiver));
        return;
    }
    panic!("the receiver never got its material: {:?}", app.world().get::<HikageError>(receiver));
}

/// Hair bound to a skinned scalp follows the `SkinnedMesh` it is given: the devkit's character
/// (a head on a neck, two joints) posed by its joint entities draws its hair, and the hair's
/// shadow on a ground, as the same strands posed on the CPU and baked there — with the light box
/// and density the skin gives — within 1/255 on at least 99.9% of the pixels.
#[test]
fn hair_follows_a_skinned_mesh_as_if_baked_posed() {
    use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
    use hikage_runtime::hair::reference::{skin_bounds, skin_polylines};
    if !gpu_or_skip("hair_follows_a_skinned_mesh_as_if_baked_posed") {
        return;
    }
    let character = hikage_devkit::synth::character(600, 10, 11);
    let dir = option_env!("CARGO_TARGET_TMPDIR")
        .map_or_else(std::env::temp_dir, std::path::PathBuf::from)
        .join("hair_skinned");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("character.glb"), &character.glb).unwrap();
    let skinned = hikage_bake::mesh::gltf::load_skinned(&dir.join("character.glb"), Default::default()).unwrap();
    let sets = StripSets { shading: (0.04, 0.5), opacity: (0.25, 0.06), taper: 0.0 };
    let s = &character.hair;
    let bound = hikage_bake::strands::bind::bind(s, &skinned, 0.5, 0.125).unwrap();
    let scalp_mesh = bound.scalp.to_mesh().unwrap();
    let binding_mesh = hikage_bundle::binding::binding_mesh(&bound.bindings).unwrap();
    // What the GPU reads: the weights as stored.
    let scalp = hikage_bundle::Scalp::read(&scalp_mesh).unwrap();
    let bindings = hikage_bundle::binding::read_binding(&binding_mesh).unwrap();
    let t = 0.3f32;
    let joints = hikage_devkit::synth::pose(t);
    let posed = Strands { points: skin_polylines(&s.segments, &s.points, &bindings, &scalp, &joints), ..s.clone() };
    // The posed copy carries the skin's box and the density the rest pose has in its own box.
    let (lo, hi) = skin_bounds(&scalp, &joints);
    let here = build(s, &sets);
    let here_settings = here.settings(s, &sets, None);
    let there = build(&posed, &sets);
    let mut there_settings = there.settings(&posed, &sets, None);
    let volume = |a: [f32; 3], b: [f32; 3]| (0..3).map(|k| b[k] - a[k]).product::<f32>();
    there_settings.opacity_area = here_settings.opacity_area * (hi - lo).to_array().iter().product::<f32>()
        / volume(here_settings.bounds_min, here_settings.bounds_max);
    (there_settings.bounds_min, there_settings.bounds_max) = (lo.to_array(), hi.to_array());
    let mut writer = BundleWriter::open(&dir.join("bundle"), WriteMode::Replace).unwrap();
    writer.put_mesh("here.strips", Settings::Strands(here_settings), "test", &here.mesh).unwrap();
    writer.put_mesh("there.strips", Settings::Strands(there_settings), "test", &there.mesh).unwrap();
    let scalp_settings = hikage_bundle::ScalpSettings { joints: skinned.joint_names.clone(), source_triangles: 1 };
    writer.put_mesh("here.scalp", Settings::Scalp(scalp_settings), "test", &scalp_mesh).unwrap();
    let binding_settings = hikage_bundle::HairBindingSettings {
        strands: "here.strips".into(),
        scalp: "here.scalp".into(),
        max_distance: bound.max_distance,
    };
    writer.put_mesh("here.binding", Settings::HairBinding(binding_settings), "test", &binding_mesh).unwrap();
    writer.commit().unwrap();

    let centre = Vec3::new(0.0, 8.0, 0.0);
    let view = Transform::from_xyz(25.0, 30.0, 60.0).looking_at(centre, Vec3::Y);
    let projection = Projection::Perspective(PerspectiveProjection { fov: 45f32.to_radians(), near: 1.0, ..default() });
    let MaskScene { mut app, target, .. } =
        MaskScene::new(&dir, SIZE, Vec3::new(0.4, 1.0, 0.3).normalize(), view, projection);
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(80.0, 80.0));
    let bevy_mat = |m: glam::Mat4| Mat4::from_cols_array(&m.to_cols_array());
    let inverse = app
        .world()
        .resource_mut::<Assets<SkinnedMeshInverseBindposes>>()
        .add(vec![Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, -6.0, 0.0))]);
    let draw = |app: &mut common::Headless, skinned: bool| {
        let world = app.world();
        let mut spawned = Vec::new();
        let hair = if skinned {
            // The joints where the pose puts them: joint matrix × bind pose.
            let neck = world.spawn(Transform::from_matrix(bevy_mat(joints[0]))).id();
            let head = world
                .spawn(Transform::from_matrix(bevy_mat(joints[1]) * Mat4::from_translation(Vec3::new(0.0, 6.0, 0.0))))
                .id();
            let body = world.spawn(SkinnedMesh { inverse_bindposes: inverse.clone(), joints: vec![neck, head] }).id();
            spawned.extend([neck, head, body]);
            world.spawn(HairStrands::new(bundle.clone(), "here.strips").with_skin(body)).id()
        } else {
            world.spawn(HairStrands::new(bundle.clone(), "there.strips")).id()
        };
        let ground =
            world.spawn((Mesh3d(plane.clone()), Transform::from_xyz(0.0, -8.0, 0.0), HairReceiver::new(hair))).id();
        let built = app.update_until(600, |w| w.get::<MeshMaterial3d<HairReceiverMaterial>>(ground).is_some());
        assert!(built, "the receiver was not built");
        let image = app.capture_bytes_settled(&target);
        assert!(app.world().get::<HikageError>(hair).is_none(), "{:?}", app.world().get::<HikageError>(hair));
        for e in spawned.into_iter().chain([hair, ground]) {
            app.world().despawn(e);
        }
        image
    };
    let baked = draw(&mut app, false);
    let followed = draw(&mut app, true);
    let white = app.world().resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    app.world().spawn((Mesh3d(plane), MeshMaterial3d(white), Transform::from_xyz(0.0, -8.0, 0.0)));
    app.update();
    let bare = app.capture_bytes(&target);
    let n = baked.len();
    let agree = followed.iter().zip(&baked).filter(|(a, b)| (0..3).all(|k| a[k].abs_diff(b[k]) <= 1)).count();
    let changed = baked.iter().zip(&bare).filter(|(a, b)| (0..3).any(|k| a[k].abs_diff(b[k]) > 8)).count();
    eprintln!(
        "bevy hair following a skin: {agree} of {n} pixels within 1/255 of the hair baked posed ({changed} pixels show hair or its shadow)"
    );
    assert!(changed > 2000, "the hair and its shadow change part of the frame");
    assert!(agree as f64 >= 0.999 * n as f64, "{agree} of {n}");
    // Mistakes are said on the hair: a skin entity without a SkinnedMesh, strands the bundle
    // binds to no scalp, a skin of other joints.
    let world = app.world();
    let nothing = world.spawn(Transform::default()).id();
    let joint = world.spawn(Transform::default()).id();
    let three = world.spawn(SkinnedMesh { inverse_bindposes: inverse.clone(), joints: vec![joint; 3] }).id();
    let cases = [
        (world.spawn(HairStrands::new(bundle.clone(), "here.strips").with_skin(nothing)).id(), "has no SkinnedMesh"),
        (
            world.spawn(HairStrands::new(bundle.clone(), "there.strips").with_skin(three)).id(),
            "binds no scalp to `there.strips`",
        ),
        (
            world.spawn(HairStrands::new(bundle.clone(), "here.strips").with_skin(three)).id(),
            "has 3 joints; the scalp was bound to a skin of 2 (neck, head)",
        ),
    ];
    for (hair, needle) in cases {
        let said = app.update_until(100, |w| w.get::<HikageError>(hair).is_some_and(|e| e.0.contains(needle)));
        assert!(said, "{needle}: {:?}", app.world().get::<HikageError>(hair));
    }
}
