//! A method kernel file: its `//!` header (id, target, source, M⁻¹ support, parameters)
//! and its WGSL text. Built-in kernels are compiled into the binary; a user's kernel is
//! read from disk and goes through the same path (kernels/README.md).

use crate::input::target::Target;
use crate::input::texture_file::TextureData;
use crate::limits::MAX_ID;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

/// Which LTC matrices a method handles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MinvSupport {
    /// Any invertible M⁻¹.
    Full,
    /// Only the isotropic-GGX form `[[a,0,b],[0,c,0],[d,0,1]]`.
    Sparse,
    /// Only the diffuse material: `//! minv: diffuse` or `//! minv: none` (the kernel ignores
    /// M⁻¹; a formula for Lambertian irradiance, such as the engines' line irradiance, that has
    /// no LTC form); every other material is reported as unsupported.
    Diffuse,
    /// Only the `ggx` material: `//! minv: ggx`, a kernel that evaluates the GGX lobe itself
    /// from the scene's `view`, `alpha_x`, `tangent`, `alpha_y` (an engine's specular term);
    /// it ignores M⁻¹ and its result is not multiplied by the fed LTC's magnitude.
    Ggx,
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
    pub params: Vec<Param>,
    /// `//! uses: line`: the kernel calls `I_line(p1, p2)`, which the harness supplies
    /// from a line method chosen at run time (`cylinder.line[line.ltc2023]`).
    pub uses_line: bool,
    /// The target the inner method of a composite must have: `line` (`//! uses: line`) or
    /// `line_isotropic` (`//! uses: line_isotropic`, a composite built on an isotropic-emitter
    /// line formula). Both call it as `I_line(p1, p2)`.
    pub uses_target: Target,
    /// For a kernel translated from another language (GLSL, HLSL): its own text and
    /// which of its lines each line of the translation came from, so that errors and
    /// attributed lines name the file the user wrote.
    pub origin: Option<Arc<Origin>>,
    /// `//! derive: BASE` + `//! replace: F G`: a kernel that is its base with the named
    /// functions replaced by this file's (kernels/README.md). None: a standalone kernel.
    pub derived: Option<Derivation>,
    /// This file's own source parts: its text, or for a WGSL kernel with `#include`s its
    /// lines and the included pieces' in their order (src/kernel/pieces.rs).
    pub own_parts: Vec<(String, String)>,
    /// `//! texture: NAME = FILE`: the texture globals bound to files, in header order.
    pub textures: Vec<TextureBinding>,
    /// `//! sampler: NAME = linear|nearest, clamp|repeat`: the sampler globals, in header order.
    pub samplers: Vec<SamplerBinding>,
}

/// A `//! texture: NAME = FILE` header: the kernel's texture global `NAME` bound to the look-up
/// table `FILE` (relative to the kernel's folder), read when the header is parsed.
#[derive(Clone, Debug)]
pub struct TextureBinding {
    pub name: String,
    /// As the header writes it.
    pub file: String,
    /// The header's 1-based line in the kernel file.
    pub line: usize,
    /// Level 0 of the file (src/input/texture_file), shared between clones of the kernel.
    pub data: Arc<TextureData>,
}

/// A `//! sampler: NAME = FILTER, ADDRESS` header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SamplerSpec {
    pub filter: Filter,
    pub address: AddressMode,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SamplerBinding {
    pub name: String,
    pub spec: SamplerSpec,
    /// The header's 1-based line in the kernel file.
    pub line: usize,
}

/// A sampler's magnification and minification filter (a kernel's textures have one level).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
}

/// A sampler's address mode, on every axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AddressMode {
    /// Clamp to the edge texel.
    Clamp,
    Repeat,
}

/// The file a translated kernel came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Origin {
    /// The file's own text (GLSL).
    pub text: String,
    /// `lines[i]`: the 1-based line of `text` that line `i + 1` of the translation came
    /// from (0 when none did: the translator's own comment).
    pub lines: Vec<u32>,
    /// The language it was written in.
    pub language: Language,
    /// Constants of the translation whose written digits could not be recovered
    /// (src/kernel/written.rs), each with its function and `path:line: why`: the f64 column
    /// of a method that reaches one is refused.
    pub lost_digits: Vec<super::written::LostDigits>,
}

