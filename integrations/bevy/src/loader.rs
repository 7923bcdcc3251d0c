//! The [`AssetLoader`] of `bundle.ron`: the manifest, then every payload as a labelled
//! sub-asset, each checked (size, BLAKE3, contents) as the core's readers check it.

use std::path::Path;
use std::sync::Arc;

use bevy_asset::io::Reader;
use bevy_asset::{AssetLoader, LoadContext, RenderAssetUsages};
use bevy_image::{
    CompressedImageFormats, Image, ImageAddressMode, ImageFilterMode, ImageSampler, ImageSamplerDescriptor, ImageType,
};
use bevy_mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues, VertexFormat};
use bevy_reflect::TypePath;
use hikage_bundle::{
    Asset as ManifestAsset, AssetKind, ComponentType, EdgeMode, Limits, Manifest, MeshData, MeshDesc, Payload, Settings,
};

use crate::HikageBundle;

/// Loads a hikage bundle's `bundle.ron` (registered by [`crate::HikagePlugin`] for `.ron`).
///
/// Block-compressed textures (BC4, BC5) stay blocks on a render device that can sample them
/// (`hikage_runtime::device_format`), and are decoded to `R8Unorm`/`Rg8Unorm` on the CPU
/// otherwise, or where no render device exists yet.
#[derive(Debug, Default, Clone, TypePath)]
pub struct BundleLoader {
    /// The render device's features, once [`crate::HikageAssetsPlugin`] has seen the device.
    features: Arc<std::sync::OnceLock<hikage_runtime::wgpu::Features>>,
}

impl BundleLoader {
    /// Records the render device's features (the first call wins).
    pub(crate) fn set_device(&self, features: hikage_runtime::wgpu::Features) {
        let _ = self.features.set(features);
    }

    pub(crate) fn device_features(&self) -> hikage_runtime::wgpu::Features {
        self.features.get().copied().unwrap_or_else(hikage_runtime::wgpu::Features::empty)
    }
}

/// Why a bundle did not load: the manifest, or one asset, named.
#[derive(Debug, thiserror::Error)]
pub enum BundleLoadError {
    /// The manifest cannot be read or used.
    #[error("{message}")]
    Manifest {
        /// The manifest's asset path.
        path: String,
        /// What is wrong, beginning with the path (and the line and column, where the text is
        /// at fault).
        message: String,
    },
    /// An asset's payload is missing, damaged or of a kind Bevy cannot hold.
    #[error("{path}: asset `{asset}`: {message}")]
    Asset {
        /// The manifest's asset path.
        path: String,
        /// The asset id.
        asset: String,
        /// What is wrong.
        message: String,
    },
}

