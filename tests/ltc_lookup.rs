//! The device look-ups of our LTC tables (kernels/ltc/, reading `ll_ltc`,
//! binding 4) against the host feeds they mirror. A probe derived from each look-up kernel
//! returns one channel of the fed LTC (M⁻¹ entry, magnitude or Fresnel term); on a fixed set of
//! (θ, φ, α, r) the GPU and the CPU evaluator (f32) must give the host's `ltc::feed_aniso` (our
//! 4D table) and `Table::sample` (our 2D table) to the tolerances below, each 10× the worst
//! difference measured on lavapipe (Mesa 22.3.6) and the evaluator (re-measure with
//! `LINELIGHT_MEASURE=1 cargo test --release --test all ltc_lookup:: -- --nocapture`). The whole
//! method, the device-fed line beside the host-fed `line.ltc2017`, is checked the same way.

use crate::common;
use common::segment;

use linelight::eval::interp::{CpuColumns, Mode};
use linelight::input::ltc::{self, table::Storage, Feed};
use linelight::input::scene::{Config, Material, Roughness};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, KernelFile};

const ANISO_PROBE: &str = "//! id: user.ltc_aniso_probe
//! derive: line.ltc_lookup_aniso
//! replace: method
//! source: tests/ltc_lookup.rs: channel K of the device's anisotropic feed
//! params: K=1
override K: u32 = 1u;
fn method(scene: Scene) -> f32 {
    // Channel K − 1 (integer params start at 1).
    let c = K - 1u;
    let feed = ltc_aniso_feed(scene);
    if (c < 9u) {
        let e = min(c, 8u);
        return feed.minv[e % 3u][e / 3u];
    }
    if (c == 9u) {
        return feed.magnitude;
    }
    return feed.fresnel;
}
";

const ISO_PROBE: &str = "//! id: user.ltc_iso_probe
//! derive: line.ltc_lookup_iso
//! replace: method
//! source: tests/ltc_lookup.rs: channel K of the device's isotropic feed
//! params: K=1
override K: u32 = 1u;
fn method(scene: Scene) -> f32 {
    // Channel K − 1 (integer params start at 1).
    let c = K - 1u;
    let feed = ltc_iso_feed(scene);
    if (c < 9u) {
        let e = min(c, 8u);
        return feed.minv[e % 3u][e / 3u];
    }
    if (c == 9u) {
        return feed.magnitude;
    }
    return feed.fresnel;
}
";

/// Tolerances, 10× the worst difference measured (lavapipe, Mesa 22.3.6; CPU evaluator), as
/// [GPU, CPU f32]. M⁻¹ entries relative to the largest entry of the host's M⁻¹; the magnitude and
/// the Fresnel term relative. Measured on the anisotropic look-up: M⁻¹ 5.74e-4 and 3.62e-7, the
/// channels 2.40e-3 and 3.57e-7 (the CPU evaluator is the host's arithmetic but for its `libm`
/// acos and atan2; the GPU's difference is lavapipe's arithmetic, not isolated further). The
/// isotropic look-up measured 0 on both: it is asserted bit for bit.
const ANISO_MINV_TOL: [f64; 2] = [5.7e-3, 3.6e-6];
const ANISO_CHANNEL_TOL: [f64; 2] = [2.4e-2, 3.6e-6];
/// The device-fed line against the host-fed `line.ltc2017`, relative: measured 7.73e-4 (GPU) and
/// 9.26e-6 (CPU f32) with the anisotropic look-up, 0 with the isotropic one (asserted exactly).
const ANISO_LINE_TOL: [f64; 2] = [7.7e-3, 9.3e-5];

/// (θ, φ, α_max, r, swapped): on and between the 8⁴ table's nodes, every quadrant of φ, both
/// roughness axes as the larger, the table's edges and beyond them (α_max < 0.02, r < 1/4).
fn points() -> Vec<(f64, f64, f64, f64, bool)> {
    let mut out = Vec::new();
    let thetas = [0.0, 0.2243, 0.61, 1.0, 1.3457, 1.55];
    let phis = [0.0, 0.3, 1.2, std::f64::consts::FRAC_PI_2, 2.4, 3.5, 5.1];
    let alphas = [0.01, 0.02, 0.09, 0.3, 0.58, 1.0];
    let ratios = [0.2, 0.25, 0.4, 0.7857142857142857, 1.0];
    let mut k = 0usize;
    for &t in &thetas {
        for &p in &phis {
            // A spread of the other two axes (every combination would be 1260 points).
            let a = alphas[k % alphas.len()];
            let r = ratios[(k / 2) % ratios.len()];
            out.push((t, p, a, r, k % 3 == 1));
            k += 1;
        }
    }
    out
}

