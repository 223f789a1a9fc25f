//! The attribution ("where the bits go") alone, timed: for each case named, each method's
//! [`Program::attribute`] on the subset a sweep takes (every k-th configuration of the case's
//! sample, k = expected count / `ATTRIBUTION_CONFIGURATIONS`, where the method applies, at most
//! that many), its wall seconds and the process's CPU seconds (user + sys, all threads) over
//! it. Nothing else runs (no GPU, no references), so A/B runs of two builds compare the
//! attribution's own cost (docs/evaluator.md).
//! `cargo run --release --example attribution_bench -- cases/caps.toml [cases/…]`
use linelight::eval::interp::program;
use linelight::input::case::Case;
use linelight::input::scene::Config;
use linelight::measure::sweep::ATTRIBUTION_CONFIGURATIONS;

/// The process's user + sys CPU seconds so far (all threads).
fn cpu_seconds() -> f64 {
    let mut u = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage fills the struct it is given.
    let u = unsafe {
        libc::getrusage(libc::RUSAGE_SELF, u.as_mut_ptr());
        u.assume_init()
    };
    let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
    t(u.ru_utime) + t(u.ru_stime)
}

fn main() -> anyhow::Result<()> {
    let cases: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(!cases.is_empty(), "usage: attribution_bench CASE.toml…");
    for path in cases {
        let case = Case::load(std::path::Path::new(&path))?;
        let expected: usize = case.materials.iter().map(|m| m.count).sum();
        let step = expected.div_ceil(ATTRIBUTION_CONFIGURATIONS).max(1);
        let setup = linelight::app::prepare(case, &[], &linelight::kernel::Includes::none(), None)?;
        let (mut wall, mut cpu) = (0.0, 0.0);
        for m in &setup.methods {
            let subset: Vec<&Config> = setup
                .samples
                .iter()
                .enumerate()
                .filter(|(i, s)| i % step == 0 && m.applies(&s.config))
                .map(|(_, s)| &s.config)
                .take(ATTRIBUTION_CONFIGURATIONS)
                .collect();
            let p = program(m)?;
            let (t0, c0) = (std::time::Instant::now(), cpu_seconds());
            let a = p.attribute(&subset)?;
            let (dt, dc) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
            let lines: usize = a.per_config.iter().map(Vec::len).sum();
            println!(
                "{} {}: {} configurations, {lines} line records, wall {dt:.3} s, cpu {dc:.3} s",
                setup.case.name,
                m.label,
                subset.len()
            );
            wall += dt;
            cpu += dc;
        }
        println!("{} total: wall {wall:.3} s, cpu {cpu:.3} s", setup.case.name);
    }
    Ok(())
}