impl AssetLoader for BundleLoader {
    type Asset = HikageBundle;
    type Settings = ();
    type Error = BundleLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _: &(),
        context: &mut LoadContext<'_>,
    ) -> Result<HikageBundle, BundleLoadError> {
        let path = context.path().to_string();
        let limits = Limits::default();
        let mut text = Vec::new();
        reader.read_to_end(&mut text).await.map_err(|e| manifest_error(&path, e.to_string()))?;
        let (text, names) = manifest_text(text, &path)?;
        let mut tables = std::collections::BTreeMap::new();
        for name in names {
            let table_path = context.path().path().with_file_name(&name);
            let bytes = context.read_asset_bytes(table_path).await.map_err(|e| manifest_error(&path, e.to_string()))?;
            tables.insert(name, bytes);
        }
        let manifest = parse_manifest(&text, &path, tables)?;
        let mut bundle = HikageBundle {
            manifest: manifest.clone(),
            images: Vec::new(),
            image_ids: Vec::new(),
            meshes: Vec::new(),
            mesh_ids: Vec::new(),
            grids: Vec::new(),
            grid_ids: Vec::new(),
            strands: Vec::new(),
        };
        // The tiles of a map baked in tiles are streamed (`StreamedTerrain`), not loaded with the
        // bundle: a large map's tiles would not fit in memory.
        for asset in manifest.assets.iter().filter(|a| a.settings.tile().is_none()) {
            let bad = |message: String| BundleLoadError::Asset { path: path.clone(), asset: asset.id.clone(), message };
            let payload_path = context.path().path().with_file_name(&asset.file);
            let bytes = context.read_asset_bytes(payload_path).await.map_err(|e| bad(e.to_string()))?;
            check(asset, &bytes, &limits).map_err(&bad)?;
            match &asset.payload {
                Payload::Texture(_) => {
                    let image = texture_image(asset, &bytes, self.device_features(), RenderAssetUsages::default())
                        .map_err(&bad)?;
                    if let Settings::Heightfield(settings) = &asset.settings {
                        let heights = hikage_bundle::ktx2_file::decode(&bytes, Path::new(&asset.file), &limits)
                            .map_err(|e| bad(e.to_string()))?;
                        let grid = crate::grid::grid_mesh(&heights, settings).map_err(&bad)?;
                        let label = format!("{}/{}", asset.id, crate::grid::GRID_LABEL);
                        bundle.grids.push(context.add_labeled_asset(label, grid));
                        bundle.grid_ids.push(asset.id.clone());
                    }
                    bundle.images.push(context.add_labeled_asset(asset.id.clone(), image));
                    bundle.image_ids.push(asset.id.clone());
                }
                // A hair binding and its scalp are read by hikage-runtime's `HairSkin`, not drawn.
                Payload::Mesh(_) if matches!(asset.kind, AssetKind::HairBinding | AssetKind::Scalp) => {
                    let payload = hikage_runtime::PayloadData::Mesh(decoded_mesh(asset, bytes, &limits).map_err(&bad)?);
                    bundle.strands.push(Arc::new(hikage_runtime::CpuAsset { asset: asset.clone(), payload }));
                }
                Payload::Mesh(_) => {
                    let data = decoded_mesh(asset, bytes, &limits).map_err(&bad)?;
                    let mesh = mesh(asset.kind, &data).map_err(&bad)?;
                    if asset.kind == AssetKind::Strands {
                        let payload = hikage_runtime::PayloadData::Mesh(data);
                        bundle.strands.push(Arc::new(hikage_runtime::CpuAsset { asset: asset.clone(), payload }));
                    }
                    bundle.meshes.push(context.add_labeled_asset(asset.id.clone(), mesh));
                    bundle.mesh_ids.push(asset.id.clone());
                }
            }
        }
        Ok(bundle)
    }

    fn extensions(&self) -> &[&str] {
        &["ron"]
    }
}

/// The manifest `text` of the bundle at asset path `path` as text, and the tile tables beside it
/// to read (their file names), checked against the limits every reader keeps. With
/// [`parse_manifest`], the one way the loader and a [`crate::StreamedTerrain`] (which streams
/// before the bundle has loaded) read a manifest.
pub(crate) fn manifest_text(text: Vec<u8>, path: &str) -> Result<(String, Vec<String>), BundleLoadError> {
    let limits = Limits::default();
    if text.len() as u64 > limits.max_manifest_bytes {
        return Err(manifest_error(
            path,
            format!("{} bytes, above the limit of {}", text.len(), limits.max_manifest_bytes),
        ));
    }
    let text = String::from_utf8(text).map_err(|e| manifest_error(path, format!("expected UTF-8 text: {e}")))?;
    // A map baked in tiles is listed in a tile table beside the manifest: each is read first.
    let mut tables = Vec::new();
    for set in Manifest::tile_sets(&text, Path::new(path)).map_err(|e| parse_error(path, e))? {
        if set.byte_length > limits.max_manifest_bytes || !hikage_bundle::is_valid_asset_id(&set.table) {
            return Err(manifest_error(
                path,
                format!("tile table {:?} of {} bytes is not one a reader takes", set.table, set.byte_length),
            ));
        }
        tables.push(set.table);
    }
    Ok((text, tables))
}

/// The manifest `text` of the bundle at asset path `path` with its tile tables' bytes (by file
/// name, [`manifest_text`]), checked as every reader checks it.
pub(crate) fn parse_manifest(
    text: &str,
    path: &str,
    mut tables: std::collections::BTreeMap<String, Vec<u8>>,
) -> Result<Manifest, BundleLoadError> {
    let limits = Limits::default();
    let manifest = Manifest::parse_with_tables(text, Path::new(path), &limits, &mut |set| {
        Ok(tables.remove(&set.table).unwrap_or_default())
    })
    .map_err(|e| parse_error(path, e))?;
    if let Some((asset, message)) = hikage_bundle::validate::manifest_problems(&manifest, &limits).into_iter().next() {
        return Err(BundleLoadError::Asset { path: path.to_string(), asset, message });
    }
    Ok(manifest)
}

