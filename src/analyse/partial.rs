//! The mergeable state of a sweep's measuring, or one shard's (`sweep --shard i/n`, read back
//! by `linelight merge`; docs/scale.md): the statistics folded so far and the measure stage's
//! kept state, and the merge of shards 0..n into the whole run's. The shard record that holds
//! it on disk, with the files it was measured from, is `app::shard`'s.

use super::analysis::{Accumulators, Fold, LeakAccumulator};
use super::observations::Observations;
use super::stats::{add_to_each, Accumulate};
use crate::measure::sweep::{self, Setup};

/// The version of the shard record (`--shard`, docs/scale.md; 4 records the contents of the
/// case and kernels, `app::shard`; 5 adds the `line_upper` view's per-bin accumulators, the
/// error apart from missed light, the references' brightness and the lights wholly below the
/// surface; 6 names the measuring times of the CPU evaluator's columns `cpu_f64_seconds` and
/// `cpu_f32_seconds`, once `f64_ports` and `f32_ports`; 7 draws each configuration from its
/// own counter-based stream, so a shard draws only its own, and keeps its natural bin counts,
/// its draws and its measured top-ups whole until the merge settles them; 8 holds the
/// shard's search climbs and, in shard 0, the timing of methods, the attribution and the
/// envelope, so that the merge needs no GPU; 9 carries each attribution
/// configuration's material, so the envelope's rows name the material they were drawn for).
pub const SHARD_FORMAT: u32 = 9;

/// What measuring a sweep's configurations, or one shard's, leaves before the searches and
/// the cost pass: mergeable (`linelight merge`). Written by `sweep --shard i/n`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Partial {
    pub format: u32,
    pub case: String,
    pub seed: u64,
    pub count_override: Option<usize>,
    /// (i, n): this part is shard i of n; (0, 1) for a whole run.
    pub shard: (usize, usize),
    pub methods: Vec<String>,
    /// The statistics, folded in chunk by chunk.
    pub accumulators: Accumulators,
    pub leak: LeakAccumulator,
    /// The measure stage's kept state, draws and times.
    pub measured: sweep::Part,
    /// The gate's observations, when asked for (never in a shard file: the gate is unsharded).
    #[serde(skip)]
    pub observations: Option<Observations>,
}

/// What a shard record says of itself before its state: what the merge checks before it folds
/// any shard in. Decoded from the record's state ([`Partial`]'s first fields) without the rest.
#[derive(Clone, Debug)]
pub struct Header {
    pub format: u32,
    pub case: String,
    pub seed: u64,
    pub count_override: Option<usize>,
    /// (i, n): this part is shard i of n.
    pub shard: (usize, usize),
    pub methods: Vec<String>,
}

impl<'de> serde::Deserialize<'de> for Header {
    /// Reads the state's fields until it has the header's (the first six a record holds) and
    /// stops there: the rest of the state is not read at all, which is sound only because the
    /// state is the record's last field (`ShardFile`, `HeaderFile` in `app::shard`).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Header, D::Error> {
        use serde::de::{Error, IgnoredAny, MapAccess, Visitor};
        struct Fields;
        impl<'de> Visitor<'de> for Fields {
            type Value = Header;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a shard state")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Header, A::Error> {
                let mut format = None;
                let mut case = None;
                let mut seed = None;
                let mut count_override = None;
                let mut shard = None;
                let mut methods = None;
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "format" => format = Some(map.next_value()?),
                        "case" => case = Some(map.next_value()?),
                        "seed" => seed = Some(map.next_value()?),
                        "count_override" => count_override = Some(map.next_value()?),
                        "shard" => shard = Some(map.next_value()?),
                        "methods" => methods = Some(map.next_value()?),
                        _ => {
                            map.next_value::<IgnoredAny>()?;
                        }
                    }
                    if format.is_some()
                        && case.is_some()
                        && seed.is_some()
                        && count_override.is_some()
                        && shard.is_some()
                        && methods.is_some()
                    {
                        break;
                    }
                }
                let missing = |f: &'static str| A::Error::missing_field(f);
                Ok(Header {
                    format: format.ok_or_else(|| missing("format"))?,
                    case: case.ok_or_else(|| missing("case"))?,
                    seed: seed.ok_or_else(|| missing("seed"))?,
                    count_override: count_override.ok_or_else(|| missing("count_override"))?,
                    shard: shard.ok_or_else(|| missing("shard"))?,
                    methods: methods.ok_or_else(|| missing("methods"))?,
                })
            }
        }
        d.deserialize_map(Fields)
    }
}

