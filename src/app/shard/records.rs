//! The shard records on disk: `OUT/shard-I-of-N.cbor` written whole, and read back by
//! `linelight merge` with the case and kernel files they ran, found beside the records and
//! checked by their SHA-256.

use super::{sha256, short, source_sha256};
use crate::analyse::partial::{Header, Partial, SHARD_FORMAT};
use crate::kernel::methods::Method;
use anyhow::Context;
use std::path::{Path, PathBuf};

/// A file a shard ran, as recorded.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Recorded {
    /// As given on the shard's command line (shown in messages).
    pub given: PathBuf,
    /// Relative to the folder of the shard record.
    pub relative: PathBuf,
    /// Absolute, where the shard ran (tried when the relative path finds nothing).
    pub absolute: PathBuf,
    /// SHA-256 of the contents, hex.
    pub sha256: String,
}

impl Recorded {
    /// Records `path`, whose contents are `bytes`, for a shard record in `out`.
    pub fn new(path: &Path, bytes: &[u8], out: &Path) -> Recorded {
        Recorded {
            given: path.to_path_buf(),
            relative: relative_to(path, out),
            absolute: crate::io::resolved(path),
            sha256: sha256(bytes),
        }
    }

    /// Reads the file `path` and records it.
    pub fn read(path: &Path, out: &Path) -> anyhow::Result<Recorded> {
        let bytes = crate::io::read_bounded(path, "input", crate::limits::MAX_TEXT_INPUT)?;
        Ok(Recorded::new(path, &bytes, out))
    }

    /// The file as it is now, found from the record in `folder` (then at the absolute path),
    /// and its contents: refused when it is missing or its contents changed.
    fn find(&self, what: &str, folder: &Path) -> anyhow::Result<(PathBuf, Vec<u8>)> {
        let near = crate::io::resolved(&crate::io::resolved(folder).join(&self.relative));
        let path = [near.clone(), self.absolute.clone()]
            .into_iter()
            .find(|p| p.is_file())
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "merge: the {what} {} the shards ran is neither at {} (beside the shard record) nor at {}",
                    self.given.display(),
                    near.display(),
                    self.absolute.display()
                )
            })?;
        let bytes = crate::io::read_regular(&path, what, crate::limits::MAX_TEXT_INPUT)
            .with_context(|| format!("merge: cannot read the {what} {}", path.display()))?;
        let now = sha256(&bytes);
        anyhow::ensure!(
            now == self.sha256,
            "merge: the {what} {} changed since the shards ran (SHA-256 {} now, {} then): its statistics \
             would be mixed with the new file's; restore it or re-run the shards",
            path.display(),
            short(&now),
            short(&self.sha256)
        );
        Ok((path, bytes))
    }
}

/// What a shard ran: its record without the state.
struct Ran {
    case: Recorded,
    kernels: Vec<Recorded>,
    sources: Vec<(String, String)>,
}

impl Ran {
    /// Every content hash: equal for the shards of one sweep.
    fn hashes(&self) -> Vec<&str> {
        let files = std::iter::once(&self.case)
            .chain(&self.kernels)
            .map(|r| r.sha256.as_str());
        files.chain(self.sources.iter().map(|(_, h)| h.as_str())).collect()
    }
}

/// A shard record: what the shard ran and its state.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct ShardFile {
    case: Recorded,
    /// The `--kernel` files, in command-line order.
    kernels: Vec<Recorded>,
    /// (method label, SHA-256 of its kernel's source) for every method the shard measured.
    sources: Vec<(String, String)>,
    /// Last: a merge reads the records' headers without the rest of their states ([`Header`]).
    pub(super) state: Partial,
}

/// A shard record's [`ShardFile`] without the state past its header (not read: the state is
/// the record's last field, so the decoder stops there).
#[derive(serde::Deserialize)]
struct HeaderFile {
    case: Recorded,
    kernels: Vec<Recorded>,
    sources: Vec<(String, String)>,
    state: Header,
}

/// [`ShardFile`] as written: the same fields, borrowed.
#[derive(serde::Serialize)]
struct ShardFileRef<'a> {
    case: &'a Recorded,
    kernels: &'a [Recorded],
    sources: Vec<(String, String)>,
    state: &'a Partial,
}