/// A manifest that cannot be used, `message` after its path.
fn manifest_error(path: &str, message: String) -> BundleLoadError {
    BundleLoadError::Manifest { path: path.to_string(), message: format!("{path}: {message}") }
}

/// A parser's error (it names the path, and the line and column, itself).
fn parse_error(path: &str, e: hikage_bundle::BundleError) -> BundleLoadError {
    BundleLoadError::Manifest { path: path.to_string(), message: e.to_string() }
}

/// The image of texture asset `asset` from its checked payload `bytes`: BC4/BC5 blocks kept on a
/// device with `features` that samples them and decoded otherwise, sampled as the asset wants.
pub(crate) fn texture_image(
    asset: &ManifestAsset,
    bytes: &[u8],
    features: hikage_runtime::wgpu::Features,
    usage: RenderAssetUsages,
) -> Result<Image, String> {
    let Payload::Texture(desc) = &asset.payload else {
        return Err("not a texture".into());
    };
    let decoded;
    let (ktx2, formats) = if !desc.format.is_block_compressed() {
        (bytes, CompressedImageFormats::NONE)
    } else if hikage_runtime::device_format(features, desc) == desc.format {
        (bytes, CompressedImageFormats::BC)
    } else {
        decoded = decode_blocks(bytes, &asset.file, &Limits::default())?;
        (decoded.as_slice(), CompressedImageFormats::NONE)
    };
    Image::from_buffer(ktx2, ImageType::Extension("ktx2"), formats, false, sampler(&asset.settings), usage)
        .map_err(|e| format!("Bevy's KTX2 reader: {e}"))
}

/// A BC4/BC5 texture's KTX2 file as the `R8Unorm`/`Rg8Unorm` KTX2 file it decodes to, for
/// Bevy's reader on a device that cannot sample the blocks: decoded on the CPU (2× or 4× the GPU
/// memory of the blocks), read by the same materials.
fn decode_blocks(bytes: &[u8], file: &str, limits: &Limits) -> Result<Vec<u8>, String> {
    let texture = hikage_bundle::ktx2_file::decode(bytes, Path::new(file), limits).map_err(|e| e.to_string())?;
    let mut decoded = texture.decoded().into_owned();
    decoded.desc.supercompression = hikage_bundle::Supercompression::None;
    hikage_bundle::ktx2_file::encode(&decoded, hikage_bundle::GENERATOR).map_err(|e| e.to_string())
}

/// The sampler a texture asset wants, as `hikage-runtime` samples it: a horizon map filters
/// linearly, wraps its azimuth axis (2π → 0) and repeats or clamps u and v as its bake's edge
/// mode says (a terrain's edge texels are not blended with the far side); others keep Bevy's
/// default.
fn sampler(settings: &Settings) -> ImageSampler {
    let Settings::Horizon(horizon) = settings else {
        return ImageSampler::Default;
    };
    let uv = match horizon.edge {
        EdgeMode::Wrap => ImageAddressMode::Repeat,
        EdgeMode::Clamp => ImageAddressMode::ClampToEdge,
    };
    ImageSampler::Descriptor(ImageSamplerDescriptor {
        label: Some("hikage horizon".into()),
        address_mode_u: uv,
        address_mode_v: uv,
        address_mode_w: ImageAddressMode::Repeat,
        mag_filter: ImageFilterMode::Linear,
        min_filter: ImageFilterMode::Linear,
        ..ImageSamplerDescriptor::default()
    })
}

/// The payload's length and BLAKE3 against the manifest, then a texture's contents as every
/// reader checks them (a mesh's are checked once inflated, [`decoded_mesh`]).
pub(crate) fn check(asset: &ManifestAsset, bytes: &[u8], limits: &Limits) -> Result<(), String> {
    if bytes.len() as u64 != asset.byte_length {
        return Err(format!("payload is {} bytes, the manifest says {}", bytes.len(), asset.byte_length));
    }
    let hash = blake3::hash(bytes).to_hex();
    if hash.as_str() != asset.blake3 {
        return Err(format!("payload BLAKE3 {hash} does not match the manifest's {}", asset.blake3));
    }
    match asset.payload {
        Payload::Texture(_) => {
            hikage_bundle::check_payload(asset, bytes, Path::new(&asset.file), limits).map_err(|e| e.to_string())
        }
        Payload::Mesh(_) => Ok(()),
    }
}

