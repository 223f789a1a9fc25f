//! Round trips (a table written in each format, half and float, reads back to its texels) and
//! refusals (truncated, oversized, wrong magic, unsupported layouts) before any payload is read.

use super::*;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use ddsfile::{AlphaMode, Caps2, D3D10ResourceDimension, Dds, DxgiFormat, NewDxgiParams};
use npyz::WriterBuilder;

/// Values that f16 rounds, 0, negatives, and 70000, which overflows f16 to inf.
fn values(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| {
            let x = i as f32;
            let v = (x * 0.37).sin() * 10f32.powi((i % 7) as i32 - 3);
            match i % 11 {
                3 => -v,
                5 => 0.0,
                7 => 1e-3 * std::f32::consts::PI,
                9 => 70000.0,
                _ => v,
            }
        })
        .collect()
}

fn halved(v: &[f32]) -> Vec<f32> {
    v.iter().map(|&x| half::f16::from_f32(x).to_f32()).collect()
}

fn le(v: &[f32], stored: TexelFormat) -> Vec<u8> {
    match stored {
        TexelFormat::F32 => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        TexelFormat::F16 => v.iter().flat_map(|&x| half::f16::from_f32(x).to_le_bytes()).collect(),
    }
}

fn expected(v: &[f32], stored: TexelFormat) -> Vec<f32> {
    match stored {
        TexelFormat::F32 => v.to_vec(),
        TexelFormat::F16 => halved(v),
    }
}

/// Bit-for-bit equality (so NaN and −0 compare too).
fn assert_texels(got: &[f32], want: &[f32]) {
    assert_eq!(got.len(), want.len());
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(g.to_bits(), w.to_bits(), "texel value {i}: {g} != {w}");
    }
}

/// Test files in a scratch folder, written through io (as every file is).
struct Dir(crate::io::Scratch);

impl Dir {
    fn new() -> Dir {
        Dir(crate::io::Scratch::new("linelight-lut-test").expect("temp dir"))
    }

    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        self.0.write(name, bytes).expect("write")
    }
}

/// `read` with the payload counter reset; returns the bytes of payload it read.
fn read_counted(path: &Path) -> (Result<TextureData, InputError>, u64) {
    PAYLOAD_READ.with(|c| c.set(0));
    let r = read(path);
    (r, PAYLOAD_READ.with(|c| c.get()))
}

/// A refusal before any payload was read, fast, naming the file and containing `want`.
fn refused(path: &Path, want: &[&str]) -> String {
    let start = Instant::now();
    let (r, payload) = read_counted(path);
    let e = r.expect_err("refused").to_string();
    assert!(
        start.elapsed() < Duration::from_secs(2),
        "{e}: took {:?}",
        start.elapsed()
    );
    assert_eq!(payload, 0, "{e}: {payload} payload bytes read");
    assert!(e.contains(&path.display().to_string()), "{e}");
    for w in want {
        assert!(e.contains(w), "`{w}` not in: {e}");
    }
    println!("{e}");
    e
}

// ---- DDS ----

fn dds_params(width: u32, height: u32, format: DxgiFormat) -> NewDxgiParams {
    NewDxgiParams {
        height,
        width,
        depth: None,
        format,
        mipmap_levels: Some(1),
        array_layers: None,
        caps2: None,
        is_cubemap: false,
        resource_dimension: D3D10ResourceDimension::Texture2D,
        alpha_mode: AlphaMode::Unknown,
    }
}

fn dds_bytes(params: NewDxgiParams, data: Vec<u8>) -> Vec<u8> {
    let mut dds = Dds::new_dxgi(params).expect("dds");
    assert_eq!(dds.data.len(), data.len(), "the test's data fills the texture");
    dds.data = data;
    let mut out = Vec::new();
    dds.write(&mut out).expect("write dds");
    out
}

