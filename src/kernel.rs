//! A method kernel file: its `//!` header (id, target, source, M⁻¹ support, parameters)
//! and its WGSL text. Built-in kernels are compiled into the binary; a user's kernel is
//! read from disk and goes through the same path (kernels/README.md).

use crate::target::Target;
use std::path::Path;

/// Which LTC matrices a method handles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MinvSupport {
    /// Any invertible M⁻¹.
    Full,
    /// Only the isotropic-GGX form `[[a,0,b],[0,c,0],[d,0,1]]`.
    Sparse,
}

#[derive(Clone, Debug)]
pub struct KernelFile {
    /// Shown in messages: `kernels/line_ltc2017.wgsl` or the user's path.
    pub path: String,
    pub text: String,
    pub id: String,
    pub target: Target,
    pub source: String,
    pub minv: MinvSupport,
    /// Overridable constants and their defaults, in the order `id@NxM` sets them.
    pub params: Vec<(String, u32)>,
    /// `//! uses: line`: the kernel calls `I_line(p1, p2)`, which the harness supplies
    /// from a line method chosen at run time (`cylinder.line[line.ltc2023]`).
    pub uses_line: bool,
}

#[derive(Debug, thiserror::Error)]
#[error("{path}:{line}: {message}")]
pub struct HeaderError {
    pub path: String,
    pub line: usize,
    pub message: String,
}

/// The prelude every kernel is composed with.
pub const PRELUDE: &str = include_str!("../kernels/prelude.wgsl");
pub const PRELUDE_PATH: &str = "kernels/prelude.wgsl";

macro_rules! builtin {
    ($($file:literal),* $(,)?) => {
        &[$(( concat!("kernels/", $file), include_str!(concat!("../kernels/", $file)) )),*]
    };
}

/// Built-in method kernels: (path, text).
const BUILTIN: &[(&str, &str)] = builtin![
    "line_ltc2017.wgsl",
    "line_ltc2017_fwt.wgsl",
    "line_ltc2023.wgsl",
    "line_ltc2023_full.wgsl",
    "line_ltc2023_fix.wgsl",
    "line_numeric_paper.wgsl",
    "line_numeric.wgsl",
    "cylinder_numeric_paper.wgsl",
    "cylinder_numeric.wgsl",
    "cylinder_line.wgsl",
    "caps_numeric_paper.wgsl",
    "caps_point.wgsl",
    "tube_line.wgsl",
    "rectangle_numeric.wgsl",
    "rectangle_line.wgsl",
    "rectangle_line_fixed.wgsl",
];

pub fn builtin_kernels() -> Vec<KernelFile> {
    BUILTIN
        .iter()
        .map(|(path, text)| KernelFile::parse(path, text).expect("built-in kernel header is valid"))
        .collect()
}

impl KernelFile {
    pub fn read(path: &Path) -> anyhow::Result<KernelFile> {
        let text =
            std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("cannot read kernel {}: {e}", path.display()))?;
        Ok(KernelFile::parse(&path.display().to_string(), &text)?)
    }

    pub fn parse(path: &str, text: &str) -> Result<KernelFile, HeaderError> {
        let err = |line: usize, message: String| HeaderError {
            path: path.to_string(),
            line,
            message,
        };
        let (mut id, mut target, mut source, mut minv, mut params) = (None, None, None, None, Vec::new());
        let mut uses_line = false;
        for (i, raw) in text.lines().enumerate() {
            let Some(rest) = raw.trim_start().strip_prefix("//!") else {
                continue;
            };
            let lineno = i + 1;
            let Some((key, value)) = rest.split_once(':') else {
                return Err(err(
                    lineno,
                    format!("header line must be `//! key: value`, got `{}`", raw.trim()),
                ));
            };
            let value = value.trim();
            match key.trim() {
                "id" => id = Some(value.to_string()),
                "target" => {
                    target = Some(Target::from_name(value).ok_or_else(|| {
                        err(
                            lineno,
                            format!("unknown target `{value}` (line, line_upper, line_isotropic, cylinder, caps, tube, rectangle)"),
                        )
                    })?)
                }
                "source" => source = Some(value.to_string()),
                "minv" => {
                    minv = Some(match value {
                        "full" => MinvSupport::Full,
                        "sparse" => MinvSupport::Sparse,
                        _ => return Err(err(lineno, format!("minv must be `full` or `sparse`, got `{value}`"))),
                    })
                }
                "params" => {
                    for item in value.split_whitespace() {
                        let parsed = item
                            .split_once('=')
                            .and_then(|(name, v)| Some((name.to_string(), v.parse::<u32>().ok()?)));
                        params.push(
                            parsed.ok_or_else(|| {
                                err(lineno, format!("params must be `NAME=integer ...`, got `{item}`"))
                            })?,
                        );
                    }
                }
                "uses" => {
                    if value != "line" {
                        return Err(err(lineno, format!("uses must be `line`, got `{value}`")));
                    }
                    uses_line = true;
                }
                other => {
                    return Err(err(
                        lineno,
                        format!("unknown header key `{other}` (id, target, source, minv, params, uses)"),
                    ))
                }
            }
        }
        let missing = |what: &str| err(1, format!("missing `//! {what}: ...` header line"));
        let id = id.ok_or_else(|| missing("id"))?;
        if id.is_empty() || id.contains(['@', ',', ' ']) {
            return Err(err(
                1,
                format!("id `{id}` must be non-empty without '@', ',' or spaces"),
            ));
        }
        Ok(KernelFile {
            path: path.to_string(),
            text: text.to_string(),
            id,
            target: target.ok_or_else(|| missing("target"))?,
            source: source.unwrap_or_else(|| "user kernel".to_string()),
            minv: minv.unwrap_or(MinvSupport::Full),
            params,
            uses_line,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_parses_and_errors_name_the_line() {
        let k = KernelFile::parse(
            "k.wgsl",
            "//! id: line.x\n//! target: line\n//! params: SAMPLES=64\nfn method(s: Scene) -> f32 { return 0.0; }\n",
        )
        .unwrap();
        assert_eq!(k.params, vec![("SAMPLES".to_string(), 64)]);
        assert_eq!(k.minv, MinvSupport::Full);
        let e = KernelFile::parse("k.wgsl", "//! id: line.x\n//! target: lines\n").unwrap_err();
        assert_eq!((e.line, e.path.as_str()), (2, "k.wgsl"));
        assert!(e.to_string().starts_with("k.wgsl:2: unknown target `lines`"));
        assert!(KernelFile::parse("k.wgsl", "//! target: line\n").is_err());
    }

    #[test]
    fn uses_line_header() {
        let k = KernelFile::parse("c.wgsl", "//! id: cyl.x\n//! target: cylinder\n//! uses: line\n").unwrap();
        assert!(k.uses_line);
        let k = KernelFile::parse("c.wgsl", "//! id: cyl.x\n//! target: cylinder\n").unwrap();
        assert!(!k.uses_line);
        let e = KernelFile::parse("c.wgsl", "//! id: cyl.x\n//! target: cylinder\n//! uses: caps\n").unwrap_err();
        assert_eq!(e.to_string(), "c.wgsl:3: uses must be `line`, got `caps`");
    }
}
