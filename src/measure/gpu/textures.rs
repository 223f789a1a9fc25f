//! A kernel's textures and samplers on the device (kernels/README.md, "Textures and samplers of
//! a kernel"): each `//! texture:` file uploaded as a one-level texture of its stored precision
//! (R/RG/RGBA 32- or 16-bit float; three channels padded to four with 1), each `//! sampler:`
//! made with its filter and address mode, bound in group 1 at the bindings composition gave
//! them. A float32 texture filters linearly only with `FLOAT32_FILTERABLE`, requested when the
//! adapter has it (src/kernel/caps.rs); without it a linear sampler beside a float32 texture is
//! refused, saying so.

use super::device::Gpu;
use crate::input::texture_file::{TexelFormat, TextureData};
use crate::kernel::{AddressMode, Filter, KernelError, KernelFile, KERNEL_GROUP};
use naga::{ImageDimension, TypeInner};

/// Group 1 of a texture kernel: its layout and bind group (the textures kept alive with it).
pub(crate) struct KernelResources {
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) bind_group: wgpu::BindGroup,
    _textures: Vec<wgpu::Texture>,
}

fn format(data: &TextureData) -> (wgpu::TextureFormat, u8) {
    use wgpu::TextureFormat as F;
    let channels = if data.channels == 3 { 4 } else { data.channels };
    let f = match (data.stored, channels) {
        (TexelFormat::F32, 1) => F::R32Float,
        (TexelFormat::F32, 2) => F::Rg32Float,
        (TexelFormat::F32, _) => F::Rgba32Float,
        (TexelFormat::F16, 1) => F::R16Float,
        (TexelFormat::F16, 2) => F::Rg16Float,
        (TexelFormat::F16, _) => F::Rgba16Float,
    };
    (f, channels)
}

/// The texels as the format stores them (three channels padded with 1; half texels, widened
/// exactly on reading, narrowed back exactly).
fn bytes(data: &TextureData, channels: u8) -> Vec<u8> {
    let n = data.channels as usize;
    let mut out = Vec::new();
    for texel in data.texels.chunks_exact(n) {
        for c in 0..channels as usize {
            let v = texel.get(c).copied().unwrap_or(1.0);
            match data.stored {
                TexelFormat::F32 => out.extend_from_slice(&v.to_le_bytes()),
                TexelFormat::F16 => out.extend_from_slice(&half::f16::from_f32(v).to_le_bytes()),
            }
        }
    }
    out
}