impl Partial {
    /// Checks the headers of shards 0..n of one sweep (each exactly once), before any state is
    /// folded in.
    fn check_headers(setup: &Setup, parts: &[&Header]) -> anyhow::Result<()> {
        anyhow::ensure!(!parts.is_empty(), "merge: no shard states given");
        let n = parts[0].shard.1;
        let labels: Vec<String> = setup.methods.iter().map(|m| m.label.clone()).collect();
        for (k, p) in parts.iter().enumerate() {
            anyhow::ensure!(
                p.format == SHARD_FORMAT,
                "merge: shard {}/{} is a record of format {}; this linelight reads format {SHARD_FORMAT}: re-run the shards",
                p.shard.0,
                p.shard.1,
                p.format
            );
            // `--count 50`, or the case's own counts.
            let count = |c: Option<usize>| c.map_or("the case's counts".to_string(), |n| format!("--count {n}"));
            anyhow::ensure!(
                p.case == setup.case.name && p.seed == setup.case.seed && p.count_override == setup.count_override,
                "merge: shard {}/{} is of case `{}`, seed {}, {}; not of case `{}`, seed {}, {}",
                p.shard.0,
                p.shard.1,
                crate::input::names::clip(&p.case),
                p.seed,
                count(p.count_override),
                setup.case.name,
                setup.case.seed,
                count(setup.count_override)
            );
            anyhow::ensure!(
                p.methods == labels,
                "merge: shard {}/{} measured the methods {}; the case has {}",
                p.shard.0,
                p.shard.1,
                crate::input::names::clip(&p.methods.join(", ")),
                crate::input::names::clip(&labels.join(", "))
            );
            anyhow::ensure!(
                p.shard.0 < p.shard.1,
                "merge: a record claims to be shard {}/{}, which no sweep writes",
                p.shard.0,
                p.shard.1
            );
            // Sorted by index: place k holds shard k of n, when each is given once.
            anyhow::ensure!(
                p.shard.1 == n,
                "merge: shard {}/{} is of a sweep in {} shards, shard {}/{n} of one in {n}",
                p.shard.0,
                p.shard.1,
                p.shard.1,
                parts[0].shard.0
            );
            if p.shard.0 != k {
                let given = if p.shard.0 < k { "given twice" } else { "missing" };
                let which = if p.shard.0 < k { p.shard.0 } else { k };
                anyhow::bail!(
                    "merge: shard {which}/{n} is {given}: give each of {n} shards once (0/{n} … {}/{n})",
                    n - 1
                );
            }
        }
        anyhow::ensure!(
            parts.len() == n,
            "merge: shard {}/{n} is missing: give each of {n} shards once (0/{n} … {}/{n})",
            parts.len(),
            n - 1
        );
        Ok(())
    }

    /// Merges shards 0..n of one sweep (each exactly once) into the state of the whole run,
    /// `next` giving each one's state in turn (in shard order): each is folded in and dropped
    /// before the next is asked for, so a merge holds the merged state and one shard's.
    pub fn merge_each(
        setup: &Setup,
        headers: &[&Header],
        next: &mut dyn FnMut(usize) -> anyhow::Result<Partial>,
    ) -> anyhow::Result<Partial> {
        Partial::check_headers(setup, headers)?;
        let n = headers[0].shard.1;
        let mut all = next(0)?;
        for k in 1..n {
            let p = next(k)?;
            Accumulate::merge(&mut all.accumulators, &p.accumulators).map_err(anyhow::Error::msg)?;
            Accumulate::merge(&mut all.leak, &p.leak).map_err(anyhow::Error::msg)?;
            Accumulate::merge(&mut all.measured, &p.measured).map_err(anyhow::Error::msg)?;
        }
        // The top-ups the whole sample's counts call for are folded in now, as the unsharded
        // run folds them; the shards' extra ones are dropped.
        let Partial {
            accumulators,
            leak,
            measured,
            ..
        } = &mut all;
        let case = &setup.case;
        sweep::settle_topups(
            setup,
            measured,
            &mut |c| {
                add_to_each(&mut [&mut *accumulators, &mut *leak], Fold { case, chunk: c });
                Ok(())
            },
            None,
        )?;
        all.shard = (0, 1);
        all.measured.timing.shards = n;
        Ok(all)
    }
}
