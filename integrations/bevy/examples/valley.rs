//! A valley at sunset: houses and trees on the default bundle's terrain, under a sun 3° up. On
//! the left they are drawn as Bevy draws any mesh (its cascades reach 150 m, and the camera is
//! farther than that from every house: the mountains' shadow stops at their walls); on the right
//! each is a `TerrainReceiver` and stands in the terrain's far shadow. Bake the bundle first
//! (`cargo run --release -- bake` in the repository root). Without a display both frames are
//! rendered headless and saved side by side, cropped to the village (`target/valley.png`, or the
//! path given: docs/images/bevy_valley.png is this); with one, the right-hand scene opens in a
//! window.

#[path = "common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};

use bevy::prelude::*;
use hikage_bevy::{HorizonTerrain, TerrainReceiver};
use hikage_devkit::brute_force::bilinear_height;
use hikage_runtime::CpuBundle;
use hikage_runtime::glam;
use hikage_runtime::horizon::reference::{HorizonMap, horizon_sun_visible};

/// Elevation and azimuth of the sun (degrees; azimuth from +x toward +z).
const SUN: (f32, f32) = (3.0, 200.0);
/// The village's side, in texels of the terrain.
const VILLAGE: usize = 14;

fn main() {
    let valley = Valley::choose(&common::repo_root());
    let windowed = std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some();
    if windowed {
        common::run("valley", move |app| valley.scene(app, true));
        return;
    }
    let out = std::env::args()
        .nth(1)
        .map_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target").join("valley.png"), PathBuf::from);
    let halves = Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    let (left, right) = (halves.join("valley.cascades.png"), halves.join("valley.field.png"));
    let root = common::repo_root();
    let (a, b) = (valley.clone(), valley);
    common::render("valley", &root, &left, move |app| a.scene(app, false));
    common::render("valley", &root, &right, move |app| b.scene(app, true));
    side_by_side(&left, &right, &out);
    println!("valley: Bevy's cascades alone (left), with the terrain's far shadow (right): {}", out.display());
}

/// Where the village stands and the camera looks from: chosen on the CPU from the baked
/// horizons, where about half the ground is in the mountains' shadow at this sun.
#[derive(Clone)]
struct Valley {
    houses: Vec<Vec3>,
    trees: Vec<Vec3>,
    eye: Vec3,
    target: Vec3,
}

