//! Kernel composition: prelude + method kernel + harness entry point, parsed and
//! validated by naga before wgpu ever sees it, so errors name the user's file and line.
//!
//! A composite kernel (`//! uses: line`) is composed with its inner line method: the
//! inner's `method` and `override`s are renamed (`ll_line_method`, `ll_inner_NAME`) and
//! glue defines the `I_line(p1, p2)` the composite calls.

use super::diagnostic::{KernelError, SourceMap, ENTRY_PATH};
use super::rename::{find_fn, rename_identifiers};
use super::{builtin_kernels, KernelFile, DEFAULT_INNER, PRELUDE, PRELUDE_PATH};
use naga::common::wgsl::TypeContext;
use naga::valid::{Capabilities, ValidationFlags, Validator};
use naga::{Scalar, ScalarKind, Span, TypeInner};
use std::ops::Range;

/// The compute entry point appended to every kernel. Bindings and names are fixed: the
/// runner's bind group layout matches them (runner.rs), and `ll_` names are reserved.
/// `{scene}` binds the configuration: a `let`, or for a composite the private `ll_scene`
/// the glue's `I_line` reads.
const ENTRY_POINT: &str = "\
// linelight entry point: evaluates `method` on every configuration of one chunk.
@group(0) @binding(0) var<storage, read> ll_scenes: array<Scene>;
@group(0) @binding(1) var<storage, read_write> ll_results: array<f32>;
@group(0) @binding(2) var<uniform> ll_count: u32;
// Binding 3, `ll_texels` (light textures' texels), and binding 4, `ll_ltc` (our LTC tables,
// read by kernels/ltc/), are declared in the prelude beside what reads them, so a kernel parses
// before this entry point is appended.

@compute @workgroup_size(64)
fn ll_main(@builtin(global_invocation_id) ll_id: vec3<u32>) {
    let ll_i = ll_id.x;
    if (ll_i >= ll_count) {
        return;
    }
    {scene} = ll_scenes[ll_i];
    Minv = ll_scene.minv;
    ll_results[ll_i] = method(ll_scene);
}
";

/// The entry point for a kernel, composite (`//! uses: line`) or not.
pub fn entry_point(uses_line: bool) -> String {
    ENTRY_POINT.replace("{scene}", if uses_line { "ll_scene" } else { "let ll_scene" })
}

/// Between a composite and its inner line method (the file errors in it are shown under).
pub const GLUE_PATH: &str = "<linelight I_line glue>";
const LINE_GLUE: &str = "\
// linelight glue: the line integral a `//! uses: line` kernel calls, evaluated by the
// inner line method on the current configuration with the segment replaced.
var<private> ll_scene: Scene;

fn I_line(p1: vec3<f32>, p2: vec3<f32>) -> f32 {
    var s = ll_scene;
    s.p1 = p1;
    s.p2 = p2;
    return ll_line_method(s);
}
";

/// What a composite is checked against before its inner method is known.
const STAND_IN: &str = "\
// linelight: a stand-in for the `I_line` of the line method chosen at run time.
fn I_line(p1: vec3<f32>, p2: vec3<f32>) -> f32 {
    return 0.0;
}
";

/// What the inner line method's names become in a composite; its overrides are set
/// under their new names (runner.rs).
pub(crate) const INNER_METHOD: &str = "ll_line_method";
pub(crate) fn inner_name(name: &str) -> String {
    format!("ll_inner_{name}")
}

/// The entry point's name and workgroup size, as the runner dispatches it.
pub const ENTRY_NAME: &str = "ll_main";
pub const WORKGROUP_SIZE: u32 = 64;

/// Invocations whose private memory a CPU driver holds at once: a workgroup per core (the
/// memory check of a kernel's private arrays, `methods::validate_kernel`, multiplies by it).
pub fn invocations_in_flight() -> u64 {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get() as u64);
    u64::from(WORKGROUP_SIZE) * cores
}

/// A kernel ready for a pipeline: the composed WGSL and naga's validated module.
#[derive(Debug)]
pub struct Composed {
    pub source: String,
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
    /// The line method a composite was composed with (given or [`DEFAULT_INNER`]).
    pub inner: Option<KernelFile>,
    map: SourceMap,
}

