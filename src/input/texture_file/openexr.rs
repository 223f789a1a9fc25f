//! OpenEXR: the magic `76 2f 31 01`, the version and flags, then the headers (attributes), read
//! and checked by the `exr` crate's meta-data reader before any pixel is; then level 0 of the one
//! part, through `exr`'s image reader. Scan lines or tiles; a mip-mapped file reports its
//! levels (rip maps are refused). Channels are stored sorted by name (`A`, `B`, `G`, `R`); they
//! are read as `R`, `R G`, `R G B` or `R G B A`, or a single channel of any name (`Y`, `L`, …).
//! All channels half, or all float: u32 channels and mixed types are refused. A file's pixels
//! may be compressed, so its length bounds them only when it is uncompressed; otherwise the
//! offset table (8 bytes a chunk) must fit, and the declared size is capped all the same.

use exr::meta::attribute::{LevelMode, SampleType};
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::{ReadChannels as _, ReadLayers as _};

use super::{Declared, Dimension, FileFormat, Source, TexelFormat, TextureData};
use crate::io::InputError;

const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

pub(crate) fn read(src: &mut Source) -> Result<TextureData, InputError> {
    let head = src.head(4)?;
    if head[..] != MAGIC {
        return Err(src.refuse(format!(
            "not an OpenEXR file: its first bytes are {head:02x?}, not {MAGIC:02x?}"
        )));
    }
    let meta = {
        let file = src.file();
        use std::io::Seek;
        file.rewind().map_err(|e| InputError(e.to_string()))?;
        MetaData::read_from_buffered(std::io::BufReader::new(&*file), false)
    }
    .map_err(|e| src.refuse(format!("bad OpenEXR header: {e}")))?;
    let [header] = &meta.headers[..] else {
        return Err(src.refuse(format!(
            "{} parts: one (a single-part file) is read",
            meta.headers.len()
        )));
    };
    if header.deep {
        return Err(src.refuse("deep data: a look-up table is a flat image"));
    }
    let mip_levels = match header.blocks {
        BlockDescription::ScanLines => 1,
        BlockDescription::Tiles(t) => match t.level_mode {
            LevelMode::Singular => 1,
            LevelMode::MipMap => {
                let longest = header.layer_size.0.max(header.layer_size.1);
                if longest == 0 || longest > super::MAX_LUT_SIDE as usize {
                    1 // refused below, by the caps
                } else {
                    exr::meta::compute_level_count(t.rounding_mode, longest) as u32
                }
            }
            LevelMode::RipMap => {
                return Err(src.refuse("rip-mapped tiles: store level 0 alone (or mip-mapped)"));
            }
        },
    };
    let names: Vec<String> = header.channels.list.iter().map(|c| c.name.to_string()).collect();
    let order = channel_order(&names).ok_or_else(|| {
        src.refuse(format!(
            "channels {}: read are R, R G, R G B, R G B A, or one channel of any name",
            names.join(" ")
        ))
    })?;
    if header
        .channels
        .list
        .iter()
        .any(|c| c.sampling.0 != 1 || c.sampling.1 != 1)
    {
        return Err(src.refuse("subsampled channels: every channel of a look-up table is full resolution"));
    }
    let stored = match header.channels.uniform_sample_type {
        Some(SampleType::F16) => TexelFormat::F16,
        Some(SampleType::F32) => TexelFormat::F32,
        Some(SampleType::U32) => {
            return Err(src.refuse("u32 channels: an integer format; store half or float channels"))
        }
        None => {
            return Err(src.refuse("channels of mixed types: store every channel as half, or every channel as float"))
        }
    };
    let declared = Declared {
        width: header.layer_size.0 as u64,
        height: header.layer_size.1 as u64,
        depth_or_layers: 1,
        kind: Dimension::D2,
        channels: order.len() as u8,
        stored,
        mip_levels,
    };
    declared.check_caps(src)?;
    // The offset table and, uncompressed, level 0's pixels must be inside the file.
    let table = (header.chunk_count as u64).saturating_mul(8);
    if header.compression == exr::compression::Compression::Uncompressed {
        let least = table.saturating_add(declared.level0_bytes());
        declared.check_length(src, least, ", uncompressed, so its offset table and pixels need")?;
    } else {
        let what = format!(
            " in {} compressed chunks, so its offset table needs",
            header.chunk_count
        );
        declared.check_length(src, table, &what)?;
    }
    #[cfg(test)]
    super::PAYLOAD_READ.with(|c| c.set(c.get() + src.len()));
    let image = {
        let file = src.file();
        use std::io::Seek;
        file.rewind().map_err(|e| InputError(e.to_string()))?;
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(std::io::BufReader::new(&*file))
    }
    .map_err(|e| src.refuse(format!("bad OpenEXR file: {e}")))?;
    let layer = &image.layer_data;
    let n = layer.size.0 * layer.size.1;
    let planes: Vec<Vec<f32>> = order
        .iter()
        .map(|&i| match &layer.channel_data.list[i].sample_data {
            exr::prelude::FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
            exr::prelude::FlatSamples::F32(v) => v.clone(),
            exr::prelude::FlatSamples::U32(_) => unreachable!("refused above"),
        })
        .collect();
    if planes.iter().any(|p| p.len() != n) {
        return Err(src.refuse("a channel's samples do not fill the image"));
    }
    let mut out = declared.finish(&[], FileFormat::Exr);
    out.texels = (0..n).flat_map(|t| planes.iter().map(move |p| p[t])).collect();
    Ok(out)
}

/// The list positions (channels sorted by name, as OpenEXR stores them) of R, G, B, A in that
/// order, for the sets read; a single channel of any name.
fn channel_order(names: &[String]) -> Option<Vec<usize>> {
    if names.len() == 1 {
        return Some(vec![0]);
    }
    let want: &[&str] = match names.len() {
        2 => &["R", "G"],
        3 => &["R", "G", "B"],
        4 => &["R", "G", "B", "A"],
        _ => return None,
    };
    want.iter().map(|w| names.iter().position(|n| n == w)).collect()
}
