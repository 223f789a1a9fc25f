//! Methods under test: a kernel file, the values of its parameters and the inner line
//! method of a composite (`cylinder.line[line.ltc2023]`). Its `f64` and `cpu_f32` columns
//! come from the same kernel on the CPU evaluator (src/eval/interp, `interp::CpuColumns`).

use crate::input::scene::Config;
use crate::input::target::Target;
use crate::kernel::{Includes, KernelFile, MinvSupport};
use anyhow::Context;

pub use crate::kernel::{DEFAULT_INNER, DEFAULT_INNER_ISOTROPIC};

#[derive(Clone, Debug)]
pub struct Method {
    /// As written by the user: `line.numeric@256`, `cylinder.line[line.ltc2023]`.
    pub label: String,
    pub kernel: KernelFile,
    /// Override values in the kernel's header order (defaults filled in).
    pub params: Vec<f64>,
    /// For a kernel with `//! uses: line`: the line method its `I_line` calls.
    pub inner: Option<Box<Method>>,
    /// `id~target`: the method judged against another target than its kernel's (an
    /// isotropic-emitter formula against the chapter's `line`, to show how far the models
    /// are apart). None: the kernel's own target.
    pub judged: Option<Target>,
}

impl Method {
    pub fn id(&self) -> &str {
        &self.kernel.id
    }

    /// The target the method is judged against: its kernel's, or the one named by `~target`.
    pub fn target(&self) -> Target {
        self.judged.unwrap_or(self.kernel.target)
    }

    /// The label with the inner method spelled out, defaults included:
    /// `cylinder.line` → `cylinder.line[line.ltc2023_full]`.
    pub fn describe(&self) -> String {
        let judged = self.judged.map(|t| format!("~{t}")).unwrap_or_default();
        match &self.inner {
            Some(inner) => {
                let head = self.label.split(['[', '~']).next().unwrap_or(&self.label);
                format!("{head}[{}]{judged}", inner.describe())
            }
            None => self.label.clone(),
        }
    }

    /// Whether the method (and its inner line method) claims to handle this
    /// configuration's material.
    pub fn supports(&self, config: &Config) -> bool {
        let own = match self.kernel.minv {
            MinvSupport::Full => true,
            MinvSupport::Sparse => config.material.is_sparse(),
            MinvSupport::Diffuse => config.material == crate::input::scene::Material::Diffuse,
            MinvSupport::Ggx => matches!(config.material, crate::input::scene::Material::Ggx { .. }),
        };
        own && self.inner.as_ref().is_none_or(|inner| inner.supports(config))
    }

    /// Whether the configuration has what the method's target needs.
    pub fn applies(&self, config: &Config) -> bool {
        match self.target() {
            Target::Line | Target::LineUpper | Target::LineIsotropic | Target::LineSum | Target::LineIsotropicSum => {
                true
            }
            Target::Cylinder
            | Target::Caps
            | Target::Tube
            | Target::CylinderUpper
            | Target::CapsUpper
            | Target::TubeUpper => config.radius.is_some(),
            Target::Rectangle | Target::RectangleUpper => config.rect.is_some(),
        }
    }

    /// Whether the method's result is multiplied by a `ggx` configuration's fed magnitude:
    /// an LTC method's is, a `minv: ggx` kernel's (which evaluates the GGX lobe) is not.
    /// A composite follows its inner line method (its own formula is linear in `I_line`).
    pub fn scaled_by_magnitude(&self) -> bool {
        self.kernel.minv != MinvSupport::Ggx && self.inner.as_ref().is_none_or(|inner| inner.scaled_by_magnitude())
    }

    /// The factor the method's value on `config` is multiplied by: a `ggx` configuration's
    /// fed magnitude (Fresnel-weighted with `f0`) when [`Method::scaled_by_magnitude`], else 1.
    pub fn magnitude(&self, config: &Config) -> f64 {
        match config.material.fed_magnitude() {
            Some(m) if self.scaled_by_magnitude() => m,
            _ => 1.0,
        }
    }
}

