//! `linelight fit`'s runs: the LTC fits of `input::ltc` (the isotropic table, the anisotropic
//! table resumable from a checkpoint, the sliced-Wasserstein subset) on every thread, with a
//! progress bar and their run time. No statistics, no files: the checkpoint is handed to the
//! caller to write.

use crate::input::ltc::{aniso, fit, sw};
use std::path::Path;
use std::time::Instant;

/// A fit's result with how long it took and on how many threads.
pub struct Timed<T> {
    pub value: T,
    /// Wall-clock seconds (a resumed run's earlier seconds included).
    pub seconds: f64,
    pub threads: usize,
}

/// The progress bar of a fit of `len` entries.
fn bar(len: u64, name: &str) -> indicatif::ProgressBar {
    super::progress::styled(len, name, "{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})")
}

/// The isotropic table of `size`×`size` entries.
pub fn iso(size: usize) -> Timed<Vec<fit::Fit>> {
    let threads = rayon::current_num_threads();
    eprintln!("fitting a {size}×{size} isotropic GGX LTC table on {threads} thread(s)");
    let pb = bar((size * size) as u64, "fit");
    let start = Instant::now();
    let fits = fit::fit_table(size, &|| pb.inc(1));
    pb.finish_and_clear();
    Timed {
        value: fits,
        seconds: start.elapsed().as_secs_f64(),
        threads,
    }
}

/// Where an anisotropic fit starts: the entries a checkpoint holds and its seconds.
pub struct Resume<'a> {
    pub checkpoint: &'a Path,
    pub done: &'a [aniso::Fitted],
    pub seconds: f64,
}

/// The anisotropic table (or a slice) of `size`, from `resume`'s entries on: every `every`
/// finished chains the entries so far go to `save` as a checkpoint. The error is `save`'s
/// first (the fit runs to its end regardless).
pub fn aniso(
    size: [usize; 4],
    slice: aniso::Slice,
    resume: &Resume,
    every: usize,
    save: &(dyn Fn(&aniso::Checkpoint) -> anyhow::Result<()> + Sync),
) -> anyhow::Result<Timed<aniso::AnisoTable>> {
    let threads = rayon::current_num_threads();
    let fitted = aniso::fitted_count(size);
    let (done, before) = (resume.done, resume.seconds);
    eprintln!(
        "fitting a {}×{}×{}×{} anisotropic GGX LTC table (θ × φ × α_max × r; {fitted} fits in {} chains, the rest by symmetry) on {threads} thread(s){}",
        size[0],
        size[1],
        size[2],
        size[3],
        aniso::chains(size).len(),
        if done.is_empty() {
            String::new()
        } else {
            format!(
                "; resuming from {} ({} entries, {before:.0} s)",
                resume.checkpoint.display(),
                done.len()
            )
        }
    );
    let pb = bar(fitted as u64, "fit");
    pb.inc(done.len() as u64);
    let start = Instant::now();
    let state = std::sync::Mutex::new((done.to_vec(), 0usize));
    let checkpoint = |entries: &[aniso::Fitted]| -> anyhow::Result<()> {
        let mut sorted = entries.to_vec();
        sorted.sort_by_key(|(i, _)| aniso::index(size, *i));
        save(&aniso::Checkpoint {
            size,
            slice,
            seconds: before + start.elapsed().as_secs_f64(),
            entries: sorted,
        })
    };
    let failed = std::sync::Mutex::new(None::<anyhow::Error>);
    let table = aniso::fit_table_in(size, slice, done, &|chain| {
        pb.inc(chain.len() as u64);
        let mut s = state.lock().unwrap_or_else(|e| e.into_inner());
        s.0.extend_from_slice(chain);
        s.1 += 1;
        if s.1 % every == 0 {
            if let Err(e) = checkpoint(&s.0) {
                failed.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e);
            }
        }
    });
    pb.finish_and_clear();
    if let Some(e) = failed.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    Ok(Timed {
        value: table,
        seconds: before + start.elapsed().as_secs_f64(),
        threads,
    })
}

/// The sliced-Wasserstein fits of the subset of a `size` table's entries (`sw::subset`).
pub fn aniso_sw(size: [usize; 4], params: &sw::Params) -> Timed<Vec<aniso::Fitted>> {
    let subset = sw::subset(size);
    let threads = rayon::current_num_threads();
    eprintln!(
        "fitting {} entries of a {size:?} anisotropic table with the sliced-Wasserstein objective \
         ({} steps × {} directions × {} samples, learning rate {} decaying linearly) on {threads} thread(s)",
        subset.len(),
        params.steps,
        params.directions,
        params.samples,
        params.learning_rate
    );
    let pb = bar(subset.len() as u64, "fit sw");
    let start = Instant::now();
    let entries = sw::fit_subset(size, params, &|| pb.inc(1));
    pb.finish_and_clear();
    Timed {
        value: entries,
        seconds: start.elapsed().as_secs_f64(),
        threads,
    }
}