#[test]
fn dds_tables_read_back_in_half_and_float() {
    let dir = Dir::new();
    let (w, h) = (7, 5);
    for (format, channels, stored) in [
        (DxgiFormat::R32G32B32A32_Float, 4, TexelFormat::F32),
        (DxgiFormat::R16G16B16A16_Float, 4, TexelFormat::F16),
        (DxgiFormat::R32G32_Float, 2, TexelFormat::F32),
        (DxgiFormat::R16G16_Float, 2, TexelFormat::F16),
        (DxgiFormat::R32_Float, 1, TexelFormat::F32),
        (DxgiFormat::R16_Float, 1, TexelFormat::F16),
    ] {
        let v = values(w * h * channels);
        let p = dir.write(
            "t.dds",
            &dds_bytes(dds_params(w as u32, h as u32, format), le(&v, stored)),
        );
        let t = read(&p).unwrap_or_else(|e| panic!("{format:?}: {e}"));
        assert_eq!(
            (
                t.width,
                t.height,
                t.depth_or_layers,
                t.kind,
                t.channels,
                t.stored,
                t.mip_levels,
                t.format
            ),
            (7, 5, 1, Dimension::D2, channels as u8, stored, 1, FileFormat::Dds),
            "{format:?}"
        );
        assert_texels(&t.texels, &expected(&v, stored));
        assert_eq!(
            t.texel(6, 4, 0, channels as u8 - 1),
            *expected(&v, stored).last().unwrap()
        );
    }
}

#[test]
fn dds_arrays_volumes_and_mip_chains_read_level_0() {
    let dir = Dir::new();
    // Three layers of 4 × 4 RGBA16F, each with its 3-level chain (4², 2², 1²): level 0 of each.
    let mut params = dds_params(4, 4, DxgiFormat::R16G16B16A16_Float);
    params.mipmap_levels = Some(3);
    params.array_layers = Some(3);
    let chain = (16 + 4 + 1) * 4;
    let v = values(3 * chain);
    let p = dir.write("array.dds", &dds_bytes(params, le(&v, TexelFormat::F16)));
    let t = read(&p).expect("array");
    assert_eq!((t.kind, t.depth_or_layers, t.mip_levels), (Dimension::D2Array, 3, 3));
    let level0: Vec<f32> = (0..3).flat_map(|l| v[l * chain..l * chain + 64].to_vec()).collect();
    assert_texels(&t.texels, &halved(&level0));
    // A 3 × 2 × 4 volume of R32F.
    let mut params = dds_params(3, 2, DxgiFormat::R32_Float);
    params.depth = Some(4);
    params.resource_dimension = D3D10ResourceDimension::Texture3D;
    params.caps2 = Some(Caps2::VOLUME);
    let v = values(24);
    let p = dir.write("volume.dds", &dds_bytes(params, le(&v, TexelFormat::F32)));
    let t = read(&p).expect("volume");
    assert_eq!((t.kind, t.width, t.height, t.depth_or_layers), (Dimension::D3, 3, 2, 4));
    assert_texels(&t.texels, &v);
    assert_eq!(t.texel(2, 1, 3, 0), v[23]);
}

#[test]
fn legacy_dds_headers_with_a_float_fourcc_read_back() {
    use ddsfile::{D3DFormat, NewD3dParams};
    let dir = Dir::new();
    for (format, stored) in [
        (D3DFormat::A32B32G32R32F, TexelFormat::F32),
        (D3DFormat::A16B16G16R16F, TexelFormat::F16),
    ] {
        let v = values(3 * 2 * 4);
        let mut dds = Dds::new_d3d(NewD3dParams {
            height: 2,
            width: 3,
            depth: None,
            format,
            mipmap_levels: None,
            caps2: None,
        })
        .expect("dds");
        dds.data = le(&v, stored);
        let mut bytes = Vec::new();
        dds.write(&mut bytes).expect("write");
        // ddsfile writes these as a 128- or 64-bit RGB pixel format without masks; D3DX and
        // DirectXTex write the FourCC (116, 113), which is what is read: patch it in.
        let code = if stored == TexelFormat::F32 { 116u32 } else { 113 };
        bytes[80..84].copy_from_slice(&4u32.to_le_bytes()); // DDPF_FOURCC
        bytes[84..88].copy_from_slice(&code.to_le_bytes());
        bytes[88..108].fill(0);
        let t = read(&dir.write("legacy.dds", &bytes)).expect("legacy");
        assert_eq!((t.width, t.height, t.channels, t.stored), (3, 2, 4, stored));
        assert_texels(&t.texels, &expected(&v, stored));
    }
}

