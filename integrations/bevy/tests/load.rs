//! A bundle loaded through Bevy's asset server: the textures keep their dimension, size and
//! texels, the meshes their streams as attributes, and a damaged payload is a load error naming
//! its asset.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use bevy_app::{App, TaskPoolPlugin};
use bevy_asset::{AssetPlugin, AssetServer, Assets, Handle, LoadState};
use bevy_image::Image;
use bevy_mesh::{Mesh, VertexAttributeValues};
use hikage_bevy::{HikageAssetsPlugin, HikageBundle, attributes};
use hikage_bundle::{
    BundleWriter, MeshData, Settings, StrandPoint, StrandsSettings, TextureData, TextureDesc, TextureDimension,
    TextureFormat, WriteMode, strands_desc,
};

/// A fresh directory under the target directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A 3D two-channel texture (a horizon map's shape), a 2D one, a triangle and two strands.
fn write_bundle(dir: &Path) -> (Vec<f32>, Vec<StrandPoint>) {
    let mut w = BundleWriter::open(&dir.join("b"), WriteMode::Replace).unwrap();
    let desc = |format, dimension, (width, height, depth), channels: &[&str]| TextureDesc {
        format,
        dimension,
        width,
        height,
        depth,
        layers: 1,
        levels: 1,
        supercompression: hikage_bundle::Supercompression::None,
        channels: channels.iter().map(|c| c.to_string()).collect(),
    };
    let volume: Vec<f32> = (0..4 * 3 * 5 * 2).map(|i| i as f32 * 0.25 - 3.0).collect();
    let horizon = TextureData::from_f32(
        desc(TextureFormat::Rg32Float, TextureDimension::D3, (4, 3, 5), &["slope", "distance"]),
        &volume,
    )
    .unwrap();
    w.put_texture("t.volume", Settings::Generic, "x", &horizon).unwrap();
    let flat: Vec<f32> = (0..8 * 8).map(|i| i as f32 / 64.0).collect();
    let plane =
        TextureData::from_f32(desc(TextureFormat::R32Float, TextureDimension::D2, (8, 8, 1), &["height"]), &flat)
            .unwrap();
    w.put_texture("t.plane", Settings::Generic, "x", &plane).unwrap();
    // A BC5 volume of 8 × 4 texels × 2 slices: blocks whose red half is flat at 10 × the block's
    // number and whose green half holds r0 = 200, r1 = 100 with every texel at index 2
    // ((6·200 + 100)/7 ≈ 185.7, decoded to 186).
    let blocks: Vec<u8> = (0..4u8)
        .flat_map(|b| {
            let mut g = [200u8, 100, 0, 0, 0, 0, 0, 0];
            let bits = (0..16).fold(0u64, |acc, i| acc | 2 << (3 * i));
            g[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
            [[b * 10, b * 10, 0, 0, 0, 0, 0, 0], g].concat()
        })
        .collect();
    let bc5 = TextureData {
        desc: desc(TextureFormat::Bc5RgUnorm, TextureDimension::D3, (8, 4, 2), &["slope", "distance"]),
        levels: vec![blocks],
    };
    w.put_texture("t.blocks", Settings::Generic, "x", &bc5).unwrap();
    let mut tri = MeshData::new(3);
    tri.push_f32("position", 3, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]).unwrap();
    tri.push_f32("uv", 2, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]).unwrap();
    tri.set_indices(&[0, 1, 2]).unwrap();
    w.put_mesh("m.tri", Settings::Generic, "x", &tri).unwrap();
    let points: Vec<StrandPoint> = (0..5)
        .map(|i| StrandPoint {
            position: [i as f32, 0.5 * i as f32, -1.0],
            tangent: [1.0, 0.0, 0.0],
            width: 0.01 * (1 + i % 2) as f32,
            alpha: 0.5,
            color: [0.2, 0.3, 0.4],
            index: [0, 1, 2, 0, 1][i],
            segments: [2, 2, 2, 1, 1][i],
            strand_id: [7, 7, 7, 3, 3][i],
        })
        .collect();
    let bytes: Vec<u8> = points.iter().flat_map(|p| p.encode(0.02)).collect();
    let settings = StrandsSettings {
        strands: 2,
        points: 5,
        shading: (0.01, 0.5),
        opacity: (0.08, 0.05),
        taper: 0.0,
        auto_resolution: None,
        bounds_min: [-0.1, -0.1, -1.1],
        bounds_max: [4.1, 2.1, -0.9],
        max_width: 0.02,
        levels: vec![[2, 5], [1, 3]],
        opacity_area: 0.01,
    };
    w.put_mesh("h.strips", Settings::Strands(settings), "x", &MeshData { desc: strands_desc(5), bytes }).unwrap();
    // The strands bound to a one-triangle scalp: read as data, not made meshes.
    let scalp = hikage_bundle::Scalp {
        positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        joints: vec![[0, 0, 0, 0]; 3],
        weights: vec![[1.0, 0.0, 0.0, 0.0]; 3],
        reach: vec![5.0; 3],
        triangles: vec![[0, 1, 2]],
    };
    let scalp_settings = hikage_bundle::ScalpSettings { joints: vec!["root".into()], source_triangles: 1 };
    w.put_mesh("h.scalp", Settings::Scalp(scalp_settings), "x", &scalp.to_mesh().unwrap()).unwrap();
    let bindings = vec![hikage_bundle::StrandBinding { triangle: 0, barycentric: [0.25, 0.25] }; 8];
    let binding_settings =
        hikage_bundle::HairBindingSettings { strands: "h.strips".into(), scalp: "h.scalp".into(), max_distance: 0.0 };
    let binding = hikage_bundle::binding::binding_mesh(&bindings).unwrap();
    w.put_mesh("h.binding", Settings::HairBinding(binding_settings), "x", &binding).unwrap();
    w.commit().unwrap();
    (volume, points)
}