impl Composed {
    /// The same composition with its module replaced (by one naga derived from it: overrides
    /// processed), the source and its map kept.
    pub fn with_module(self, module: naga::Module, info: naga::valid::ModuleInfo) -> Composed {
        Composed { module, info, ..self }
    }

    /// The file, line and line text of byte `offset` of [`Composed::source`].
    pub fn locate(&self, offset: usize) -> (String, usize, String) {
        self.map.locate(offset)
    }
}

/// Composes and validates `kernel` with naga's default capabilities; a composite with
/// the default line method, [`DEFAULT_INNER`].
pub fn compose(kernel: &KernelFile) -> Result<Composed, KernelError> {
    compose_with(kernel, None, Capabilities::default())
}

/// Composes and validates `kernel` (a composite with `inner`, or the default line method
/// when `None`), allowing what `capabilities` allows (the device's).
pub fn compose_with(
    kernel: &KernelFile,
    inner: Option<&KernelFile>,
    capabilities: Capabilities,
) -> Result<Composed, KernelError> {
    compose_parts(PRELUDE, kernel, inner, capabilities)
}

pub(crate) fn compose_parts(
    prelude: &str,
    kernel: &KernelFile,
    inner: Option<&KernelFile>,
    capabilities: Capabilities,
) -> Result<Composed, KernelError> {
    let inner = match (kernel.uses_line, inner) {
        (false, None) => None,
        (false, Some(inner)) => {
            return Err(KernelError::plain(
                &kernel.path,
                format!(
                    "{} has no `//! uses: line`, so it takes no line method ({} given)",
                    kernel.id, inner.id
                ),
            ))
        }
        (true, Some(inner)) => Some(inner.clone()),
        (true, None) => Some(default_inner()),
    };
    // A derived kernel is several files (its base's, then its own): each part keeps every
    // line of its file, so errors name the file and line they are in.
    let parts = split_parts(kernel);
    let body: String = parts.iter().map(|(_, _, b)| b.as_str()).collect();

    // The kernel on its own first (a composite with a stand-in `I_line`), so that its
    // contract is checked before any name of the inner method can clash with its own.
    //
    // WGSL wants directives (`enable f16;`) before any declaration, so the kernel's go
    // above the prelude. Both parts keep the kernel's line numbers.
    let alone = |parts: &[(String, String, String)]| {
        let mut c = Composition::new(&kernel.path, capabilities);
        if let Some(origin) = &kernel.origin {
            c.map.translated_from(&kernel.path, origin);
        }
        c.push_directives(parts);
        c.push(PRELUDE_PATH, prelude);
        if kernel.uses_line {
            c.push(GLUE_PATH, STAND_IN);
        }
        let kernel_start = c.source.len();
        c.push_bodies(parts);
        (c, kernel_start)
    };
    let (mut c, kernel_start) = alone(&parts);
    if let Some(name) = find_fn(&body, "I_line").filter(|_| kernel.uses_line) {
        let span = Span::from(kernel_start + name.start..kernel_start + name.end);
        return Err(c.map.diagnose(
            "a kernel with `//! uses: line` must not define `I_line`: the harness defines it, \
             calling the line method chosen at run time",
            vec![(span, "defined here".to_string())],
            Vec::new(),
        ));
    }
    // Parse without the entry point first: an unclosed brace or comment in the kernel is
    // then reported at the kernel's end, not inside the entry point it swallowed, and a
    // missing `method` gets its own message instead of "unknown identifier" in our code.
    let module = c.parse().map_err(|e| {
        if !kernel.uses_line && e.message.contains("`I_line`") {
            e.with_note("`I_line` is defined for kernels whose header has `//! uses: line`")
        } else {
            e
        }
    })?;
    check_contract(&c.map, &c.source, kernel_start..c.source.len(), &body, kernel, &module)?;
    // Texture and sampler globals without `@group`/`@binding` get theirs in group 1, and
    // implicit-LOD sampling becomes level 0; the kernel is then composed again.
    let parts = match bind_resources(&c, kernel_start, &parts, &module)? {
        Some(edited) => {
            let (again, _) = alone(&edited);
            c = again;
            c.parse()?;
            edited
        }
        None => parts,
    };

    if let Some(inner) = &inner {
        c = with_inner(prelude, inner, &kernel.path, &parts, capabilities)?;
        if let Some(origin) = &kernel.origin {
            c.map.translated_from(&kernel.path, origin);
        }
    }
    c.push(ENTRY_PATH, &entry_point(kernel.uses_line));
    let module = c.parse()?;
    let info = Validator::new(ValidationFlags::all(), capabilities)
        .validate(&module)
        .map_err(|e| c.map.validation_error(&e))?;
    Ok(Composed {
        source: c.source,
        module,
        info,
        inner,
        map: c.map,
    })
}

