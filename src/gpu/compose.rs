//! Kernel composition: prelude + method kernel + harness entry point, parsed and
//! validated by naga before wgpu ever sees it, so errors name the user's file and line.

use super::diagnostic::{KernelError, SourceMap, ENTRY_PATH};
use crate::kernel::{KernelFile, PRELUDE, PRELUDE_PATH};
use naga::common::wgsl::TypeContext;
use naga::valid::{Capabilities, ValidationFlags, Validator};
use naga::{Scalar, ScalarKind, Span, TypeInner};

/// The compute entry point appended to every kernel. Bindings and names are fixed: the
/// runner's bind group layout matches them (runner.rs), and `ll_` names are reserved.
pub const ENTRY_POINT: &str = "\
// linelight entry point: evaluates `method` on every configuration of one chunk.
@group(0) @binding(0) var<storage, read> ll_scenes: array<Scene>;
@group(0) @binding(1) var<storage, read_write> ll_results: array<f32>;
@group(0) @binding(2) var<uniform> ll_count: u32;

@compute @workgroup_size(64)
fn ll_main(@builtin(global_invocation_id) ll_id: vec3<u32>) {
    let ll_i = ll_id.x;
    if (ll_i >= ll_count) {
        return;
    }
    let ll_scene = ll_scenes[ll_i];
    Minv = ll_scene.minv;
    ll_results[ll_i] = method(ll_scene);
}
";

/// The entry point's name and workgroup size, as the runner dispatches it.
pub const ENTRY_NAME: &str = "ll_main";
pub const WORKGROUP_SIZE: u32 = 64;

/// A kernel ready for a pipeline: the composed WGSL and naga's validated module.
#[derive(Debug)]
pub struct Composed {
    pub source: String,
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
}

/// Composes and validates `kernel` with naga's default capabilities.
pub fn compose(kernel: &KernelFile) -> Result<Composed, KernelError> {
    compose_with(kernel, Capabilities::default())
}

/// Composes and validates `kernel`, allowing what `capabilities` allows (the device's).
pub fn compose_with(kernel: &KernelFile, capabilities: Capabilities) -> Result<Composed, KernelError> {
    compose_parts(PRELUDE, kernel, capabilities)
}

pub(crate) fn compose_parts(
    prelude: &str,
    kernel: &KernelFile,
    capabilities: Capabilities,
) -> Result<Composed, KernelError> {
    let mut map = SourceMap::new(&kernel.path);
    let mut source = String::new();
    // WGSL wants directives (`enable f16;`) before any declaration, so the kernel's go
    // above the prelude. Both parts keep the kernel's line numbers.
    let (directives, body) = split_directives(&kernel.text);
    if !directives.is_empty() {
        map.push(&mut source, &kernel.path, &directives);
    }
    map.push(&mut source, PRELUDE_PATH, prelude);
    let kernel_start = source.len();
    map.push(&mut source, &kernel.path, &body);

    // Parse without the entry point first: an unclosed brace or comment in the kernel is
    // then reported at the kernel's end, not inside the entry point it swallowed, and a
    // missing `method` gets its own message instead of "unknown identifier" in our code.
    let front = || {
        let mut options = naga::front::wgsl::Options::new();
        options.capabilities = capabilities;
        naga::front::wgsl::Frontend::new_with_options(options)
    };
    let module = front().parse(&source).map_err(|e| map.parse_error(&e))?;
    check_contract(&map, &source, kernel_start, &body, kernel, &module)?;

    map.push(&mut source, ENTRY_PATH, ENTRY_POINT);
    let module = front().parse(&source).map_err(|e| map.parse_error(&e))?;
    let info = Validator::new(ValidationFlags::all(), capabilities)
        .validate(&module)
        .map_err(|e| map.validation_error(&e))?;
    Ok(Composed { source, module, info })
}