/// ltc_code ships its table as `ltc_1.dds` (RGBA32F, DX10 header); the anchor here is
/// `ltc.inc`, so its tabMinv is written as such a DDS, the four entries of the sparse form
/// [[a,0,b],[0,c,0],[d,0,1]] as (a, b, c, d), and read back.
#[test]
fn ltc_code_tabminv_as_a_dds_reads_back() {
    let table = crate::input::ltc::table::published().expect("the published table");
    let n = table.size;
    let v: Vec<f32> = table
        .entries
        .iter()
        .flat_map(|e| [e.minv[0][0], e.minv[0][2], e.minv[1][1], e.minv[2][0]].map(|x| x as f32))
        .collect();
    let dir = Dir::new();
    for (format, stored) in [
        (DxgiFormat::R32G32B32A32_Float, TexelFormat::F32),
        (DxgiFormat::R16G16B16A16_Float, TexelFormat::F16),
    ] {
        let p = dir.write(
            "ltc_1.dds",
            &dds_bytes(dds_params(n as u32, n as u32, format), le(&v, stored)),
        );
        let t = read(&p).expect("ltc_1.dds");
        assert_eq!((t.width, t.height, t.channels, t.stored), (64, 64, 4, stored));
        assert_texels(&t.texels, &expected(&v, stored));
        // Entry (a, t) = (63, 0) is texel (63, 0): its c.
        assert_eq!(
            t.texel(63, 0, 0, 2),
            expected(&[table.entries[63].minv[1][1] as f32], stored)[0]
        );
    }
}

/// A DX10 header declaring `w × h` RGBA32F (pitch computed by ddsfile), then `tail` bytes.
fn dds_header_only(w: u32, h: u32, tail: usize) -> Vec<u8> {
    let f = DxgiFormat::R32G32B32A32_Float;
    let mut out = b"DDS ".to_vec();
    ddsfile::Header::new_dxgi(h, w, None, f, None, None, None)
        .expect("header")
        .write(&mut out)
        .expect("write");
    ddsfile::Header10::new(f, false, D3D10ResourceDimension::Texture2D, 1, AlphaMode::Unknown)
        .write(&mut out)
        .expect("write");
    out.resize(out.len() + tail, 0);
    out
}

#[test]
fn dds_refusals_come_before_the_payload() {
    let dir = Dir::new();
    let p = dir.write("short.dds", &dds_header_only(1024, 1024, 52));
    assert_eq!(std::fs::metadata(&p).unwrap().len(), 200);
    refused(
        &p,
        &[
            "1024 × 1024 texels of 16 bytes",
            "16777216 bytes from byte 148",
            "only 200 bytes",
            "truncated",
        ],
    );
    let p = dir.write("huge.dds", &dds_header_only(60000, 60000, 52));
    refused(
        &p,
        &[
            "60000 × 60000 texels of 16 bytes",
            "at most 8192 a side and 16777216 texels",
        ],
    );
    let p = dir.write("cut.dds", &dds_header_only(4, 4, 0)[..100]);
    refused(&p, &["DDS header is cut short"]);
    let p = dir.write("png.dds", b"\x89PNG\r\n\x1a\n and so on");
    refused(&p, &["not a DDS file"]);
    let p = dir.write("empty.dds", b"");
    refused(&p, &["not a DDS file"]);
    // Block-compressed, integer and cube maps.
    let bc = dds_bytes(dds_params(4, 4, DxgiFormat::BC6H_UF16), vec![0; 16]);
    refused(&dir.write("bc.dds", &bc), &["BC6H_UF16", "block-compressed"]);
    let int = dds_bytes(dds_params(1, 1, DxgiFormat::R32G32B32A32_UInt), vec![0; 16]);
    refused(&dir.write("int.dds", &int), &["R32G32B32A32_UInt", "integer"]);
    let mut cube = dds_params(1, 1, DxgiFormat::R32_Float);
    cube.is_cubemap = true;
    cube.array_layers = Some(6);
    refused(&dir.write("cube.dds", &dds_bytes(cube, vec![0; 24])), &["cube map"]);
}