/// Resolves a method spec against the built-in kernels and the user's: `id`, `id@N` or
/// `id@NxM`, and for a kernel with `//! uses: line` optionally its line method in
/// brackets, `cylinder.line@4[line.numeric@64]` (default [`DEFAULT_INNER`]).
/// A spec may end in `~target` to judge the method against another target
/// (`line_isotropic.karis2013~line`).
pub fn resolve(spec: &str, kernels: &[KernelFile]) -> anyhow::Result<Method> {
    let Some((plain, judged)) = spec.rsplit_once('~') else {
        return resolve_unjudged(spec, kernels);
    };
    let target = Target::from_name(judged).ok_or_else(|| {
        let names: Vec<_> = Target::ALL.iter().map(|t| t.name()).collect();
        anyhow::anyhow!("`{spec}`: unknown target `{judged}` after `~` ({})", names.join(", "))
    })?;
    let mut method = resolve_unjudged(plain, kernels)?;
    method.label = spec.to_string();
    method.judged = Some(target);
    Ok(method)
}

fn resolve_unjudged(spec: &str, kernels: &[KernelFile]) -> anyhow::Result<Method> {
    let (head, inner_spec) = split_inner(spec)?;
    let mut method = resolve_plain(spec, head, kernels)?;
    if !method.kernel.uses_line {
        if inner_spec.is_some() {
            anyhow::bail!("`{spec}`: {}", takes_no_inner(&method.kernel));
        }
        return Ok(method);
    }
    let wanted = method.kernel.uses_target;
    let inner_spec = inner_spec.unwrap_or(if wanted == Target::LineIsotropic {
        DEFAULT_INNER_ISOTROPIC
    } else {
        DEFAULT_INNER
    });
    let (inner_head, nested) = split_inner(inner_spec)?;
    let inner = resolve_plain(inner_spec, inner_head, kernels).with_context(|| format!("`{spec}`"))?;
    let k = &inner.kernel;
    if k.uses_line {
        anyhow::bail!(
            "`{spec}`: the inner method {} itself uses a line method (`//! uses: line` in {}); \
             it must be a plain line method",
            k.id,
            k.path
        );
    }
    if nested.is_some() {
        anyhow::bail!("`{spec}`: {}", takes_no_inner(k));
    }
    if k.target != wanted {
        anyhow::bail!(
            "`{spec}`: the inner method must be a `target: {wanted}` kernel; {} targets {}",
            k.id,
            k.target
        );
    }
    method.inner = Some(Box::new(inner));
    Ok(method)
}

fn takes_no_inner(kernel: &KernelFile) -> String {
    format!(
        "{} takes no `[line method]`: its kernel ({}) has no `//! uses: line`",
        kernel.id, kernel.path
    )
}

/// `outer[inner]` → (`outer`, Some(`inner`)); a spec without brackets → (spec, None).
fn split_inner(spec: &str) -> anyhow::Result<(&str, Option<&str>)> {
    let Some(open) = spec.find('[') else {
        if spec.contains(']') {
            anyhow::bail!("`{spec}`: `]` without `[`");
        }
        return Ok((spec, None));
    };
    let inner = spec[open + 1..].strip_suffix(']').ok_or_else(|| {
        anyhow::anyhow!("`{spec}`: the inner line method goes in brackets at the end: `method@N[line.method@M]`")
    })?;
    if inner.is_empty() {
        anyhow::bail!("`{spec}`: empty `[]`: name a line method, or drop the brackets for {DEFAULT_INNER}");
    }
    Ok((&spec[..open], Some(inner)))
}

/// `id`, `id@N` or `id@NxM` (no brackets) → a method without an inner; `spec` is the
/// whole text as written, for the label and messages.
fn resolve_plain(spec: &str, head: &str, kernels: &[KernelFile]) -> anyhow::Result<Method> {
    let (id, args) = match head.split_once('@') {
        Some((id, args)) => (id, Some(args)),
        None => (head, None),
    };
    let kernel = kernels.iter().find(|k| k.id == id).ok_or_else(|| {
        let known: Vec<_> = kernels.iter().map(|k| k.id.as_str()).collect();
        anyhow::anyhow!(
            "unknown method `{}` (known: {})",
            crate::input::names::clip(id),
            known.join(", ")
        )
    })?;
    let mut params: Vec<f64> = kernel.params.iter().map(|p| p.default).collect();
    if let Some(args) = args {
        let values: Vec<&str> = args.split('x').collect();
        if values.len() > params.len() {
            anyhow::bail!(
                "`{spec}`: {id} takes {} parameter(s) ({}), got {}",
                params.len(),
                kernel
                    .params
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                values.len()
            );
        }
        for ((slot, v), p) in params.iter_mut().zip(values).zip(&kernel.params) {
            *slot = p
                .value(v)
                .map_err(|e| anyhow::anyhow!("`{}`: {e}", crate::input::names::clip(spec)))?;
        }
    }
    Ok(Method {
        label: spec.to_string(),
        kernel: kernel.clone(),
        params,
        inner: None,
        judged: None,
    })
}

