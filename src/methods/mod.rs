//! Methods under test: a kernel file, the values of its parameters, and (for built-ins)
//! a CPU port of the same formula for the f64 column.

pub mod ports;

use crate::kernel::{KernelFile, MinvSupport};
use crate::scene::Config;
use crate::target::Target;

#[derive(Clone, Debug)]
pub struct Method {
    /// As written by the user: `line.numeric@256`.
    pub label: String,
    pub kernel: KernelFile,
    /// Override values in the kernel's header order (defaults filled in).
    pub params: Vec<u32>,
}

impl Method {
    pub fn id(&self) -> &str {
        &self.kernel.id
    }

    pub fn target(&self) -> Target {
        self.kernel.target
    }

    /// Whether the method claims to handle this configuration's material.
    pub fn supports(&self, config: &Config) -> bool {
        self.kernel.minv == MinvSupport::Full || config.material.is_sparse()
    }

    /// Whether the configuration has what the method's target needs.
    pub fn applies(&self, config: &Config) -> bool {
        match self.target() {
            Target::Line | Target::LineUpper => true,
            Target::Cylinder | Target::Caps | Target::Tube => config.radius.is_some(),
            Target::Rectangle => config.rect.is_some(),
        }
    }

    /// The same formula in double precision, when a CPU port exists.
    pub fn eval_f64(&self, config: &Config) -> Option<f64> {
        ports::evaluate::<f64>(self.id(), &self.params, config)
    }

    /// The same formula in single precision on the CPU (cross-checks the GPU port).
    pub fn eval_f32_cpu(&self, config: &Config) -> Option<f32> {
        ports::evaluate::<f32>(self.id(), &self.params, config)
    }
}

/// Resolves `id` or `id@N` / `id@NxM` against the built-in kernels and the user's.
pub fn resolve(spec: &str, kernels: &[KernelFile]) -> anyhow::Result<Method> {
    let (id, args) = match spec.split_once('@') {
        Some((id, args)) => (id, Some(args)),
        None => (spec, None),
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
