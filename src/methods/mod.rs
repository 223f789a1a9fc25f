//! Methods under test: a kernel file, the values of its parameters, the inner line method
//! of a composite (`cylinder.line[line.ltc2023]`), and (for built-ins) a CPU port of the
//! same formula for the f64 column.

pub mod ports;

use crate::kernel::{KernelFile, MinvSupport};
use crate::scene::Config;
use crate::target::Target;
use std::cell::Cell;

/// The line method a composite uses when its spec names none: it handles every M⁻¹.
pub const DEFAULT_INNER: &str = "line.ltc2023_full";

/// The inner method of a `//! uses: line_isotropic` composite when its spec names none: the
/// horizon-clipped line irradiance, exact for isotropic emitters on the diffuse material.
pub const DEFAULT_INNER_ISOTROPIC: &str = "line_isotropic.karis2013_clip";

#[derive(Clone, Debug)]
pub struct Method {
    /// As written by the user: `line.numeric@256`, `cylinder.line[line.ltc2023]`.
    pub label: String,
    pub kernel: KernelFile,
    /// Override values in the kernel's header order (defaults filled in).
    pub params: Vec<u32>,
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
            MinvSupport::Diffuse => config.material == crate::scene::Material::Diffuse,
        };
        own && self.inner.as_ref().is_none_or(|inner| inner.supports(config))
    }

    /// Whether the configuration has what the method's target needs.
    pub fn applies(&self, config: &Config) -> bool {
        match self.target() {
            Target::Line | Target::LineUpper | Target::LineIsotropic => true,
            Target::Cylinder | Target::Caps | Target::Tube => config.radius.is_some(),
            Target::Rectangle => config.rect.is_some(),
        }
    }

    /// The same formula in double precision, when a CPU port exists (for a composite:
    /// for it and its inner method).
    pub fn eval_f64(&self, config: &Config) -> Option<f64> {
        self.eval_cpu::<f64>(config)
    }

    /// The same formula in single precision on the CPU (cross-checks the GPU port).
    pub fn eval_f32_cpu(&self, config: &Config) -> Option<f32> {
        self.eval_cpu::<f32>(config)
    }

    fn eval_cpu<T: ports::Real>(&self, config: &Config) -> Option<T> {
        let Some(inner) = &self.inner else {
            return ports::evaluate::<T>(self.id(), &self.params, config);
        };
        // The inner port sees the configuration with the segment replaced, as the GPU
        // glue does. T → f64 is exact for f32 and f64.
        let unported = Cell::new(false);
        let i_line = |p1: [T; 3], p2: [T; 3]| {
            let f64s = |p: [T; 3]| p.map(|x| x.to_f64().unwrap_or(f64::NAN));
            let segment = Config {
                id: String::new(),
                p1: f64s(p1),
                p2: f64s(p2),
                radius: config.radius,
                rect: config.rect.clone(),
                material: config.material.clone(),
            };
            inner.eval_cpu::<T>(&segment).unwrap_or_else(|| {
                unported.set(true);
                T::nan()
            })
        };
        let value = ports::evaluate_composite::<T>(self.id(), &self.params, config, &i_line)?;
        (!unported.get()).then_some(value)
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
    let inner = resolve_plain(inner_spec, inner_head, kernels).map_err(|e| anyhow::anyhow!("`{spec}`: {e}"))?;
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
        anyhow::anyhow!("unknown method `{id}` (known: {})", known.join(", "))
    })?;
    let mut params: Vec<u32> = kernel.params.iter().map(|(_, v)| *v).collect();
    if let Some(args) = args {
        let values: Vec<&str> = args.split('x').collect();
        if values.len() > params.len() {
            anyhow::bail!(
                "`{spec}`: {id} takes {} parameter(s) ({}), got {}",
                params.len(),
                kernel
                    .params
                    .iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                values.len()
            );
        }
        for (slot, v) in params.iter_mut().zip(values) {
            *slot = v
                .parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| anyhow::anyhow!("`{spec}`: parameter `{v}` is not a positive integer"))?;
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

/// All kernels a run can name: the built-ins and the user's `--kernel` files.
/// A user kernel may not reuse a built-in id (results would be ambiguous).
pub fn kernel_set(user: &[std::path::PathBuf]) -> anyhow::Result<Vec<KernelFile>> {
    let mut kernels = crate::kernel::builtin_kernels();
    for path in user {
        let k = KernelFile::read(path)?;
        if let Some(other) = kernels.iter().find(|o| o.id == k.id) {
            anyhow::bail!("{}: id `{}` is already defined by {}", k.path, k.id, other.path);
        }
        kernels.push(k);
    }
    Ok(kernels)
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
}
