//! The shader capabilities kernels are composed and validated with, before any device is
//! open: those of the optional wgpu features linelight requests (wgpu's feature names are
//! constants here; no device is needed).

use naga::valid::Capabilities;

/// Requested when the adapter has them: timestamps to time dispatches, and the shader
/// types and operations a kernel may `enable`.
pub(crate) const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::TIMESTAMP_QUERY
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES)
    .union(wgpu::Features::SHADER_F16)
    .union(wgpu::Features::SHADER_F64)
    .union(wgpu::Features::SHADER_I16)
    .union(wgpu::Features::SHADER_INT64)
    .union(wgpu::Features::SUBGROUP)
    .union(wgpu::Features::SUBGROUP_BARRIER)
    // Linear filtering of a kernel's float32 textures (src/measure/gpu/textures.rs).
    .union(wgpu::Features::FLOAT32_FILTERABLE);

/// The shader capabilities kernels are checked with before any device is open: those of
/// every feature linelight requests when the adapter has it. A device without one of them
/// then refuses the kernel when its pipeline is made, naming the device.
pub fn kernel_capabilities() -> Capabilities {
    naga_capabilities(OPTIONAL_FEATURES)
}

/// The shader capabilities the requested features grant (as wgpu maps them), so naga
/// accepts exactly what wgpu will.
pub(crate) fn naga_capabilities(features: wgpu::Features) -> Capabilities {
    let mut caps = Capabilities::default();
    for (feature, cap) in [
        (wgpu::Features::SHADER_F16, Capabilities::SHADER_FLOAT16),
        (wgpu::Features::SHADER_F64, Capabilities::FLOAT64),
        (wgpu::Features::SHADER_I16, Capabilities::SHADER_INT16),
        (wgpu::Features::SHADER_INT64, Capabilities::SHADER_INT64),
        (wgpu::Features::SUBGROUP, Capabilities::SUBGROUP),
        (wgpu::Features::SUBGROUP_BARRIER, Capabilities::SUBGROUP_BARRIER),
    ] {
        caps.set(cap, features.contains(feature));
    }
    caps
}
