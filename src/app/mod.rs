//! The app layer: what each command does with the stages (measure → analyse → report), its
//! inputs checked before any work; `main.rs` parses the command line and calls these. Each
//! returns a [`Status`], and an error's [`Status`] says which exit code it is (README,
//! "Exit status"; docs/exit-codes.md).

mod bench;
pub mod chain;
pub mod diff;
pub mod eval;
pub mod fit;
pub mod gate;
pub mod objectives;
pub mod options;
pub mod render;
pub mod resolution;
pub mod shard;
mod status;
pub mod sweep;

pub use bench::{bench, BenchOptions};

pub use status::{status_of, Status};

use crate::io::{OutputPlan, SetKind};
use crate::kernel::methods;
use crate::measure::gpu::{self, Gpu};
use crate::report::format::{Format, Json, Jsonl, Layout, Markdown};
use anyhow::Result;
use std::path::{Path, PathBuf};

/// The device options every GPU command takes.
pub struct GpuOptions {
    /// Any part of the adapter's name (default: lavapipe / llvmpipe).
    pub adapter: Option<String>,
    /// `--kernel` files.
    pub kernels: Vec<PathBuf>,
    /// Configurations per dispatch and readback.
    pub chunk: usize,
}

/// `--kernel` files as inputs an output may not be.
pub fn kernel_inputs(kernels: &[PathBuf]) -> Vec<(&'static str, &Path)> {
    kernels.iter().map(|k| ("--kernel", k.as_path())).collect()
}

/// Opens the adapter asked for and says which it is.
pub fn open_gpu(adapter: Option<&str>) -> Result<Gpu> {
    let gpu = Gpu::new(adapter)?;
    eprintln!("adapter: {}", gpu.adapter);
    Ok(gpu)
}

/// A count as typed: `1000000`, `1e9` or `1_000_000`; a positive whole number.
pub fn parse_count(text: &str) -> Result<u64> {
    let clean = text.replace('_', "");
    let v: f64 = clean
        .parse()
        .map_err(|_| anyhow::anyhow!("--count `{text}`: not a number (write e.g. 1000000 or 1e9)"))?;
    if !((1.0..=crate::limits::MAX_SCAN_COUNT as f64).contains(&v) && v.fract() == 0.0) {
        anyhow::bail!("--count `{text}`: need a whole number from 1 to 1e15");
    }
    Ok(v as u64)
}

/// A message stays readable whatever the input: long lines (a 100 MB id, a minified JSON
/// line) are cut, and past a screenful of lines the rest is counted.
pub fn bounded(message: &str) -> String {
    const LINE: usize = 400;
    const LINES: usize = 40;
    let lines: Vec<&str> = message.lines().collect();
    let mut out: Vec<String> = lines
        .iter()
        .take(LINES)
        .map(|l| {
            if l.chars().count() > LINE {
                let head: String = l.chars().take(LINE).collect();
                format!("{head}… ({} more bytes)", l.len() - head.len())
            } else {
                l.to_string()
            }
        })
        .collect();
    if lines.len() > LINES {
        out.push(format!("… and {} more lines", lines.len() - LINES));
    }
    out.join("\n")
}

/// Options of `linelight scan`.
pub struct ScanOptions {
    pub case: PathBuf,
    pub count: String,
    pub methods: Vec<String>,
    pub capture: usize,
    pub bound: Option<f64>,
    pub out: PathBuf,
}