fn app(root: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        TaskPoolPlugin::default(),
        AssetPlugin { file_path: root.to_string_lossy().into_owned(), ..Default::default() },
        HikageAssetsPlugin,
    ));
    app
}

/// Runs the app until `handle` is loaded or failed (a minute at most).
fn wait(app: &mut App, handle: &Handle<HikageBundle>) -> LoadState {
    let start = Instant::now();
    loop {
        app.update();
        let state = app.world().resource::<AssetServer>().load_state(handle);
        if matches!(state, LoadState::Loaded | LoadState::Failed(_)) || start.elapsed() > Duration::from_secs(60) {
            return state;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_bundle_loads_as_labelled_images_and_meshes() {
    let root = scratch("loads");
    let (volume, points) = write_bundle(&root);
    let mut app = app(&root);
    let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("b/bundle.ron");
    let state = wait(&mut app, &handle);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    let world = app.world();
    let bundle = world.resource::<Assets<HikageBundle>>().get(&handle).unwrap();
    assert_eq!(bundle.image_ids, ["t.blocks", "t.plane", "t.volume"]);
    assert_eq!(bundle.mesh_ids, ["h.strips", "m.tri"]);
    assert!(bundle.asset("h.strips").unwrap().settings.strands().is_some());
    let scalp = bundle.hair_binding("h.scalp").expect("the scalp is read");
    assert_eq!(scalp.mesh().unwrap().read_indices().unwrap(), [0, 1, 2]);
    assert_eq!(bundle.hair_binding("h.binding").unwrap().mesh().unwrap().desc.vertex_count, 8);
    assert!(bundle.strands("h.binding").is_none() && bundle.hair_binding("h.strips").is_none());
    // The labelled path names the same image.
    let labelled: Handle<Image> = world.resource::<AssetServer>().load("b/bundle.ron#t.volume");
    assert_eq!(labelled.id(), bundle.image("t.volume").unwrap().id());

    let images = world.resource::<Assets<Image>>();
    let image = images.get(bundle.image("t.volume").unwrap()).unwrap();
    let d = &image.texture_descriptor;
    assert_eq!(format!("{:?}", d.dimension), "D3");
    assert_eq!((d.size.width, d.size.height, d.size.depth_or_array_layers), (4, 3, 5));
    let texels: Vec<f32> =
        image.data.as_ref().unwrap().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(texels, volume, "the volume's texels, slice by slice");
    // Block-compressed textures arrive decoded, in the 8-bit format of the same channels.
    let blocks = images.get(bundle.image("t.blocks").unwrap()).unwrap();
    let d = &blocks.texture_descriptor;
    assert_eq!(format!("{:?} {:?}", d.dimension, d.format), "D3 Rg8Unorm");
    assert_eq!((d.size.width, d.size.height, d.size.depth_or_array_layers), (8, 4, 2));
    let data = blocks.data.as_ref().unwrap();
    for (i, texel) in data.chunks_exact(2).enumerate() {
        let (x, y, z) = (i % 8, i / 8 % 4, i / 32);
        assert_eq!(texel, [(z * 2 + x / 4) as u8 * 10, 186], "texel ({x}, {y}, {z})");
    }
    let plane = images.get(bundle.image("t.plane").unwrap()).unwrap();
    assert_eq!(format!("{:?}", plane.texture_descriptor.dimension), "D2");

    let meshes = world.resource::<Assets<Mesh>>();
    let tri = meshes.get(bundle.mesh("m.tri").unwrap()).unwrap();
    assert_eq!(tri.count_vertices(), 3);
    assert!(
        matches!(tri.attribute(Mesh::ATTRIBUTE_UV_0), Some(VertexAttributeValues::Float32x2(v)) if v[1] == [1.0, 0.0])
    );
    let strips = meshes.get(bundle.mesh("h.strips").unwrap()).unwrap();
    assert_eq!(strips.count_vertices(), 5);
    let Some(VertexAttributeValues::Float32x3(positions)) = strips.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("positions")
    };
    assert_eq!(positions[4], points[4].position);
    let Some(VertexAttributeValues::Uint16x2(strand)) = strips.attribute(attributes::STRAND_INDEX) else {
        panic!("strand")
    };
    assert_eq!(strand[..3], [[0, 2], [1, 2], [2, 2]]);
    let Some(VertexAttributeValues::Uint32(ids)) = strips.attribute(attributes::STRAND_ID) else { panic!("ids") };
    assert_eq!(ids, &[7, 7, 7, 3, 3]);
}

#[test]
fn a_damaged_payload_fails_the_load_naming_its_asset() {
    let root = scratch("damaged");
    write_bundle(&root);
    let payload = std::fs::read_dir(root.join("b"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("t.plane."))
        .unwrap();
    let mut bytes = std::fs::read(&payload).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x40;
    std::fs::write(&payload, bytes).unwrap();
    let mut app = app(&root);
    let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("b/bundle.ron");
    match wait(&mut app, &handle) {
        LoadState::Failed(e) => {
            let message = e.to_string();
            assert!(message.contains("t.plane") && message.contains("BLAKE3"), "{message}");
        }
        other => panic!("expected a failed load, found {other:?}"),
    }
}

/// Images and meshes a game (or Bevy's own plugins: the tonemapping LUTs) added before the
/// plugin are still there after it: the plugin keeps the asset storage it finds.
#[test]
fn the_plugin_keeps_images_and_meshes_added_before_it() {
    use bevy_asset::AssetApp;
    let mut app = App::new();
    app.add_plugins((TaskPoolPlugin::default(), AssetPlugin::default()));
    app.init_asset::<Image>().init_asset::<Mesh>();
    let image = app.world_mut().resource_mut::<Assets<Image>>().add(Image::default());
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Mesh::new(bevy_mesh::PrimitiveTopology::TriangleList, bevy_asset::RenderAssetUsages::default()));
    app.add_plugins(HikageAssetsPlugin);
    assert!(app.world().resource::<Assets<Image>>().get(&image).is_some(), "an image added before the plugin");
    assert!(app.world().resource::<Assets<Mesh>>().get(&mesh).is_some(), "a mesh added before the plugin");
}

/// A bake that replaces the bundle (what Bevy's file watcher reports as a change to
/// `bundle.ron`) reloads it: the labelled image keeps its handle and takes the new texels.
#[test]
fn a_rebaked_bundle_reloads_into_the_same_handles() {
    let root = scratch("reload");
    write_bundle(&root);
    let mut app = app(&root);
    let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("b/bundle.ron");
    assert!(matches!(wait(&mut app, &handle), LoadState::Loaded));
    let image = app.world().resource::<Assets<HikageBundle>>().get(&handle).unwrap().image("t.plane").unwrap().clone();
    let before = app.world().resource::<Assets<Image>>().get(&image).unwrap().data.clone();

    // The bake: the same ids, the plane's texels doubled.
    let mut w = BundleWriter::open(&root.join("b"), WriteMode::Update).unwrap();
    let flat: Vec<f32> = (0..8 * 8).map(|i| 2.0 * i as f32 / 64.0).collect();
    let desc = TextureDesc {
        format: TextureFormat::R32Float,
        dimension: TextureDimension::D2,
        width: 8,
        height: 8,
        depth: 1,
        layers: 1,
        levels: 1,
        supercompression: hikage_bundle::Supercompression::None,
        channels: vec!["height".into()],
    };
    w.put_texture("t.plane", Settings::Generic, "y", &TextureData::from_f32(desc, &flat).unwrap()).unwrap();
    w.commit().unwrap();
    app.world().resource::<AssetServer>().reload("b/bundle.ron");
    let start = Instant::now();
    let after = loop {
        app.update();
        let data = app.world().resource::<Assets<Image>>().get(&image).and_then(|i| i.data.clone());
        if let Some(data) = data.filter(|d| Some(d) != before.as_ref()) {
            break data;
        }
        assert!(start.elapsed() < Duration::from_secs(60), "the image did not change after the reload");
        std::thread::sleep(Duration::from_millis(5));
    };
    let texels: Vec<f32> = after.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(texels, flat);
    let bundle = app.world().resource::<Assets<HikageBundle>>().get(&handle).unwrap();
    assert_eq!(bundle.image("t.plane"), Some(&image), "the same handle");
}
