//! [`HairSkin`]: strands that follow a skinned scalp. Each frame a compute pass poses every
//! strand record by the scalp triangle its strand is bound to, from the joint matrices the
//! game's animation gives the skin, and the renderer draws the posed records.

use glam::{Mat4, Vec3};
use hikage_bundle::{Scalp, StrandBinding};

use super::HAIR_SKIN_WGSL;
use crate::error::RuntimeError;
use crate::gpu;
use crate::load::CpuAsset;
use crate::upload::GpuBundle;

/// Invocations per workgroup of the skinning pass (one record each).
pub const SKIN_WORKGROUP: u32 = 64;

/// The skinning pass's parameters, as `SkinParams` in the WGSL (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SkinParams {
    points: u32,
    joint_count: u32,
    strands: u32,
    groups_x: u32,
    position: [u32; 2],
    joints: [u32; 2],
    weights: [u32; 2],
    index_at: u32,
    triangle: [u32; 2],
    barycentric: [u32; 2],
    _pad: u32,
}

/// Hair bound to a skinned scalp (a `HairBinding` asset and its `Scalp`, baked with the strands
/// job's `scalp` setting): poses the strands of the binding's `Strands` asset every frame from the
/// skin's joint matrices, on the GPU, into a buffer of records a [`super::HairRenderer`] draws
/// once it [`follows`](super::HairRenderer::follow) this skin.
///
/// Each strand moves rigidly with the frame of its triangle (origin at its root's bound point,
/// axes from the triangle's first edge and normal), skinned by linear blending of up to four
/// joints a vertex: strands keep their shape and length and never stretch; nothing simulates
/// them.
///
/// ```no_run
/// # fn f(device: &hikage_runtime::wgpu::Device, queue: &hikage_runtime::wgpu::Queue, camera: hikage_runtime::glam::Mat4, eye: hikage_runtime::glam::Vec3, joints: &[hikage_runtime::glam::Mat4]) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::glam::Vec3;
/// use hikage_runtime::hair::{HairFrame, HairLight, HairOptions, HairRenderer, HairSkin};
/// use hikage_runtime::{CpuBundle, GpuBundle, wgpu};
///
/// // Once: the strands on the device, the binding and scalp read on the CPU.
/// let cpu = CpuBundle::read_prefix("bundle".as_ref(), "head.")?;
/// let gpu = GpuBundle::upload(device, queue, &cpu)?;
/// let (binding, scalp) = (cpu.asset("head.binding").unwrap(), cpu.asset("head.scalp").unwrap());
/// let skin = HairSkin::new(device, queue, &gpu, binding, scalp)?;
/// let options = HairOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb, (1280, 720));
/// let mut hair = HairRenderer::new(device, queue, &gpu, "head.strips", &options)?;
/// hair.follow(&skin)?;
///
/// // Every frame: the skin's joint matrices (joint world × inverse bind, in the order of
/// // `skin.joint_names()`), then the light fitted to where the hair is now.
/// let bounds = skin.update(queue, joints)?;
/// let light = HairLight::for_bounds(bounds.0, bounds.1, Vec3::new(0.3, 1.0, 0.2));
/// let frame = HairFrame { bounds: Some(bounds), ..HairFrame::new(camera, eye, light) };
/// hair.update(queue, &frame);
/// let mut encoder = device.create_command_encoder(&Default::default());
/// skin.record(&mut encoder);
/// hair.render_opacity_maps(&mut encoder);
/// // … the camera passes as without a skin.
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct HairSkin {
    assets: Vec<String>,
    joint_names: Vec<String>,
    scalp: Scalp,
    points: u32,
    posed: wgpu::Buffer,
    joints: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    groups: (u32, u32),
}

