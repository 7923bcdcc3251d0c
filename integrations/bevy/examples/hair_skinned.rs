//! Hair on a skinned character in Bevy: the devkit's generated character (a head on a neck, two
//! joints, a skinned GLB) with 8,000 strands bound to its scalp by the strands job's `scalp`,
//! drawn by `HairStrands::with_skin` while the neck turns and the head nods over a four-second
//! loop. Bevy skins the head mesh from the same joints, so the roots stay on it. The example
//! bakes its own bundle into the target directory; without a display it saves one frame of the
//! loop as a PNG.

#[path = "common/mod.rs"]
mod common;

use bevy::asset::RenderAssetUsages;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use hikage_bevy::hair::{HairReceiver, HairStrands};
use hikage_devkit::synth::{self, Character};

/// A joint of the character: 0 the neck, 1 the head.
#[derive(Component)]
struct Joint(usize);

/// The character, shared by the setup and the animation.
#[derive(Resource)]
struct Generated(Character);

fn main() {
    let character = synth::character(8_000, 16, 5);
    let dir = option_env!("CARGO_TARGET_TMPDIR")
        .map_or_else(std::env::temp_dir, std::path::PathBuf::from)
        .join("hair_skinned_example");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("character.glb"), &character.glb).unwrap();
    std::fs::write(dir.join("head.hair"), hikage_bake::strands::cyhair::encode(&character.hair, "character")).unwrap();
    let jobs = r#"Strands(id: "head", input: "head.hair", scalp: Some("character.glb"), color: (0.32, 0.2, 0.11))"#;
    std::fs::write(dir.join("pipeline.ron"), format!("(output: \"bundle\", jobs: [{jobs}])")).unwrap();
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default()).unwrap();
    common::run_in("hair_skinned", &dir, |app| {
        app.insert_resource(Generated(character)).add_systems(Startup, setup).add_systems(Update, animate);
    });
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    character: Res<Generated>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut bindposes: ResMut<Assets<SkinnedMeshInverseBindposes>>,
) {
    let c = &character.0;
    // The joints as the bind pose has them; `animate` poses them.
    let neck = commands.spawn((Joint(0), Transform::default())).id();
    let head = commands.spawn((Joint(1), Transform::from_xyz(0.0, 6.0, 0.0))).id();
    let inverse = bindposes.add(vec![Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, -6.0, 0.0))]);
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default());
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, c.positions.clone());
    let joints: Vec<[u16; 4]> = c.positions.iter().map(|_| [0, 1, 0, 0]).collect();
    mesh.insert_attribute(Mesh::ATTRIBUTE_JOINT_INDEX, VertexAttributeValues::Uint16x4(joints));
    let weights: Vec<[f32; 4]> = c.weights.iter().map(|w| [w[0], w[1], 0.0, 0.0]).collect();
    mesh.insert_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights);
    mesh.insert_indices(Indices::U32(c.triangles.iter().flatten().copied().collect()));
    mesh.compute_smooth_normals();
    let skin = StandardMaterial { base_color: Color::srgb(0.85, 0.62, 0.5), perceptual_roughness: 0.7, ..default() };
    let body = commands
        .spawn((
            Mesh3d(meshes.add(mesh)),
            MeshMaterial3d(assets.add(skin)),
            SkinnedMesh { inverse_bindposes: inverse, joints: vec![neck, head] },
        ))
        .id();
    // The hair follows the body's skin: its own transform is not used.
    let mut hair = HairStrands::new(assets.load("bundle/bundle.ron"), "head.strips").with_skin(body);
    hair.style.tip_tint = Vec3::new(1.6, 1.4, 1.2);
    hair.style.color_variation = 0.3;
    let hair = commands.spawn(hair).id();
    let ground = Plane3d::default().mesh().size(120.0, 120.0);
    let sand = StandardMaterial { base_color: Color::srgb(0.75, 0.7, 0.62), perceptual_roughness: 1.0, ..default() };
    commands.spawn((
        Mesh3d(meshes.add(ground)),
        Transform::from_xyz(0.0, -8.0, 0.0),
        HairReceiver::new(hair).with_base(sand),
    ));
    commands.spawn((
        DirectionalLight { illuminance: 9_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(-Vec3::new(0.45, 1.0, 0.3), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(38.0, 26.0, 52.0).looking_at(Vec3::new(0.0, 6.0, 0.0), Vec3::Y),
    ));
}

/// Poses the joints at the loop's time: the devkit's joint matrices × the bind pose.
fn animate(time: Res<Time>, mut joints: Query<(&Joint, &mut Transform)>) {
    let t = (time.elapsed_secs() / 4.0).fract();
    let pose = synth::pose(t);
    let bind = [Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, 6.0, 0.0))];
    for (joint, mut transform) in &mut joints {
        let matrix = Mat4::from_cols_array(&pose[joint.0].to_cols_array()) * bind[joint.0];
        *transform = Transform::from_matrix(matrix);
    }
}
