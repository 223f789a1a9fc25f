//! Render images (docs/render.md): tone mapping, false colour, PNG encoding (the `png` crate),
//! HDR images (the `exr` crate) and FLIP (the `nv-flip` crate, NVIDIA's LDR-FLIP). No codec or metric is written here.

/// 8-bit RGB, row-major from the top-left.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb {
    pub width: u32,
    pub height: u32,
    pub data: Vec<u8>,
}

/// Pixels the floor does not cover (the sky): the same in every image, so FLIP sees no error there.
pub const BACKGROUND: [u8; 3] = [32, 40, 64];
/// NaN or ±inf values: a colour no tone map or colour map produces.
pub const NONFINITE: [u8; 3] = [0, 255, 0];
/// Light where the reference has none (reference exactly 0), in the relative-error image.
pub const FALSE_LIGHT: [u8; 3] = [0, 200, 255];

/// Reinhard's key: the log-average of the lit reference is exposed to this.
pub const KEY: f64 = 0.18;

/// FLIP's observer: pixels per degree of visual angle (FLIP's default, a 0.7 m view of a 24"
/// 3840-wide monitor).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// The relative-error colour scale: log10 from this (left) to 0 (right, ≥ 100 %).
pub const REL_LOG_MIN: f64 = -6.0;

impl Rgb {
    pub fn new(width: u32, height: u32, fill: [u8; 3]) -> Rgb {
        Rgb {
            width,
            height,
            data: fill.repeat((width * height) as usize),
        }
    }

    pub fn set(&mut self, x: u32, y: u32, c: [u8; 3]) {
        let i = 3 * (y * self.width + x) as usize;
        self.data[i..i + 3].copy_from_slice(&c);
    }

    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y * self.width + x) as usize;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// An 8-bit RGB PNG read back (a render baseline's images), or why it is not one. Its size
    /// is checked from the header before anything is decoded: at most `limits::MAX_PIXELS`,
    /// and `expect` (width, height) when given.
    pub fn from_png(bytes: &[u8], expect: Option<(u32, u32)>) -> Result<Rgb, String> {
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().map_err(|e| format!("not a PNG image: {e}"))?;
        let (width, height) = (reader.info().width, reader.info().height);
        if let Some((w, h)) = expect.filter(|&e| e != (width, height)) {
            return Err(format!(
                "size mismatch: the PNG declares {width} × {height} pixels, the scene {w} × {h} (not decoded)"
            ));
        }
        let pixels = u64::from(width) * u64::from(height);
        if pixels > crate::limits::MAX_PIXELS {
            return Err(format!(
                "the PNG declares {width} × {height} pixels, more than the {} a render may have (not decoded)",
                crate::limits::MAX_PIXELS
            ));
        }
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| "PNG image too large".to_string())?;
        let mut data = vec![0; size];
        let info = reader
            .next_frame(&mut data)
            .map_err(|e| format!("not a PNG image: {e}"))?;
        if info.color_type != png::ColorType::Rgb || info.bit_depth != png::BitDepth::Eight {
            return Err(format!(
                "a {:?} {:?}-bit PNG, not the 8-bit RGB linelight writes",
                info.color_type, info.bit_depth
            ));
        }
        data.truncate(info.line_size * info.height as usize);
        if info.line_size != 3 * info.width as usize {
            return Err("PNG rows are not packed 8-bit RGB".into());
        }
        Ok(Rgb {
            width: info.width,
            height: info.height,
            data,
        })
    }

    /// PNG bytes.
    pub fn png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header().expect("PNG header into memory");
            writer.write_image_data(&self.data).expect("PNG data into memory");
        }
        out
    }
}

/// The exposure: Reinhard's key over the lit reference, `KEY / exp(mean ln L)` over the
/// pixels whose reference is > 0; None when there is none (a black reference).
pub fn exposure(reference: &[f64]) -> Option<f64> {
    let lit: Vec<f64> = reference
        .iter()
        .copied()
        .filter(|&v| v > 0.0 && v.is_finite())
        .collect();
    if lit.is_empty() {
        return None;
    }
    let mean_log = lit.iter().map(|v| v.ln()).sum::<f64>() / lit.len() as f64;
    Some(KEY / mean_log.exp())
}

