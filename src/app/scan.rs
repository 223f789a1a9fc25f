//! `linelight scan`: the stability scan on the device (docs/scan.md), its inputs checked
//! before any work, then measure::scan per method and family, analyse::scan, report::scan.

use super::{kernel_inputs, open_gpu, parse_count, GpuOptions, Status};
use crate::io::{OutputPlan, SetKind};
use crate::kernel::methods;
use crate::report::format::{Format, Json, Jsonl, Layout, Markdown};
use anyhow::Result;
use std::path::PathBuf;

/// Options of `linelight scan`.
#[derive(clap::Args)]
pub struct ScanOptions {
    /// Case file whose families' distributions are scanned.
    pub case: PathBuf,
    /// Configurations per method, split evenly over the case's families (`1e9` is allowed).
    #[arg(long, default_value = "1e6")]
    pub count: String,
    /// Comma-separated method specs (default: the case's line methods).
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Offending configurations to capture per method and family.
    #[arg(long, default_value_t = 64)]
    pub capture: usize,
    /// Also count values above this bound (units where d = 1; above 0, at most f32's largest).
    #[arg(long, value_parser = super::options::bound)]
    pub bound: Option<f64>,
    /// The scan's report goes to OUT/<case name>-scan/.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
    #[command(flatten)]
    pub gpu: GpuOptions,
}

/// `linelight scan`: the stability scan on the device (docs/scan.md).
pub fn scan(options: ScanOptions, includes: &crate::kernel::Includes) -> Result<Status> {
    let ScanOptions {
        case,
        count,
        methods: specs,
        capture,
        bound,
        out,
        gpu,
    } = options;
    let command_line = shell_words::join(std::env::args());
    let count = parse_count(&count)?;
    if let Some(b) = bound {
        super::options::check_float("--bound", b, super::options::BOUND).map_err(anyhow::Error::msg)?;
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
    let kernels = methods::kernel_set(&gpu.kernels, includes)?;
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