/// The language of a kernel file: by its `//! language:` header, else by its extension
/// (`.wgsl`; `.glsl`, `.comp`, `.frag`, `.vert`; `.hlsl`, `.hlsli`); WGSL for any other.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Language {
    Wgsl,
    Glsl,
    Hlsl,
}

impl Language {
    pub fn from_name(name: &str) -> Option<Language> {
        match name {
            "wgsl" => Some(Language::Wgsl),
            "glsl" => Some(Language::Glsl),
            "hlsl" => Some(Language::Hlsl),
            _ => None,
        }
    }

    /// The language of the file at `path` with text `text`, or why not.
    pub fn of(path: &Path, text: &str) -> Result<Language, HeaderError> {
        for (i, l) in text.lines().enumerate() {
            let Some((key, value)) = l.trim_start().strip_prefix("//!").and_then(|r| r.split_once(':')) else {
                continue;
            };
            if key.trim() == "language" {
                return Language::from_name(value.trim()).ok_or_else(|| HeaderError {
                    path: path.display().to_string(),
                    line: i + 1,
                    message: format!(
                        "language must be `wgsl`, `glsl` or `hlsl`, got `{}`",
                        crate::input::names::clip(value.trim())
                    ),
                });
            }
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        Ok(match ext.as_str() {
            "glsl" | "comp" | "frag" | "vert" => Language::Glsl,
            "hlsl" | "hlsli" => Language::Hlsl,
            _ => Language::Wgsl,
        })
    }
}

impl Origin {
    /// The original line behind 1-based line `translated`, and its text.
    pub fn line(&self, translated: usize) -> Option<(usize, &str)> {
        let line = *self.lines.get(translated.checked_sub(1)?)? as usize;
        let text = self.text.lines().nth(line.checked_sub(1)?)?;
        Some((line, text))
    }
}

/// What a derived kernel is made from.
#[derive(Clone, Debug)]
pub struct Derivation {
    /// The base kernel (itself standalone or derived).
    pub base: Box<KernelFile>,
    /// The base's functions this file replaces, in header order.
    pub replace: Vec<String>,
}

/// A pipeline-overridable constant of the header (`//! params: SAMPLES=64 SCALE=0.5`).
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: String,
    pub default: f64,
    /// Written with a decimal point or an exponent (`0.5`, `1.0`, `1e-3`): a float param,
    /// whose `override` must be `f32` and whose values may be any finite number. Otherwise
    /// an integer param: values are positive integers (sample counts).
    pub float: bool,
}

