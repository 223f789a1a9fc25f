//! Look-up table files as engines ship them, read into one typed value, [`TextureData`]: level 0
//! of a 2-D, 2-D array or 3-D texture of 1 to 4 float channels, its texels widened to f32
//! (exactly, from binary16 where the file stores half floats).
//!
//! | format | file | texel formats | kinds |
//! | --- | --- | --- | --- |
//! | DDS ([`dds`]) | `.dds` with a DX10 header (ltc_code's `ltc_1.dds`, `ltc_2.dds`), or a legacy header with a float FourCC (111–116) | DXGI `R32G32B32A32_FLOAT` (2), `R32G32B32_FLOAT` (6), `R16G16B16A16_FLOAT` (10), `R32G32_FLOAT` (16), `R16G16_FLOAT` (34), `R32_FLOAT` (41), `R16_FLOAT` (54) | 2d (1-D as 2d of height 1), 2d_array, 3d |
//! | KTX2 ([`ktx`]) | `.ktx2`, no supercompression | `VK_FORMAT_R16…_SFLOAT` and `R32…_SFLOAT` of 1–4 channels, checked against the data format descriptor | 2d, 2d_array, 3d |
//! | OpenEXR ([`openexr`]) | `.exr`, one part, scan lines or tiles (mip-mapped: level 0) | all channels half or all float: `R`, `R G`, `R G B`, `R G B A`, or one channel of any name | 2d |
//! | NumPy ([`numpy`]) | `.npy`, C order, little- or big-endian | `float16`, `float32` | (N,) and (H, W): 2d, 1 channel; (H, W, C): 2d, C ≤ 4 channels; (D, H, W, C): 3d |
//!
//! Texels are stored x fastest, then y, then the layer or slice, channels interleaved:
//! channel `c` of texel (x, y, z) is `texels[((z·height + y)·width + x)·channels + c]`. Row 0
//! is the first row in the file (what wgpu uploads as v = 0); KTX2's `KTXorientation` is not
//! applied.
//!
//! **Sizes are checked before the texels are read.** A file is opened as a regular file of at
//! most [`MAX_LUT_FILE_BYTES`] (checked from its length, before a byte is read); its header is
//! read and parsed (by the crates `ddsfile`, `ktx2`, `exr` and `npyz`); the declared sides must
//! be at most [`MAX_LUT_SIDE`] and level 0 at most [`MAX_LUT_TEXELS`] texels; and the bytes it
//! declares must lie inside the file. Only then is the payload read (and allocated, at most its
//! declared size, itself bounded by the caps). A refusal names the file, what it declared and the
//! limit or the file's length. An OpenEXR file compresses its pixels, so its length bounds them only
//! where it is uncompressed; its declared size is capped all the same.
//!
//! More than one mip level: level 0 is read and [`TextureData::mip_levels`] says how many the
//! file holds (a kernel's binding refuses more than one). Cube maps, block-compressed formats
//! (BCn, ASTC, ETC, Basis), integer and normalised formats, float64 and KTX2 supercompression
//! are refused, each with a message saying what to store instead.

pub mod dds;
pub mod ktx;
pub mod numpy;
pub mod openexr;

use std::fmt;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use crate::io::InputError;
use crate::limits::Bytes;
pub use crate::limits::{MAX_LUT_FILE_BYTES, MAX_LUT_SIDE, MAX_LUT_TEXELS};

/// The file formats read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FileFormat {
    Dds,
    Ktx2,
    Exr,
    Npy,
}

impl FileFormat {
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Dds => "DDS",
            FileFormat::Ktx2 => "KTX2",
            FileFormat::Exr => "OpenEXR",
            FileFormat::Npy => "NumPy .npy",
        }
    }

    /// The format a file name's extension names (`.dds`, `.ktx2`, `.exr`, `.npy`, any case).
    pub fn from_path(path: &Path) -> Option<FileFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "dds" => FileFormat::Dds,
            "ktx2" => FileFormat::Ktx2,
            "exr" => FileFormat::Exr,
            "npy" => FileFormat::Npy,
            _ => return None,
        })
    }
}

/// The texture's dimensionality, as a kernel declares it (`texture_2d`, `texture_2d_array`,
/// `texture_3d`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dimension {
    D2,
    D2Array,
    D3,
}

impl Dimension {
    pub fn name(self) -> &'static str {
        match self {
            Dimension::D2 => "2d",
            Dimension::D2Array => "2d_array",
            Dimension::D3 => "3d",
        }
    }
}

/// A texel channel as the file stores it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TexelFormat {
    F16,
    F32,
}

impl TexelFormat {
    /// Bytes of one channel.
    pub fn bytes(self) -> u64 {
        match self {
            TexelFormat::F16 => 2,
            TexelFormat::F32 => 4,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            TexelFormat::F16 => "f16",
            TexelFormat::F32 => "f32",
        }
    }
}

