//! DDS: the 4-byte magic `DDS `, the 124-byte header and, where its FourCC is `DX10`, the
//! 20-byte DX10 header (parsed by `ddsfile`), then every array layer's mip chain in turn, each
//! level x fastest. ltc_code writes its `ltc_1.dds` and `ltc_2.dds` this way, as
//! `R32G32B32A32_FLOAT` (or `R16G16B16A16_FLOAT`). A legacy header (no DX10) is read where its
//! FourCC names a float format (D3DFMT 111–116). Sizes are computed here in u64 from the header's
//! fields, never from the crate's u32 arithmetic.

use ddsfile::{Caps2, D3D10ResourceDimension, DxgiFormat, FourCC, Header, Header10, MiscFlag};

use super::{max_mip_levels, Declared, Dimension, FileFormat, Source, TexelFormat, TextureData};
use crate::io::InputError;

const MAGIC: &[u8; 4] = b"DDS ";
const HEADER: u64 = 4 + 124;
const HEADER_DX10: u64 = HEADER + 20;

/// Channels and their format of the DXGI formats read; why not, for the others.
fn dxgi(format: DxgiFormat) -> Result<(u8, TexelFormat), String> {
    use DxgiFormat as D;
    Ok(match format {
        D::R32G32B32A32_Float => (4, TexelFormat::F32),
        D::R32G32B32_Float => (3, TexelFormat::F32),
        D::R16G16B16A16_Float => (4, TexelFormat::F16),
        D::R32G32_Float => (2, TexelFormat::F32),
        D::R16G16_Float => (2, TexelFormat::F16),
        D::R32_Float => (1, TexelFormat::F32),
        D::R16_Float => (1, TexelFormat::F16),
        other => {
            let name = format!("{other:?}");
            let why = if name.starts_with("BC") {
                "a block-compressed format"
            } else if name.contains("Int") || name.contains("Norm") {
                "an integer or normalised format"
            } else {
                "not one of the float formats read"
            };
            return Err(format!(
                "DXGI format {name} ({}) is {why}: store the table as R32G32B32A32_FLOAT or R16G16B16A16_FLOAT \
                 (or their 1- and 2-channel forms), uncompressed",
                other as u32
            ));
        }
    })
}

/// The float FourCCs of a legacy header (D3DFMT_R16F … D3DFMT_A32B32G32R32F; memory order R, G,
/// B, A).
fn legacy(fourcc: u32) -> Option<(u8, TexelFormat)> {
    Some(match fourcc {
        FourCC::R16F => (1, TexelFormat::F16),
        FourCC::G16R16F => (2, TexelFormat::F16),
        FourCC::A16B16G16R16F => (4, TexelFormat::F16),
        FourCC::R32F => (1, TexelFormat::F32),
        FourCC::G32R32F => (2, TexelFormat::F32),
        FourCC::A32B32G32R32F => (4, TexelFormat::F32),
        _ => return None,
    })
}

pub(crate) fn read(src: &mut Source) -> Result<TextureData, InputError> {
    let head = src.head(HEADER_DX10)?;
    if head.len() < 4 || &head[..4] != MAGIC {
        return Err(src.refuse(format!(
            "not a DDS file: its first bytes are {:02x?}, not `DDS `",
            &head[..head.len().min(4)]
        )));
    }
    if (head.len() as u64) < HEADER {
        return Err(src.refuse(format!(
            "its DDS header is cut short: {} bytes, the header needs {HEADER}; truncated",
            head.len()
        )));
    }
    let header = Header::read(&head[4..HEADER as usize]).map_err(|e| src.refuse(format!("bad DDS header: {e}")))?;
    let fourcc = header.spf.fourcc.as_ref().map(|f| f.0);
    let (channels, stored, layers, dimension, cube, data_offset) = if fourcc == Some(FourCC::DX10) {
        if (head.len() as u64) < HEADER_DX10 {
            return Err(src.refuse(format!(
                "its DX10 header is cut short: {} bytes, the headers need {HEADER_DX10}; truncated",
                head.len()
            )));
        }
        let h10 = Header10::read(&head[HEADER as usize..HEADER_DX10 as usize])
            .map_err(|e| src.refuse(format!("bad DX10 header: {e}")))?;
        let (channels, stored) = dxgi(h10.dxgi_format).map_err(|e| src.refuse(e))?;
        let dimension = match h10.resource_dimension {
            D3D10ResourceDimension::Texture1D | D3D10ResourceDimension::Texture2D => Dimension::D2,
            D3D10ResourceDimension::Texture3D => Dimension::D3,
            other => return Err(src.refuse(format!("DX10 resource dimension {other:?} is not a texture"))),
        };
        let cube = h10.misc_flag.contains(MiscFlag::TEXTURECUBE);
        (
            channels,
            stored,
            u64::from(h10.array_size.max(1)),
            dimension,
            cube,
            HEADER_DX10,
        )
    } else {
        let Some((channels, stored)) = fourcc.and_then(legacy) else {
            return Err(src.refuse(format!(
                "a DDS file without a DX10 header whose pixel format ({}) is not a float one: write it with a \
                 DX10 header as R32G32B32A32_FLOAT or R16G16B16A16_FLOAT",
                match fourcc {
                    Some(f) => format!("FourCC {f:#x}"),
                    None => "an RGB bit mask".into(),
                }
            )));
        };
        let dimension = if header.caps2.contains(Caps2::VOLUME) || header.depth.is_some_and(|d| d > 1) {
            Dimension::D3
        } else {
            Dimension::D2
        };
        (
            channels,
            stored,
            1,
            dimension,
            header.caps2.contains(Caps2::CUBEMAP),
            HEADER,
        )
    };
    if cube {
        return Err(src.refuse("a cube map: look-up tables are 2d, 2d_array or 3d textures"));
    }
    let depth = u64::from(header.depth.unwrap_or(1).max(1));
    let (kind, depth_or_layers) = match dimension {
        Dimension::D3 if layers > 1 => {
            return Err(src.refuse(format!(
                "a 3d texture with {layers} array layers: DDS volume textures have one"
            )))
        }
        Dimension::D3 => (Dimension::D3, depth),
        _ if layers > 1 => (Dimension::D2Array, layers),
        _ => (Dimension::D2, 1),
    };
    let (width, height) = (u64::from(header.width), u64::from(header.height.max(1)));
    let mip_levels = header.mip_map_count.unwrap_or(1).max(1);
    let declared = Declared {
        width,
        height,
        depth_or_layers,
        kind,
        channels,
        stored,
        mip_levels,
    };
    declared.check_caps(src)?;
    let slices = if kind == Dimension::D3 { depth } else { 1 };
    if mip_levels > max_mip_levels(&[width, height, slices]) {
        return Err(src.refuse(format!(
            "declares {mip_levels} mip levels, more than a {width} × {height} × {slices} texture has"
        )));
    }
    // Each layer holds its whole mip chain, level 0 first.
    let level0 = width * height * slices * declared.texel_bytes();
    let stride: u64 = (0..mip_levels)
        .map(|i| (width >> i).max(1) * (height >> i).max(1) * (slices >> i).max(1) * declared.texel_bytes())
        .sum();
    let layer_count = if kind == Dimension::D2Array { layers } else { 1 };
    declared.check_inside(src, data_offset, stride * layer_count)?;
    let mut bytes = Vec::with_capacity(declared.level0_bytes() as usize);
    for layer in 0..layer_count {
        bytes.extend(src.bytes(data_offset + layer * stride, level0, "level 0")?);
    }
    Ok(declared.finish(&bytes, FileFormat::Dds))
}