// ---- KTX2 ----

/// A minimal KTX2 file: header, level index, a basic data format descriptor (from the `ktx2`
/// crate's table for `format`), then the levels' data, each 16-byte aligned. `declared0`
/// overrides level 0's declared length (for truncated files).
fn ktx2_bytes(format: ktx2::Format, size: [u32; 4], levels: &[Vec<u8>], declared0: Option<u64>) -> Vec<u8> {
    let [w, h, d, layers] = size;
    let (basic, type_size) = ktx2::dfd::Basic::from_format(format).expect("dfd");
    let block = ktx2::dfd::Block::Basic(basic).to_vec();
    let index_end = 80 + 24 * levels.len();
    let dfd_len = 4 + block.len();
    let mut data_start = (index_end + dfd_len).next_multiple_of(16);
    let mut index = Vec::new();
    let mut data = Vec::new();
    for (i, l) in levels.iter().enumerate() {
        let len = if i == 0 {
            declared0.unwrap_or(l.len() as u64)
        } else {
            l.len() as u64
        };
        let entry = ktx2::LevelIndex {
            byte_offset: data_start as u64,
            byte_length: len,
            uncompressed_byte_length: len,
        };
        index.extend(entry.as_bytes());
        data.extend(l);
        let padded = l.len().next_multiple_of(16);
        data.resize(data.len() + padded - l.len(), 0);
        data_start += padded;
    }
    let header = ktx2::Header {
        format: Some(format),
        type_size,
        pixel_width: w,
        pixel_height: h,
        pixel_depth: d,
        layer_count: layers,
        face_count: 1,
        level_count: levels.len() as u32,
        supercompression_scheme: None,
        index: ktx2::Index {
            dfd_byte_offset: index_end as u32,
            dfd_byte_length: dfd_len as u32,
            kvd_byte_offset: 0,
            kvd_byte_length: 0,
            sgd_byte_offset: 0,
            sgd_byte_length: 0,
        },
    };
    let mut out = header.as_bytes().to_vec();
    out.extend(index);
    out.extend((dfd_len as u32).to_le_bytes());
    out.extend(block);
    out.resize(out.len().next_multiple_of(16), 0);
    out.extend(data);
    out
}

