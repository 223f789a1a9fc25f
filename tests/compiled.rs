//! The compiled CPU evaluator (src/eval/interp/compiled/) against the interpreter, the
//! specification: the same bits in f32 and in f64 on every built-in kernel and composite,
//! over every case's seeded sample (all materials), on non-finite and degenerate inputs, and
//! on a user kernel that exercises the WGSL rules the interpreter implements (integer
//! division by zero, min/max of NaN, select, switch fall-through, dynamic indices, the loop
//! limit).

use linelight::eval::interp::{program, CpuColumns, Engine, Mode, Path, LANES};
use linelight::input::case::Case;
use linelight::input::scene::{Config, Material};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, KernelFile};

/// Configurations per material of each case: every case's seeded sample, cut down.
const PER_CASE: usize = 1200;

fn case_configs() -> Vec<Config> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    let mut out = Vec::new();
    for path in paths {
        let case = Case::load(&path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
        let setup = linelight::app::prepare(case, &[], &linelight::kernel::Includes::none(), Some(PER_CASE)).unwrap();
        out.extend(setup.samples.into_iter().map(|s| s.config));
    }
    out
}

/// Inputs no sampler draws: zero-length and huge segments, points on the surface,
/// infinities and NaNs, in each of the three material kinds.
fn odd_configs(like: &[Config]) -> Vec<Config> {
    let coords = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1e-30, -1e-30, 1e-20],
        [3e19, -2e19, 1e19],
        [f64::INFINITY, 0.0, 1.0],
        [0.0, f64::NEG_INFINITY, 1.0],
        [f64::NAN, 0.5, 1.0],
        [0.3, -0.2, -1e-7],
    ];
    let mut out = Vec::new();
    let mut kinds: Vec<&Config> = Vec::new();
    for c in like {
        let same = |k: &&Config| std::mem::discriminant(&k.material) == std::mem::discriminant(&c.material);
        if !kinds.iter().any(same) {
            kinds.push(c);
        }
    }
    for base in kinds {
        for a in coords {
            for b in coords {
                let mut c = base.clone();
                c.p1 = a;
                c.p2 = b;
                out.push(c);
            }
        }
    }
    out
}

/// The path every built-in kernel takes: SIMD vectors (one F32X4, two F64X2) in both modes.
/// Whether no switch (`LINELIGHT_LANES`, `LINELIGHT_F64_PATH`, `LINELIGHT_VECTORS`) asks for
/// another path.
fn default_paths() -> bool {
    ["LINELIGHT_LANES", "LINELIGHT_F64_PATH", "LINELIGHT_VECTORS"]
        .iter()
        .all(|v| std::env::var(v).is_err())
}

fn expected_path(_mode: Mode) -> Path {
    Path::Simd(LANES)
}

fn same_bits(a: &[Option<f64>], b: &[Option<f64>]) -> Option<usize> {
    a.iter().zip(b).position(|(x, y)| match (x, y) {
        (Some(x), Some(y)) => !(x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan())),
        (None, None) => false,
        _ => true,
    })
}

/// Every built-in id, and every composite with every plain line method that resolves as
/// its inner.
fn every_builtin() -> Vec<Method> {
    let kernels = builtin_kernels();
    let mut out = Vec::new();
    for k in &kernels {
        out.push(resolve(&k.id, &kernels).unwrap_or_else(|e| panic!("{}: {e:#}", k.id)));
        if k.uses_line {
            for inner in kernels.iter().filter(|i| !i.uses_line) {
                if let Ok(m) = resolve(&format!("{}[{}]", k.id, inner.id), &kernels) {
                    out.push(m);
                }
            }
        }
    }
    out
}

