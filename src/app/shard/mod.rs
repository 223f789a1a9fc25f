//! The shard record `OUT/shard-I-of-N.cbor` (`sweep --shard I/N`, read by `linelight merge`;
//! docs/scale.md): the mergeable state (`analyse::partial`) and what it was measured from. The case file and every
//! `--kernel` file are recorded by their path relative to the record's own folder (so a merge
//! run from another folder finds them) and by the SHA-256 of their contents, as is the text of
//! every method's kernel (built-ins included): a merge refuses a file changed since sharding,
//! which would otherwise mix the old statistics with the new file's op counts and attribution.

use crate::analyse::partial::{Header, Partial};
use crate::kernel::methods::Method;
use crate::measure::sweep::Setup;
use sha2::Digest;
use std::path::PathBuf;

/// The shard records on disk: what each ran, written and read back.
mod records;
use records::{read_record, ShardFile};
pub use records::{read_shards, shard_path, write_shard, Recorded, Shards};

/// Merges the shard records read by [`read_shards`], decoding one at a time (docs/scale.md).
pub fn merge_records(setup: &Setup, shards: &Shards) -> anyhow::Result<Partial> {
    let mut order: Vec<&(PathBuf, Header)> = shards.records.iter().collect();
    order.sort_by_key(|(_, h)| h.shard.0);
    let headers: Vec<&Header> = order.iter().map(|(_, h)| h).collect();
    Partial::merge_each(setup, &headers, &mut |k| {
        Ok(read_record::<ShardFile>(&order[k].0)?.state)
    })
}

/// SHA-256 of `bytes`, hex.
pub fn sha256(bytes: &[u8]) -> String {
    format!("{:x}", sha2::Sha256::digest(bytes))
}

/// The first 12 hex digits, enough to tell two hashes apart in a message.
fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

/// SHA-256 of what a method's values come from: its kernel's text (every part of a derived
/// kernel, the GLSL a kernel was translated from) and its inner method's, paths left out.
pub(crate) fn source_sha256(m: &Method) -> String {
    let mut h = sha2::Sha256::new();
    for k in std::iter::once(&m.kernel).chain(m.inner.as_deref().map(|i| &i.kernel)) {
        for (_, text) in k.parts() {
            h.update(text.as_bytes());
            h.update([0]);
        }
        if let Some(origin) = &k.origin {
            h.update(origin.text.as_bytes());
            h.update([0]);
        }
    }
    format!("{:x}", h.finalize())
}