/// Level 0 of a look-up table file.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureData {
    pub width: u32,
    pub height: u32,
    /// Layers of a 2d_array, slices of a 3d texture, 1 for a 2d one.
    pub depth_or_layers: u32,
    pub kind: Dimension,
    /// 1 to 4.
    pub channels: u8,
    /// The channels' format in the file (the texels below are f32 either way).
    pub stored: TexelFormat,
    /// Mip levels in the file, level 0 included; only level 0 is read.
    pub mip_levels: u32,
    /// `width × height × depth_or_layers × channels` values, x fastest, channels interleaved.
    pub texels: Vec<f32>,
    pub format: FileFormat,
}

impl TextureData {
    /// Channel `c` of texel (x, y, z).
    pub fn texel(&self, x: u32, y: u32, z: u32, c: u8) -> f32 {
        let (w, h, n) = (self.width as usize, self.height as usize, self.channels as usize);
        self.texels[((z as usize * h + y as usize) * w + x as usize) * n + c as usize]
    }
}

impl fmt::Display for TextureData {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {} texture {} × {}",
            self.format.name(),
            self.kind.name(),
            self.width,
            self.height
        )?;
        if self.kind != Dimension::D2 {
            write!(f, " × {}", self.depth_or_layers)?;
        }
        write!(
            f,
            ", {} channel{} of {}, {} mip level{}",
            self.channels,
            if self.channels == 1 { "" } else { "s" },
            self.stored.name(),
            self.mip_levels,
            if self.mip_levels == 1 { "" } else { "s" }
        )
    }
}

/// Reads a look-up table file, its format chosen by its extension (`.dds`, `.ktx2`, `.exr`,
/// `.npy`) and checked against its magic bytes.
pub fn read(path: &Path) -> Result<TextureData, InputError> {
    let format = FileFormat::from_path(path).ok_or_else(|| {
        InputError(format!(
            "look-up table file {}: unknown extension (expected .dds, .ktx2, .exr or .npy)",
            path.display()
        ))
    })?;
    read_as(path, format)
}

/// Reads a look-up table file in `format`.
pub fn read_as(path: &Path, format: FileFormat) -> Result<TextureData, InputError> {
    let mut src = Source::open(path)?;
    match format {
        FileFormat::Dds => dds::read(&mut src),
        FileFormat::Ktx2 => ktx::read(&mut src),
        FileFormat::Exr => openexr::read(&mut src),
        FileFormat::Npy => numpy::read(&mut src),
    }
}

/// An opened look-up table file: its length, known before anything is read, and reads of its
/// header and of byte ranges checked to lie inside it.
pub(crate) struct Source {
    path: PathBuf,
    file: std::fs::File,
    len: u64,
}

#[cfg(test)]
thread_local! {
    /// Bytes of payload read on this thread (the tests check that a refused file had none).
    pub(crate) static PAYLOAD_READ: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

impl Source {
    fn open(path: &Path) -> Result<Source, InputError> {
        let (take, len) = crate::io::open_regular(path, "look-up table file", MAX_LUT_FILE_BYTES)?;
        Ok(Source {
            path: path.to_path_buf(),
            file: take.into_inner(),
            len,
        })
    }

    pub(crate) fn len(&self) -> u64 {
        self.len
    }

    /// A refusal naming the file.
    pub(crate) fn refuse(&self, message: impl fmt::Display) -> InputError {
        InputError(format!("look-up table file {}: {message}", self.path.display()))
    }

    /// The first `n` bytes, or the whole file when it is shorter (headers: the caller checks
    /// what it needs).
    pub(crate) fn head(&mut self, n: u64) -> Result<Vec<u8>, InputError> {
        let n = n.min(self.len);
        self.range(0, n)
    }

    /// Bytes `offset .. offset + n`, which the caller has checked against the caps; refused as
    /// truncated where they pass the file's end.
    pub(crate) fn bytes(&mut self, offset: u64, n: u64, what: &str) -> Result<Vec<u8>, InputError> {
        if offset.checked_add(n).is_none_or(|end| end > self.len) {
            return Err(self.refuse(format!(
                "{what} spans bytes {offset} to {} but the file has only {} bytes: truncated, not read",
                offset.saturating_add(n),
                self.len
            )));
        }
        #[cfg(test)]
        PAYLOAD_READ.with(|c| c.set(c.get() + n));
        self.range(offset, n)
    }

    fn range(&mut self, offset: u64, n: u64) -> Result<Vec<u8>, InputError> {
        let mut out = vec![0u8; n as usize];
        self.file
            .seek(SeekFrom::Start(offset))
            .and_then(|_| self.file.read_exact(&mut out))
            .map_err(|e| self.refuse(format!("cannot read bytes {offset} to {}: {e}", offset + n)))?;
        Ok(out)
    }

    /// The file itself, for a decoder that seeks (OpenEXR).
    pub(crate) fn file(&mut self) -> &mut std::fs::File {
        &mut self.file
    }
}

/// What a header declares, checked against the caps before anything else is read.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Declared {
    pub width: u64,
    pub height: u64,
    pub depth_or_layers: u64,
    pub kind: Dimension,
    pub channels: u8,
    pub stored: TexelFormat,
    pub mip_levels: u32,
}

