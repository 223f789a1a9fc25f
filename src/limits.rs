//! Resource limits checked before anything is allocated: a run's memory is estimated from
//! its sizes (configurations, methods, targets) and refused above `--max-memory`, which
//! defaults to half of the machine's memory. The estimates are deliberately generous
//! (measured peaks of a sweep were about 1 KB per configuration for nine methods).

use std::fmt;

/// Bytes, shown in binary units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Bytes(pub u64);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Whole bytes as they are: "1 B", not "1.0 B".
        if self.0 < 1024 {
            return write!(f, "{} B", self.0);
        }
        let b = self.0 as f64;
        let (v, unit) = if b >= (1u64 << 30) as f64 {
            (b / (1u64 << 30) as f64, "GiB")
        } else if b >= (1u64 << 20) as f64 {
            (b / (1u64 << 20) as f64, "MiB")
        } else if b >= 1024.0 {
            (b / 1024.0, "KiB")
        } else {
            (b, "B")
        };
        write!(f, "{v:.1} {unit}")
    }
}

/// Parses `--max-memory`: a number of bytes with an optional K, M, G or T (binary units).
pub fn parse_memory(s: &str) -> Result<Bytes, String> {
    let t = s.trim();
    let (digits, shift) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (
            &t[..i],
            match c.to_ascii_uppercase() {
                'K' => 10,
                'M' => 20,
                'G' => 30,
                'T' => 40,
                _ => return Err(format!("`{s}`: unknown unit `{c}` (K, M, G or T)")),
            },
        ),
        _ => (t, 0),
    };
    let v: f64 = digits
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: expected a size such as 8G, 512M or 1000000"))?;
    if !(v > 0.0 && v.is_finite()) {
        return Err(format!("`{s}`: the size must be > 0"));
    }
    let bytes = v * (1u64 << shift) as f64;
    Ok(Bytes(if bytes >= u64::MAX as f64 {
        u64::MAX
    } else {
        bytes as u64
    }))
}

/// The default limit: half of the machine's memory (MemTotal in /proc/meminfo), or 4 GiB
/// where that cannot be read.
pub fn default_max_memory() -> Bytes {
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| {
        m.lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
            .map(|kib| kib * 1024)
    });
    Bytes(total.map_or(4 << 30, |t| t / 2))
}

static MAX_MEMORY: std::sync::OnceLock<Bytes> = std::sync::OnceLock::new();

/// Whether `--max-memory` set the limit (messages then name it, not the default).
static GIVEN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Sets the limit for this process (`--max-memory`); the first call wins.
pub fn set_max_memory(limit: Bytes) {
    if MAX_MEMORY.set(limit).is_ok() {
        GIVEN.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The limit in force: `--max-memory`, or [`default_max_memory`].
pub fn max_memory() -> Bytes {
    *MAX_MEMORY.get_or_init(default_max_memory)
}

/// Estimated peak bytes of a sweep: per configuration its sample, GPU scene, references
/// and each method's values and statistics, and with `--raw` its JSON row.
pub fn sweep_estimate(configurations: u64, methods: u64, targets: u64, raw: bool) -> Bytes {
    let per = 1000 + 96 * methods + 96 * targets + if raw { 1500 + 200 * methods } else { 0 };
    Bytes(configurations.saturating_mul(per))
}

/// Estimated peak bytes of one step of the worst-case search: each candidate's sample,
/// GPU scene, value and reference.
pub fn search_estimate(candidates: u64) -> Bytes {
    Bytes(candidates.saturating_mul(2000))
}

/// Estimated peak bytes of an eval: the configurations kept, each method's GPU values, one
/// block of output rows at a time.
pub fn eval_estimate(configurations: u64, methods: u64) -> Bytes {
    Bytes(configurations.saturating_mul(400 + 16 * methods))
}

/// Bytes of private and function-local memory one invocation of a kernel holds: every
/// `var<private>` and every local `var` of every function (an upper bound: not all live at
/// once). None when naga cannot lay the types out.
pub fn kernel_invocation_bytes(module: &naga::Module) -> Option<u64> {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).ok()?;
    let size = |ty: naga::Handle<naga::Type>| u64::from(layouter[ty].size);
    let private: u64 = module
        .global_variables
        .iter()
        .filter(|(_, g)| g.space == naga::AddressSpace::Private)
        .map(|(_, g)| size(g.ty))
        .sum();
    let locals: u64 = module
        .functions
        .iter()
        .map(|(_, f)| f)
        .chain(module.entry_points.iter().map(|e| &e.function))
        .flat_map(|f| f.local_variables.iter().map(|(_, v)| size(v.ty)))
        .sum();
    Some(private.saturating_add(locals))
}

/// Invocations whose private memory a CPU driver holds at once: a workgroup per core.
pub fn invocations_in_flight() -> u64 {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get() as u64);
    u64::from(crate::kernel::WORKGROUP_SIZE) * cores
}

/// Refuses an estimate above the limit, with both numbers and what to change.
pub fn check(what: &str, estimate: Bytes, limit: Bytes) -> Result<(), String> {
    if estimate > limit {
        let limit = if GIVEN.load(std::sync::atomic::Ordering::Relaxed) {
            format!("--max-memory {limit}")
        } else {
            format!("the default limit {limit} (half of this machine's memory)")
        };
        return Err(format!(
            "{what} needs an estimated {estimate} of memory, more than {limit}: use fewer configurations or \
             raise --max-memory"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_refusals_say_both_numbers() {
        assert_eq!(parse_memory("512M"), Ok(Bytes(512 << 20)));
        assert_eq!(parse_memory("1.5G"), Ok(Bytes(3 << 29)));
        assert_eq!(parse_memory("1000"), Ok(Bytes(1000)));
        assert!(parse_memory("-1G").is_err() && parse_memory("3Q").is_err() && parse_memory("").is_err());
        let e = check("sweep", Bytes(10 << 30), Bytes(1 << 30)).unwrap_err();
        assert!(e.contains("10.0 GiB") && e.contains("1.0 GiB"), "{e}");
        assert_eq!(Bytes(1).to_string(), "1 B");
        assert_eq!(Bytes(1023).to_string(), "1023 B");
        assert_eq!(Bytes(1024).to_string(), "1.0 KiB");
        assert!(default_max_memory().0 > 0);
    }
}