/// A mesh payload inflated (when compressed) and checked as every reader checks it.
fn decoded_mesh(asset: &ManifestAsset, bytes: Vec<u8>, limits: &Limits) -> Result<MeshData, String> {
    let mesh = hikage_bundle::decode_mesh(asset, bytes, Path::new(&asset.file), limits).map_err(|e| e.to_string())?;
    hikage_bundle::validate::check_mesh(&mesh.desc, &mesh.bytes)?;
    Ok(mesh)
}

/// A Bevy mesh of a mesh payload: each stream as its attribute ([`crate::attributes`]), U32
/// triangle indices where there are any; strands (no indices) are a point list of records.
fn mesh(kind: AssetKind, data: &MeshData) -> Result<Mesh, String> {
    let desc: &MeshDesc = &data.desc;
    let strands = kind == AssetKind::Strands;
    let topology = if desc.indices.is_some() { PrimitiveTopology::TriangleList } else { PrimitiveTopology::PointList };
    let mut mesh = Mesh::new(topology, RenderAssetUsages::default());
    for a in &desc.attributes {
        let attribute = crate::attributes::for_stream(&a.name, a.components, strands)
            .ok_or_else(|| format!("stream `{}` has no Bevy attribute", a.name))?;
        let values = values(data, a, attribute.format).ok_or_else(|| {
            format!(
                "stream `{}`: {:?} × {} cannot load as its attribute's {:?}",
                a.name, a.component, a.components, attribute.format
            )
        })?;
        mesh.try_insert_attribute(attribute, values).map_err(|e| e.to_string())?;
    }
    if let Some(indices) = data.read_indices() {
        mesh.insert_indices(Indices::U32(indices));
    }
    Ok(mesh)
}

/// The values of stream `a` in the vertex format `format` of the attribute it loads as: floats
/// for Bevy's standard attributes and the float custom ones (8- and 16-bit streams dequantized
/// as glTF's normalized accessors are, so quantized normals, tangents, UVs and colours load),
/// and the stored bytes for a strands record's packed streams; `None` when the stream cannot
/// give that format.
fn values(data: &MeshData, a: &hikage_bundle::Accessor, format: VertexFormat) -> Option<VertexAttributeValues> {
    let u16s = |e: &[u8], k: usize| u16::from_le_bytes([e[2 * k], e[2 * k + 1]]);
    let elements = data.elements(a);
    Some(match (format, a.component, a.components) {
        (VertexFormat::Float32, ..) => VertexAttributeValues::Float32(floats::<1>(data, a)?.concat()),
        (VertexFormat::Float32x2, ..) => VertexAttributeValues::Float32x2(floats(data, a)?),
        (VertexFormat::Float32x3, ..) => VertexAttributeValues::Float32x3(floats(data, a)?),
        (VertexFormat::Float32x4, ..) => VertexAttributeValues::Float32x4(floats(data, a)?),
        (VertexFormat::Uint16x2, ComponentType::U16, 2) => {
            VertexAttributeValues::Uint16x2(elements.map(|e| [0, 1].map(|k| u16s(e, k))).collect())
        }
        (VertexFormat::Unorm16x2, ComponentType::U16, 2) => {
            VertexAttributeValues::Unorm16x2(elements.map(|e| [0, 1].map(|k| u16s(e, k))).collect())
        }
        (VertexFormat::Unorm8x4, ComponentType::U8, 4) => {
            VertexAttributeValues::Unorm8x4(elements.map(|e| [e[0], e[1], e[2], e[3]]).collect())
        }
        (VertexFormat::Uint32, ComponentType::U32, 1) => {
            VertexAttributeValues::Uint32(elements.map(|e| u32::from_le_bytes([e[0], e[1], e[2], e[3]])).collect())
        }
        _ => return None,
    })
}

/// Stream `a`'s elements as `N` floats each (8- and 16-bit components normalized), when it has
/// `N` components of a type that is not an integer stream's `U32`.
fn floats<const N: usize>(data: &MeshData, a: &hikage_bundle::Accessor) -> Option<Vec<[f32; N]>> {
    (a.components as usize == N && a.component != ComponentType::U32)
        .then(|| data.elements(a).map(|e| std::array::from_fn(|k| a.component.normalized(e, k))).collect())
}