impl Param {
    /// `v` as a value of this param, or why not.
    pub fn value(&self, v: &str) -> Result<f64, String> {
        let shown = crate::input::names::clip(v);
        if self.float {
            return v
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("parameter `{shown}` of {} is not a finite number", self.name));
        }
        match v.parse::<u64>() {
            Ok(0) => Err(format!("parameter `{shown}` is not a positive integer (at least 1)")),
            Ok(n) => u32::try_from(n).map(f64::from).map_err(|_| {
                format!(
                    "parameter `{shown}` is larger than {} (the largest a kernel takes)",
                    u32::MAX
                )
            }),
            Err(_) if !v.is_empty() && v.bytes().all(|b| b.is_ascii_digit()) => Err(format!(
                "parameter `{shown}` is larger than {} (the largest a kernel takes)",
                u32::MAX
            )),
            Err(_) => Err(format!("parameter `{shown}` is not a positive integer")),
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[error("{path}:{line}: {message}")]
pub struct HeaderError {
    pub path: String,
    pub line: usize,
    pub message: String,
}

/// The prelude every kernel is composed with.
pub const PRELUDE: &str = include_str!("../../kernels/prelude.wgsl");
pub const PRELUDE_PATH: &str = "kernels/prelude.wgsl";

/// Built-in method kernels: (path, text), every `.wgsl` under `kernels/` but the prelude and
/// `kernels/lib/`, subfolders included, sorted by path (generated by `build.rs`).
const BUILTIN: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/builtin_kernels.rs"));

/// A kernel id: what a method spec can name without ambiguity.
pub fn valid_id(id: &str) -> bool {
    !id.is_empty()
        && id.len() <= MAX_ID
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
}

/// The built-in kernels, in path order. A derived one is parsed after its base.
pub fn builtin_kernels() -> Vec<KernelFile> {
    static KERNELS: std::sync::OnceLock<Vec<KernelFile>> = std::sync::OnceLock::new();
    KERNELS
        .get_or_init(|| {
            let mut done: Vec<KernelFile> = Vec::new();
            let mut pending: Vec<(&str, &str)> = BUILTIN.to_vec();
            while !pending.is_empty() {
                let before = pending.len();
                let mut waiting = Vec::new();
                for (path, text) in pending {
                    let ready = derive_of(text).is_none_or(|base| done.iter().any(|k| k.id == base));
                    if ready {
                        let lookup = |id: &str| done.iter().find(|k| k.id == id).cloned();
                        let k = KernelFile::parse_with(path, text, &lookup, None)
                            .unwrap_or_else(|e| panic!("built-in kernel header is valid: {e}"));
                        done.push(k);
                    } else {
                        waiting.push((path, text));
                    }
                }
                pending = waiting;
                assert!(
                    pending.len() < before,
                    "built-in kernels derive in a circle: {pending:?}"
                );
            }
            done.sort_by(|a, b| a.path.cmp(&b.path));
            done
        })
        .clone()
}

/// The `//! derive:` value of a kernel text, read without parsing the rest.
fn derive_of(text: &str) -> Option<&str> {
    text.lines().find_map(|l| {
        let (key, value) = l.trim_start().strip_prefix("//!")?.split_once(':')?;
        (key.trim() == "derive").then_some(value.trim())
    })
}

impl KernelFile {
    /// Reads the kernel file `path`; its `#include`s search `includes` after the including
    /// file's own folder (GLSL, HLSL) or `kernels/lib/` (WGSL).
    pub fn read(path: &Path, includes: &super::Includes) -> anyhow::Result<KernelFile> {
        let bytes = crate::io::read_bounded(path, "kernel", crate::limits::MAX_TEXT_INPUT)?;
        let text = String::from_utf8(bytes)
            .map_err(|e| anyhow::anyhow!("cannot read kernel {}: not UTF-8 text ({e})", path.display()))?;
        // A byte-order mark (some editors write one) is not part of the source, in either language.
        let text = match text.strip_prefix('\u{feff}') {
            Some(rest) => rest.to_string(),
            None => text,
        };
        let shown = path.display().to_string();
        let language = Language::of(path, &text)?;
        if language == Language::Wgsl {
            return Ok(KernelFile::parse_including(&shown, &text, includes)?);
        }
        // The header is checked on the file itself (its lines), then the translation is the text.
        KernelFile::parse(&shown, &text)?;
        let expanded = super::include::expand(path, &shown, &text, includes)?;
        let (wgsl, lines, lost_digits) = match language {
            Language::Glsl => super::glsl::translate_expanded(&shown, &expanded)?,
            _ => super::hlsl::translate(&shown, &expanded)?,
        };
        let mut kernel = KernelFile::parse(&shown, &wgsl)?;
        if !lost_digits.is_empty() {
            crate::warnings::raise(crate::warnings::Warning::LostDigits {
                kernel: kernel.path.clone(),
                constants: lost_digits.iter().map(|l| l.message.clone()).collect(),
            });
        }
        kernel.origin = Some(Arc::new(Origin {
            text,
            lines,
            language,
            lost_digits,
        }));
        Ok(kernel)
    }

    /// Parses a kernel file; a derived one (`//! derive:`) is derived from a built-in kernel.
    /// Its `#include`s name only `kernels/lib/` ([`KernelFile::parse_including`]: folders too).
    pub fn parse(path: &str, text: &str) -> Result<KernelFile, HeaderError> {
        KernelFile::parse_including(path, text, &super::Includes::none())
    }

    /// [`KernelFile::parse`], a WGSL kernel's `#include`s searching `includes` too.
    pub fn parse_including(path: &str, text: &str, includes: &super::Includes) -> Result<KernelFile, HeaderError> {
        KernelFile::parse_with(
            path,
            text,
            &|id| builtin_kernels().into_iter().find(|k| k.id == id),
            Some(includes),
        )
    }

    /// The source parts of the kernel, in composition order: (path, text), each text with
    /// every line of its file up to its last. A standalone kernel is its own file (with the
    /// pieces it includes where it includes them); a derived kernel is its base's parts,
    /// each replaced function blanked where it stood, then its own.
    pub fn parts(&self) -> Vec<(String, String)> {
        let Some(d) = &self.derived else {
            return self.own_parts.clone();
        };
        let mut parts = d.base.parts();
        for name in &d.replace {
            for (_, text) in parts.iter_mut() {
                if let Some((_, range)) = super::rename::fn_decls(text).into_iter().find(|(n, _)| n == name) {
                    *text = super::rename::blank(text, range);
                }
            }
        }
        parts.extend(self.own_parts.iter().cloned());
        parts
    }

    /// `user`: a user's kernel with its `--include` folders, whose `#include`s may name files
    /// in them; None: a built-in kernel.
    fn parse_with(
        path: &str,
        text: &str,
        base_of: &dyn Fn(&str) -> Option<KernelFile>,
        user: Option<&super::Includes>,
    ) -> Result<KernelFile, HeaderError> {
        let err = |line: usize, message: String| HeaderError {
            path: path.to_string(),
            line,
            message,
        };
        let (mut id, mut target, mut source, mut minv, mut params) = (None, None, None, None, Vec::new());
        let mut uses_line = false;
        let (mut derive, mut replace) = (None::<(String, usize)>, None::<(Vec<String>, usize)>);
        // Each key once: with two `id` lines the last would silently win.
        let mut seen: Vec<(String, usize)> = Vec::new();
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut uses_target = Target::Line;
        let (mut textures, mut samplers) = (Vec::<TextureBinding>::new(), Vec::<SamplerBinding>::new());
        for (i, raw) in text.lines().enumerate() {
            let Some(rest) = raw.trim_start().strip_prefix("//!") else {
                continue;
            };
            let lineno = i + 1;
            let raw = &crate::input::names::clip(raw);
            let Some((key, value)) = rest.split_once(':') else {
                return Err(err(
                    lineno,
                    format!("header line must be `//! key: value`, got `{}`", raw.trim()),
                ));
            };
            let value = value.trim();
            let key_name = key.trim();
            // `texture` and `sampler` appear once per binding (a name twice is refused below).
            let repeated = matches!(key_name, "texture" | "sampler");
            if let Some((_, first)) = seen.iter().find(|(k, _)| k == key_name).filter(|_| !repeated) {
                return Err(err(
                    lineno,
                    format!("`//! {key_name}:` appears twice (first on line {first})"),
                ));
            }
            seen.push((key_name.to_string(), lineno));
            let value_shown = crate::input::names::clip(value);
            let value_shown = value_shown.as_str();
            match key_name {
                "id" => id = Some(value.to_string()),
                "target" => {
                    target = Some(Target::from_name(value).ok_or_else(|| {
                        err(
                            lineno,
                            format!(
                                "unknown target `{value_shown}` (line, line_upper, line_isotropic, line_sum, line_isotropic_sum, cylinder, caps, tube, rectangle, cylinder_upper, caps_upper, tube_upper, rectangle_upper)"
                            ),
                        )
                    })?)
                }
                "source" => source = Some(value.to_string()),
                "minv" => {
                    minv = Some(match value {
                        "full" => MinvSupport::Full,
                        "sparse" => MinvSupport::Sparse,
                        "diffuse" | "none" => MinvSupport::Diffuse,
                        "ggx" => MinvSupport::Ggx,
                        _ => {
                            return Err(err(
                                lineno,
                                format!("minv must be `full`, `sparse`, `diffuse`, `none` or `ggx`, got `{value_shown}`"),
                            ))
                        }
                    })
                }
                "params" => {
                    for item in value.split_whitespace() {
                        let parsed = item.split_once('=').and_then(|(name, v)| {
                            let float = v.contains(['.', 'e', 'E']);
                            let default = if float {
                                v.parse::<f64>().ok().filter(|x| x.is_finite())?
                            } else {
                                f64::from(v.parse::<u32>().ok()?)
                            };
                            Some(Param {
                                name: name.to_string(),
                                default,
                                float,
                            })
                        });
                        params.push(parsed.ok_or_else(|| {
                            err(
                                lineno,
                                format!(
                                    "params must be `NAME=integer ...` (an identifier, then 1 to 4294967295) \
                                     or `NAME=float` (written with a '.' or an exponent), got `{}`",
                                    crate::input::names::clip(item)
                                ),
                            )
                        })?);
                    }
                }
                "uses" => {
                    uses_target = match value {
                        "line" => Target::Line,
                        "line_isotropic" => Target::LineIsotropic,
                        _ => {
                            return Err(err(
                                lineno,
                                format!("uses must be `line` or `line_isotropic`, got `{value_shown}`"),
                            ))
                        }
                    };
                    uses_line = true;
                }
                "derive" => derive = Some((value.to_string(), lineno)),
                // Read by `KernelFile::read` (which front end); checked here as any key.
                "language" => {
                    if Language::from_name(value).is_none() {
                        return Err(err(
                            lineno,
                            format!("language must be `wgsl`, `glsl` or `hlsl`, got `{value_shown}`"),
                        ));
                    }
                }
                "texture" | "sampler" => {
                    let (name, rhs) = binding_header(key_name, value).map_err(|m| err(lineno, m))?;
                    let first = textures
                        .iter()
                        .map(|t| (&t.name, t.line))
                        .chain(samplers.iter().map(|s| (&s.name, s.line)))
                        .find(|(n, _)| **n == name);
                    if let Some((_, first)) = first {
                        return Err(err(
                            lineno,
                            format!("`{name}` is bound twice (first on line {first})"),
                        ));
                    }
                    if key_name == "texture" {
                        let data = read_texture(path, rhs).map_err(|m| err(lineno, m))?;
                        textures.push(TextureBinding {
                            name,
                            file: rhs.to_string(),
                            line: lineno,
                            data: Arc::new(data),
                        });
                    } else {
                        let spec = sampler_spec(rhs).map_err(|m| err(lineno, m))?;
                        samplers.push(SamplerBinding {
                            name,
                            spec,
                            line: lineno,
                        });
                    }
                }
                "replace" => {
                    let names: Vec<String> = value
                        .split(|c: char| c == ',' || c.is_whitespace())
                        .filter(|n| !n.is_empty())
                        .map(str::to_string)
                        .collect();
                    if names.is_empty() {
                        return Err(err(lineno, "`//! replace:` names no function".to_string()));
                    }
                    replace = Some((names, lineno));
                }
                other => {
                    return Err(err(
                        lineno,
                        format!(
                            "unknown header key `{}` (id, target, source, minv, params, uses, derive, replace, language, texture, sampler)",
                            crate::input::names::clip(other)
                        ),
                    ))
                }
            }
        }
        let missing = |what: &str| err(1, format!("missing `//! {what}: ...` header line"));
        let id: String = id.ok_or_else(|| missing("id"))?;
        let line_of = |key: &str| seen.iter().find(|(k, _)| k == key).map_or(1, |(_, l)| *l);
        let id_line = seen.iter().find(|(k, _)| k == "id").map_or(1, |(_, l)| *l);
        if !valid_id(&id) {
            return Err(err(
                id_line,
                format!(
                    "id `{}` must be 1–{MAX_ID} letters, digits, '.', '_' or '-' (no '@', ',', brackets or spaces: \
                     they separate parameters and inner methods in a method spec)",
                    crate::input::names::clip(&id)
                ),
            ));
        }
        let derived = match (derive, replace) {
            (None, None) => None,
            (Some((_, line)), None) => {
                return Err(err(
                    line,
                    "a derived kernel names the functions it replaces: add `//! replace: NAME ...`".to_string(),
                ))
            }
            (None, Some((_, line))) => {
                return Err(err(
                    line,
                    "`//! replace:` needs `//! derive: BASE_ID`, the kernel whose functions it replaces".to_string(),
                ))
            }
            (Some((base_id, line)), Some((replace, replace_line))) => {
                let base = base_of(&base_id).ok_or_else(|| {
                    err(
                        line,
                        format!(
                            "unknown base kernel `{}`: a derived kernel's base is a built-in kernel id (linelight methods)",
                            crate::input::names::clip(&base_id)
                        ),
                    )
                })?;
                check_derivation(text, &base, &replace, replace_line, &err)?;
                for (key, same) in [
                    ("target", target.is_none_or(|t| t == base.target)),
                    (
                        "uses",
                        !uses_line || (base.uses_line && uses_target == base.uses_target),
                    ),
                ] {
                    if !same {
                        return Err(err(
                            line_of(key),
                            format!("`//! {key}:` of a derived kernel is its base's ({base_id}): drop the line"),
                        ));
                    }
                }
                target = Some(base.target);
                minv = minv.or(Some(base.minv));
                if !seen.iter().any(|(k, _)| k == "params") {
                    params = base.params.clone();
                }
                (uses_line, uses_target) = (base.uses_line, base.uses_target);
                Some(Derivation {
                    base: Box::new(base),
                    replace,
                })
            }
        };
        // A WGSL kernel's `#include`s; a GLSL or HLSL file's are expanded before translation.
        let own_parts = if Language::of(Path::new(path), text).ok() == Some(Language::Wgsl) {
            super::pieces::expand(path, text, user)?
        } else {
            vec![(path.to_string(), text.to_string())]
        };
        Ok(KernelFile {
            own_parts,
            path: path.to_string(),
            text: text.to_string(),
            id,
            target: target.ok_or_else(|| missing("target"))?,
            source: source.unwrap_or_else(|| "user kernel".to_string()),
            minv: minv.unwrap_or(MinvSupport::Full),
            params,
            uses_line,
            uses_target,
            origin: None,
            derived,
            textures,
            samplers,
        })
    }
}

/// `NAME = REST` of a `//! texture:` or `//! sampler:` header: NAME an identifier.
fn binding_header<'a>(key: &str, value: &'a str) -> Result<(String, &'a str), String> {
    let form = if key == "texture" {
        "`//! texture: NAME = FILE`"
    } else {
        "`//! sampler: NAME = linear|nearest, clamp|repeat`"
    };
    let shown = crate::input::names::clip(value);
    let Some((name, rest)) = value.split_once('=') else {
        return Err(format!("a {key} header is {form}, got `{shown}`"));
    };
    let (name, rest) = (name.trim(), rest.trim());
    let ident = name.chars().next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_alphanumeric() || c == '_');
    if !ident || rest.is_empty() {
        return Err(format!(
            "a {key} header is {form} (NAME the kernel's global), got `{shown}`"
        ));
    }
    Ok((name.to_string(), rest))
}