/// A composite (its `parts`, already checked) with its inner line method and the glue
/// between them, without the entry point.
fn with_inner(
    prelude: &str,
    inner: &KernelFile,
    path: &str,
    parts: &[(String, String, String)],
    capabilities: Capabilities,
) -> Result<Composition, KernelError> {
    if inner.uses_line {
        return Err(KernelError::plain(
            &inner.path,
            format!("{} uses a line method itself, so it cannot be one", inner.id),
        ));
    }
    // The inner alone: its errors read as when it runs alone, and its module lists the
    // overrides to rename.
    let alone = compose_parts(prelude, inner, None, capabilities)?;
    let mut renames = vec![("method", INNER_METHOD.to_string()), ("I_line", inner_name("I_line"))];
    renames.extend(alone.module.overrides.iter().filter_map(|(_, o)| {
        let name = o.name.as_deref()?;
        Some((name, inner_name(name)))
    }));
    let inner_parts = split_parts(inner);

    let mut c = Composition::new(path, capabilities);
    if let Some(origin) = &inner.origin {
        c.map.translated_from(&inner.path, origin);
    }
    c.push_directives(&inner_parts);
    c.push_directives(parts);
    c.push(PRELUDE_PATH, prelude);
    for (inner_path, _, inner_body) in &inner_parts {
        let (renamed, edits) = rename_identifiers(inner_body, &renames);
        c.map
            .push_renamed(&mut c.source, inner_path, inner_body, &renamed, edits);
    }
    c.push(GLUE_PATH, LINE_GLUE);
    c.push_bodies(parts);
    Ok(c)
}

/// The kernel's source parts (one file, or a derived kernel's files) as (path, directives,
/// body), each body ending in a newline so that the bodies join as they are composed.
fn split_parts(kernel: &KernelFile) -> Vec<(String, String, String)> {
    kernel
        .parts()
        .into_iter()
        .map(|(path, text)| {
            let (directives, mut body) = split_directives(&text);
            if !body.ends_with('\n') {
                body.push('\n');
            }
            (path, directives, body)
        })
        .collect()
}

fn default_inner() -> KernelFile {
    builtin_kernels()
        .into_iter()
        .find(|k| k.id == DEFAULT_INNER)
        .expect("the default line method is built in")
}

/// The composed source so far and which file each part came from.
struct Composition {
    map: SourceMap,
    source: String,
    capabilities: Capabilities,
}

impl Composition {
    fn new(kernel_path: &str, capabilities: Capabilities) -> Composition {
        Composition {
            map: SourceMap::new(kernel_path),
            source: String::new(),
            capabilities,
        }
    }

    /// Appends `text` (owned by `path`); nothing when it is empty.
    fn push(&mut self, path: &str, text: &str) {
        if !text.is_empty() {
            self.map.push(&mut self.source, path, text);
        }
    }

    fn push_directives(&mut self, parts: &[(String, String, String)]) {
        for (path, directives, _) in parts {
            self.push(path, directives);
        }
    }

    fn push_bodies(&mut self, parts: &[(String, String, String)]) {
        for (path, _, body) in parts {
            self.push(path, body);
        }
    }

    fn parse(&self) -> Result<naga::Module, KernelError> {
        let mut options = naga::front::wgsl::Options::new();
        options.capabilities = self.capabilities;
        naga::front::wgsl::Frontend::new_with_options(options)
            .parse(&self.source)
            .map_err(|e| self.map.parse_error(&e))
    }
}

