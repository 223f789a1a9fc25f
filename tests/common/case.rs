//! Sweep case files built from parts (docs/case-format.md), so that a test writes only what
//! its case changes: `case("tiny").methods(&["line.ltc2017"]).diffuse(20)`.

use std::fmt;

/// A case file's text: its top-level keys, its `[geometry]` axes, then its tables.
#[derive(Clone, Debug)]
pub struct CaseText {
    keys: Vec<(String, String)>,
    axes: Vec<(String, String)>,
    tables: Vec<String>,
}

/// The case `name` (its title too), seed 7, method `line.ltc2023`, on the small geometry most
/// tests draw from: elevation 10–90°, any tilt, length 0.1–10 log-uniform, centre ±1. No
/// material yet.
pub fn case(name: &str) -> CaseText {
    CaseText {
        keys: Vec::new(),
        axes: Vec::new(),
        tables: Vec::new(),
    }
    .key("name", &quoted(name))
    .key("title", &quoted(name))
    .key("seed", "7")
    .methods(&["line.ltc2023"])
    .axis("elevation", r#"{ dist = "uniform", min = 10.0, max = 90.0 }"#)
    .axis("tilt_angle", r#"{ dist = "uniform", min = 0.0, max = 180.0 }"#)
    .axis("length", r#"{ dist = "log_uniform", min = 0.1, max = 10.0 }"#)
    .axis("center", r#"{ dist = "uniform", min = -1.0, max = 1.0 }"#)
}

fn quoted(s: &str) -> String {
    format!("{s:?}")
}

fn set(list: &mut Vec<(String, String)>, key: &str, value: &str) {
    match list.iter_mut().find(|(k, _)| k == key) {
        Some(entry) => entry.1 = value.to_string(),
        None => list.push((key.to_string(), value.to_string())),
    }
}

impl CaseText {
    /// Sets the top-level `key = value` (`value` as TOML writes it), in place of an earlier one.
    pub fn key(mut self, key: &str, value: &str) -> Self {
        set(&mut self.keys, key, value);
        self
    }

    /// The title, in place of the name.
    pub fn title(self, title: &str) -> Self {
        self.key("title", &quoted(title))
    }

    /// The methods swept.
    pub fn methods(self, methods: &[&str]) -> Self {
        self.key("methods", &list(methods))
    }

    /// The pair `[a, b]` compared.
    pub fn compare(self, a: &str, b: &str) -> Self {
        self.key("compare", &format!("[{}]", list(&[a, b])))
    }

    /// Sets the `[geometry]` axis `axis = value`, in place of an earlier one.
    pub fn axis(mut self, axis: &str, value: &str) -> Self {
        set(&mut self.axes, axis, value);
        self
    }

    /// A `[[materials]]` entry named and of kind `diffuse`, `count` configurations.
    pub fn diffuse(self, count: usize) -> Self {
        self.material("diffuse", "diffuse", count, "")
    }

    /// A `[[materials]]` entry, with `extra` (`key = value` lines, or nothing) after its count.
    pub fn material(self, name: &str, kind: &str, count: usize, extra: &str) -> Self {
        self.table(&format!(
            "[[materials]]\nname = {}\nkind = {}\ncount = {count}\n{extra}",
            quoted(name),
            quoted(kind)
        ))
    }

    /// Any other table (`[[bins]]`, `[budget]`, a material's `[materials.texture]`), as
    /// written, after the geometry and the tables before it.
    pub fn table(mut self, text: &str) -> Self {
        let mut text = text.trim_start_matches('\n').to_string();
        if !text.ends_with('\n') {
            text.push('\n');
        }
        self.tables.push(text);
        self
    }
}

fn list(items: &[&str]) -> String {
    let quoted: Vec<String> = items.iter().map(|m| quoted(m)).collect();
    format!("[{}]", quoted.join(", "))
}

impl fmt::Display for CaseText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, v) in &self.keys {
            writeln!(f, "{k} = {v}")?;
        }
        writeln!(f, "[geometry]")?;
        for (k, v) in &self.axes {
            writeln!(f, "{k} = {v}")?;
        }
        self.tables.iter().try_for_each(|t| f.write_str(t))
    }
}

/// The `[[bins]]` most tests split by: length below and above 1.
pub const LENGTH_BINS: &str = "[[bins]]\naxis = \"length\"\nedges = [0.1, 1.0, 10.0]\n";

/// The roughness of most LTC materials: α log-uniform on [0.1, 1].
pub const LTC_ALPHA: &str = r#"alpha = { dist = "log_uniform", min = 0.1, max = 1.0 }"#;

/// An elevation that crosses the horizon: −10° to 90°.
pub const CROSSING: &str = r#"{ dist = "uniform", min = -10.0, max = 90.0 }"#;

/// A case of one material family `g` of `count` configurations, `material` its `kind = …` and
/// parameter lines, measured with `method`: for checking what a family's keys draw and refuse.
pub fn family(method: &str, count: usize, material: &str) -> String {
    case("t")
        .key("seed", "1")
        .methods(&[method])
        .key("min_per_bin", "0")
        .axis("elevation", r#"{ dist = "uniform", min = 0.0, max = 90.0 }"#)
        .table(&format!("[[materials]]\nname = \"g\"\ncount = {count}\n{material}"))
        .to_string()
}