impl Valley {
    fn choose(root: &Path) -> Valley {
        let cpu = CpuBundle::read_prefix(&root.join("bundle"), "terrain.").expect("bake the bundle first");
        let asset = cpu.asset("terrain.horizon").expect("the default bundle's terrain");
        let settings = asset.asset.settings.horizon().unwrap();
        let map = HorizonMap::new(asset.texture().unwrap(), settings, true).unwrap();
        let hf = cpu.asset("terrain.height").unwrap();
        let hs = hf.asset.settings.heightfield().unwrap();
        let desc = hf.texture().unwrap().desc.clone();
        let (w, h) = (desc.width as usize, desc.height as usize);
        let heights: Vec<f32> = hf.texture().unwrap().to_f32(0).iter().map(|&v| hs.world_height(v)).collect();
        let (sx, sy) = settings.texel_size;
        let ground = |x: f32, z: f32| bilinear_height(&heights, (w, h), (sx, sy), (x, z)).unwrap_or(0.0);
        let (e, a) = (SUN.0.to_radians(), SUN.1.to_radians());
        let bump = glam::Vec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin());
        let lit = |i: usize, j: usize| {
            let uv = glam::Vec2::new((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
            horizon_sun_visible(&map, uv, bump, glam::Vec2::new(sx, sy), 0.0) > 0.5
        };
        // The window with half its ground shadowed and the least relief: a valley floor.
        let mut best = (f32::MAX, 0, 0);
        for j in (40..h - 40 - VILLAGE).step_by(6) {
            for i in (40..w - 40 - VILLAGE).step_by(6) {
                let (mut shadowed, mut n, mut lo, mut hi) = (0, 0, f32::MAX, f32::MIN);
                for y in (j..j + VILLAGE).step_by(2) {
                    for x in (i..i + VILLAGE).step_by(2) {
                        shadowed += usize::from(!lit(x, y));
                        n += 1;
                        let z = heights[y * w + x];
                        (lo, hi) = (lo.min(z), hi.max(z));
                    }
                }
                let score = (shadowed as f32 / n as f32 - 0.5).abs() + (hi - lo) / 1500.0;
                if score < best.0 {
                    best = (score, i, j);
                }
            }
        }
        let (_, i, j) = best;
        let corner = Vec2::new(i as f32 * sx, j as f32 * sy);
        let side = Vec2::new(VILLAGE as f32 * sx, VILLAGE as f32 * sy);
        // Scattered on a jittered grid, standing on the ground.
        let scatter = |count: usize, seed: u32| -> Vec<Vec3> {
            (0..count)
                .map(|k| {
                    let r = |s: u32| {
                        ((k as u32).wrapping_mul(2_654_435_761) ^ s.wrapping_mul(40_503)).wrapping_mul(2_246_822_519)
                            as f32
                            / u32::MAX as f32
                    };
                    let p = corner + side * Vec2::new(r(seed), r(seed + 7));
                    Vec3::new(p.x, ground(p.x, p.y), p.y)
                })
                .collect()
        };
        let centre = corner + side / 2.0;
        // The camera stands off the village, the sun over its left shoulder.
        let look = Vec2::from_angle((SUN.1 + 130.0).to_radians());
        let back = centre - look * 0.9 * side.length();
        let eye = Vec3::new(back.x, ground(back.x, back.y).max(ground(centre.x, centre.y)) + 180.0, back.y);
        Valley {
            houses: scatter(36, 1),
            trees: scatter(70, 2),
            eye,
            target: Vec3::new(centre.x, ground(centre.x, centre.y), centre.y),
        }
    }

    /// The scene: the terrain, the sun, the camera, and the village, each mesh a
    /// `TerrainReceiver` when `receivers`.
    fn scene(self, app: &mut App, receivers: bool) {
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  assets: Res<AssetServer>,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                let bundle = assets.load("bundle/bundle.ron");
                let rock = StandardMaterial {
                    base_color: Color::srgb(0.5, 0.47, 0.4),
                    perceptual_roughness: 1.0,
                    ..default()
                };
                let terrain = commands
                    .spawn(HorizonTerrain::new(bundle, "terrain.horizon").with_ao("terrain.ao").with_base(rock))
                    .id();
                let (e, a) = (SUN.0.to_radians(), SUN.1.to_radians());
                let toward = Vec3::new(e.cos() * a.cos(), e.sin(), e.cos() * a.sin());
                commands.spawn((
                    DirectionalLight {
                        illuminance: 8_000.0,
                        color: Color::srgb(1.0, 0.8, 0.6),
                        shadow_maps_enabled: true,
                        ..default()
                    },
                    Transform::default().looking_to(-toward, Vec3::Y),
                ));
                commands.spawn((
                    Camera3d::default(),
                    Projection::Perspective(PerspectiveProjection { fov: 0.5, far: 100_000.0, ..default() }),
                    Transform::from_translation(self.eye).looking_at(self.target, Vec3::Y),
                ));
                let walls = StandardMaterial { base_color: Color::srgb(0.9, 0.85, 0.75), ..default() };
                let leaves = StandardMaterial {
                    base_color: Color::srgb(0.25, 0.5, 0.2),
                    perceptual_roughness: 0.9,
                    ..default()
                };
                let house = meshes.add(Cuboid::new(16.0, 10.0, 12.0));
                let tree = meshes.add(Cone { radius: 5.0, height: 18.0 });
                let (house_material, tree_material) = (materials.add(walls.clone()), materials.add(leaves.clone()));
                let mut spawn =
                    |mesh: &Handle<Mesh>, at: Vec3, base: &StandardMaterial, plain: &Handle<StandardMaterial>| {
                        let mut entity = commands.spawn((Mesh3d(mesh.clone()), Transform::from_translation(at)));
                        if receivers {
                            entity.insert(TerrainReceiver::new(terrain).with_base(base.clone()));
                        } else {
                            entity.insert(MeshMaterial3d(plain.clone()));
                        }
                    };
                for &p in &self.houses {
                    spawn(&house, p + Vec3::Y * 4.0, &walls, &house_material);
                }
                for &p in &self.trees {
                    spawn(&tree, p + Vec3::Y * 8.0, &leaves, &tree_material);
                }
            },
        );
    }
}

/// `left` and `right` side by side in `out`, cropped to the band of rows the village is in.
fn side_by_side(left: &Path, right: &Path, out: &Path) {
    let (a, b) = (image::open(left).unwrap().to_rgb8(), image::open(right).unwrap().to_rgb8());
    let (top, rows) = (a.height() * 5 / 18, a.height() / 2);
    let mut both = image::RgbImage::new(a.width() + b.width(), rows);
    for (image, x) in [(&a, 0), (&b, a.width())] {
        let band = image::imageops::crop_imm(image, 0, top, image.width(), rows).to_image();
        image::imageops::replace(&mut both, &band, i64::from(x), 0);
    }
    both.save(out).unwrap();
}