fn config(i: usize, (t, p, a, r, swapped): (f64, f64, f64, f64, bool), iso_feed: bool) -> Config {
    let view = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
    let alpha = if swapped { [r * a, a] } else { [a, r * a] };
    let material = if iso_feed {
        Material::ggx(Roughness::Iso(a), view, Some("table")).unwrap()
    } else {
        Material::ggx(Roughness::Aniso(alpha), view, Some("aniso")).unwrap()
    };
    segment(format!("p{i}"), [0.3, -0.2, 1.0], [-0.6, 0.4, 0.8], material)
}

fn gpu_values(m: &Method, configs: &[Config]) -> Vec<f64> {
    common::gpu_values(m, configs).into_iter().map(f64::from).collect()
}

/// The host's fed channels (M⁻¹ row-major in the scene's frame, magnitude, Fresnel term).
fn host(c: &Config) -> [f64; 11] {
    let Material::Ggx { fed, .. } = &c.material else {
        unreachable!()
    };
    let mut out = [0.0; 11];
    for r in 0..3 {
        for k in 0..3 {
            out[3 * r + k] = fed.minv[r][k];
        }
    }
    out[9] = fed.magnitude;
    out[10] = fed.fresnel;
    out
}

/// Worst differences [M⁻¹, channels] of the probe against `host`, on the GPU and in CPU f32.
fn probe_worst(id: &str, configs: &[Config]) -> [[f64; 2]; 2] {
    let mut kernels = builtin_kernels();
    kernels.push(KernelFile::parse("aniso_probe.wgsl", ANISO_PROBE).unwrap());
    kernels.push(KernelFile::parse("iso_probe.wgsl", ISO_PROBE).unwrap());
    let hosts: Vec<[f64; 11]> = configs.iter().map(host).collect();
    let mut worst = [[0.0f64; 2]; 2];
    for k in 0..11 {
        let m = resolve(&format!("{id}@{}", k + 1), &kernels).unwrap();
        let gpu = gpu_values(&m, configs);
        let cpu = m.cpu_column(configs, Mode::F32).unwrap();
        for (i, h) in hosts.iter().enumerate() {
            let scale = if k < 9 {
                h[..9].iter().fold(0.0f64, |a, x| a.max(x.abs()))
            } else {
                h[k].abs()
            };
            for (e, v) in [gpu[i], cpu[i].unwrap()].into_iter().enumerate() {
                let d = (v - h[k]).abs() / scale;
                let d = if d.is_nan() { f64::INFINITY } else { d };
                let slot = &mut worst[usize::from(k >= 9)][e];
                *slot = slot.max(d);
            }
        }
    }
    worst
}

fn measuring() -> bool {
    std::env::var("LINELIGHT_MEASURE").is_ok()
}

fn check(what: &str, worst: [[f64; 2]; 2], minv_tol: [f64; 2], channel_tol: [f64; 2]) {
    if measuring() {
        println!(
            "{what}: M⁻¹ GPU {:.2e} CPU {:.2e}; channels GPU {:.2e} CPU {:.2e}",
            worst[0][0], worst[0][1], worst[1][0], worst[1][1]
        );
        return;
    }
    for (e, name) in ["GPU", "CPU f32"].into_iter().enumerate() {
        assert!(
            worst[0][e] <= minv_tol[e],
            "{what}: {name} M⁻¹ differs by {:e} > {:e}",
            worst[0][e],
            minv_tol[e]
        );
        assert!(
            worst[1][e] <= channel_tol[e],
            "{what}: {name} magnitude/Fresnel differ by {:e} > {:e}",
            worst[1][e],
            channel_tol[e]
        );
    }
}

#[test]
fn the_device_aniso_lookup_is_the_host_feed() {
    let configs: Vec<Config> = points()
        .into_iter()
        .enumerate()
        .map(|(i, p)| config(i, p, false))
        .collect();
    // The host feed the scenes carry is `feed_aniso` of our table.
    let c = &configs[9];
    let Material::Ggx { alpha, view, fed, .. } = &c.material else {
        unreachable!()
    };
    let direct = ltc::feed_aniso(ltc::aniso::ours(), alpha.xy(), *view, Storage::F32);
    assert_eq!(*fed, direct);
    check(
        "aniso",
        probe_worst("user.ltc_aniso_probe", &configs),
        ANISO_MINV_TOL,
        ANISO_CHANNEL_TOL,
    );
}