/// The shard records given to a merge, checked against each other and against the files now.
pub struct Shards {
    /// The case file as found now (its contents are those the shards ran).
    pub case_path: PathBuf,
    /// How to show the case file: as given to the shards, when that still names it.
    pub case_shown: String,
    pub case_text: String,
    pub kernels: Vec<PathBuf>,
    sources: Vec<(String, String)>,
    /// The record the merge read the files from (for messages).
    first: PathBuf,
    /// Each record's path and header; its state is decoded when the merge folds it in
    /// ([`Partial::merge_records`]).
    pub records: Vec<(PathBuf, Header)>,
}

impl Shards {
    /// Refuses a merge whose methods' kernels (built-ins included, which come with the
    /// binary) are not the text the shards measured.
    pub fn check_sources(&self, methods: &[Method]) -> anyhow::Result<()> {
        for m in methods {
            let then = self.sources.iter().find(|(l, _)| *l == m.label).map(|(_, h)| h);
            let now = source_sha256(m);
            if then.is_some_and(|t| *t != now) {
                anyhow::bail!(
                    "merge: the kernel of `{}` ({}) is not the one the shards measured ({}): its statistics \
                     would be mixed with the new kernel's op counts and attribution; re-run the shards with this \
                     kernel and this linelight",
                    crate::input::names::clip(&m.label),
                    m.kernel.path,
                    self.first.display()
                );
            }
        }
        Ok(())
    }
}

/// Where shard I of N keeps its state: `OUT/shard-I-of-N.cbor`.
pub fn shard_path(out: &Path, i: usize, n: usize) -> PathBuf {
    out.join(format!("shard-{i}-of-{n}.cbor"))
}

/// Writes `OUT/shard-I-of-N.cbor` (atomically); returns its path. `case` and `kernels` were
/// recorded when the sweep read them.
pub fn write_shard(
    out: &Path,
    case: Recorded,
    kernels: Vec<Recorded>,
    methods: &[Method],
    part: &Partial,
) -> anyhow::Result<PathBuf> {
    let (i, n) = part.shard;
    let path = shard_path(out, i, n);
    // Encoded straight into the file from the state, neither copied nor held as bytes: a
    // shard's peak memory is its statistics once, as the unsharded run's is.
    let file = ShardFileRef {
        case: &case,
        kernels: &kernels,
        sources: methods.iter().map(|m| (m.label.clone(), source_sha256(m))).collect(),
        state: part,
    };
    crate::io::write_output(&path, &mut |w| {
        ciborium::into_writer(&file, w).map_err(|e| match e {
            ciborium::ser::Error::Io(io) => io,
            ciborium::ser::Error::Value(m) => std::io::Error::other(format!("cannot encode the shard state: {m}")),
        })
    })?;
    Ok(path)
}

/// Only the format of a record, readable in every version (each keeps `state.format`).
#[derive(serde::Deserialize)]
struct Probe {
    state: ProbeState,
}

#[derive(serde::Deserialize)]
struct ProbeState {
    format: u32,
}