/// `linear|nearest, clamp|repeat`.
fn sampler_spec(value: &str) -> Result<SamplerSpec, String> {
    let words: Vec<&str> = value.split(',').map(str::trim).collect();
    let filter = match words.first() {
        Some(&"linear") => Some(Filter::Linear),
        Some(&"nearest") => Some(Filter::Nearest),
        _ => None,
    };
    let address = match words.get(1) {
        Some(&"clamp") => Some(AddressMode::Clamp),
        Some(&"repeat") => Some(AddressMode::Repeat),
        _ => None,
    };
    match (filter, address, words.len()) {
        (Some(filter), Some(address), 2) => Ok(SamplerSpec { filter, address }),
        _ => Err(format!(
            "a sampler is `linear` or `nearest`, then `clamp` or `repeat` (`//! sampler: s = linear, clamp`), got `{}`",
            crate::input::names::clip(value)
        )),
    }
}

/// The look-up table `file` of a `//! texture:` header in kernel `kernel` (as shown): a path
/// relative to the kernel's folder that stays inside it (no absolute path, no `..`, no symlink
/// out), read by src/input/texture_file (its size checked against src/limits.rs before its
/// texels are read), with one mip level.
fn read_texture(kernel: &str, file: &str) -> Result<TextureData, String> {
    let shown = crate::input::names::clip(file);
    let relative = Path::new(file);
    if relative.is_absolute() || relative.has_root() {
        return Err(format!(
            "texture file `{shown}` is an absolute path: name it relative to the kernel's folder"
        ));
    }
    if relative
        .components()
        .any(|c| matches!(c, Component::ParentDir | Component::Prefix(_)))
    {
        return Err(format!(
            "texture file `{shown}` leaves the kernel's folder (`..`): a texture file lies in the kernel's folder or below it"
        ));
    }
    let folder = match Path::new(kernel).parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let joined = folder.join(relative);
    let real = std::fs::canonicalize(&joined)
        .map_err(|e| format!("cannot find texture file `{shown}` ({}: {e})", joined.display()))?;
    let real_folder = std::fs::canonicalize(&folder)
        .map_err(|e| format!("cannot read the kernel's folder {}: {e}", folder.display()))?;
    if !real.starts_with(&real_folder) {
        return Err(format!(
            "texture file `{shown}` resolves to {}, outside the kernel's folder {} (through a symlink): \
             a texture file lies in the kernel's folder or below it",
            real.display(),
            real_folder.display()
        ));
    }
    let data = crate::input::texture_file::read(&joined).map_err(|e| e.0)?;
    if data.mip_levels > 1 {
        return Err(format!(
            "texture file `{shown}` holds {} mip levels: a kernel's texture has one (the harness samples \
             level 0, `textureSampleLevel(…, 0.0)`); store level 0 alone",
            data.mip_levels
        ));
    }
    Ok(data)
}

