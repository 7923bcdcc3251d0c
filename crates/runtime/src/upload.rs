//! The device half of loading: create wgpu textures and buffers from a [`CpuBundle`].

use std::collections::BTreeMap;

use hikage_bundle::{Asset, MeshDesc, PayloadData, TextureData, TextureDesc, TextureDimension, TextureFormat};

use crate::error::RuntimeError;
use crate::load::CpuBundle;

/// The wgpu format of a bundle texture format.
pub fn wgpu_format(format: TextureFormat) -> wgpu::TextureFormat {
    match format {
        TextureFormat::R8Unorm => wgpu::TextureFormat::R8Unorm,
        TextureFormat::Rg8Unorm => wgpu::TextureFormat::Rg8Unorm,
        TextureFormat::R16Float => wgpu::TextureFormat::R16Float,
        TextureFormat::Rg16Float => wgpu::TextureFormat::Rg16Float,
        TextureFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
        TextureFormat::R32Float => wgpu::TextureFormat::R32Float,
        TextureFormat::Rg32Float => wgpu::TextureFormat::Rg32Float,
        TextureFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
        TextureFormat::Bc4RUnorm => wgpu::TextureFormat::Bc4RUnorm,
        TextureFormat::Bc5RgUnorm => wgpu::TextureFormat::Bc5RgUnorm,
    }
}

/// The wgpu features hikage uses when the adapter has them; request `OPTIONAL_FEATURES &
/// adapter.features()`. Without them everything still loads and draws: block-compressed
/// textures are decoded at upload (2× or 4× the memory), 32-bit float horizons are sampled
/// nearest, hair blends in half floats.
///
/// ```no_run
/// # async fn f(adapter: &hikage_runtime::wgpu::Adapter) -> Result<(), hikage_runtime::wgpu::RequestDeviceError> {
/// let (device, queue) = adapter
///     .request_device(&hikage_runtime::wgpu::DeviceDescriptor {
///         required_features: hikage_runtime::OPTIONAL_FEATURES & adapter.features(),
///         ..Default::default()
///     })
///     .await?;
/// # Ok(()) }
/// ```
pub const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::TEXTURE_COMPRESSION_BC
    .union(wgpu::Features::TEXTURE_COMPRESSION_BC_SLICED_3D)
    .union(wgpu::Features::FLOAT32_FILTERABLE)
    .union(wgpu::Features::FLOAT32_BLENDABLE);

/// The format a texture of `desc` has on `device`: its own, or for a block-compressed texture
/// the device cannot hold, the 8-bit format it decodes to. A device holds BC4/BC5 with
/// `TEXTURE_COMPRESSION_BC` (3D textures also need `TEXTURE_COMPRESSION_BC_SLICED_3D`, which
/// WebGPU's BC lacks) when the level-0 size is a multiple of the 4×4 block, as wgpu asks.
///
/// ```
/// use hikage_runtime::hikage_bundle::{Supercompression, TextureDesc, TextureDimension, TextureFormat};
///
/// let desc = TextureDesc {
///     format: TextureFormat::Bc5RgUnorm,
///     dimension: TextureDimension::D3,
///     width: 512,
///     height: 512,
///     depth: 32,
///     layers: 1,
///     levels: 1,
///     supercompression: Supercompression::Zstd,
///     channels: vec!["slope".into(), "distance".into()],
/// };
/// let bc = hikage_runtime::wgpu::Features::TEXTURE_COMPRESSION_BC;
/// assert_eq!(hikage_runtime::device_format(bc, &desc), TextureFormat::Rg8Unorm);
/// let sliced = bc | hikage_runtime::wgpu::Features::TEXTURE_COMPRESSION_BC_SLICED_3D;
/// assert_eq!(hikage_runtime::device_format(sliced, &desc), TextureFormat::Bc5RgUnorm);
/// ```
pub fn device_format(features: wgpu::Features, desc: &TextureDesc) -> TextureFormat {
    let format = desc.format;
    if !format.is_block_compressed() {
        return format;
    }
    let mut needed = wgpu::Features::TEXTURE_COMPRESSION_BC;
    if desc.dimension == TextureDimension::D3 {
        needed |= wgpu::Features::TEXTURE_COMPRESSION_BC_SLICED_3D;
    }
    let whole_blocks = desc.width.is_multiple_of(4) && desc.height.is_multiple_of(4);
    if features.contains(needed) && whole_blocks { format } else { format.decoded() }
}

/// A texture on the device.
#[derive(Debug)]
pub struct GpuTexture {
    /// The manifest entry.
    pub asset: Asset,
    /// Format and dimensions as on the device: the manifest's, except that a block-compressed
    /// texture the device cannot hold was decoded at upload and says `R8Unorm` or `Rg8Unorm`
    /// (see [`device_format`]).
    pub desc: TextureDesc,
    /// The texture (usage: `TEXTURE_BINDING | COPY_DST | COPY_SRC`).
    pub texture: wgpu::Texture,
    /// A view of every level (and every layer, as an array, for `D2Array`).
    pub view: wgpu::TextureView,
    /// The smallest and largest value of level 0 of a one-channel texture, as stored (for a
    /// heightfield, the sample range its world heights follow from); `None` for other formats.
    pub range: Option<(f32, f32)>,
}