#[test]
fn ktx2_tables_read_back_in_half_and_float() {
    use ktx2::Format as F;
    let dir = Dir::new();
    for (format, channels, stored) in [
        (F::R32G32B32A32_SFLOAT, 4, TexelFormat::F32),
        (F::R16G16B16A16_SFLOAT, 4, TexelFormat::F16),
        (F::R32G32_SFLOAT, 2, TexelFormat::F32),
        (F::R16G16_SFLOAT, 2, TexelFormat::F16),
        (F::R32_SFLOAT, 1, TexelFormat::F32),
        (F::R16_SFLOAT, 1, TexelFormat::F16),
    ] {
        let v = values(6 * 3 * channels);
        let bytes = ktx2_bytes(format, [6, 3, 0, 0], &[le(&v, stored)], None);
        ktx2::Reader::new(&bytes[..]).expect("the test's file is valid KTX2");
        let t = read(&dir.write("t.ktx2", &bytes)).unwrap_or_else(|e| panic!("{format:?}: {e}"));
        assert_eq!(
            (
                t.width,
                t.height,
                t.depth_or_layers,
                t.kind,
                t.channels,
                t.stored,
                t.mip_levels,
                t.format
            ),
            (6, 3, 1, Dimension::D2, channels as u8, stored, 1, FileFormat::Ktx2),
            "{format:?}"
        );
        assert_texels(&t.texels, &expected(&v, stored));
    }
    // A 2 × 2 × 3 volume with two levels, and an array of two 2 × 1 layers.
    let v = values(12 * 4);
    let bytes = ktx2_bytes(
        F::R32G32B32A32_SFLOAT,
        [2, 2, 3, 0],
        &[le(&v, TexelFormat::F32), vec![0; 16]],
        None,
    );
    let t = read(&dir.write("volume.ktx2", &bytes)).expect("volume");
    assert_eq!((t.kind, t.depth_or_layers, t.mip_levels), (Dimension::D3, 3, 2));
    assert_texels(&t.texels, &v);
    let v = values(4 * 2);
    let bytes = ktx2_bytes(F::R16G16_SFLOAT, [2, 1, 0, 2], &[le(&v, TexelFormat::F16)], None);
    let t = read(&dir.write("array.ktx2", &bytes)).expect("array");
    assert_eq!((t.kind, t.height, t.depth_or_layers), (Dimension::D2Array, 1, 2));
    assert_texels(&t.texels, &halved(&v));
}

#[test]
fn ktx2_refusals_come_before_the_payload() {
    use ktx2::Format as F;
    let dir = Dir::new();
    let declared = 1024 * 1024 * 16;
    let mut short = ktx2_bytes(
        F::R32G32B32A32_SFLOAT,
        [1024, 1024, 0, 0],
        &[vec![0; 16]],
        Some(declared),
    );
    short.truncate(200);
    let p = dir.write("short.ktx2", &short);
    refused(
        &p,
        &[
            "1024 × 1024 texels of 16 bytes",
            "16777216 bytes from byte",
            "only 200 bytes",
            "truncated",
        ],
    );
    let mut huge = ktx2_bytes(F::R32G32B32A32_SFLOAT, [60000, 60000, 0, 0], &[vec![0; 16]], None);
    huge.truncate(200);
    refused(
        &dir.write("huge.ktx2", &huge),
        &["60000 × 60000 texels of 16 bytes", "at most 8192"],
    );
    refused(&dir.write("cut.ktx2", &huge[..50]), &["KTX2 header is cut short"]);
    refused(&dir.write("dds.ktx2", &dds_header_only(1, 1, 16)), &["not a KTX2 file"]);
    // Supercompressed (zstd), a cube map, a UNORM format, a level whose length disagrees.
    let mut z = ktx2_bytes(F::R32_SFLOAT, [1, 1, 0, 0], &[vec![0; 4]], None);
    z[44..48].copy_from_slice(&2u32.to_le_bytes());
    refused(&dir.write("zstd.ktx2", &z), &["supercompressed (Zstandard)"]);
    let mut cube = ktx2_bytes(F::R32_SFLOAT, [1, 1, 0, 0], &[vec![0; 4]], None);
    cube[36..40].copy_from_slice(&6u32.to_le_bytes());
    refused(&dir.write("cube.ktx2", &cube), &["cube map"]);
    let unorm = ktx2_bytes(F::R8G8B8A8_UNORM, [1, 1, 0, 0], &[vec![0; 4]], None);
    refused(
        &dir.write("unorm.ktx2", &unorm),
        &["R8G8B8A8_UNORM", "integer or normalised"],
    );
    let odd = ktx2_bytes(F::R32_SFLOAT, [2, 1, 0, 0], &[vec![0; 4]], None);
    refused(&dir.write("odd.ktx2", &odd), &["level 0 holds 4 bytes", "need 8"]);
    // The data format descriptor must agree with vkFormat (here: RGBA16F's descriptor, R32F's format).
    let mut lie = ktx2_bytes(F::R16G16B16A16_SFLOAT, [1, 1, 0, 0], &[vec![0; 8]], None);
    lie[12..16].copy_from_slice(&F::R32G32_SFLOAT.value().to_le_bytes());
    let e = read(&dir.write("lie.ktx2", &lie)).expect_err("refused").to_string();
    assert!(e.contains("disagrees with vkFormat"), "{e}");
}

