//! Resource limits checked before anything is allocated, in one place: the caps every count
//! passes, from the command line and from case files alike ([`check_count`]), and the memory
//! budget. A run's memory is estimated from its sizes, part by part ([`Budget`]: measuring
//! chunks, every bin and map cell of the statistics, kept observations, held rows, input
//! lines), and refused above `--max-memory`, which defaults to half of the machine's memory.
//! The estimates are deliberately generous (measured peaks of a sweep were about 1 KB per
//! configuration for nine methods; the per-bin and per-cell sizes below are about twice those
//! measured).

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
    let total = crate::io::read_system("/proc/meminfo", MAX_SYSTEM_FILE).and_then(|m| {
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

/// The most configurations per family a sweep, merge, diff, bench or chain takes, from
/// `--count` or a case file's `count`: stability counts beyond are `linelight scan`'s.
pub const MAX_COUNT: u64 = 1_000_000_000_000;

/// The most configurations per method a scan generates (`scan --count`): generated and
/// counted on the device, its memory does not grow with the count.
pub const MAX_SCAN_COUNT: u64 = 1_000_000_000_000_000;

/// The `[search]` and `[disagreements]` candidates one step may hold (restarts × population), a
/// bound on its memory.
pub const MAX_SEARCH_BATCH: usize = 1 << 20;

/// Refinement steps a search may take.
pub const MAX_STEPS: usize = 10_000;

/// The top-up budget's largest multiple of a family's count (`topup_draws`).
pub const MAX_TOPUP_DRAWS: usize = 1000;

/// The most timed or warm-up rounds a bench runs.
pub const MAX_ROUNDS: u64 = 10_000;

/// The largest case or kernel file read (a case with 200,000 bin edges is 4 MB).
pub const MAX_TEXT_INPUT: u64 = 64 << 20;

/// The deepest chain of `#include`s a GLSL or HLSL kernel may nest (src/kernel/include.rs).
pub const MAX_INCLUDE_DEPTH: usize = 16;

/// The most bytes a kernel and everything it includes may add up to, each file counted every
/// time it is included.
pub const MAX_INCLUDE_BYTES: u64 = 16 << 20;

/// Operations one claim expression or text placeholder may take (src/analyse/claims.rs): a
/// claim reads a few statistics, so this is far beyond any real one and stops a `loop` at once.
pub const MAX_CLAIM_OPERATIONS: u64 = 1_000_000;

/// The longest string a claim may build, in bytes.
pub const MAX_CLAIM_STRING: usize = 1 << 20;

/// The most elements of an array or object map a claim may build.
pub const MAX_CLAIM_ARRAY: usize = 1 << 16;

/// The deepest nesting of a claim's expressions (and of a closure's body in one).
pub const MAX_CLAIM_DEPTH: usize = 64;

/// The deepest chain of function calls a claim may make.
pub const MAX_CLAIM_CALLS: usize = 32;

/// The fewest configurations a quantile check, a region of What to ship (the default of a
/// case's `budget.min_count`) or a paired comparison (`diff`) is judged from: fewer give no
/// verdict, never a pass, and no bootstrap interval is printed from them. At 300 the p99 rests
/// on its three largest values.
pub const MIN_JUDGED: usize = 300;

/// A light texture's longest side, in texels (`texture.size` of `[materials.texture]`).
pub const MAX_TEXTURE_SIDE: u32 = 4096;

/// The most texels one configuration's texture may hold (a cubemap counts its six faces): a
/// texel costs 8 bytes in the configuration and 4 in the GPU's texel buffer.
pub const MAX_TEXELS: u64 = 1 << 20;

/// Estimated bytes of the light textures of `configurations` configurations held at once, each
/// with `texels` texels (a case's `[materials.texture]`, the largest of its families): per texel
/// the f64 in the configuration and in its f32-rounded copy (the references at the f32 inputs),
/// the f32 in the GPU's texel buffer, and with `--raw` its number in the JSON row.
pub fn texel_estimate(configurations: u64, texels: u64, raw: bool) -> Bytes {
    let per_texel = 8 + 8 + 4 + if raw { 24 } else { 0 };
    Bytes(configurations.saturating_mul(texels).saturating_mul(per_texel))
}

/// A look-up table file's longest side, layer count or depth, in texels (wgpu's default
/// `max_texture_dimension_2d`; a device's own limits are the binding's to check).
pub const MAX_LUT_SIDE: u32 = 8192;

/// The most texels level 0 of a look-up table file may hold, every layer or slice counted (4096²
/// or 256³): at most 256 MiB of RGBA32F, and as much again widened to f32 (src/input/texture_file).
pub const MAX_LUT_TEXELS: u64 = 1 << 24;

/// The largest look-up table file opened, in bytes, checked from its length before it is read:
/// level 0 at the texel cap in RGBA32F with its mip chain and headers.
pub const MAX_LUT_FILE_BYTES: u64 = 384 << 20;

/// The most texels the top-up holds in one batch of draws (src/input/sampler.rs): a batch of
/// textured draws is smaller, so its memory stays below 8 bytes × this.
pub const TOPUP_BATCH_TEXELS: u64 = 1 << 24;

/// Bytes the GPU's texel buffer takes for `texels` texels (f32 each).
pub fn texel_buffer_bytes(texels: u64) -> Bytes {
    Bytes(texels.max(1).saturating_mul(4))
}

/// The largest file of the system read (`/proc/meminfo`, the host name).
pub const MAX_SYSTEM_FILE: u64 = 1 << 20;

/// The largest JSON record read back (a baseline's `baseline.json`, `timings.json`).
pub const MAX_RECORD_BYTES: u64 = 64 << 20;

/// Bytes a line of an errors file may take (a token is at most about a dozen).
pub const MAX_TOKEN_LINE: u64 = 32;

/// Bytes an image of a render baseline may take (a 4096 × 4096 RGB image is 48 MiB raw).
pub const MAX_IMAGE_BYTES: u64 = 64 << 20;

/// At most this many tables in one study (each is fed to every configuration).
pub const MAX_TABLES: usize = 8;

/// The most SGD steps `--sw-steps` takes (each about a millisecond per entry).
pub const MAX_SW_STEPS: usize = 1_000_000;

/// The most lines per region and entry `--lines` takes (each is three adaptive references).
pub const MAX_LINES: usize = 4096;

/// The longest id a kernel may have.
pub const MAX_ID: usize = 100;

/// The most entries `linelight fit` makes a table of (256 × 256, or 16⁴ anisotropic): a fit
/// takes about a quarter of a second per core, so this is already hours, and larger sizes
/// would overflow the table's size or memory. The published tables are 64 × 64.
pub const MAX_TABLE_ENTRIES: usize = 1 << 16;

/// A case name becomes a folder under `--out`: letters, digits, `.`, `_`, `-`, starting
/// with a letter or digit, at most this long.
pub const MAX_NAME: usize = 100;

/// Pixels a render may have (memory: a few configurations' worth of values each).
pub const MAX_PIXELS: u64 = 4096 * 4096;

/// Bad lines listed in one message.
pub const MAX_ERRORS: usize = 20;

/// The most offending configurations `--capture` keeps per method and family: a buffer of
/// 5 MiB on the device, well inside every device's storage binding.
pub const MAX_CAPTURE: usize = 1 << 16;

/// Refuses a count of configurations (`what` says where it came from: `--count`, a case
/// file's key) that is 0 or above [`MAX_COUNT`].
pub fn check_count(what: &str, n: u64) -> Result<(), String> {
    if n == 0 {
        return Err(format!("{what} must be at least 1"));
    }
    if n > MAX_COUNT {
        return Err(format!(
            "{what} {n}: more than the {MAX_COUNT} configurations per family a sweep takes (stability \
             counts beyond are `linelight scan`'s)"
        ));
    }
    Ok(())
}

/// Refuses a number of rounds, repeats or similar (`what`: the option) outside 1..=`max`
/// (0..=`max` when `zero` is allowed).
pub fn check_rounds(what: &str, n: u64, max: u64, zero: bool) -> Result<(), String> {
    if n == 0 && !zero {
        return Err(format!("{what} must be at least 1"));
    }
    if n > max {
        return Err(format!("{what} {n}: at most {max}"));
    }
    Ok(())
}

/// Bytes of one bin of one material's statistics, for each method and compared pair and once
/// for the bin itself: its accumulator, finished statistics and rows in every report file
/// (measured: 11 KB per method, 7 KB per bin, 3 KB per pair, with 20,000 bins).
pub const BIN_BYTES: u64 = 16 << 10;

/// Bytes of one map cell of one method on one material, with its SVG and table rows
/// (measured: 4.6 KB).
pub const MAP_CELL_BYTES: u64 = 8 << 10;

/// Bytes an accumulator grows by for each configuration folded in while it keeps values
/// exactly: nine distributions of f64, twice for a vector's growth.
pub const VALUE_BYTES: u64 = 9 * 8 * 2;

/// The most an accumulator grows to: 2048 exact values per distribution (then a sketch of
/// at most 2048 buckets; `analyse::stats::EXACT_LIMIT`), with a vector's growth.
pub const FULL_CELL_BYTES: u64 = 2048 * VALUE_BYTES;

/// The sizes a sweep's statistics grow with (`analyse::analysis::statistics_size`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatisticsSize {
    /// Accumulators of the bins (each material's whole-material rows included), per method,
    /// per compared pair and once for the bin itself, over every material.
    pub bins: u64,
    /// Map cells × materials × methods each map draws.
    pub map_cells: u64,
    /// Accumulators one configuration is folded into.
    pub per_configuration: u64,
}

/// Estimated peak bytes of a sweep's statistics over `configurations`: every bin and map
/// cell, plus the values they keep (bounded per cell).
pub fn statistics_estimate(size: StatisticsSize, configurations: u64) -> Bytes {
    let fixed = size
        .bins
        .saturating_mul(BIN_BYTES)
        .saturating_add(size.map_cells.saturating_mul(MAP_CELL_BYTES));
    let cells = size.bins.saturating_add(size.map_cells);
    let fill = configurations
        .saturating_mul(size.per_configuration)
        .saturating_mul(VALUE_BYTES)
        .min(cells.saturating_mul(FULL_CELL_BYTES));
    Bytes(fixed.saturating_add(fill))
}

/// Estimated bytes of the gate's per-configuration observations: this run's (with each
/// reference's ULP), a loaded baseline's, the saved tokens, and each configuration kept for
/// `regressed.jsonl` with its bins.
pub fn observations_estimate(configurations: u64, methods: u64) -> Bytes {
    Bytes(
        configurations
            .saturating_mul(methods)
            .saturating_mul(56)
            .saturating_add(configurations.saturating_mul(512)),
    )
}

/// Estimated peak bytes of a chain: every configuration with its feeds, GPU scenes, values
/// and references, and per method its row and the row's JSON.
pub fn chain_estimate(configurations: u64, methods: u64) -> Bytes {
    Bytes(configurations.saturating_mul(4096u64.saturating_add(methods.saturating_mul(2048))))
}

/// Bytes an input line of `bytes` holds once parsed, while a chunk of lines is evaluated: the
/// text, the configuration and the output row (a texture's numbers as JSON values).
pub fn line_estimate(bytes: u64) -> Bytes {
    Bytes(bytes.saturating_mul(4))
}

/// A run's memory estimate, part by part, checked once against `--max-memory`: a refusal
/// names the largest parts, so the user sees what to shrink.
#[derive(Clone, Debug, Default)]
pub struct Budget {
    parts: Vec<(String, Bytes)>,
}

impl Budget {
    pub fn new() -> Budget {
        Budget::default()
    }

    /// Adds a part (`what`: what grows, with its size).
    pub fn add(&mut self, what: impl Into<String>, bytes: Bytes) -> &mut Self {
        self.parts.push((what.into(), bytes));
        self
    }

    pub fn total(&self) -> Bytes {
        Bytes(self.parts.iter().fold(0u64, |t, (_, b)| t.saturating_add(b.0)))
    }

    /// Refuses the run (`what`: which) when the total exceeds the limit in force.
    pub fn check(&self, what: &str) -> Result<(), String> {
        self.check_against(what, max_memory())
    }

    pub fn check_against(&self, what: &str, limit: Bytes) -> Result<(), String> {
        let total = self.total();
        if total <= limit {
            return Ok(());
        }
        let mut parts: Vec<&(String, Bytes)> = self.parts.iter().filter(|(_, b)| b.0 > 0).collect();
        parts.sort_by_key(|p| std::cmp::Reverse(p.1));
        let shown: Vec<String> = parts.iter().take(4).map(|(w, b)| format!("{w}: {b}")).collect();
        Err(format!(
            "{what} needs an estimated {total} of memory ({}), more than {}: make the largest part smaller \
             or raise --max-memory",
            shown.join("; "),
            limit_named(limit)
        ))
    }
}

/// The limit in force, as a message names it: `--max-memory` only when it was given.
fn limit_named(limit: Bytes) -> String {
    if GIVEN.load(std::sync::atomic::Ordering::Relaxed) {
        format!("--max-memory {limit}")
    } else {
        format!("the default limit {limit} (half of this machine's memory)")
    }
}

/// Refuses an estimate above the limit, with both numbers and what to change.
pub fn check(what: &str, estimate: Bytes, limit: Bytes) -> Result<(), String> {
    if estimate > limit {
        let limit = limit_named(limit);
        return Err(format!(
            "{what} needs an estimated {estimate} of memory, more than {limit}: use fewer configurations or \
             raise --max-memory"
        ));
    }
    Ok(())
}

/// The sizes a sweep's memory is estimated from (`measure::setup::run_size`; merge, diff and
/// bench run its stages too).
#[derive(Clone, Copy, Debug, Default)]
pub struct RunSize {
    /// Natural configurations.
    pub naturals: u64,
    /// Natural and top-up configurations.
    pub total: u64,
    pub methods: u64,
    /// Targets whose references are computed.
    pub targets: u64,
    /// Configurations of one measuring chunk.
    pub chunk: u64,
    /// Texels of the largest light texture a family draws (0: none).
    pub texels: u64,
    pub statistics: StatisticsSize,
    /// Bins over every axis, and map cells over every map (for the message).
    pub bins: usize,
    pub cells: usize,
    /// `[search]`: restarts and population.
    pub search: Option<(usize, usize)>,
    /// Candidates of one step of the disagreement search (the case compares pairs).
    pub disagreement_batch: Option<u64>,
    /// `--raw` rows are written.
    pub raw: bool,
    /// Every natural configuration's observation is kept (the gate, `diff`).
    pub observations: bool,
    /// Every configuration is drawn up front (bench).
    pub all_samples: bool,
}

/// The memory of a sweep, part by part: one measuring chunk of configurations (samples,
/// scenes, references, values, --raw rows), or every configuration when all are drawn up
/// front; light textures; every bin and map cell of the statistics; one step of the
/// worst-case search; the gate's observations.
pub fn run_budget(size: &RunSize) -> Budget {
    let mut budget = Budget::new();
    let held = if size.all_samples {
        size.total
    } else {
        size.total.min(size.chunk)
    };
    budget.add(
        format!("{held} configurations measured at once"),
        sweep_estimate(held, size.methods, size.targets, size.raw),
    );
    // Light textures drawn by the case (`[materials.texture]`): each configuration held carries
    // its texels; the top-ups are held all at once, and a top-up batch holds at most
    // TOPUP_BATCH_TEXELS.
    let texels = size.texels;
    if texels > 0 {
        let topups = size.total.saturating_sub(size.naturals);
        let held_textures = held.saturating_add(if size.all_samples { 0 } else { topups });
        budget.add(
            format!("light textures of {held_textures} configurations held at once, {texels} texels each"),
            texel_estimate(held_textures, texels, size.raw),
        );
        budget.add(
            "one top-up batch of textured draws",
            Bytes(TOPUP_BATCH_TEXELS.max(texels).saturating_mul(8)),
        );
    }
    budget.add(
        format!(
            "statistics of {} bins and {} map cells, per method and material",
            size.bins, size.cells
        ),
        statistics_estimate(size.statistics, size.total),
    );
    if let Some((restarts, population)) = size.search {
        // One step's candidates (samples, scenes, references) at a time.
        let batch = (restarts as u64).saturating_mul(population as u64);
        budget.add(
            format!("[search] with {restarts} × {population} candidates per step"),
            search_estimate(batch),
        );
        if texels > 0 {
            budget.add(
                "[search] candidates' light textures",
                texel_estimate(batch, texels, false),
            );
        }
    }
    if let (true, Some(batch)) = (texels > 0, size.disagreement_batch) {
        // The disagreement search's candidates of one step carry their textures too.
        budget.add(
            format!("disagreement candidates' light textures ({batch} per step)"),
            texel_estimate(batch, texels, false),
        );
    }
    if size.observations {
        budget.add(
            format!("the gate's observations of {} configurations", size.naturals),
            observations_estimate(size.naturals, size.methods),
        );
    }
    budget
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

    #[test]
    fn counts_and_budgets_are_refused_naming_what_and_the_parts() {
        assert!(check_count("--count", 1).is_ok() && check_count("--count", MAX_COUNT).is_ok());
        let e = check_count("`materials[0].count` =", 9_223_372_036_854_775_807).unwrap_err();
        assert!(
            e.contains("`materials[0].count` = 9223372036854775807: more than"),
            "{e}"
        );
        assert!(check_count("--count", 0).unwrap_err().contains("at least 1"));
        let mut b = Budget::new();
        b.add("map cells", Bytes(3 << 30)).add("one chunk", Bytes(1 << 20));
        assert_eq!(b.total(), Bytes((3 << 30) + (1 << 20)));
        let e = b.check_against("case `x`", Bytes(2 << 30)).unwrap_err();
        assert!(
            e.starts_with("case `x` needs an estimated 3.0 GiB of memory (map cells: 3.0 GiB; one chunk: 1.0 MiB)"),
            "{e}"
        );
        assert!(b.check_against("case `x`", Bytes(4 << 30)).is_ok());
        // The statistics grow with the cells, and with the values until every cell is full.
        let size = StatisticsSize {
            bins: 10,
            map_cells: 0,
            per_configuration: 3,
        };
        assert_eq!(statistics_estimate(size, 0), Bytes(10 * BIN_BYTES));
        assert_eq!(statistics_estimate(size, 1), Bytes(10 * BIN_BYTES + 3 * VALUE_BYTES));
        assert_eq!(
            statistics_estimate(size, u64::MAX),
            Bytes(10 * BIN_BYTES + 10 * FULL_CELL_BYTES)
        );
    }
}