/// A mesh buffer on the device.
#[derive(Debug)]
pub struct GpuMesh {
    /// The manifest entry.
    pub asset: Asset,
    /// Accessors into `buffer`.
    pub desc: MeshDesc,
    /// The whole payload (usage: `VERTEX | INDEX | STORAGE | COPY_DST`), padded to 4 bytes.
    pub buffer: wgpu::Buffer,
}

/// Every asset of a bundle on the device, by id.
#[derive(Debug, Default)]
pub struct GpuBundle {
    /// Textures by asset id.
    pub textures: BTreeMap<String, GpuTexture>,
    /// Meshes by asset id.
    pub meshes: BTreeMap<String, GpuMesh>,
}

impl GpuBundle {
    /// The texture `id`, or an error listing the textures there are.
    pub fn texture(&self, id: &str) -> Result<&GpuTexture, RuntimeError> {
        self.textures.get(id).ok_or_else(|| missing(id, "texture", self.textures.keys()))
    }

    /// The mesh `id`, or an error listing the meshes there are.
    pub fn mesh(&self, id: &str) -> Result<&GpuMesh, RuntimeError> {
        self.meshes.get(id).ok_or_else(|| missing(id, "mesh", self.meshes.keys()))
    }

    /// Applies a [`CpuBundle::reload`]: uploads the changed and added assets of `cpu` in place
    /// of the old ones and drops the removed ones. Components built on a replaced texture or
    /// buffer hold the old one: build them again (cheap) for the assets in `changes`.
    ///
    /// [`CpuBundle::reload`]: crate::CpuBundle::reload
    pub fn apply(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        cpu: &CpuBundle,
        changes: &crate::load::Changes,
    ) -> Result<(), RuntimeError> {
        for id in changes.changed.iter().chain(&changes.added) {
            let Some(a) = cpu.asset(id) else { continue };
            self.insert(device, queue, a)?;
        }
        for id in &changes.removed {
            self.textures.remove(id);
            self.meshes.remove(id);
        }
        Ok(())
    }

    /// Uploads one decoded asset in place of any asset of its id: for a game (or an engine
    /// integration) that reads its payloads itself and uploads them as they arrive.
    ///
    /// ```no_run
    /// # fn f(device: &hikage_runtime::wgpu::Device, queue: &hikage_runtime::wgpu::Queue) -> Result<(), hikage_runtime::RuntimeError> {
    /// use hikage_runtime::{CpuBundle, GpuBundle};
    ///
    /// let cpu = CpuBundle::read_ids("assets/bundle".as_ref(), &["head.strips"])?;
    /// let mut gpu = GpuBundle::default();
    /// gpu.insert(device, queue, cpu.asset("head.strips").expect("read above"))?;
    /// # Ok(()) }
    /// ```
    pub fn insert(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        a: &crate::load::CpuAsset,
    ) -> Result<(), RuntimeError> {
        match &a.payload {
            PayloadData::Texture(t) => {
                let gpu = upload_texture(device, queue, &a.asset, t)?;
                self.meshes.remove(&a.asset.id);
                self.textures.insert(a.asset.id.clone(), gpu);
            }
            PayloadData::Mesh(m) => {
                let gpu = upload_mesh(device, queue, &a.asset, &m.desc, &m.bytes)?;
                self.textures.remove(&a.asset.id);
                self.meshes.insert(a.asset.id.clone(), gpu);
            }
        }
        Ok(())
    }

    /// Uploads every asset. Sizes are checked against the device's limits first, and the
    /// upload runs inside a validation error scope, so a bundle the device cannot hold gives an
    /// error naming the asset.
    pub fn upload(device: &wgpu::Device, queue: &wgpu::Queue, cpu: &CpuBundle) -> Result<GpuBundle, RuntimeError> {
        let mut out = GpuBundle::default();
        for a in &cpu.assets {
            out.insert(device, queue, a)?;
        }
        Ok(out)
    }
}

fn missing<'a>(id: &str, what: &str, have: impl Iterator<Item = &'a String>) -> RuntimeError {
    let have: Vec<&str> = have.map(String::as_str).collect();
    RuntimeError::Asset {
        asset: id.to_string(),
        message: format!("no such {what} was uploaded; there are: {}", have.join(", ")),
    }
}

fn unsupported(asset: &Asset, message: String) -> RuntimeError {
    RuntimeError::Unsupported { asset: asset.id.clone(), message }
}