#[test]
fn the_device_iso_lookup_is_the_host_feed() {
    let configs: Vec<Config> = points()
        .into_iter()
        .enumerate()
        .map(|(i, p)| config(i, p, true))
        .collect();
    let c = &configs[3];
    let Material::Ggx { fed, view, alpha, .. } = &c.material else {
        unreachable!()
    };
    assert_eq!(*fed, ltc::feed(alpha.xy(), *view, Feed::Table).unwrap());
    check("iso", probe_worst("user.ltc_iso_probe", &configs), [0.0; 2], [0.0; 2]);
}

/// The engines' fallback on anisotropic roughness: the device's isotropic look-up at
/// √(αx·αy) is the host's table at that α (computed here in f64, so within the same tolerances).
#[test]
fn the_device_iso_lookup_falls_back_to_the_geometric_mean() {
    let configs: Vec<Config> = points()
        .into_iter()
        .enumerate()
        .map(|(i, p)| config(i, p, false))
        .collect();
    let mut kernels = builtin_kernels();
    kernels.push(KernelFile::parse("iso_probe.wgsl", ISO_PROBE).unwrap());
    let mut worst = 0.0f64;
    for k in [0usize, 1, 4, 6, 9] {
        let m = resolve(&format!("user.ltc_iso_probe@{}", k + 1), &kernels).unwrap();
        let gpu = gpu_values(&m, &configs);
        let cpu = m.cpu_column(&configs, Mode::F32).unwrap();
        for (i, c) in configs.iter().enumerate() {
            let Material::Ggx { alpha, view, .. } = &c.material else {
                unreachable!()
            };
            let [ax, ay] = alpha.xy();
            let (minv, magnitude, _) = ltc::table::ours().sample((ax * ay).sqrt(), view[2], Storage::F32);
            let h = if k < 9 { minv[k / 3][k % 3] } else { magnitude };
            let scale = if k < 9 {
                minv.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()))
            } else {
                magnitude
            };
            for (e, v) in [gpu[i], cpu[i].unwrap()].into_iter().enumerate() {
                worst = worst.max((v - h).abs() / scale);
                // The host's α is √(αx·αy) in f64, the device's in f32 from f32 roughness: the worst
                // difference relative to the scale measured 1.47e-7; 10× that.
                assert!(
                    measuring() || (v - h).abs() <= 1.5e-6 * scale,
                    "{}: channel {k} engine {e}: {v} vs {h}",
                    c.id
                );
            }
        }
    }
    if measuring() {
        println!("iso fallback: worst {worst:.2e}");
    }
}

/// The whole method: the device-fed line against the host-fed `line.ltc2017` (its value times
/// the fed magnitude), on the same configurations.
#[test]
fn the_device_fed_line_is_the_host_fed_line() {
    let kernels = builtin_kernels();
    for (iso, spec) in [
        (false, "line.ltc_lookup_aniso[line.ltc2017]"),
        (true, "line.ltc_lookup_iso[line.ltc2017]"),
    ] {
        let configs: Vec<Config> = points()
            .into_iter()
            .enumerate()
            .map(|(i, p)| config(i, p, iso))
            .collect();
        let device = resolve(spec, &kernels).unwrap();
        let fed = resolve("line.ltc2017", &kernels).unwrap();
        assert!(!device.scaled_by_magnitude() && fed.scaled_by_magnitude());
        let (dg, fg) = (gpu_values(&device, &configs), gpu_values(&fed, &configs));
        let dc = device.cpu_column(&configs, Mode::F32).unwrap();
        let fc = fed.cpu_column(&configs, Mode::F32).unwrap();
        let mut worst = [0.0f64; 2];
        for i in 0..configs.len() {
            for (e, (a, b)) in [(dg[i], fg[i]), (dc[i].unwrap(), fc[i].unwrap())]
                .into_iter()
                .enumerate()
            {
                if b != 0.0 {
                    let d = ((a - b) / b).abs();
                    worst[e] = worst[e].max(if d.is_nan() { f64::INFINITY } else { d });
                }
            }
        }
        if measuring() {
            println!("{spec}: line GPU {:.2e} CPU {:.2e}", worst[0], worst[1]);
            continue;
        }
        let tol = if iso { [0.0; 2] } else { ANISO_LINE_TOL };
        for e in 0..2 {
            assert!(
                worst[e] <= tol[e],
                "{spec}: engine {e} differs by {:e} > {:e}",
                worst[e],
                tol[e]
            );
        }
    }
}
