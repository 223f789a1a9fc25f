//! NumPy `.npy`: the magic `\x93NUMPY`, a version (1.0, 2.0 or 3.0), the header's length (u16
//! for 1.0, u32 after) and the header, a Python dict literal (`descr`, `fortran_order`,
//! `shape`) that `npyz` parses, then the array. The header's length is checked here, against
//! [`MAX_HEADER`] and the file, before the header is read (`npyz` would allocate what it says).
//!
//! Accepted: dtype `float16` or `float32` (`<f2`, `<f4`, `>f2`, `>f4`), C order. Shapes map as
//! - `(N,)`: 2d, N × 1, 1 channel;
//! - `(H, W)`: 2d, W × H, 1 channel;
//! - `(H, W, C)`, C ≤ 4: 2d, W × H, C channels;
//! - `(D, H, W, C)`, C ≤ 4: 3d, W × H × D, C channels (a single-channel 3-D table is
//!   `(D, H, W, 1)`; an array of 2-D tables is laid out alike, and a binding may declare it
//!   `texture_2d_array`).
//!
//! float64 (NumPy's default) is refused: GPU textures hold f16 or f32, so the narrowing is the
//! table maker's to choose (`a.astype(np.float32)`).

use npyz::{DType, NpyHeader, Order, TypeChar};

use super::{Declared, Dimension, FileFormat, Source, TexelFormat, TextureData};
use crate::io::InputError;

const MAGIC: &[u8; 6] = b"\x93NUMPY";

/// The longest header read (NumPy itself refuses headers over 10,000 bytes by default).
pub const MAX_HEADER: u64 = 64 << 10;

pub(crate) fn read(src: &mut Source) -> Result<TextureData, InputError> {
    let pre = src.head(12)?;
    if pre.len() < MAGIC.len() || &pre[..MAGIC.len()] != MAGIC {
        return Err(src.refuse(format!(
            "not a NumPy .npy file: its first bytes are {:02x?}, not \\x93NUMPY",
            &pre[..pre.len().min(MAGIC.len())]
        )));
    }
    let short = |src: &Source| {
        src.refuse(format!(
            "its .npy preamble is cut short ({} bytes); truncated",
            pre.len()
        ))
    };
    let (major, minor) = match pre.get(6..8) {
        Some(v) => (v[0], v[1]),
        None => return Err(short(src)),
    };
    let (len_bytes, header_len) = match major {
        1 => (2, pre.get(8..10).map(|b| u64::from(u16::from_le_bytes([b[0], b[1]])))),
        2 | 3 => (
            4,
            pre.get(8..12)
                .map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))),
        ),
        _ => {
            return Err(src.refuse(format!(
                ".npy version {major}.{minor}: versions 1.0, 2.0 and 3.0 are read"
            )))
        }
    };
    let Some(header_len) = header_len else {
        return Err(short(src));
    };
    let data_offset = 8 + len_bytes + header_len;
    if header_len > MAX_HEADER {
        return Err(src.refuse(format!(
            "declares a .npy header of {header_len} bytes, more than the {MAX_HEADER} read; not read"
        )));
    }
    if data_offset > src.len() {
        return Err(src.refuse(format!(
            "declares a .npy header of {header_len} bytes but the file has only {} bytes: truncated, not read",
            src.len()
        )));
    }
    let head = src.head(data_offset)?;
    guard_shape_text(&head[(8 + len_bytes) as usize..]).map_err(|e| src.refuse(e))?;
    let header = NpyHeader::from_reader(&head[..]).map_err(|e| src.refuse(format!("bad .npy header: {e}")))?;
    let stored = match header.dtype() {
        DType::Plain(t) if t.type_char() == TypeChar::Float && t.size_field() == 2 => TexelFormat::F16,
        DType::Plain(t) if t.type_char() == TypeChar::Float && t.size_field() == 4 => TexelFormat::F32,
        DType::Plain(t) if t.type_char() == TypeChar::Float && t.size_field() == 8 => {
            return Err(src.refuse(format!(
                "dtype {t} (float64): GPU textures hold float16 or float32; save `a.astype(np.float32)` (or \
                 np.float16)"
            )))
        }
        other => return Err(src.refuse(format!("dtype {}: float16 or float32 arrays are read", other.descr()))),
    };
    if header.order() == Order::Fortran {
        return Err(src.refuse("a Fortran-order array: save it in C order (np.ascontiguousarray)"));
    }
    let shape = header.shape().to_vec();
    let shown = format!(
        "({}{})",
        shape.iter().map(u64::to_string).collect::<Vec<_>>().join(", "),
        if shape.len() == 1 { "," } else { "" }
    );
    let channels_of = |c: u64| u8::try_from(c).ok().filter(|c| (1..=4).contains(c));
    let (kind, width, height, depth, channels) = match shape[..] {
        [n] => (Dimension::D2, n, 1, 1, Some(1)),
        [h, w] => (Dimension::D2, w, h, 1, Some(1)),
        [h, w, c] => (Dimension::D2, w, h, 1, channels_of(c)),
        [d, h, w, c] => (Dimension::D3, w, h, d, channels_of(c)),
        _ => {
            return Err(src.refuse(format!(
                "shape {shown}: read are (N,), (H, W), (H, W, C) and (D, H, W, C) with C ≤ 4"
            )))
        }
    };
    let Some(channels) = channels else {
        return Err(src.refuse(format!(
            "shape {shown}: the last axis holds the channels, 1 to 4 (a single-channel 3-D table is (D, H, W, 1))"
        )));
    };
    let declared = Declared {
        width,
        height,
        depth_or_layers: depth,
        kind,
        channels,
        stored,
        mip_levels: 1,
    };
    declared.check_caps(src)?;
    let n = declared.level0_bytes();
    declared.check_inside(src, data_offset, n)?;
    let payload = src.bytes(data_offset, n, "the array")?;
    let npy = npyz::NpyFile::with_header(header, &payload[..]);
    let bad = |e: std::io::Error| src.refuse(format!("bad .npy data: {e}"));
    let texels: Vec<f32> = match stored {
        TexelFormat::F32 => npy.into_vec::<f32>().map_err(bad)?,
        TexelFormat::F16 => npy
            .into_vec::<half::f16>()
            .map_err(bad)?
            .into_iter()
            .map(half::f16::to_f32)
            .collect(),
    };
    let mut out = declared.finish(&[], FileFormat::Npy);
    out.texels = texels;
    Ok(out)
}

/// Refuses a header whose numbers could overflow `npyz`'s product of the shape (a panic in a
/// build with overflow checks): the product of every decimal number in the text, each at least
/// 1, must not pass u64, and no number may be written in another radix. NumPy writes neither.
fn guard_shape_text(text: &[u8]) -> Result<(), String> {
    let lower = text.to_ascii_lowercase();
    if lower.windows(2).any(|w| matches!(w, b"0x" | b"0o" | b"0b")) {
        return Err("its .npy header writes a number in hex, octal or binary; NumPy writes decimal".into());
    }
    let mut product: u64 = 1;
    for run in lower.split(|b| !b.is_ascii_digit()).filter(|r| !r.is_empty()) {
        let v = std::str::from_utf8(run)
            .ok()
            .and_then(|s| s.parse::<u64>().ok())
            .unwrap_or(u64::MAX);
        product = product
            .checked_mul(v.max(1))
            .ok_or_else(|| "its .npy header's shape holds numbers whose product passes 2⁶⁴; not read".to_string())?;
    }
    Ok(())
}