/// `d`'s sizes against the device's limits, and whether the device can sample `format` (the
/// format it will hold the texture in).
fn check_texture(
    device: &wgpu::Device,
    asset: &Asset,
    d: &TextureDesc,
    format: TextureFormat,
) -> Result<(), RuntimeError> {
    let limits = device.limits();
    let (max_dim, what) = match d.dimension {
        TextureDimension::D3 => (limits.max_texture_dimension_3d, "3D"),
        _ => (limits.max_texture_dimension_2d, "2D"),
    };
    let largest = d.width.max(d.height).max(if d.dimension == TextureDimension::D3 { d.depth } else { 1 });
    if largest > max_dim {
        return Err(unsupported(asset, format!("{what} size {largest} is above the device limit of {max_dim}")));
    }
    if d.layers > limits.max_texture_array_layers {
        return Err(unsupported(
            asset,
            format!("{} layers is above the device limit of {}", d.layers, limits.max_texture_array_layers),
        ));
    }
    let format = wgpu_format(format);
    let needed = format.guaranteed_format_features(device.features());
    if !needed.allowed_usages.contains(wgpu::TextureUsages::TEXTURE_BINDING) {
        return Err(unsupported(asset, format!("format {format:?} cannot be sampled on this device")));
    }
    Ok(())
}

fn upload_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    asset: &Asset,
    tex: &TextureData,
) -> Result<GpuTexture, RuntimeError> {
    let on_device = device_format(device.features(), &tex.desc);
    check_texture(device, asset, &tex.desc, on_device)?;
    let tex = if on_device == tex.desc.format { std::borrow::Cow::Borrowed(tex) } else { tex.decoded() };
    let d = &tex.desc;
    let (dimension, depth_or_array_layers) = match d.dimension {
        TextureDimension::D2 => (wgpu::TextureDimension::D2, 1),
        TextureDimension::D2Array => (wgpu::TextureDimension::D2, d.layers),
        TextureDimension::D3 => (wgpu::TextureDimension::D3, d.depth),
    };
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(&asset.id),
        size: wgpu::Extent3d { width: d.width, height: d.height, depth_or_array_layers },
        mip_level_count: d.levels,
        sample_count: 1,
        dimension,
        format: wgpu_format(d.format),
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let side = d.format.block_side();
    for (level, data) in tex.levels.iter().enumerate() {
        let (w, h, depth) = d.level_extent(level as u32);
        let slices = if d.dimension == TextureDimension::D3 { depth } else { d.layers };
        // Block formats copy whole blocks: rows of blocks, and the level's size rounded up to
        // them (wgpu's physical size of a level smaller than a block).
        let (blocks_wide, blocks_high) = (w.div_ceil(side), h.div_ceil(side));
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(blocks_wide * d.format.block_bytes() as u32),
                rows_per_image: Some(blocks_high),
            },
            wgpu::Extent3d { width: blocks_wide * side, height: blocks_high * side, depth_or_array_layers: slices },
        );
    }
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some(&asset.id),
        dimension: Some(match d.dimension {
            TextureDimension::D2 => wgpu::TextureViewDimension::D2,
            TextureDimension::D2Array => wgpu::TextureViewDimension::D2Array,
            TextureDimension::D3 => wgpu::TextureViewDimension::D3,
        }),
        ..Default::default()
    });
    if let Some(e) = block_on(scope.pop()) {
        return Err(RuntimeError::Wgpu { asset: asset.id.clone(), message: e.to_string() });
    }
    let range = (d.format.channels() == 1 && d.levels >= 1).then(|| {
        tex.channel_f32(0, 0).iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
    });
    Ok(GpuTexture { asset: asset.clone(), desc: d.clone(), texture, view, range })
}

fn upload_mesh(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    asset: &Asset,
    desc: &MeshDesc,
    bytes: &[u8],
) -> Result<GpuMesh, RuntimeError> {
    let size = (bytes.len() as u64).div_ceil(4).max(1) * 4;
    let max = device.limits().max_buffer_size;
    if size > max {
        return Err(unsupported(asset, format!("{size}-byte buffer is above the device limit of {max}")));
    }
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(&asset.id),
        size,
        usage: wgpu::BufferUsages::VERTEX
            | wgpu::BufferUsages::INDEX
            | wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut padded = bytes.to_vec();
    padded.resize(size as usize, 0);
    queue.write_buffer(&buffer, 0, &padded);
    if let Some(e) = block_on(scope.pop()) {
        return Err(RuntimeError::Wgpu { asset: asset.id.clone(), message: e.to_string() });
    }
    Ok(GpuMesh { asset: asset.clone(), desc: desc.clone(), buffer })
}

/// Drives a future to completion on this thread. wgpu's native futures (error scopes, adapter
/// and device requests) are ready at once or after a device poll, so a spin with yields is
/// enough and spares the runtime an executor dependency.
pub(crate) fn block_on<F: std::future::Future>(future: F) -> F::Output {
    let mut future = std::pin::pin!(future);
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    loop {
        if let std::task::Poll::Ready(v) = future.as_mut().poll(&mut cx) {
            return v;
        }
        std::thread::yield_now();
    }
}