/// Values compared bit for bit, or None when the compiler handles the kernel in neither mode
/// (it is interpreted everywhere, for a reason the assertion below accepts).
fn compare(m: &Method, configs: &[Config]) -> Option<usize> {
    let p = program(m).unwrap_or_else(|e| panic!("{}: {e:#}", m.label));
    let mut compared = 0;
    let mut compiled = false;
    for mode in [Mode::F32, Mode::F64] {
        let interp = m.cpu_column_on(configs, mode, Engine::Interpreter);
        if let Some(why) = p.not_compiled(mode) {
            // A kernel the compiler does not handle is interpreted; only constructs it
            // does not know yet may send a built-in there.
            assert!(
                why.contains("outside the private space"),
                "{} is not compiled in {mode:?}: {why}",
                m.label
            );
            continue;
        }
        compiled = true;
        assert_eq!(p.engine(mode), Engine::Compiled, "{}", m.label);
        // The SIMD path is what runs in both modes, unless LINELIGHT_LANES or
        // LINELIGHT_F64_PATH asks for another.
        if default_paths() {
            assert_eq!(p.path(mode), Some(expected_path(mode)), "{} {mode:?}", m.label);
        }
        let native = m.cpu_column_on(configs, mode, Engine::Compiled);
        match (interp, native) {
            (Ok(a), Ok(b)) => {
                if let Some(i) = same_bits(&a, &b) {
                    panic!(
                        "{} {mode:?}: interpreter {:?} ≠ compiled {:?} on {:?}",
                        m.label, a[i], b[i], configs[i]
                    );
                }
                compared += a.iter().filter(|v| v.is_some()).count();
            }
            (Err(a), Err(b)) => assert_eq!(format!("{a:#}"), format!("{b:#}"), "{}", m.label),
            (a, b) => panic!(
                "{} {mode:?}: interpreter {:?}, compiled {:?}",
                m.label,
                a.err(),
                b.err()
            ),
        }
    }
    compiled.then_some(compared)
}

#[test]
fn every_builtin_kernel_gives_the_interpreters_bits_in_f32_and_f64() {
    let configs = case_configs();
    let materials: Vec<&str> = configs
        .iter()
        .map(|c| match c.material {
            Material::Diffuse => "diffuse",
            Material::Ltc { .. } => "ltc",
            Material::Ggx { .. } => "ggx",
        })
        .collect();
    for kind in ["diffuse", "ltc", "ggx"] {
        assert!(materials.contains(&kind), "the sample has no {kind} configuration");
    }
    let odd = odd_configs(&configs);
    let methods = every_builtin();
    assert!(methods.len() > 40, "{} methods", methods.len());
    let (mut total, mut interpreted) = (0, Vec::new());
    for m in &methods {
        match (compare(m, &configs), compare(m, &odd)) {
            (Some(a), Some(b)) => {
                assert!(a + b > 0, "{}: no configuration compared", m.label);
                total += a + b;
            }
            // The texel buffer (`ll_texels`) and the LTC tables (`ll_ltc`, the
            // device look-ups) are not compiled yet: those kernels run on the interpreter
            // (their reason is checked in `compare`).
            _ => interpreted.push(m.label.clone()),
        }
    }
    assert!(
        interpreted
            .iter()
            .all(|l| l.starts_with("line.texture_") || l.starts_with("line.ltc_lookup_")),
        "built-ins interpreted: {interpreted:?}"
    );
    eprintln!(
        "{} methods, {total} values compared bit for bit; interpreted: {interpreted:?}",
        methods.len()
    );
}

/// A user kernel that goes through the WGSL rules the interpreter implements.
const RULES: &str = "\
//! id: test.rules
//! target: line

fn pick(a: array<f32, 5>, i: i32) -> f32 {
    return a[i];
}

