//! One trait for every output file of every command: an encoder turns what it holds into bytes
//! and writes nothing; `io` writes the bytes (`io::write_set` for a folder swapped in whole,
//! `io::write_atomic` for one file). Markdown, CSV, SVG and JUnit XML are text; JSON is one
//! value (compact, or pretty as people read it); JSONL is one value per line.

use crate::io::SetKind;
use std::path::{Path, PathBuf};

/// An output file: its name in its folder and its contents.
pub trait Format {
    fn name(&self) -> &str;
    fn encode(&self) -> anyhow::Result<Vec<u8>>;
}

macro_rules! text_format {
    ($($(#[$doc:meta])* $t:ident),*) => {$(
        $(#[$doc])*
        pub struct $t {
            pub name: String,
            pub text: String,
        }

        impl $t {
            pub fn new(name: impl Into<String>, text: impl Into<String>) -> $t {
                $t { name: name.into(), text: text.into() }
            }
        }

        impl Format for $t {
            fn name(&self) -> &str {
                &self.name
            }

            fn encode(&self) -> anyhow::Result<Vec<u8>> {
                Ok(self.text.clone().into_bytes())
            }
        }
    )*};
}

text_format!(
    /// A Markdown report (report.md, scan.md, chain.md).
    Markdown,
    /// A CSV table (stats.csv, comparisons.csv, chain.csv, a fitted LTC table).
    Csv,
    /// An SVG image (heat maps, speed-accuracy charts).
    Svg,
    /// A JUnit XML report (`--junit`).
    Junit,
    /// Plain text, one value per line (a baseline's `errors/` files).
    Plain
);

/// How a JSON file is laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// One line, no final newline (summary.json, chain.json: large, for tools).
    Compact,
    /// Indented, no final newline.
    Pretty,
    /// Indented, with a final newline (files people read and commit: bench JSON, run records).
    PrettyLine,
}

/// One JSON value. `T` is serialised as it is (a struct keeps its field order).
pub struct Json<T> {
    pub name: String,
    pub value: T,
    pub layout: Layout,
}

impl<T> Json<T> {
    pub fn new(name: impl Into<String>, value: T, layout: Layout) -> Json<T> {
        Json {
            name: name.into(),
            value,
            layout,
        }
    }
}

impl<T: serde::Serialize> Format for Json<T> {
    fn name(&self) -> &str {
        &self.name
    }

    fn encode(&self) -> anyhow::Result<Vec<u8>> {
        Ok(match self.layout {
            Layout::Compact => serde_json::to_vec(&self.value)?,
            Layout::Pretty => serde_json::to_vec_pretty(&self.value)?,
            Layout::PrettyLine => {
                let mut v = serde_json::to_vec_pretty(&self.value)?;
                v.push(b'\n');
                v
            }
        })
    }
}

/// JSON Lines: one compact value per line (eval's input format for replayable files).
pub struct Jsonl {
    pub name: String,
    pub rows: Vec<serde_json::Value>,
}

impl Jsonl {
    pub fn new(name: impl Into<String>, rows: Vec<serde_json::Value>) -> Jsonl {
        Jsonl {
            name: name.into(),
            rows,
        }
    }
}

impl Format for Jsonl {
    fn name(&self) -> &str {
        &self.name
    }

    fn encode(&self) -> anyhow::Result<Vec<u8>> {
        Ok(crate::io::to_jsonl(&self.rows))
    }
}

/// Already-encoded bytes (a PNG image made by its own encoder).
pub struct Bytes {
    pub name: String,
    pub bytes: Vec<u8>,
}

impl Format for Bytes {
    fn name(&self) -> &str {
        &self.name
    }

    fn encode(&self) -> anyhow::Result<Vec<u8>> {
        Ok(self.bytes.clone())
    }
}

/// The outputs, encoded: the (name, bytes) list `io::write_set` takes.
pub fn encode_all(outputs: &[Box<dyn Format + '_>]) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
    outputs
        .iter()
        .map(|o| Ok((o.name().to_string(), o.encode()?)))
        .collect()
}

/// Encodes the outputs and has `io` write them as the set `dir`, swapped in whole.
pub fn write_set(dir: &Path, kind: SetKind, outputs: &[Box<dyn Format + '_>]) -> anyhow::Result<Vec<PathBuf>> {
    let files = encode_all(outputs)?;
    Ok(crate::io::write_set(dir, kind, &files)?)
}

/// Encodes one output and has `io` write it at `path`, whole or not at all.
pub fn write_file(path: &Path, output: &dyn Format) -> anyhow::Result<()> {
    crate::io::write_atomic(path, &output.encode()?)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each encoder's bytes read back as what it holds, and `io` writes exactly those bytes.
    #[test]
    fn every_format_round_trips_through_io() {
        #[derive(serde::Serialize)]
        struct Keys {
            zeta: f64,
            alpha: Option<u32>,
        }
        let rows = vec![
            serde_json::json!({"id": "a", "v": "NaN"}),
            serde_json::json!({"id": "b"}),
        ];
        let outputs: Vec<Box<dyn Format>> = vec![
            Box::new(Markdown::new("r.md", "# Title\n\n| a |\n|---|\n| 1 |\n")),
            Box::new(Csv::new("s.csv", "a,b\n1,2\n")),
            Box::new(Svg::new("c.svg", "<svg/>")),
            Box::new(Junit::new("j.xml", "<testsuites/>\n")),
            Box::new(Plain::new("e.txt", "1e-7\nNaN\n")),
            Box::new(Json::new("c.json", Keys { zeta: 1.5, alpha: None }, Layout::Compact)),
            Box::new(Json::new(
                "p.json",
                Keys {
                    zeta: 2.0,
                    alpha: Some(3),
                },
                Layout::PrettyLine,
            )),
            Box::new(Jsonl::new("rows.jsonl", rows.clone())),
            Box::new(Bytes {
                name: "b.png".into(),
                bytes: vec![0x89, b'P', b'N', b'G'],
            }),
        ];
        let t = tempfile::tempdir().unwrap();
        let dir = t.path().join("set");
        let written = write_set(&dir, SetKind::Sweep, &outputs).unwrap();
        for o in &outputs {
            assert!(written.contains(&dir.join(o.name())), "{}: {written:?}", o.name());
        }
        let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
        for o in &outputs {
            assert_eq!(read(o.name()), o.encode().unwrap(), "{}", o.name());
        }
        assert_eq!(read("r.md"), b"# Title\n\n| a |\n|---|\n| 1 |\n");
        // A struct keeps its field order; compact is one line, pretty ends with a newline.
        assert_eq!(read("c.json"), br#"{"zeta":1.5,"alpha":null}"#);
        let pretty = String::from_utf8(read("p.json")).unwrap();
        assert!(
            pretty.ends_with("}\n") && pretty.find("zeta") < pretty.find("alpha"),
            "{pretty}"
        );
        let back: Vec<serde_json::Value> = String::from_utf8(read("rows.jsonl"))
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(back, rows);
        // One file, whole.
        let one = t.path().join("one.csv");
        write_file(&one, &Csv::new("one.csv", "x\n")).unwrap();
        assert_eq!(std::fs::read(&one).unwrap(), b"x\n");
    }
}