impl Declared {
    /// Bytes of one texel.
    pub fn texel_bytes(&self) -> u64 {
        u64::from(self.channels) * self.stored.bytes()
    }

    /// Level 0's texels (saturating: the caps refuse what saturates).
    pub fn texels(&self) -> u64 {
        self.width
            .saturating_mul(self.height)
            .saturating_mul(self.depth_or_layers)
    }

    /// Level 0's bytes.
    pub fn level0_bytes(&self) -> u64 {
        self.texels().saturating_mul(self.texel_bytes())
    }

    fn shape(&self) -> String {
        let mut s = format!("{} × {}", self.width, self.height);
        if self.kind != Dimension::D2 {
            s += &format!(" × {}", self.depth_or_layers);
        }
        s
    }

    /// Refuses sides of 0 or above [`MAX_LUT_SIDE`], more than [`MAX_LUT_TEXELS`] texels, and
    /// channels outside 1–4.
    pub fn check_caps(&self, src: &Source) -> Result<(), InputError> {
        if !(1..=4).contains(&self.channels) {
            return Err(src.refuse(format!("declares {} channels: 1 to 4 are read", self.channels)));
        }
        let sides = [self.width, self.height, self.depth_or_layers];
        if sides.contains(&0) {
            return Err(src.refuse(format!("declares an empty texture ({})", self.shape())));
        }
        if sides.iter().any(|&s| s > u64::from(MAX_LUT_SIDE)) || self.texels() > MAX_LUT_TEXELS {
            return Err(src.refuse(format!(
                "declares {} texels of {} bytes ({} in level 0): more than a look-up table may hold \
                 (at most {MAX_LUT_SIDE} a side and {MAX_LUT_TEXELS} texels); not read",
                self.shape(),
                self.texel_bytes(),
                Bytes(self.level0_bytes())
            )));
        }
        Ok(())
    }

    /// Refuses a payload of `n` bytes at `offset` that passes the file's end, before it is read.
    pub fn check_inside(&self, src: &Source, offset: u64, n: u64) -> Result<(), InputError> {
        if offset.checked_add(n).is_none_or(|end| end > src.len()) {
            return Err(src.refuse(format!(
                "declares {} texels of {} bytes ({} bytes from byte {offset}), but the file has only {} \
                 bytes: truncated, not read",
                self.shape(),
                self.texel_bytes(),
                n,
                src.len()
            )));
        }
        Ok(())
    }

    /// Refuses a file shorter than the `least` bytes its header implies (`what`: which bytes),
    /// where the payload's place is not known before decoding (OpenEXR).
    pub fn check_length(&self, src: &Source, least: u64, what: &str) -> Result<(), InputError> {
        if least > src.len() {
            return Err(src.refuse(format!(
                "declares {} texels of {} bytes{what}: at least {least} bytes, but the file has only {} bytes: \
                 truncated, not read",
                self.shape(),
                self.texel_bytes(),
                src.len()
            )));
        }
        Ok(())
    }

    /// The value, with level 0's stored bytes widened to f32.
    pub fn finish(self, bytes: &[u8], format: FileFormat) -> TextureData {
        TextureData {
            width: self.width as u32,
            height: self.height as u32,
            depth_or_layers: self.depth_or_layers as u32,
            kind: self.kind,
            channels: self.channels,
            stored: self.stored,
            mip_levels: self.mip_levels,
            texels: widen(bytes, self.stored),
            format,
        }
    }
}

/// Little-endian f16 or f32 values, as f32 (binary16 widens exactly).
pub(crate) fn widen(bytes: &[u8], stored: TexelFormat) -> Vec<f32> {
    match stored {
        TexelFormat::F32 => bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
        TexelFormat::F16 => bytes
            .chunks_exact(2)
            .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())
            .collect(),
    }
}

/// The most mip levels a texture of these sides can have (⌊log₂ of the longest⌋ + 1).
pub(crate) fn max_mip_levels(sides: &[u64]) -> u32 {
    let longest = sides.iter().copied().max().unwrap_or(1).max(1);
    64 - longest.leading_zeros()
}

#[cfg(test)]
mod tests;