/// `linelight scan`: the stability scan on the device (docs/scan.md).
pub fn scan(options: ScanOptions, gpu: &GpuOptions) -> Result<Status> {
    let ScanOptions {
        case,
        count,
        methods: specs,
        capture,
        bound,
        out,
    } = options;
    let command_line = shell_words::join(std::env::args());
    let count = parse_count(&count)?;
    if let Some(b) = bound {
        options::check_float("--bound", b, options::BOUND).map_err(anyhow::Error::msg)?;
    }
    let max = crate::limits::MAX_CAPTURE;
    anyhow::ensure!(
        capture <= max,
        "--capture {capture}: at most {max} offending configurations are kept per method and family"
    );
    let case_path = case;
    let case = crate::input::case::Case::load(&case_path)?;
    let dir = out.join(format!("{}-scan", case.name));
    let mut plan = OutputPlan::new();
    plan.input("the case file", &case_path);
    for (what, path) in kernel_inputs(&gpu.kernels) {
        plan.input(what, path);
    }
    plan.set("--out", &dir, SetKind::Scan).check()?;
    let kernels = methods::kernel_set(&gpu.kernels)?;
    let given = !specs.is_empty();
    let specs: Vec<String> = if given { specs } else { case.methods.clone() };
    let mut chosen = Vec::new();
    for s in &specs {
        let m = methods::resolve(s, &kernels)?;
        if matches!(
            m.target(),
            crate::input::target::Target::Line | crate::input::target::Target::LineUpper
        ) {
            chosen.push(m);
        } else if given {
            // Asked for by name: never dropped in silence.
            anyhow::bail!(
                "scan generates line configurations only: `{s}` approximates `{}`",
                m.target()
            );
        } else {
            crate::warnings::raise(crate::warnings::Warning::MethodNotScanned {
                method: s.to_string(),
                target: m.target().to_string(),
            });
        }
    }
    if chosen.is_empty() {
        anyhow::bail!("no line method to scan in {}", specs.join(", "));
    }
    // Families whose M⁻¹ comes from a fitted table are not generated on the device.
    let scannable: Vec<usize> = (0..case.materials.len())
        .filter(|&f| {
            let family = &case.materials[f];
            let ok = crate::measure::scan::generated_on_device(family.kind);
            if !ok {
                crate::warnings::raise(crate::warnings::Warning::FamilyNotScanned {
                    family: family.name.clone(),
                    kind: format!("{:?}", family.kind),
                });
            }
            ok
        })
        .collect();
    if scannable.is_empty() {
        anyhow::bail!(
            "no family of {} can be generated on the device (diffuse, ltc_sparse, ltc_full)",
            case.name
        );
    }
    // The captured offenders are held until the report is written: about 400 bytes each
    // with their JSON line.
    let captured = (capture as u64)
        .saturating_mul(chosen.len() as u64)
        .saturating_mul(scannable.len() as u64);
    crate::limits::check(
        &format!(
            "scan of case `{}` capturing up to {captured} offending configurations",
            case.name
        ),
        crate::limits::Bytes(captured.saturating_mul(400)),
        crate::limits::max_memory(),
    )
    .map_err(anyhow::Error::msg)?;
    let device = open_gpu(gpu.adapter.as_deref())?;
    // Every method against the driver's loop limit before any is scanned (as sweep, eval and
    // diff do): a static trip count past it is refused now, not after the methods before it.
    for m in &chosen {
        device.check_loops(m)?;
    }
    let families = scannable.len() as u64;
    let per_family = count.div_ceil(families);
    let pb = crate::measure::progress::styled(
        per_family * families * chosen.len() as u64,
        "",
        "{msg:>40} [{bar:30}] {human_pos}/{human_len} ({per_sec}, eta {eta})",
    );
    let mut results = Vec::new();
    let mut finished = 0u64;
    for m in &chosen {
        for &f in &scannable {
            let size = crate::measure::scan::ScanSize {
                count: per_family,
                capture,
                bound,
            };
            let scanned = crate::measure::scan::scan(&device, &case, m, f, size, &mut |done, bad| {
                pb.set_position(finished + done);
                pb.set_message(format!(
                    "{} {}: rate {:.1e}",
                    m.label,
                    case.materials[f].name,
                    bad as f64 / done as f64
                ));
            })?;
            finished += per_family;
            results.push(crate::analyse::scan::ScanResult::from(scanned));
        }
    }
    pb.finish_and_clear();
    let text = crate::report::scan::markdown(&case, &command_line, &device.adapter.to_string(), &results);
    print!("{}", crate::report::scan::table(&results));
    let rows: Vec<_> = results
        .iter()
        .flat_map(|r| &r.captured)
        .map(serde_json::to_value)
        .collect::<Result<_, _>>()?;
    let outputs: Vec<Box<dyn Format>> = vec![
        Box::new(Markdown::new("scan.md", text)),
        Box::new(Json::new("summary.json", &results, Layout::Pretty)),
        Box::new(Jsonl::new("offending.jsonl", rows)),
    ];
    crate::report::format::write_set(&dir, SetKind::Scan, &outputs)?;
    eprintln!("wrote {}", dir.display());
    Ok(Status::Ok)
}