/// What kernels/README.md promises the harness: `fn method(scene: Scene) -> f32`, an
/// `override` for each header param, no `ll_` names. Only the kernel's own declarations
/// (in `kernel_range`) are checked: the inner line method of a composite was checked alone.
fn check_contract(
    map: &SourceMap,
    source: &str,
    kernel_range: Range<usize>,
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
    let own = |span: Span| span.to_range().is_some_and(|r| kernel_range.contains(&r.start));
    for (name, span) in named.filter(|(_, span)| own(*span)) {
        if let Some(name) = name.as_deref().filter(|n| n.starts_with("ll_")) {
            return at(
                span,
                format!("`{name}`: names beginning with `ll_` are reserved for the harness"),
                "reserved name",
            );
        }
    }

    check_bindings(map, source, &own, kernel, module)?;

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
        let start = kernel_range.start + body.split_inclusive('\n').take(i).map(str::len).sum::<usize>();
        Span::from(start..start + body.lines().nth(i).unwrap_or("").len())
    });
    for param in &kernel.params {
        let name = &param.name;
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
        let float = found.is_some_and(|(_, o)| {
            matches!(
                types[o.ty].inner,
                TypeInner::Scalar(Scalar {
                    kind: ScalarKind::Float,
                    ..
                })
            )
        });
        if numeric && param.float && !float {
            let (h, _) = found.expect("numeric implies found");
            return at(
                module.overrides.get_span(h),
                format!(
                    "param `{name}` is a float in the header ({}), so its override must be `f32`",
                    param.default
                ),
                "declared here",
            );
        }
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
    for (h, o) in module
        .overrides
        .iter()
        .filter(|(h, _)| own(module.overrides.get_span(*h)))
    {
        let name = o.name.as_deref().unwrap_or("?");
        if o.init.is_none() && !kernel.params.iter().any(|p| p.name == name) {
            return at(
                module.overrides.get_span(h),
                format!("`override {name}` has no default and is not among the header's params"),
                "no value to compile with",
            );
        }
    }
    Ok(())
}

/// A kernel source part: (path, directives, body).
type Part = (String, String, String);

/// The group a kernel's textures and samplers are bound in when they name none (group 0 is the
/// harness's: the entry point's and the prelude's buffers).
pub const KERNEL_GROUP: u32 = 1;