fn method(scene: Scene) -> f32 {
    let x = scene.p1.x;
    let k = i32(floor(x * 7.0));
    let u = u32(abs(x) * 5.0);
    var acc = 0.0;
    // Integer division and remainder by zero, the signed overflow, shifts.
    acc += f32(k / (k - k)) + f32(k % (k - k)) + f32(u / (u - u)) + f32(u % (u - u));
    acc += f32((-2147483647 - 1) / select(1, -1, x > -100.0)) * 1e-9;
    acc += f32((k << 3u) >> 1u) + f32(u >> 2u) + f32(k & 5) + f32(u ^ 3u);
    // min/max/clamp of NaN and infinities, step, sign, saturate, fract, round.
    let nan = (scene.p2.y - scene.p2.y) / (scene.p2.y - scene.p2.y);
    acc += min(nan, x) + max(x, nan) + clamp(x, -0.5, 0.5) + step(0.1, x) + sign(x) + saturate(x);
    acc += fract(x * 3.3) + round(x * 2.5) + trunc(-x) + ceil(x);
    acc += select(1.0, 2.0, nan != nan) + f32(all(vec2<bool>(x > 0.0, k > 0))) + f32(any(vec2<bool>(x > 0.0, k > 0)));
    // A dynamic index into a local array, clamped out of range as the interpreter does.
    var a = array<f32, 5>(1.0, 2.0, 3.0, 4.0, 5.0);
    a[k] = x;
    acc += a[k + 1] + pick(a, k - 9) + pick(a, 99);
    var v = vec3<f32>(x, 2.0 * x, 3.0);
    v[u] += 1.0;
    acc += v[u % 3u] + dot(v, v) + length(v) + distance(v, scene.p2) + cross(v, scene.p2).z;
    // switch with fall-through and default; a loop with continue and break.
    switch (k) {
        case 0, 1: { acc += 10.0; }
        case 2: { acc -= 3.0; }
        case 3: { acc *= 1.5; }
        default: { acc += 0.25; }
    }
    var i = 0;
    loop {
        i += 1;
        if (i % 3 == 0) { continue; }
        acc += sin(f32(i) * x) * exp2(-f32(i)) + atan2(x, f32(i)) + pow(abs(x) + 0.5, 1.3);
        if (i > 7) { break; }
        continuing { break if i >= 20; }
    }
    let m = mat3x3<f32>(scene.p1, scene.p2, v);
    acc += determinant(m) + (m * v).y + (v * m).z + (transpose(m) * m)[1].x + normalize(v).x + inverseSqrt(abs(x) + 1.0);
    return acc + fma(x, 1.0 + x, -x) + mix(x, 2.0, 0.3) + tan(x) + acos(clamp(x, -1.0, 1.0)) + log2(abs(x) + 1.0);
}
";

fn user(text: &str, id: &str) -> Method {
    Method {
        label: id.to_string(),
        kernel: KernelFile::parse(&format!("user/{id}.wgsl"), text).unwrap_or_else(|e| panic!("{e}")),
        params: Vec::new(),
        inner: None,
        judged: None,
    }
}

#[test]
fn a_kernel_of_many_rules_gives_the_interpreters_bits() {
    let m = user(RULES, "test.rules");
    let mut configs = case_configs();
    configs.truncate(4000);
    configs.extend(odd_configs(&configs));
    for x in [-3.0, -1.0, -0.0, 0.0, 0.1, 0.3, 0.45, 1.0, 2.9, 1e10, -1e10] {
        let mut c = configs[0].clone();
        c.p1[0] = x;
        configs.push(c);
    }
    let p = program(&m).unwrap();
    for mode in [Mode::F32, Mode::F64] {
        assert_eq!(p.not_compiled(mode), None);
    }
    assert!(compare(&m, &configs).is_some_and(|n| n > 0));
}

/// A loop whose continuing block ends in `break if`: left by the body's `break` (on the first
/// pass where `scene.p1.x` ≤ 0, or later) or by `break if` after four passes.
const BREAK_IF: &str = "\
//! id: test.break_if
//! target: line
fn method(scene: Scene) -> f32 {
    var i = 0;
    var acc = 0.0;
    loop {
        if (f32(i) >= scene.p1.x * 3.0) { break; }
        acc += sin(f32(i) + scene.p2.y) + 0.5;
        continuing {
            let j = i + 1;
            i = j;
            break if j >= 4 || acc > scene.p1.z * 2.0;
        }
    }
    return acc;
}
";

#[test]
fn a_loop_with_break_if_gives_the_interpreters_bits() {
    let m = user(BREAK_IF, "test.break_if");
    let p = program(&m).unwrap();
    for mode in [Mode::F32, Mode::F64] {
        assert_eq!(p.not_compiled(mode), None);
    }
    let base = case_configs().swap_remove(0);
    let mut configs = Vec::new();
    for (i, x) in [-1.0, -0.0, 0.0, 0.1, 0.3, 0.5, 0.9, 1.4, 3.0].into_iter().enumerate() {
        for z in [0.1, 0.6, 1.5, 4.0] {
            let mut c = base.clone();
            c.p1 = [x, 0.3, z];
            c.p2 = [0.1, 0.2 * i as f64 - 0.7, 1.0];
            configs.push(c);
        }
    }
    // All lanes leaving by `break` on the first pass (x ≤ 0: the first 12), and all mixed.
    assert_eq!(compare(&m, &configs[..12]), Some(24));
    assert_eq!(compare(&m, &configs), Some(2 * configs.len()));
}