/// Group 1 of `kernel` composed as `module`; None for a kernel without textures or samplers.
pub(crate) fn kernel_resources(
    gpu: &Gpu,
    kernel: &KernelFile,
    module: &naga::Module,
) -> Result<Option<KernelResources>, KernelError> {
    if kernel.textures.is_empty() && kernel.samplers.is_empty() {
        return Ok(None);
    }
    let refuse = |line: usize, message: String| KernelError {
        path: kernel.path.clone(),
        location: Some((line as u32, 1)),
        report: format!("{}:{line}: {message}", kernel.path),
        message,
    };
    let filterable_f32 = gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE);
    let any_f32 = kernel.textures.iter().any(|t| t.data.stored == TexelFormat::F32);
    let filterable = filterable_f32 || !any_f32;
    if let Some(s) = kernel.samplers.iter().find(|s| s.spec.filter == Filter::Linear) {
        if !filterable {
            let t = kernel
                .textures
                .iter()
                .find(|t| t.data.stored == TexelFormat::F32)
                .expect("any_f32");
            return Err(refuse(
                s.line,
                format!(
                    "sampler `{}` filters linearly and texture `{}` holds float32 texels, which filter linearly \
                     only with wgpu's FLOAT32_FILTERABLE feature, and this adapter ({}) lacks it: sample \
                     `nearest`, or store the texels as float16",
                    s.name, t.name, gpu.adapter.name
                ),
            ));
        }
    }
    let global = |name: &str| {
        module
            .global_variables
            .iter()
            .find(|(_, g)| g.name.as_deref() == Some(name))
            .map(|(_, g)| g)
    };
    // The global a header names and its binding, which composition put in the kernel's group.
    let bound = |name: &str, line: usize, what: &str| {
        let g = global(name).ok_or_else(|| refuse(line, format!("no global `{name}`")))?;
        let binding = g.binding.expect("composition binds every texture and sampler");
        if binding.group != KERNEL_GROUP {
            return Err(refuse(
                line,
                format!(
                    "`{name}` is bound in group {}: the harness binds a kernel's {what} in group {KERNEL_GROUP} only (so far)",
                    binding.group
                ),
            ));
        }
        Ok((g, binding))
    };
    let mut layout_entries = Vec::new();
    let mut textures = Vec::new();
    let mut views = Vec::new();
    for t in &kernel.textures {
        let (g, binding) = bound(&t.name, t.line, "textures")?;
        let TypeInner::Image { dim, arrayed, .. } = module.types[g.ty].inner else {
            unreachable!("a texture header names a texture global (compose.rs)")
        };
        let d = &t.data;
        let (view_dim, texture_dim) = match (dim, arrayed) {
            (ImageDimension::D2, false) => (wgpu::TextureViewDimension::D2, wgpu::TextureDimension::D2),
            (ImageDimension::D2, true) => (wgpu::TextureViewDimension::D2Array, wgpu::TextureDimension::D2),
            (ImageDimension::D3, _) => (wgpu::TextureViewDimension::D3, wgpu::TextureDimension::D3),
            _ => {
                return Err(refuse(
                    t.line,
                    format!(
                        "`{}`: a kernel's texture is a texture_2d, texture_2d_array or texture_3d",
                        t.name
                    ),
                ))
            }
        };
        if view_dim == wgpu::TextureViewDimension::D2 && d.depth_or_layers != 1 {
            return Err(refuse(
                t.line,
                format!(
                    "`{}` is a texture_2d but {} holds {d}: declare it texture_2d_array or texture_3d",
                    t.name, t.file
                ),
            ));
        }
        let (fmt, channels) = format(d);
        let size = wgpu::Extent3d {
            width: d.width,
            height: d.height,
            depth_or_array_layers: d.depth_or_layers,
        };
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(&t.name),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: texture_dim,
            format: fmt,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let texel_bytes = u32::from(channels) * d.stored.bytes() as u32;
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &bytes(d, channels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(d.width * texel_bytes),
                rows_per_image: Some(d.height),
            },
            size,
        );
        views.push((
            binding.binding,
            texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(view_dim),
                ..Default::default()
            }),
        ));
        layout_entries.push(wgpu::BindGroupLayoutEntry {
            binding: binding.binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable },
                view_dimension: view_dim,
                multisampled: false,
            },
            count: None,
        });
        textures.push(texture);
    }
    let mut samplers = Vec::new();
    for s in &kernel.samplers {
        let (_, binding) = bound(&s.name, s.line, "samplers")?;
        let filter = match s.spec.filter {
            Filter::Linear => wgpu::FilterMode::Linear,
            Filter::Nearest => wgpu::FilterMode::Nearest,
        };
        let address = match s.spec.address {
            AddressMode::Clamp => wgpu::AddressMode::ClampToEdge,
            AddressMode::Repeat => wgpu::AddressMode::Repeat,
        };
        samplers.push((
            binding.binding,
            gpu.device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some(&s.name),
                address_mode_u: address,
                address_mode_v: address,
                address_mode_w: address,
                mag_filter: filter,
                min_filter: filter,
                ..Default::default()
            }),
        ));
        layout_entries.push(wgpu::BindGroupLayoutEntry {
            binding: binding.binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Sampler(if filterable {
                wgpu::SamplerBindingType::Filtering
            } else {
                wgpu::SamplerBindingType::NonFiltering
            }),
            count: None,
        });
    }
    let layout = gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("linelight kernel textures"),
        entries: &layout_entries,
    });
    let entries: Vec<wgpu::BindGroupEntry> = views
        .iter()
        .map(|(b, v)| wgpu::BindGroupEntry {
            binding: *b,
            resource: wgpu::BindingResource::TextureView(v),
        })
        .chain(samplers.iter().map(|(b, s)| wgpu::BindGroupEntry {
            binding: *b,
            resource: wgpu::BindingResource::Sampler(s),
        }))
        .collect();
    let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("linelight kernel textures"),
        layout: &layout,
        entries: &entries,
    });
    Ok(Some(KernelResources {
        layout,
        bind_group,
        _textures: textures,
    }))
}
