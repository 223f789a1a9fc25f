//! KTX2: the 80-byte header (its 12-byte identifier `«KTX 20»\r\n\x1A\n`, `vkFormat`, sides,
//! layers, faces, levels, supercompression and the section index) and the level index (24 bytes
//! a level: offset, length, uncompressed length) are read and checked first; then the file, at
//! most [`MAX_LUT_FILE_BYTES`](super::MAX_LUT_FILE_BYTES), is handed to the `ktx2` crate, which
//! validates every section. Level 0's data is layers → faces → slices → rows → texels. The data
//! format descriptor must agree with `vkFormat`: one float sample per channel, of its width.

use ktx2::{Format, Header, LevelIndex};

use super::{max_mip_levels, Declared, Dimension, FileFormat, Source, TexelFormat, TextureData};
use crate::io::InputError;

/// Channels and their format of the Vulkan formats read; why not, for the others.
fn vk_format(format: Option<Format>) -> Result<(u8, TexelFormat), String> {
    let Some(format) = format else {
        return Err(
            "vkFormat is VK_FORMAT_UNDEFINED (a format chosen at transcoding, as Basis Universal's): \
                    store the table uncompressed as R16G16B16A16_SFLOAT or R32G32B32A32_SFLOAT"
                .into(),
        );
    };
    Ok(match format {
        Format::R16_SFLOAT => (1, TexelFormat::F16),
        Format::R16G16_SFLOAT => (2, TexelFormat::F16),
        Format::R16G16B16_SFLOAT => (3, TexelFormat::F16),
        Format::R16G16B16A16_SFLOAT => (4, TexelFormat::F16),
        Format::R32_SFLOAT => (1, TexelFormat::F32),
        Format::R32G32_SFLOAT => (2, TexelFormat::F32),
        Format::R32G32B32_SFLOAT => (3, TexelFormat::F32),
        Format::R32G32B32A32_SFLOAT => (4, TexelFormat::F32),
        other => {
            let name = format!("{other:?}");
            let why = if name.contains("BLOCK") {
                "a block-compressed format"
            } else if name.contains("INT") || name.contains("NORM") || name.contains("SCALED") || name.contains("SRGB")
            {
                "an integer or normalised format"
            } else {
                "not one of the float formats read"
            };
            return Err(format!(
                "vkFormat {name} ({}) is {why}: store the table as R16G16B16A16_SFLOAT or R32G32B32A32_SFLOAT \
                 (or their 1- and 2-channel forms), uncompressed",
                other.value()
            ));
        }
    })
}

/// The most levels read from the level index (a 2³¹-texel side has 32).
const MAX_LEVELS: u32 = 32;