/// `linelight adapters`: each Vulkan adapter and its loop limit as probed.
pub fn adapters() -> Result<Status> {
    let adapters = gpu::list_adapters();
    if adapters.is_empty() {
        println!("no Vulkan adapter found (on Debian/Ubuntu: apt-get install mesa-vulkan-drivers)");
    }
    for a in adapters {
        // The loop limit is probed on the device (src/gpu/loops.rs).
        let limit = match Gpu::new(Some(&a.name)).map(|g| g.loop_limit()) {
            Ok(Ok(Some(l))) => format!("loops stop after {l} iterations"),
            Ok(Ok(None)) => format!("no loop limit below {}", gpu::PROBE_TRIPS),
            Ok(Err(e)) => format!("loop limit not probed: {e}"),
            Err(e) => format!("loop limit not probed: {e}"),
        };
        println!("{a}; {limit}");
    }
    Ok(Status::Ok)
}

/// `linelight check`: each kernel file validated as every command validates a `--kernel`
/// file, and its loops held against the driver's loop limit as eval holds them; `emit` prints
/// the composed modules. Bad input (2) when one does not validate or loops past the limit.
pub fn check(kernels: &[PathBuf], emit: bool) -> Result<Status> {
    let mut bad = 0;
    let mut known = crate::kernel::builtin_kernels();
    // Opened for the first kernel with loops: the limit is the device's (gpu/loops.rs).
    let mut device: Option<std::result::Result<Gpu, String>> = None;
    for path in kernels {
        // The same validation eval, sweep and bench give a --kernel file.
        match methods::validate_kernel(path, &known) {
            Ok(k) => {
                // The CPU evaluator gives the kernel its f64 and cpu_f32 columns.
                // (A composite with the default line method, as it is composed here.)
                let mut set = vec![k.clone()];
                set.extend(known.iter().filter(|b| b.id != k.id).cloned());
                let method = methods::resolve(&k.id, &set);
                let cpu = match method
                    .as_ref()
                    .map_err(|e| anyhow::anyhow!("{e:#}"))
                    .and_then(|m| crate::eval::interp::program(m).map(|_| ()))
                {
                    Ok(()) => "CPU evaluator: ok".to_string(),
                    Err(e) => format!("CPU evaluator: no f64/cpu_f32 values: {e:#}"),
                };
                let loops = match &method {
                    Ok(m) => check_loops(m, &mut device),
                    Err(_) => Ok(String::new()),
                };
                let loops = match loops {
                    Ok(note) => note,
                    Err(e) => {
                        eprintln!("{}", bounded(&format!("{e:#}")));
                        bad += 1;
                        continue;
                    }
                };
                let line = format!("{}: ok ({} → {}); {cpu}{loops}", path.display(), k.id, k.target);
                if emit {
                    eprintln!("{line}");
                    let composed = crate::kernel::compose_with(&k, None, crate::kernel::kernel_capabilities())?;
                    print!("{}", composed.source);
                } else {
                    println!("{line}");
                }
                known.push(k);
            }
            Err(e) => {
                eprintln!("{}", bounded(&format!("{e:#}")));
                bad += 1;
            }
        }
    }
    Ok(if bad == 0 { Status::Ok } else { Status::BadInput })
}

/// `check`'s loop-limit check of a method with its default parameters: the one every GPU
/// command applies (`Gpu::check_loops`), on the default adapter. `Ok` carries a note for the
/// kernel's line; with no adapter the limit cannot be known, which the note says.
fn check_loops(
    method: &crate::kernel::methods::Method,
    device: &mut Option<std::result::Result<Gpu, String>>,
) -> Result<String> {
    let loops = crate::eval::cost::method_cost_of(method).map_or(1, |c| c.loops);
    if loops == 0 {
        return Ok(String::new());
    }
    let gpu = device.get_or_insert_with(|| Gpu::new(None).map_err(|e| format!("{e:#}")));
    match gpu {
        Ok(gpu) => Ok(match gpu.check_loops(method)? {
            Some(_) => "; loops: no static trip count, counted on every run".to_string(),
            None => "; loops: within the device's limit".to_string(),
        }),
        Err(e) => Ok(format!(
            "; loops: not checked against a driver's loop limit (no device: {})",
            crate::input::names::clip(e.lines().next().unwrap_or(""))
        )),
    }
}