/// The kernel's parts with a `@group(1) @binding(N)` before each texture or sampler global that
/// has none (N the first binding of group 1 no other global of the kernel takes) and implicit-LOD
/// `textureSample` rewritten to `textureSampleLevel(…, 0.0)` (rename::sample_level_zero); None
/// when nothing changes. A kernel binding in group 0, or two globals on one binding, is refused.
fn bind_resources(
    c: &Composition,
    kernel_start: usize,
    parts: &[(String, String, String)],
    module: &naga::Module,
) -> Result<Option<Vec<Part>>, KernelError> {
    let mut taken: Vec<(naga::ResourceBinding, Span, String)> = Vec::new();
    let mut absent: Vec<usize> = Vec::new();
    let mut arrayed: Vec<String> = Vec::new();
    for (h, g) in module.global_variables.iter() {
        let span = module.global_variables.get_span(h);
        let Some(range) = span.to_range().filter(|r| r.start >= kernel_start) else {
            continue;
        };
        let name = g.name.clone().unwrap_or_default();
        if let TypeInner::Image { arrayed: true, .. } = module.types[g.ty].inner {
            arrayed.push(name.clone());
        }
        let at = |message: String, label: &str| {
            c.map.diagnose(
                &message,
                vec![(first_line(&c.source, span), label.to_string())],
                Vec::new(),
            )
        };
        match &g.binding {
            Some(b) if b.group == 0 => {
                return Err(at(
                    format!(
                        "`{name}` is bound in group 0, the harness's (its scenes, results and tables): \
                         bind a kernel's textures and samplers in group {KERNEL_GROUP} or above, or drop \
                         `@group`/`@binding` to have one assigned"
                    ),
                    "group 0",
                ))
            }
            Some(b) => {
                if let Some((_, _, other)) = taken.iter().find(|(t, _, _)| t == b) {
                    return Err(at(
                        format!(
                            "`{name}` and `{other}` are both bound at @group({}) @binding({})",
                            b.group, b.binding
                        ),
                        "second binding",
                    ));
                }
                taken.push((*b, span, name));
            }
            None if matches!(
                module.types[g.ty].inner,
                TypeInner::Image { .. } | TypeInner::Sampler { .. }
            ) =>
            {
                absent.push(range.start - kernel_start)
            }
            None => {}
        }
    }
    let arrayed: Vec<&str> = arrayed.iter().map(String::as_str).collect();
    let mut next = 0;
    let mut inserts: Vec<(usize, String)> = Vec::new();
    for offset in absent {
        while taken
            .iter()
            .any(|(b, _, _)| b.group == KERNEL_GROUP && b.binding == next)
        {
            next += 1;
        }
        inserts.push((offset, format!("@group({KERNEL_GROUP}) @binding({next}) ")));
        next += 1;
    }
    let mut edited = Vec::new();
    let mut part_start = 0;
    let mut changed = false;
    for (path, directives, body) in parts {
        let mut text = String::with_capacity(body.len());
        let mut copied = 0;
        for (offset, attrs) in inserts
            .iter()
            .filter(|(o, _)| (part_start..part_start + body.len()).contains(o))
        {
            let at = offset - part_start;
            text.push_str(&body[copied..at]);
            text.push_str(attrs);
            copied = at;
        }
        text.push_str(&body[copied..]);
        let text = super::rename::sample_level_zero(&text, &arrayed);
        changed |= text != *body;
        part_start += body.len();
        edited.push((path.clone(), directives.clone(), text));
    }
    Ok(changed.then_some(edited))
}

/// The kernel's texture and sampler globals against its `//! texture:` and `//! sampler:`
/// headers: each global bound by a header, each header naming a global of its kind.
fn check_bindings(
    map: &SourceMap,
    source: &str,
    own: &dyn Fn(Span) -> bool,
    kernel: &KernelFile,
    module: &naga::Module,
) -> Result<(), KernelError> {
    let kind = |ty: naga::Handle<naga::Type>| match module.types[ty].inner {
        TypeInner::Image { .. } => Some("texture"),
        TypeInner::Sampler { .. } => Some("sampler"),
        _ => None,
    };
    let globals: Vec<(&str, &str, Span)> = module
        .global_variables
        .iter()
        .filter(|(h, _)| own(module.global_variables.get_span(*h)))
        .filter_map(|(h, g)| Some((g.name.as_deref()?, kind(g.ty)?, module.global_variables.get_span(h))))
        .collect();
    for &(name, what, span) in &globals {
        let bound = match what {
            "texture" => kernel.textures.iter().any(|t| t.name == name),
            _ => kernel.samplers.iter().any(|s| s.name == name),
        };
        if !bound {
            let form = if what == "texture" {
                format!("`//! texture: {name} = FILE`")
            } else {
                format!("`//! sampler: {name} = linear, clamp`")
            };
            return Err(map.diagnose(
                &format!("{what} `{name}` is bound to nothing: add a header line {form}"),
                vec![(first_line(source, span), "declared here".to_string())],
                Vec::new(),
            ));
        }
    }
    let headers = kernel
        .textures
        .iter()
        .map(|t| (t.name.as_str(), "texture", t.line))
        .chain(kernel.samplers.iter().map(|s| (s.name.as_str(), "sampler", s.line)));
    for (name, what, line) in headers {
        if !globals.iter().any(|&(n, w, _)| n == name && w == what) {
            let message = format!(
                "`//! {what}: {name} = …` names no {what} global of the kernel (declare `var {name}: {}`)",
                if what == "texture" {
                    "texture_2d<f32>;"
                } else {
                    "sampler;"
                }
            );
            return Err(KernelError {
                path: kernel.path.clone(),
                location: Some((line as u32, 1)),
                report: format!("{}:{line}: {message}", kernel.path),
                message,
            });
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