/// Radiance to a display byte: exposure, Reinhard's `v/(1+v)`, the sRGB curve; negative
/// light is black, NaN and ±inf are [`NONFINITE`].
pub fn tone(value: f64, exposure: f64) -> [u8; 3] {
    if !value.is_finite() {
        return NONFINITE;
    }
    let v = (value * exposure).max(0.0);
    let t = v / (1.0 + v);
    let s = if t <= 0.003_130_8 {
        12.92 * t
    } else {
        1.055 * t.powf(1.0 / 2.4) - 0.055
    };
    let b = (s * 255.0).round().clamp(0.0, 255.0) as u8;
    [b, b, b]
}

fn magma() -> Vec<u8> {
    nv_flip::magma_lut().to_vec()
}

fn lut(table: &[u8], t: f64) -> [u8; 3] {
    let i = (t.clamp(0.0, 1.0) * 255.0).round() as usize;
    [table[3 * i], table[3 * i + 1], table[3 * i + 2]]
}

/// The colour of a relative error on the magma scale, log10 from [`REL_LOG_MIN`] to 0.
pub fn rel_colour(table: &[u8], rel: f64) -> [u8; 3] {
    let t = if rel <= 0.0 {
        0.0
    } else {
        (rel.log10() - REL_LOG_MIN) / -REL_LOG_MIN
    };
    lut(table, t)
}

/// One floor pixel of an image: position and value.
pub struct Sample {
    pub x: u32,
    pub y: u32,
    pub value: f64,
    pub reference: f64,
}

/// A tone-mapped image of `value` (or of `reference` when `of_reference`).
pub fn radiance_image(width: u32, height: u32, samples: &[Sample], exposure: f64, of_reference: bool) -> Rgb {
    let mut img = Rgb::new(width, height, BACKGROUND);
    for s in samples {
        img.set(
            s.x,
            s.y,
            tone(if of_reference { s.reference } else { s.value }, exposure),
        );
    }
    img
}

/// The HDR image of `value` (or of `reference` when `of_reference`) as OpenEXR bytes (the
/// `exr` crate, ZIP-compressed, lossless): channel `Y` the radiance of a unit-intensity light,
/// untouched by exposure or tone map, rounded once to f32 (a method's GPU value is f32 already;
/// NaN and ±inf kept), and `A` 1 on the floor, 0 on the background (where `Y` is 0).
pub fn radiance_exr(width: u32, height: u32, samples: &[Sample], of_reference: bool, layer: &str) -> Vec<u8> {
    use exr::prelude::*;
    let n = (width * height) as usize;
    let (mut y, mut a) = (vec![0f32; n], vec![0f32; n]);
    for s in samples {
        let i = (s.y * width + s.x) as usize;
        y[i] = (if of_reference { s.reference } else { s.value }) as f32;
        a[i] = 1.0;
    }
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        AnyChannel::new("Y", FlatSamples::F32(y)),
        AnyChannel::new("A", FlatSamples::F32(a)),
    ]));
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::named(layer),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .expect("EXR into memory");
    out.into_inner()
}

/// Rows of legend under the relative-error image: a colour bar with a tick per decade.
pub const LEGEND_ROWS: u32 = 14;

/// The relative error |value − reference| / |reference| in false colour (magma, log scale),
/// with a legend bar below the image: left 1e-6, right ≥ 1, a white tick per decade (labels
/// in `relative_error_legend.svg`). Reference-0 pixels: black when the value is 0 too, else
/// [`FALSE_LIGHT`]; NaN/inf: [`NONFINITE`].
pub fn relative_error_image(width: u32, height: u32, samples: &[Sample]) -> Rgb {
    let table = magma();
    let mut img = Rgb::new(width, height + LEGEND_ROWS, BACKGROUND);
    for s in samples {
        let c = if !s.value.is_finite() {
            NONFINITE
        } else if s.reference == 0.0 {
            if s.value == 0.0 {
                lut(&table, 0.0)
            } else {
                FALSE_LIGHT
            }
        } else {
            rel_colour(&table, (s.value - s.reference).abs() / s.reference.abs())
        };
        img.set(s.x, s.y, c);
    }
    let decades = -REL_LOG_MIN as u32;
    for x in 0..width {
        let t = (f64::from(x) + 0.5) / f64::from(width);
        for y in height + 4..height + LEGEND_ROWS {
            img.set(x, y, lut(&table, t));
        }
    }
    for d in 0..=decades {
        let x = ((f64::from(d) / f64::from(decades)) * f64::from(width - 1)).round() as u32;
        for y in height + 1..height + 4 {
            img.set(x, y, [255, 255, 255]);
        }
    }
    img
}