/// A derived kernel's file defines exactly the functions it replaces, each one the base has.
fn check_derivation(
    text: &str,
    base: &KernelFile,
    replace: &[String],
    replace_line: usize,
    err: &dyn Fn(usize, String) -> HeaderError,
) -> Result<(), HeaderError> {
    let own = super::rename::fn_decls(text);
    let base_fns: Vec<String> = base
        .parts()
        .iter()
        .flat_map(|(_, t)| super::rename::fn_decls(t))
        .map(|(n, _)| n)
        .collect();
    for (i, name) in replace.iter().enumerate() {
        let shown = crate::input::names::clip(name);
        if replace[..i].contains(name) {
            return Err(err(replace_line, format!("`{shown}` is named twice in `//! replace:`")));
        }
        if !base_fns.contains(name) {
            return Err(err(
                replace_line,
                format!("`{shown}`: the base kernel {} has no function of that name", base.id),
            ));
        }
        if !own.iter().any(|(n, _)| n == name) {
            return Err(err(
                replace_line,
                format!("`{shown}` is to be replaced, but this file does not define `fn {shown}`"),
            ));
        }
    }
    if let Some((name, range)) = own.iter().find(|(n, _)| !replace.contains(n)) {
        return Err(err(
            text[..range.start].matches('\n').count() + 1,
            format!("`fn {name}` is not in `//! replace:`: a derived kernel holds only the functions it replaces"),
        ));
    }
    Ok(())
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
        assert_eq!(
            k.params,
            vec![Param {
                name: "SAMPLES".into(),
                default: 64.0,
                float: false
            }]
        );
        let k = KernelFile::parse(
            "k.wgsl",
            "//! id: line.x\n//! target: line\n//! params: N=4 SCALE=0.5\n",
        )
        .unwrap();
        assert_eq!((k.params[1].default, k.params[1].float), (0.5, true));
        assert_eq!(k.params[1].value("-1.5e-3"), Ok(-1.5e-3));
        assert!(k.params[0].value("2.5").unwrap_err().contains("not a positive integer"));
        assert_eq!(k.params[0].value("8"), Ok(8.0));
        assert_eq!(k.minv, MinvSupport::Full);
        let e = KernelFile::parse("k.wgsl", "//! id: line.x\n//! target: lines\n").unwrap_err();
        assert_eq!((e.line, e.path.as_str()), (2, "k.wgsl"));
        assert!(e.to_string().starts_with("k.wgsl:2: unknown target `lines`"));
        assert!(KernelFile::parse("k.wgsl", "//! target: line\n").is_err());
    }

    #[test]
    fn builtins_include_every_kernel_file_in_subfolders() {
        fn walk(dir: &Path, out: &mut Vec<String>) {
            for e in std::fs::read_dir(dir).unwrap() {
                let p = e.unwrap().path();
                let rel = p
                    .strip_prefix(env!("CARGO_MANIFEST_DIR"))
                    .unwrap()
                    .to_string_lossy()
                    .to_string();
                if p.is_dir() && !rel.ends_with("kernels/lib") {
                    walk(&p, out);
                } else if rel.ends_with(".wgsl") && !rel.ends_with("prelude.wgsl") {
                    out.push(rel);
                }
            }
        }
        let mut files = Vec::new();
        walk(&Path::new(env!("CARGO_MANIFEST_DIR")).join("kernels"), &mut files);
        let paths: Vec<String> = builtin_kernels().into_iter().map(|k| k.path).collect();
        assert!(files.iter().any(|f| f.starts_with("kernels/engines/")), "{files:?}");
        for f in &files {
            assert!(paths.contains(f), "{f} is not built in: {paths:?}");
        }
        let mut ids: Vec<String> = builtin_kernels().into_iter().map(|k| k.id).collect();
        let n = ids.len();
        ids.sort();
        ids.dedup();
        assert_eq!(ids.len(), n, "two built-in kernels share an id");
    }

    #[test]
    fn derived_kernel_inherits_and_errors_name_the_line() {
        let k = KernelFile::parse(
            "d.wgsl",
            "//! id: line.d\n//! derive: line.ltc2017\n//! replace: Fwt\nfn Fwt(d: f32, l: f32) -> f32 { return 0.0; }\n",
        )
        .unwrap();
        assert_eq!((k.target, k.minv), (Target::Line, MinvSupport::Full));
        let parts = k.parts();
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0].0, "kernels/line_ltc2017.wgsl");
        assert!(!parts[0].1.contains("fn Fwt") && parts[0].1.contains("fn Fpo"));
        let base = builtin_kernels().into_iter().find(|k| k.id == "line.ltc2017").unwrap();
        assert_eq!(
            parts[0].1.lines().count(),
            base.text.lines().count(),
            "line numbers kept"
        );
        let e = |text: &str| KernelFile::parse("d.wgsl", text).unwrap_err().to_string();
        let head = "//! id: line.d\n//! derive: line.ltc2017\n";
        assert_eq!(
            e(&format!("{head}//! replace: Nope\n")),
            "d.wgsl:3: `Nope`: the base kernel line.ltc2017 has no function of that name"
        );
        assert_eq!(
            e(&format!("{head}//! replace: Fwt\n")),
            "d.wgsl:3: `Fwt` is to be replaced, but this file does not define `fn Fwt`"
        );
        assert_eq!(
            e(&format!("{head}//! replace: Fwt\nfn Fwt() {{}}\n\nfn extra() {{}}\n")),
            "d.wgsl:6: `fn extra` is not in `//! replace:`: a derived kernel holds only the functions it replaces"
        );
        assert!(e(&format!(
            "{head}//! target: cylinder\n//! replace: Fwt\nfn Fwt() {{}}\n"
        ))
        .starts_with("d.wgsl:3: `//! target:` of a derived kernel is its base's"));
        assert!(e("//! id: line.d\n//! derive: line.nope\n//! replace: Fwt\n")
            .starts_with("d.wgsl:2: unknown base kernel `line.nope`"));
        assert!(e("//! id: line.d\n//! derive: line.ltc2017\n")
            .starts_with("d.wgsl:2: a derived kernel names the functions"));
        assert!(e("//! id: line.d\n//! target: line\n//! replace: Fwt\n").starts_with("d.wgsl:3: `//! replace:` needs"));
    }

    #[test]
    fn minv_none_header() {
        let k = KernelFile::parse("d.wgsl", "//! id: line.d\n//! target: line\n//! minv: none\n").unwrap();
        assert_eq!(k.minv, MinvSupport::Diffuse);
        let e = KernelFile::parse("d.wgsl", "//! id: line.d\n//! target: line\n//! minv: diffuse-only\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "d.wgsl:3: minv must be `full`, `sparse`, `diffuse`, `none` or `ggx`, got `diffuse-only`"
        );
    }

    #[test]
    fn uses_line_header() {
        let k = KernelFile::parse("c.wgsl", "//! id: cyl.x\n//! target: cylinder\n//! uses: line\n").unwrap();
        assert!(k.uses_line);
        let k = KernelFile::parse("c.wgsl", "//! id: cyl.x\n//! target: cylinder\n").unwrap();
        assert!(!k.uses_line);
        let e = KernelFile::parse("c.wgsl", "//! id: cyl.x\n//! target: cylinder\n//! uses: caps\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "c.wgsl:3: uses must be `line` or `line_isotropic`, got `caps`"
        );
    }
}