/// Refuses a method listed twice (`--methods`, a bench's override): its results would be
/// merged under one label.
pub fn check_unique(specs: &[String], flag: &str) -> anyhow::Result<()> {
    for (i, s) in specs.iter().enumerate() {
        if let Some(j) = specs[..i].iter().position(|o| o == s) {
            anyhow::bail!(
                "{flag}: `{}` is listed twice (entries {} and {})",
                crate::input::names::clip(s),
                j + 1,
                i + 1
            );
        }
    }
    Ok(())
}

/// All kernels a run can name: the built-ins and the user's `--kernel` files (their
/// `#include`s searching `includes`). A user kernel may not reuse a built-in id (results
/// would be ambiguous). Every file is validated whole ([`validate_kernel`]), whether a method
/// uses it or not.
pub fn kernel_set(user: &[std::path::PathBuf], includes: &Includes) -> anyhow::Result<Vec<KernelFile>> {
    let mut kernels = crate::kernel::builtin_kernels();
    for path in user {
        let k = validate_kernel(path, &kernels, includes)?;
        kernels.push(k);
    }
    Ok(kernels)
}

/// Reads a kernel file and validates it the one way every command does (`check`, `eval`,
/// `sweep`, `bench`): its header, an id no other kernel has, and the composed module
/// through naga with every shader capability linelight asks a device for.
pub fn validate_kernel(
    path: &std::path::Path,
    others: &[KernelFile],
    includes: &Includes,
) -> anyhow::Result<KernelFile> {
    let k = KernelFile::read(path, includes)?;
    // A built-in's own file (`linelight check kernels/x.wgsl`) is that built-in, not a clash.
    let same_file = |o: &KernelFile| {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        match (std::fs::canonicalize(path), std::fs::canonicalize(root.join(&o.path))) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
    };
    if let Some(other) = others.iter().find(|o| o.id == k.id && !same_file(o)) {
        anyhow::bail!("{}: id `{}` is already defined by {}", k.path, k.id, other.path);
    }
    let composed = crate::kernel::compose_with(&k, None, crate::kernel::kernel_capabilities())?;
    // Private arrays are per invocation: a large one times the invocations in flight.
    if let Some(bytes) = crate::limits::kernel_invocation_bytes(&composed.module) {
        let in_flight = crate::kernel::compose::invocations_in_flight();
        crate::limits::check(
            &format!(
                "{}: its private and local variables ({} per invocation, × {in_flight} invocations in flight)",
                k.path,
                crate::limits::Bytes(bytes)
            ),
            crate::limits::Bytes(bytes.saturating_mul(in_flight)),
            crate::limits::max_memory(),
        )
        .map_err(anyhow::Error::msg)?;
    }
    Ok(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn judged_against_another_target() {
        let kernels = crate::kernel::builtin_kernels();
        let m = resolve("line_isotropic.karis2013~line", &kernels).unwrap();
        assert_eq!((m.kernel.target, m.target()), (Target::LineIsotropic, Target::Line));
        assert_eq!(m.label, "line_isotropic.karis2013~line");
        let m = resolve("line_isotropic.karis2013", &kernels).unwrap();
        assert_eq!(m.target(), Target::LineIsotropic);
        let e = resolve("line_isotropic.karis2013~lines", &kernels)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown target `lines`"), "{e}");
        let m = resolve("cylinder.line[line.ltc2017]~line", &kernels).unwrap();
        assert_eq!(m.describe(), "cylinder.line[line.ltc2017]~line");
    }

    #[test]
    fn minv_none_supports_diffuse_only() {
        use crate::input::scene::Material;
        let k = KernelFile::parse("d.wgsl", "//! id: line.d\n//! target: line\n//! minv: none\n").unwrap();
        let m = resolve("line.d", &[k]).unwrap();
        let mut c = Config {
            id: String::new(),
            p1: [0.0, -1.0, 1.0],
            p2: [0.0, 1.0, 1.0],
            radius: None,
            rect: None,
            material: Material::Diffuse,
            texture: None,
        };
        assert!(m.supports(&c));
        // Sparse and full M⁻¹ alike are unsupported.
        c.material = Material::Ltc {
            minv: [[0.5, 0.0, 0.1], [0.0, 0.6, 0.0], [-0.2, 0.0, 1.0]],
        };
        assert!(!m.supports(&c));
    }
}