const LOOPS: &str = "\
//! id: test.loops
//! target: line
//! params: N=1
override N: u32 = 1u;
fn method(scene: Scene) -> f32 {
    var s = 0.0;
    for (var i = 0u; i < N; i++) { s += 1.0; }
    return s * scene.p1.z;
}
";

#[test]
fn the_loop_limit_is_an_error_on_both_never_a_value() {
    let configs = &case_configs()[..1];
    let loops = |n: u32| {
        let mut m = user(LOOPS, "test.loops");
        m.params = vec![f64::from(n)];
        m
    };
    // `for` runs its header once more than its body: N = 2^24 − 1 is 2^24 passes, the most
    // the interpreter allows. (The interpreter runs it in f32 only: 2^24 passes take it ~30 s.)
    let most = loops((1 << 24) - 1);
    let a = most.cpu_column_on(configs, Mode::F32, Engine::Interpreter).unwrap();
    let b = most.cpu_column_on(configs, Mode::F32, Engine::Compiled).unwrap();
    assert_eq!(a[0].map(f64::to_bits), b[0].map(f64::to_bits));
    let z = configs[0].p1[2] as f32;
    assert_eq!(b[0], Some(f64::from(16777215.0f32 * z)));
    let wide = most.cpu_column_on(configs, Mode::F64, Engine::Compiled).unwrap();
    assert_eq!(wide[0], Some(16777215.0 * configs[0].p1[2]));
    // One more pass: the interpreter's error, word for word, in both modes; never a value.
    let over = loops(1 << 24);
    for mode in [Mode::F32, Mode::F64] {
        let e = over.cpu_column_on(configs, mode, Engine::Compiled).unwrap_err();
        assert_eq!(format!("{e:#}"), "CPU evaluator: a loop ran more than 2^24 iterations");
    }
    let e = over.cpu_column_on(configs, Mode::F32, Engine::Interpreter).unwrap_err();
    assert_eq!(format!("{e:#}"), "CPU evaluator: a loop ran more than 2^24 iterations");
}

#[test]
fn an_unknown_construct_falls_back_to_the_interpreter_with_its_reason() {
    let text = "//! id: test.bits\n//! target: line\nfn method(scene: Scene) -> f32 { return bitcast<f32>(bitcast<u32>(scene.p1.z)); }\n";
    let m = user(text, "test.bits");
    let p = program(&m).unwrap();
    let why = p.not_compiled(Mode::F32).expect("bitcast is not compiled");
    assert!(why.contains("bitcast"), "{why}");
    assert_eq!(p.engine(Mode::F32), Engine::Interpreter);
    // The interpreter has no bitcast either: the column is an error naming it, as before.
    let configs = &case_configs()[..2];
    assert!(m.cpu_column(configs, Mode::F32).is_err());
}