/// Every `shard-*-of-*.cbor` in the given directories, checked: one format (this
/// linelight's), one case and one set of kernels, unchanged since the shards ran.
pub fn read_shards(dirs: &[PathBuf]) -> anyhow::Result<Shards> {
    let mut files = Vec::new();
    for d in dirs {
        let entries = std::fs::read_dir(d).with_context(|| format!("merge: cannot read {}", d.display()))?;
        for e in entries {
            let p = e?.path();
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            if name.starts_with("shard-") && name.ends_with(".cbor") {
                files.push(p);
            }
        }
    }
    files.sort();
    anyhow::ensure!(
        !files.is_empty(),
        "merge: no shard-I-of-N.cbor in {}",
        dirs.iter()
            .map(|d| d.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut first: Option<(PathBuf, Ran)> = None;
    let mut records = Vec::new();
    for p in files {
        // Only what the record ran and its header: the state is decoded when it is folded in.
        let f: HeaderFile = read_record(&p)?;
        let HeaderFile {
            case,
            kernels,
            sources,
            state,
        } = f;
        let ran = Ran { case, kernels, sources };
        match &first {
            None => first = Some((p.clone(), ran)),
            Some((p0, r0)) => anyhow::ensure!(
                ran.hashes() == r0.hashes(),
                "merge: {} ran the case file {} with the kernels [{}], and {} ran {} with [{}], not the same \
                 contents: the shards of one sweep run the same files",
                p.display(),
                ran.case.given.display(),
                shown(&ran.kernels),
                p0.display(),
                r0.case.given.display(),
                shown(&r0.kernels)
            ),
        }
        records.push((p, state));
    }
    let (record, file) = first.expect("at least one file");
    let folder = record.parent().unwrap_or(Path::new("."));
    let (case_path, case_bytes) = file.case.find("case file", folder)?;
    let case_text = String::from_utf8(case_bytes)
        .map_err(|_| anyhow::anyhow!("merge: the case file {} is not UTF-8", case_path.display()))?;
    let kernels = file
        .kernels
        .iter()
        .map(|k| k.find("kernel", folder).map(|(p, _)| p))
        .collect::<anyhow::Result<Vec<_>>>()?;
    // The path as the shards were given it, when it still names the same file from here.
    let case_shown = if crate::io::resolved(&file.case.given) == crate::io::resolved(&case_path) {
        file.case.given.display().to_string()
    } else {
        case_path.display().to_string()
    };
    Ok(Shards {
        case_path,
        case_shown,
        case_text,
        kernels,
        sources: file.sources,
        first: record,
        records,
    })
}

/// A shard record's state format, from `T`, the whole record or its header.
pub(super) trait Formatted {
    fn format(&self) -> u32;
}

impl Formatted for ShardFile {
    fn format(&self) -> u32 {
        self.state.format
    }
}

impl Formatted for HeaderFile {
    fn format(&self) -> u32 {
        self.state.format
    }
}

/// Reads and decodes the shard record `p` (whole, or its header), refusing a record of another
/// format or one that is not a shard record.
pub(super) fn read_record<T: serde::de::DeserializeOwned + Formatted>(p: &Path) -> anyhow::Result<T> {
    // A FIFO named like a shard would block; a state larger than the memory limit cannot be held.
    // Decoded as it is read: the record's bytes are never held beside its state.
    let open = || -> anyhow::Result<_> {
        let (f, _) = crate::io::open_regular(p, "shard state", crate::limits::max_memory().0)?;
        Ok(std::io::BufReader::with_capacity(1 << 16, f))
    };
    let old_format = |format: u32| {
        anyhow::anyhow!(
            "merge: {} is a shard record of format {format}; this linelight reads format {SHARD_FORMAT} (whose \
             shards run their own searches and whose shard 0 times the methods, so that the merge needs no \
             GPU): re-run the shards with this linelight (`linelight sweep CASE --shard I/N --out DIR`)",
            p.display()
        )
    };
    // Decoded once; only a record that does not decode is probed for its format, to say why.
    let f: T = match ciborium::from_reader(open()?) {
        Ok(f) => f,
        Err(e) => {
            if let Ok(probe) = ciborium::from_reader::<Probe, _>(open()?) {
                if probe.state.format != SHARD_FORMAT {
                    return Err(old_format(probe.state.format));
                }
            }
            anyhow::bail!(
                "merge: {} is not a linelight shard record: {}",
                p.display(),
                cbor_error(&e)
            );
        }
    };
    if f.format() != SHARD_FORMAT {
        return Err(old_format(f.format()));
    }
    Ok(f)
}

fn shown(kernels: &[Recorded]) -> String {
    kernels
        .iter()
        .map(|k| k.given.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// A CBOR decoding error in words (ciborium's own text is its Debug form).
fn cbor_error(e: &ciborium::de::Error<std::io::Error>) -> String {
    use ciborium::de::Error;
    match e {
        Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "it ends early (truncated, or still being written)".to_string()
        }
        Error::Io(io) => io.to_string(),
        Error::Syntax(at) => format!("not CBOR at byte {at}"),
        Error::Semantic(Some(at), m) => format!("{} (at byte {at})", crate::input::names::clip(m)),
        Error::Semantic(None, m) => crate::input::names::clip(m),
        Error::RecursionLimitExceeded => "nested too deeply".to_string(),
    }
}

/// `path` relative to the folder `base`, both resolved (symlinks, `..`): `../case.toml`.
fn relative_to(path: &Path, base: &Path) -> PathBuf {
    let (p, b) = (crate::io::resolved(path), crate::io::resolved(base));
    let common = p.components().zip(b.components()).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in b.components().skip(common) {
        out.push("..");
    }
    for c in p.components().skip(common) {
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_and_hashes() {
        assert_eq!(
            relative_to(Path::new("/a/b/case.toml"), Path::new("/a/c/d")),
            PathBuf::from("../../b/case.toml")
        );
        assert_eq!(
            relative_to(Path::new("/a/x.wgsl"), Path::new("/a")),
            PathBuf::from("x.wgsl")
        );
        // The SHA-256 of "abc" (FIPS 180-2, appendix B.1).
        assert_eq!(
            sha256(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