/// What kernels/README.md promises the harness: `fn method(scene: Scene) -> f32`, an
/// `override` for each header param, no `ll_` names.
fn check_contract(
    map: &SourceMap,
    source: &str,
    kernel_start: usize,
    body: &str,
    kernel: &KernelFile,
    module: &naga::Module,
) -> Result<(), KernelError> {
    let at = |span: Span, message: String, label: &str| {
        Err(map.diagnose(
            &message,
            vec![(first_line(source, span), label.to_string())],
            Vec::new(),
        ))
    };

    let named = module
        .functions
        .iter()
        .map(|(h, f)| (&f.name, module.functions.get_span(h)))
        .chain(
            module
                .global_variables
                .iter()
                .map(|(h, g)| (&g.name, module.global_variables.get_span(h))),
        )
        .chain(
            module
                .constants
                .iter()
                .map(|(h, c)| (&c.name, module.constants.get_span(h))),
        )
        .chain(
            module
                .overrides
                .iter()
                .map(|(h, o)| (&o.name, module.overrides.get_span(h))),
        )
        .chain(module.types.iter().map(|(h, t)| (&t.name, module.types.get_span(h))));
    for (name, span) in named {
        if let Some(name) = name.as_deref().filter(|n| n.starts_with("ll_")) {
            return at(
                span,
                format!("`{name}`: names beginning with `ll_` are reserved for the harness"),
                "reserved name",
            );
        }
    }

    const SIGNATURE: &str = "fn method(scene: Scene) -> f32";
    let Some((handle, method)) = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some("method"))
    else {
        return Err(KernelError::plain(
            &kernel.path,
            format!("the kernel does not define `{SIGNATURE}`, the function the harness evaluates (kernels/README.md)"),
        ));
    };
    let types = &module.types;
    let takes_scene = matches!(method.arguments.as_slice(), [arg] if types[arg.ty].name.as_deref() == Some("Scene"));
    let returns_f32 = method
        .result
        .as_ref()
        .is_some_and(|r| types[r.ty].inner == TypeInner::Scalar(Scalar::F32));
    if !(takes_scene && returns_f32) {
        let args: Vec<_> = method.arguments.iter().map(|a| types.type_to_string(a.ty)).collect();
        let result = method
            .result
            .as_ref()
            .map_or("()".to_string(), |r| types.type_to_string(r.ty));
        let found = format!("fn method({}) -> {result}", args.join(", "));
        return at(
            module.functions.get_span(handle),
            format!("`method` must be `{SIGNATURE}`, found `{found}`"),
            "the harness calls this with one `Scene` and stores an `f32`",
        );
    }

    let header = body.lines().position(|l| l.trim_start().starts_with("//! params"));
    let header_span = header.map(|i| {
        let start = kernel_start + body.split_inclusive('\n').take(i).map(str::len).sum::<usize>();
        Span::from(start..start + body.lines().nth(i).unwrap_or("").len())
    });
    for (name, _) in &kernel.params {
        let found = module
            .overrides
            .iter()
            .find(|(_, o)| o.name.as_deref() == Some(name.as_str()));
        let numeric = found.is_some_and(|(_, o)| {
            matches!(
                types[o.ty].inner,
                TypeInner::Scalar(Scalar {
                    kind: ScalarKind::Uint | ScalarKind::Sint | ScalarKind::Float,
                    ..
                })
            )
        });
        if !numeric {
            let message = match found {
                None => {
                    format!("the header sets param `{name}`, but the kernel declares no `override {name}: u32 = ...;`")
                }
                Some(_) => format!("param `{name}` must be a numeric scalar `override`"),
            };
            return match (found, header_span) {
                (Some((h, _)), _) => at(module.overrides.get_span(h), message, "declared here"),
                (None, Some(span)) => at(span, message, "param set here"),
                (None, None) => Err(KernelError::plain(&kernel.path, message)),
            };
        }
    }
    for (h, o) in module.overrides.iter() {
        let name = o.name.as_deref().unwrap_or("?");
        if o.init.is_none() && !kernel.params.iter().any(|(p, _)| p == name) {
            return at(
                module.overrides.get_span(h),
                format!("`override {name}` has no default and is not among the header's params"),
                "no value to compile with",
            );
        }
    }
    Ok(())
}

/// `span` cut at the end of its first line: a function's span covers its whole body.
fn first_line(source: &str, span: Span) -> Span {
    let Some(range) = span.to_range() else {
        return span;
    };
    let end = source[range.clone()].find('\n').map_or(range.end, |n| range.start + n);
    Span::from(range.start..end)
}

/// Splits the kernel's leading directives from the rest. Each part keeps every line of
/// the kernel, blank where the line went to the other part, so line numbers stay true.
fn split_directives(text: &str) -> (String, String) {
    let (mut directives, mut body) = (String::new(), String::new());
    let mut leading = true;
    for line in text.split_inclusive('\n') {
        let code = line.split("//").next().unwrap_or("").trim();
        leading &= code.is_empty() || is_directive(code);
        let newline = if line.ends_with('\n') { "\n" } else { "" };
        if leading && !code.is_empty() {
            directives.push_str(line);
            body.push_str(newline);
        } else {
            body.push_str(line);
            directives.push_str(newline);
        }
    }
    if !directives.contains(|c: char| !c.is_whitespace()) {
        directives.clear();
    }
    (directives, body)
}

/// `enable f16;`, `requires ...;`, `diagnostic(...);` (without a trailing comment).
fn is_directive(code: &str) -> bool {
    let rest = ["enable", "requires", "diagnostic"]
        .iter()
        .find_map(|k| code.strip_prefix(k));
    rest.is_some_and(|r| r.starts_with([' ', '\t', '(']) && r.ends_with(';'))
}