/// The legend of the relative-error images, labelled (SVG text; the PNG bar has no font).
pub fn relative_error_legend_svg() -> String {
    let table = magma();
    let (w, h) = (480.0, 56.0);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n"
    );
    let n = 64;
    for i in 0..n {
        let c = lut(&table, (f64::from(i) + 0.5) / f64::from(n));
        s += &format!(
            "<rect x=\"{:.2}\" y=\"8\" width=\"{:.2}\" height=\"16\" fill=\"rgb({},{},{})\"/>\n",
            20.0 + 440.0 * f64::from(i) / f64::from(n),
            440.0 / f64::from(n) + 0.2,
            c[0],
            c[1],
            c[2]
        );
    }
    let decades = -REL_LOG_MIN as i32;
    for d in 0..=decades {
        let x = 20.0 + 440.0 * f64::from(d) / f64::from(decades);
        let label = if d == decades {
            "≥ 1".to_string()
        } else {
            format!("1e{}", d - decades)
        };
        s += &format!(
            "<line x1=\"{x}\" y1=\"24\" x2=\"{x}\" y2=\"30\" stroke=\"black\"/><text x=\"{x}\" y=\"42\" text-anchor=\"middle\">{label}</text>\n"
        );
    }
    s += "<text x=\"20\" y=\"54\">relative error |value − reference| / |reference|; green: NaN/inf; cyan: light where the reference is 0</text>\n</svg>\n";
    s
}

/// FLIP of `test` against `reference` (both tone-mapped, sRGB): the per-pixel error in [0, 1].
pub fn flip(reference: &Rgb, test: &Rgb) -> Vec<f32> {
    let r = nv_flip::FlipImageRgb8::with_data(reference.width, reference.height, &reference.data);
    let t = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &test.data);
    nv_flip::flip(r, t, PIXELS_PER_DEGREE).to_vec()
}

/// The FLIP error map in magma; background pixels keep [`BACKGROUND`], NaN/inf pixels are
/// [`NONFINITE`].
pub fn flip_image(width: u32, height: u32, errors: &[f32], samples: &[Sample]) -> Rgb {
    let table = magma();
    let mut img = Rgb::new(width, height, BACKGROUND);
    for s in samples {
        let c = if s.value.is_finite() {
            lut(&table, f64::from(errors[(s.y * width + s.x) as usize]))
        } else {
            NONFINITE
        };
        img.set(s.x, s.y, c);
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_is_monotone_and_marks_nonfinite() {
        let mut last = 0;
        for i in 0..100 {
            let b = tone(f64::from(i) * 0.1, 1.0)[0];
            assert!(b >= last);
            last = b;
        }
        assert_eq!(tone(-1.0, 1.0), [0, 0, 0]);
        assert_eq!(tone(f64::NAN, 1.0), NONFINITE);
        assert_eq!(tone(f64::INFINITY, 1.0), NONFINITE);
        assert_eq!(exposure(&[0.0, 0.0]), None);
        assert!((exposure(&[2.0, 8.0]).unwrap() - KEY / 4.0).abs() < 1e-12);
    }

    #[test]
    fn flip_is_zero_on_equal_images_and_positive_on_different() {
        let a = Rgb::new(16, 16, [100, 100, 100]);
        let mut b = a.clone();
        assert!(flip(&a, &b).iter().all(|&e| e == 0.0));
        for x in 4..12 {
            b.set(x, 8, [250, 250, 250]);
        }
        assert!(flip(&a, &b).iter().any(|&e| e > 0.1));
        let png = a.png();
        assert_eq!(&png[1..4], b"PNG");
        assert_eq!(Rgb::from_png(&b.png(), None), Ok(b.clone()));
        assert_eq!(Rgb::from_png(&b.png(), Some((b.width, b.height))), Ok(b.clone()));
        let e = Rgb::from_png(&b.png(), Some((b.width + 1, b.height))).unwrap_err();
        assert!(e.contains("size mismatch") && e.contains("not decoded"), "{e}");
        assert!(Rgb::from_png(&png[..png.len() / 2], None).is_err());
        assert!(Rgb::from_png(b"not a png", None).is_err());
    }
}