// ---- OpenEXR ----

fn exr_bytes(size: (usize, usize), channels: Vec<(&str, exr::prelude::FlatSamples)>, compressed: bool) -> Vec<u8> {
    use exr::prelude::*;
    let list = channels.into_iter().map(|(n, s)| AnyChannel::new(n, s)).collect();
    let layer = Layer::new(
        size,
        LayerAttributes::named("lut"),
        if compressed {
            Encoding::SMALL_LOSSLESS
        } else {
            Encoding::UNCOMPRESSED
        },
        AnyChannels::sort(list),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .expect("write exr");
    out.into_inner()
}

/// Channel `c` of `n` interleaved texels, as a plane of f32 or f16 samples.
fn plane(v: &[f32], channels: usize, c: usize, stored: TexelFormat) -> exr::prelude::FlatSamples {
    let p = v.iter().skip(c).step_by(channels).copied();
    match stored {
        TexelFormat::F32 => exr::prelude::FlatSamples::F32(p.collect()),
        TexelFormat::F16 => exr::prelude::FlatSamples::F16(p.map(half::f16::from_f32).collect()),
    }
}

#[test]
fn exr_tables_read_back_in_half_and_float() {
    let dir = Dir::new();
    let (w, h) = (5, 4);
    for stored in [TexelFormat::F32, TexelFormat::F16] {
        for (names, compressed) in [
            (&["R", "G", "B", "A"][..], false),
            (&["R", "G", "B", "A"][..], true),
            (&["R", "G"][..], false),
            (&["R", "G", "B"][..], true),
            (&["Y"][..], false),
        ] {
            let n = names.len();
            let v = values(w * h * n);
            let channels = names
                .iter()
                .enumerate()
                .map(|(c, &name)| (name, plane(&v, n, c, stored)))
                .collect();
            let p = dir.write("t.exr", &exr_bytes((w, h), channels, compressed));
            let t = read(&p).unwrap_or_else(|e| panic!("{names:?}: {e}"));
            assert_eq!(
                (t.width, t.height, t.kind, t.channels, t.stored, t.mip_levels, t.format),
                (5, 4, Dimension::D2, n as u8, stored, 1, FileFormat::Exr),
                "{names:?}"
            );
            assert_texels(&t.texels, &expected(&v, stored));
        }
    }
}

/// `bytes` with the data window (`dataWindow`, box2i) set to `w × h`.
fn exr_with_window(mut bytes: Vec<u8>, w: i32, h: i32) -> Vec<u8> {
    let key = b"dataWindow\0box2i\0\x10\0\0\0";
    let at = bytes.windows(key.len()).position(|x| x == key).expect("dataWindow") + key.len();
    bytes[at..at + 16].copy_from_slice(&[0i32, 0, w - 1, h - 1].map(i32::to_le_bytes).concat());
    bytes
}

#[test]
fn exr_refusals_come_before_the_payload() {
    let dir = Dir::new();
    let v = values(256 * 256 * 4);
    let rgba: Vec<_> = ["R", "G", "B", "A"]
        .iter()
        .enumerate()
        .map(|(c, &n)| (n, plane(&v, 4, c, TexelFormat::F32)))
        .collect();
    // Compressed, its pixels' place is known only by decoding: cut short, the decoder refuses it.
    let mut cut = exr_bytes((256, 256), rgba.clone(), true);
    cut.truncate(1000);
    let e = read(&dir.write("cut.exr", &cut)).expect_err("refused").to_string();
    assert!(e.contains("cut.exr: bad OpenEXR file"), "{e}");
    let mut short = exr_bytes((256, 256), rgba, false);
    short.truncate(3000);
    refused(
        &dir.write("short.exr", &short),
        &[
            "256 × 256 texels of 16 bytes, uncompressed",
            "at least 1050624 bytes",
            "only 3000 bytes",
            "truncated",
        ],
    );
    let zeros = ["R", "G", "B", "A"].map(|n| (n, exr::prelude::FlatSamples::F32(vec![0.0; 4])));
    let huge = exr_with_window(exr_bytes((2, 2), zeros.to_vec(), false), 60000, 60000);
    refused(
        &dir.write("huge.exr", &huge),
        &["60000 × 60000 texels of 16 bytes", "at most 8192"],
    );
    refused(&dir.write("npy.exr", b"\x93NUMPY\x01\x00"), &["not an OpenEXR file"]);
    // u32 channels, mixed types, channels that are not R G B A.
    let u = exr_bytes((1, 1), vec![("R", exr::prelude::FlatSamples::U32(vec![1]))], false);
    refused(&dir.write("u32.exr", &u), &["u32 channels"]);
    let mixed = exr_bytes(
        (1, 1),
        vec![
            ("R", exr::prelude::FlatSamples::F32(vec![1.0])),
            ("G", exr::prelude::FlatSamples::F16(vec![half::f16::ONE])),
        ],
        false,
    );
    refused(&dir.write("mixed.exr", &mixed), &["mixed types"]);
    let xyz = exr_bytes(
        (1, 1),
        vec![
            ("X", exr::prelude::FlatSamples::F32(vec![1.0])),
            ("Z", exr::prelude::FlatSamples::F32(vec![1.0])),
        ],
        false,
    );
    refused(&dir.write("xz.exr", &xyz), &["channels X Z"]);
}

// ---- NumPy ----

fn npy_bytes<T: npyz::AutoSerialize + Copy>(shape: &[u64], v: &[T]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    {
        let mut w = npyz::WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(&mut out)
            .begin_nd()
            .expect("npy");
        w.extend(v.iter().copied()).expect("npy data");
        w.finish().expect("npy finish");
    }
    out.into_inner()
}

/// A version 1.0 header (`descr`, `fortran_order`, `shape` as NumPy writes them), then `tail`
/// zero bytes.
fn npy_header_only(descr: &str, fortran: bool, shape: &str, tail: usize) -> Vec<u8> {
    let mut text = format!(
        "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
        if fortran { "True" } else { "False" }
    );
    while (10 + text.len() + 1) % 64 != 0 {
        text.push(' ');
    }
    text.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend((text.len() as u16).to_le_bytes());
    out.extend(text.as_bytes());
    out.resize(out.len() + tail, 0);
    out
}

#[test]
fn npy_tables_read_back_in_half_and_float() {
    let dir = Dir::new();
    for (shape, dims) in [
        (&[3, 5, 4][..], (5, 3, 1, Dimension::D2, 4)),
        (&[3, 5, 2][..], (5, 3, 1, Dimension::D2, 2)),
        (&[3, 5][..], (5, 3, 1, Dimension::D2, 1)),
        (&[7][..], (7, 1, 1, Dimension::D2, 1)),
        (&[2, 3, 5, 1][..], (5, 3, 2, Dimension::D3, 1)),
    ] {
        let n: u64 = shape.iter().product();
        let v = values(n as usize);
        let hv: Vec<half::f16> = v.iter().map(|&x| half::f16::from_f32(x)).collect();
        for (bytes, stored) in [
            (npy_bytes(shape, &v), TexelFormat::F32),
            (npy_bytes(shape, &hv), TexelFormat::F16),
        ] {
            let t = read(&dir.write("t.npy", &bytes)).unwrap_or_else(|e| panic!("{shape:?}: {e}"));
            assert_eq!(
                (t.width, t.height, t.depth_or_layers, t.kind, t.channels),
                dims,
                "{shape:?}"
            );
            assert_eq!((t.stored, t.mip_levels, t.format), (stored, 1, FileFormat::Npy));
            assert_texels(&t.texels, &expected(&v, stored));
        }
    }
    // Big-endian float32 reads the same.
    let mut be = npy_header_only(">f4", false, "(2,)", 0);
    be.extend([1.5f32, -2.25].iter().flat_map(|x| x.to_be_bytes()));
    assert_texels(
        &read(&dir.write("be.npy", &be)).expect("big-endian").texels,
        &[1.5, -2.25],
    );
}

#[test]
fn npy_refusals_come_before_the_payload() {
    let dir = Dir::new();
    let short = npy_header_only("<f4", false, "(1024, 1024, 4)", 72);
    assert_eq!(short.len(), 200);
    refused(
        &dir.write("short.npy", &short),
        &[
            "1024 × 1024 texels of 16 bytes",
            "16777216 bytes from byte 128",
            "only 200 bytes",
            "truncated",
        ],
    );
    let huge = npy_header_only("<f4", false, "(60000, 60000, 4)", 72);
    refused(
        &dir.write("huge.npy", &huge),
        &["60000 × 60000 texels of 16 bytes", "at most 8192"],
    );
    let overflow = npy_header_only("<f4", false, "(4294967296, 4294967296, 4294967296)", 0);
    refused(&dir.write("overflow.npy", &overflow), &["product passes"]);
    let mut long = b"\x93NUMPY\x02\x00".to_vec();
    long.extend(u32::MAX.to_le_bytes());
    refused(
        &dir.write("long.npy", &long),
        &["header of 4294967295 bytes", "more than the 65536"],
    );
    let mut cut = b"\x93NUMPY\x01\x00".to_vec();
    cut.extend(1000u16.to_le_bytes());
    cut.extend(b"{'descr'");
    refused(&dir.write("cut.npy", &cut), &["header of 1000 bytes", "truncated"]);
    refused(
        &dir.write("exr.npy", &[0x76, 0x2f, 0x31, 0x01]),
        &["not a NumPy .npy file"],
    );
    refused(
        &dir.write("f8.npy", &npy_header_only("<f8", false, "(2,)", 16)),
        &["float64", "astype(np.float32)"],
    );
    refused(
        &dir.write("i4.npy", &npy_header_only("<i4", false, "(2,)", 8)),
        &["'<i4'", "float16 or float32"],
    );
    refused(
        &dir.write("f.npy", &npy_header_only("<f4", true, "(2, 2)", 16)),
        &["Fortran-order"],
    );
    refused(
        &dir.write("c5.npy", &npy_header_only("<f4", false, "(2, 2, 5)", 80)),
        &["(2, 2, 5)", "1 to 4"],
    );
    refused(
        &dir.write("d5.npy", &npy_header_only("<f4", false, "(1, 1, 1, 1, 1)", 4)),
        &["(1, 1, 1, 1, 1)"],
    );
}

// ---- every format ----

#[test]
fn files_are_refused_by_extension_length_and_kind() {
    let dir = Dir::new();
    let e = read(&dir.write("t.png", b"")).expect_err("extension").to_string();
    assert!(e.contains("unknown extension"), "{e}");
    // Larger than the file cap: refused from its length (a sparse file), nothing read.
    let p = dir.0.sized("big.dds", MAX_LUT_FILE_BYTES + 1).unwrap();
    refused(&p, &[&format!("more than the {MAX_LUT_FILE_BYTES}")]);
    // A folder is not a file.
    let p = dir.0.folder("folder.npy").unwrap();
    refused(&p, &["not a regular file"]);
}
