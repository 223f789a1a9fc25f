//! `linelight check` (kernel files composed and validated, no GPU needed) and `linelight
//! adapters` (the Vulkan adapters wgpu can see).

use super::{bounded, Status};
use crate::kernel::methods;
use crate::measure::gpu::{self, Gpu};
use anyhow::Result;
use std::path::PathBuf;

/// Options of `linelight check`.
#[derive(clap::Args)]
pub struct CheckOptions {
    #[arg(required = true)]
    pub kernels: Vec<PathBuf>,
    /// Print each composed WGSL module (prelude + kernel + entry point) to stdout.
    #[arg(long)]
    pub emit: bool,
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
pub fn check(kernels: &[PathBuf], emit: bool, includes: &crate::kernel::Includes) -> Result<Status> {
    let mut bad = 0;
    let mut known = crate::kernel::builtin_kernels();
    // Opened for the first kernel with loops: the limit is the device's (gpu/loops.rs).
    let mut device: Option<std::result::Result<Gpu, String>> = None;
    for path in kernels {
        // The same validation eval, sweep and bench give a --kernel file.
        match methods::validate_kernel(path, &known, includes) {
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