/// `min`, `max` and `clamp` are compares and selects in compiled code, no longer calls of
/// Rust's functions: on every pair of ±0, ±1, ±∞ and NaN they return what the interpreter's
/// Rust `min`/`max` return, the sign of a zero included (`1/x` tells +0 from −0).
#[test]
fn min_max_and_clamp_of_signed_zeros_and_nans_give_the_interpreters_bits() {
    let values = [0.0, -0.0, 1.0, -1.0, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
    let base = case_configs().swap_remove(0);
    let mut configs = Vec::new();
    for &x in &values {
        for &y in &values {
            for &z in &values {
                let mut c = base.clone();
                c.p1 = [x, y, z];
                configs.push(c);
            }
        }
    }
    for (id, body) in [
        ("test.max", "1.0 / max(scene.p1.x, scene.p1.y)"),
        ("test.min", "1.0 / min(scene.p1.x, scene.p1.y)"),
        ("test.clamp", "1.0 / clamp(scene.p1.x, scene.p1.y, scene.p1.z)"),
        ("test.max0", "1.0 / max(0.0, scene.p1.x) + 1.0 / min(-0.0, scene.p1.y)"),
    ] {
        let text = format!("//! id: {id}\n//! target: line\nfn method(scene: Scene) -> f32 {{ return {body}; }}\n");
        let m = user(&text, id);
        assert_eq!(program(&m).unwrap().not_compiled(Mode::F32), None, "{id}");
        assert_eq!(compare(&m, &configs), Some(configs.len() * 2), "{id}");
    }
}

/// Lanes that part: early returns on some lanes, loops left by `break`, `continue` and a
/// NaN at different passes, a data-dependent trip count, a switch whose cases differ per
/// lane with a `break` inside an `if`, and private state written under a mask.
const DIVERGE: &str = "\
//! id: test.diverge
//! target: line
var<private> seen: f32 = 0.0;

fn f(x: f32) -> f32 {
    if (x < 0.0) {
        return -x;
    }
    var s = 0.0;
    for (var i = 0; i < 40; i++) {
        if (s > x * 10.0) { break; }
        if (i % 3 == 0) { continue; }
        s += x + f32(i) / (x - 0.5);
        seen += 1.0;
        if (s != s) { return s + 1.0; }
    }
    return s;
}

fn method(scene: Scene) -> f32 {
    var acc = f(scene.p1.x) + f(scene.p2.y);
    let n = u32(abs(scene.p1.z) * 3.0) % 6u;
    var k = 0u;
    loop {
        if (k >= n) { break; }
        acc += sqrt(abs(acc) + f32(k));
        k++;
        if (acc > 50.0) { break; }
    }
    switch (n) {
        case 1u: { acc *= 2.0; }
        case 2u, 3u: {
            if (acc > 1.0) { break; }
            acc -= 1.0;
        }
        default: { acc += cos(acc); }
    }
    return acc + seen;
}
";

#[test]
fn lanes_that_diverge_give_the_interpreters_bits_for_any_chunk_length() {
    let m = user(DIVERGE, "test.diverge");
    let p = program(&m).unwrap();
    for mode in [Mode::F32, Mode::F64] {
        assert_eq!(p.not_compiled(mode), None);
        if default_paths() {
            assert_eq!(p.path(mode), Some(expected_path(mode)), "{mode:?}");
        } else {
            println!("{mode:?}: {}", p.path(mode).unwrap().describe());
        }
    }
    let base = case_configs().swap_remove(0);
    let xs = [
        -2.0,
        -0.0,
        0.0,
        0.25,
        0.5,
        0.7,
        1.3,
        3.0,
        f64::NAN,
        f64::INFINITY,
        -f64::INFINITY,
        1e-30,
    ];
    let mut configs = Vec::new();
    for (i, &x) in xs.iter().enumerate() {
        for (j, &y) in xs.iter().enumerate() {
            let mut c = base.clone();
            c.p1 = [x, 0.3, 0.2 + 0.37 * ((i * 7 + j) % 9) as f64];
            c.p2 = [0.1, y, 1.0];
            configs.push(c);
        }
    }
    // Every chunk length up to three calls' worth, so the last call's lanes are padded in
    // every way, and the whole set (144 configurations, neighbours on different paths).
    for len in 1..=3 * LANES + 1 {
        for start in [0, 5, 17] {
            let part = &configs[start..start + len];
            assert!(
                compare(&m, part).is_some_and(|n| n == 2 * len),
                "length {len} from {start}"
            );
        }
    }
    assert_eq!(compare(&m, &configs), Some(2 * configs.len()));
}

/// The paths the switches select (the previous f64 interleaved lanes, and other vector
/// counts per call: 2 and 6 f64 configurations, 4 and 12 f32) give the same bits too: this
/// test binary run again under each switch, on the diverging and the rules kernels.
#[test]
fn the_paths_the_switches_select_give_the_interpreters_bits() {
    if !default_paths() {
        return; // already a run under a switch
    }
    let me = std::env::current_exe().unwrap();
    for (var, value) in [
        ("LINELIGHT_F64_PATH", "lanes"),
        ("LINELIGHT_VECTORS", "1"),
        ("LINELIGHT_VECTORS", "3"),
    ] {
        let out = std::process::Command::new(&me)
            .env(var, value)
            .args([
                "compiled::lanes_that_diverge_give_the_interpreters_bits_for_any_chunk_length",
                "compiled::a_kernel_of_many_rules_gives_the_interpreters_bits",
                "--exact",
                "--test-threads=1",
            ])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{var}={value}:\n{text}");
        assert!(text.contains("2 passed"), "{var}={value}:\n{text}");
    }
}