pub(crate) fn read(src: &mut Source) -> Result<TextureData, InputError> {
    let head = src.head(Header::LENGTH as u64)?;
    if head.len() < ktx2::MAGIC.len() || head[..ktx2::MAGIC.len()] != ktx2::MAGIC {
        return Err(src.refuse(format!(
            "not a KTX2 file: its first bytes are {:02x?}, not KTX2's identifier «KTX 20»",
            &head[..head.len().min(ktx2::MAGIC.len())]
        )));
    }
    let Ok(bytes80) = <[u8; Header::LENGTH]>::try_from(&head[..]) else {
        return Err(src.refuse(format!(
            "its KTX2 header is cut short: {} bytes, the header needs {}; truncated",
            head.len(),
            Header::LENGTH
        )));
    };
    let header = Header::from_bytes(&bytes80).map_err(|e| src.refuse(format!("bad KTX2 header: {e}")))?;
    if let Some(scheme) = header.supercompression_scheme {
        return Err(src.refuse(format!(
            "supercompressed ({scheme:?}): store the table without supercompression"
        )));
    }
    let (channels, stored) = vk_format(header.format).map_err(|e| src.refuse(e))?;
    if header.face_count == 6 {
        return Err(src.refuse("a cube map: look-up tables are 2d, 2d_array or 3d textures"));
    }
    if header.face_count != 1 {
        return Err(src.refuse(format!("declares {} faces (1, or 6 for a cube map)", header.face_count)));
    }
    let (kind, depth_or_layers) = match (header.pixel_depth, header.layer_count) {
        (0, 0) => (Dimension::D2, 1),
        (0, n) => (Dimension::D2Array, u64::from(n)),
        (d, 0) => (Dimension::D3, u64::from(d)),
        (d, n) => {
            return Err(src.refuse(format!(
                "an array of {n} 3d textures of depth {d}: one 3d texture is read"
            )))
        }
    };
    let (width, height) = (u64::from(header.pixel_width), u64::from(header.pixel_height.max(1)));
    let levels = header.level_count.max(1);
    let declared = Declared {
        width,
        height,
        depth_or_layers,
        kind,
        channels,
        stored,
        mip_levels: levels,
    };
    declared.check_caps(src)?;
    let slices = if kind == Dimension::D3 { depth_or_layers } else { 1 };
    if levels > MAX_LEVELS.min(max_mip_levels(&[width, height, slices])) {
        return Err(src.refuse(format!(
            "declares {levels} mip levels, more than a {width} × {height} × {slices} texture has"
        )));
    }
    let index_end = Header::LENGTH as u64 + LevelIndex::LENGTH as u64 * u64::from(levels);
    let index = src.head(index_end)?;
    if (index.len() as u64) < index_end {
        return Err(src.refuse(format!(
            "its level index is cut short: {} bytes, the header and index of {levels} levels need {index_end}; \
             truncated",
            index.len()
        )));
    }
    let level0 = LevelIndex::from_bytes(
        index[Header::LENGTH..Header::LENGTH + LevelIndex::LENGTH]
            .try_into()
            .expect("24 bytes"),
    );
    let expected = declared.level0_bytes();
    if level0.byte_length != expected || level0.uncompressed_byte_length != expected {
        return Err(src.refuse(format!(
            "level 0 holds {} bytes ({} uncompressed) but its {} texels of {} bytes need {expected}",
            level0.byte_length,
            level0.uncompressed_byte_length,
            declared.texels(),
            declared.texel_bytes()
        )));
    }
    declared.check_inside(src, level0.byte_offset, expected)?;
    // Checked: the whole file, which the crate validates, is at most the file cap.
    let whole = src.bytes(0, src.len(), "the file")?;
    let reader = ktx2::Reader::new(&whole[..]).map_err(|e| src.refuse(format!("bad KTX2 file: {e}")))?;
    check_dfd(&reader, channels, stored).map_err(|e| src.refuse(e))?;
    let data = reader.levels().next().expect("one level at least").data;
    Ok(declared.finish(data, FileFormat::Ktx2))
}

/// The basic data format descriptor must describe `channels` float samples of `stored`'s width.
fn check_dfd(reader: &ktx2::Reader<&[u8]>, channels: u8, stored: TexelFormat) -> Result<(), String> {
    let basic = reader
        .basic_dfd()
        .ok_or("it has no basic data format descriptor block")?;
    let bits = stored.bytes() as u8 * 8;
    let samples = &basic.sample_information;
    let float = ktx2::dfd::ChannelTypeQualifiers::FLOAT;
    if samples.len() != usize::from(channels)
        || samples
            .iter()
            .any(|s| s.bit_length.get() != bits || !s.channel_type_qualifiers.contains(float))
    {
        return Err(format!(
            "its data format descriptor ({} samples: {}) disagrees with vkFormat ({channels} float channels of {bits} \
             bits)",
            samples.len(),
            samples
                .iter()
                .map(|s| format!(
                    "{} bits{}",
                    s.bit_length,
                    if s.channel_type_qualifiers.contains(float) {
                        " float"
                    } else {
                        ""
                    }
                ))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(())
}