impl HairSkin {
    /// The skin of `binding` (a `HairBinding` asset) over `scalp` (the `Scalp` asset it names),
    /// posing the records of the `Strands` asset it binds, which `gpu` must hold.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        gpu: &GpuBundle,
        binding: &CpuAsset,
        scalp: &CpuAsset,
    ) -> Result<HairSkin, RuntimeError> {
        let id = binding.asset.id.clone();
        let bad = |message: String| RuntimeError::Asset { asset: id.clone(), message };
        let settings = binding
            .asset
            .settings
            .hair_binding()
            .ok_or_else(|| bad(format!("expected a hair binding, found a {}", binding.asset.kind.name())))?;
        let joint_names = scalp
            .asset
            .settings
            .scalp()
            .filter(|_| scalp.asset.id == settings.scalp)
            .ok_or_else(|| bad(format!("names scalp `{}`, not `{}`", settings.scalp, scalp.asset.id)))?
            .joints
            .clone();
        let strips = gpu.mesh(&settings.strands)?;
        let strands = strips.asset.settings.strands().ok_or_else(|| {
            bad(format!("binds `{}`, which is a {}, not strands", settings.strands, strips.asset.kind.name()))
        })?;
        if strips.desc != hikage_bundle::strands_desc(strips.desc.vertex_count) {
            return Err(bad(format!("`{}` does not hold format 1.5's strand records", settings.strands)));
        }
        let (Some(binding_mesh), Some(scalp_mesh)) = (binding.mesh(), scalp.mesh()) else {
            return Err(bad("the binding and the scalp must be meshes".into()));
        };
        let bindings: Vec<StrandBinding> = hikage_bundle::binding::read_binding(binding_mesh).map_err(&bad)?;
        let cpu_scalp = Scalp::read(scalp_mesh).map_err(&bad)?;
        cpu_scalp.check(&bindings, joint_names.len(), strands.strands).map_err(&bad)?;
        if cpu_scalp.triangles.is_empty() {
            return Err(bad("the scalp has no triangles".into()));
        }
        // The pass reads the streams as 4-byte words, as hikage writes them.
        let aligned = |m: &hikage_bundle::MeshData| {
            m.desc.attributes.iter().chain(m.desc.indices.iter()).all(|a| a.offset % 4 == 0 && a.stride % 4 == 0)
                && m.desc.indices.as_ref().is_none_or(|i| i.component == hikage_bundle::ComponentType::U32)
        };
        if !aligned(binding_mesh) || !aligned(scalp_mesh) {
            return Err(bad("the binding and the scalp must have 4-byte aligned streams and U32 indices".into()));
        }
        let words = |a: &hikage_bundle::Accessor| [(a.offset / 4) as u32, a.stride / 4];
        let accessor = |mesh: &hikage_bundle::MeshData, name: &str| {
            mesh.desc.attribute(name).map(words).expect("streams checked when read")
        };
        let points = strips.desc.vertex_count;
        let limit = device.limits().max_compute_workgroups_per_dimension;
        let groups = points.div_ceil(SKIN_WORKGROUP).max(1);
        let groups = (groups.min(limit), groups.div_ceil(limit));
        let params = SkinParams {
            points,
            joint_count: joint_names.len() as u32,
            strands: strands.strands,
            groups_x: groups.0,
            position: accessor(scalp_mesh, "position"),
            joints: accessor(scalp_mesh, "joints"),
            weights: accessor(scalp_mesh, "weights"),
            index_at: scalp_mesh.desc.indices.as_ref().map_or(0, |a| (a.offset / 4) as u32),
            triangle: accessor(binding_mesh, "triangle"),
            barycentric: accessor(binding_mesh, "barycentric"),
            _pad: 0,
        };
        let storage = |label: &str, bytes: &[u8]| {
            let size = (bytes.len() as u64).div_ceil(4).max(1) * 4;
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut padded = bytes.to_vec();
            padded.resize(size as usize, 0);
            queue.write_buffer(&buffer, 0, &padded);
            buffer
        };
        let built = gpu::checked(device, &id, || {
            let binding_buffer = storage("hikage hair binding", &binding_mesh.bytes);
            let scalp_buffer = storage("hikage hair scalp", &scalp_mesh.bytes);
            let identity: Vec<u8> =
                (0..joint_names.len()).flat_map(|_| bytemuck::bytes_of(&Mat4::IDENTITY).to_vec()).collect();
            let joints = storage("hikage hair joints", &identity);
            let posed = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hikage hair posed records"),
                size: strips.buffer.size(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let params = gpu::uniform_buffer(device, queue, "hikage hair skin", &params);
            let read = |b| {
                gpu::entry(
                    b,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                )
            };
            let compute = |mut e: wgpu::BindGroupLayoutEntry| {
                e.visibility = wgpu::ShaderStages::COMPUTE;
                e
            };
            let entries = [
                gpu::uniform_entry::<SkinParams>(0),
                read(1),
                gpu::entry(
                    2,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: false },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
                read(3),
                read(4),
                read(5),
            ]
            .map(compute);
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("hikage hair skin"),
                entries: &entries,
            });
            let buffers = [&params, &strips.buffer, &posed, &binding_buffer, &scalp_buffer, &joints];
            let group_entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
                .collect();
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("hikage hair skin"),
                layout: &layout,
                entries: &group_entries,
            });
            let module = gpu::module(device, "hikage hair skin", HAIR_SKIN_WGSL);
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("hikage hair skin"),
                layout: Some(&gpu::pipeline_layout(device, 0, &layout)),
                module: &module,
                entry_point: Some("hair_skin"),
                compilation_options: Default::default(),
                cache: None,
            });
            (posed, joints, pipeline, group)
        })?;
        let (posed, joints, pipeline, group) = built;
        Ok(HairSkin {
            assets: vec![id, settings.scalp.clone(), settings.strands.clone()],
            joint_names,
            scalp: cpu_scalp,
            points,
            posed,
            joints,
            pipeline,
            group,
            groups,
        })
    }

    /// The skin's joints in the order [`update`](Self::update) takes their matrices: the
    /// names of the glTF joint nodes the scalp was baked from.
    pub fn joint_names(&self) -> &[String] {
        &self.joint_names
    }

    /// The ids of the assets the skin was built from (binding, scalp, strands): after a reload
    /// whose [`crate::Changes::touches`] them, build it again.
    pub fn asset_ids(&self) -> &[String] {
        &self.assets
    }

    /// Records the skin poses: the records of the strands asset, posed by the last
    /// [`update`](Self::update) once [`record`](Self::record) has run.
    pub fn posed_records(&self) -> &wgpu::Buffer {
        &self.posed
    }

    /// The number of records posed.
    pub fn points(&self) -> u32 {
        self.points
    }

    /// Takes this frame's joint matrices (each joint's world matrix times its inverse bind
    /// matrix, in [`joint_names`](Self::joint_names) order, as glTF skinning and Bevy's
    /// `SkinnedMesh` define them) and returns the box the posed hair lies in: the skinned
    /// scalp vertices, each grown by how far its strands reach. Fit the light and the frame's
    /// `bounds` to it.
    pub fn update(&self, queue: &wgpu::Queue, joints: &[Mat4]) -> Result<(Vec3, Vec3), RuntimeError> {
        if joints.len() != self.joint_names.len() {
            return Err(RuntimeError::Asset {
                asset: self.assets[0].clone(),
                message: format!(
                    "{} joint matrices given, the skin has {} joints",
                    joints.len(),
                    self.joint_names.len()
                ),
            });
        }
        queue.write_buffer(&self.joints, 0, bytemuck::cast_slice(joints));
        Ok(self.bounds(joints))
    }

    /// The box the hair lies in when posed by `joints` (see [`update`](Self::update)).
    pub fn bounds(&self, joints: &[Mat4]) -> (Vec3, Vec3) {
        super::reference::skin_bounds(&self.scalp, joints)
    }

    /// Records the skinning pass into `encoder`: every record posed by the joint matrices of
    /// the last [`update`](Self::update). Record it before the hair's passes.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("hikage hair skin"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
    }
}
