//! GLSL kernels: a `.glsl` file defines `float method(Scene scene)` under the same `//!`
//! header as a WGSL kernel. It is composed with kernels/prelude.glsl (the scene, constants and
//! helper prototypes under the WGSL prelude's names) and an empty entry point, parsed by naga's
//! GLSL front end, and written back as WGSL by naga's WGSL back end. The kernel's own
//! declarations (functions, constants, structs) become the WGSL kernel text, which then goes
//! the WGSL path: the harness's WGSL prelude, validation, GPU, op counts. Front-end errors name
//! the GLSL file's own line and column. Specialization constants become the overrides the
//! header's `params` set.

use crate::kernel::HeaderError;

pub const GLSL_PRELUDE: &str = include_str!("../kernels/prelude.glsl");

/// Names the GLSL prelude declares: dropped from the translation, the WGSL prelude has them.
const PRELUDE_NAMES: &[&str] = &[
    "PI",
    "Scene",
    "FLAG_LTC",
    "FLAG_RADIUS",
    "FLAG_RECT",
    "Minv",
    "D",
    "buildOrthonormalBasis",
    "inverse3",
    "inverse3_",
    "I_line",
    "main",
    "main_1",
];

/// The WGSL kernel text of a GLSL kernel: its `//!` header lines, then its translated
/// declarations.
pub fn translate(path: &str, text: &str) -> Result<String, HeaderError> {
    let err = |line: usize, message: String| HeaderError {
        path: path.to_string(),
        line,
        message,
    };
    // `#version` must come first: the kernel's text follows the prelude, so it may not have one.
    if let Some(i) = text.lines().position(|l| l.trim_start().starts_with("#version")) {
        return Err(err(
            i + 1,
            "a GLSL kernel has no `#version`: the prelude sets 450".into(),
        ));
    }
    let source = format!("{GLSL_PRELUDE}\n#line 1\n{text}\nvoid main() {{}}\n");
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Compute);
    let module = naga::front::glsl::Frontend::default()
        .parse(&options, &source)
        .map_err(|errors| {
            let first = errors.errors.first();
            let (line, col) = first
                .map(|e| {
                    let loc = e.meta.location(&source);
                    (loc.line_number as usize, loc.line_position)
                })
                .unwrap_or((1, 1));
            let prelude_lines = GLSL_PRELUDE.lines().count() + 2;
            let message = first.map_or("GLSL parse error".to_string(), |e| e.kind.to_string());
            if line > prelude_lines {
                err(line - prelude_lines, format!("{col}: {message} (naga GLSL front end)"))
            } else {
                err(
                    1,
                    format!("{message} (in kernels/prelude.glsl line {line}, naga GLSL front end)"),
                )
            }
        })?;
    // A body for a prelude prototype would be dropped for the WGSL prelude's: refuse it.
    for (_, f) in module.functions.iter() {
        let name = f.name.as_deref().unwrap_or("");
        if name != "main" && PRELUDE_NAMES.contains(&name) && !f.body.is_empty() {
            let line = text
                .lines()
                .position(|l| l.contains(&format!("{name}(")) && !l.trim_start().starts_with("//"))
                .map_or(1, |i| i + 1);
            return Err(err(
                line,
                format!("`{name}` is the prelude's (kernels/prelude.glsl): a GLSL kernel may call it, not define it"),
            ));
        }
    }
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| {
            err(
                1,
                format!("the translated module does not validate: {}", e.into_inner()),
            )
        })?;
    let wgsl = naga::back::wgsl::write_string(&module, &info, naga::back::wgsl::WriterFlags::empty())
        .map_err(|e| err(1, format!("cannot write the kernel as WGSL: {e}")))?;
    let header: String = text
        .lines()
        .filter(|l| l.trim_start().starts_with("//!"))
        .map(|l| format!("{}\n", l.trim_start()))
        .collect();
    Ok(format!(
        "{header}// Translated from {path} by naga's GLSL front end and WGSL back end.\n\n{}",
        prelude_names(&own_items(&wgsl))
    ))
}

/// The top-level items of naga's WGSL output that the kernel declared (not the prelude's):
/// an item starts at column 0 and a block item ends at a `}` line at column 0.
fn own_items(wgsl: &str) -> String {
    let mut out = String::new();
    let mut lines = wgsl.lines().peekable();
    while let Some(line) = lines.next() {
        if line.is_empty() {
            continue;
        }
        // A specialization constant (`layout(constant_id = N) const …`) is an `@id(N) override`:
        // the header's params name it, so the id goes.
        let line = match line.strip_prefix("@id(").and_then(|r| r.split_once(") ")) {
            Some((_, rest)) if rest.starts_with("override ") => rest,
            _ => line,
        };
        let mut item = format!("{line}\n");
        let block = line.trim_end().ends_with('{');
        if block {
            for l in lines.by_ref() {
                item.push_str(l);
                item.push('\n');
                if l == "}" {
                    break;
                }
            }
        }
        let name = item_name(line);
        if !name.is_some_and(|n| PRELUDE_NAMES.contains(&n)) && !line.starts_with('@') {
            out.push_str(&item);
            out.push('\n');
        }
    }
    out
}

/// naga's namer appends `_` to names that end in a digit; the WGSL prelude's `Scene.p1`,
/// `Scene.p2` and `inverse3` keep theirs.
fn prelude_names(wgsl: &str) -> String {
    let mut out = String::with_capacity(wgsl.len());
    let mut rest = wgsl;
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    while let Some(i) = rest.find(['.', 'i']) {
        let (head, tail) = rest.split_at(i);
        out.push_str(head);
        let boundary = !out.ends_with(ident);
        let fixed = [(".p1_", ".p1"), (".p2_", ".p2"), ("inverse3_", "inverse3")]
            .iter()
            .find(|(from, _)| tail.starts_with(from) && !tail[from.len()..].starts_with(ident))
            .filter(|(from, _)| from.starts_with('.') || boundary);
        match fixed {
            Some((from, to)) => {
                out.push_str(to);
                rest = &tail[from.len()..];
            }
            None => {
                out.push_str(&tail[..1]);
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// `fn D(` → D, `const PI: f32` → PI, `struct Scene {` → Scene, `var<private> Minv:` → Minv.
fn item_name(line: &str) -> Option<&str> {
    let rest = ["fn ", "const ", "struct ", "var<private> ", "alias ", "override "]
        .iter()
        .find_map(|k| line.strip_prefix(k))?;
    let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_'))?;
    Some(&rest[..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prelude_names_are_restored_and_errors_name_the_glsl_line() {
        assert_eq!(
            prelude_names("a.p1_ + b.p2_x + inverse3_(m) + myinverse3_(m)"),
            "a.p1 + b.p2_x + inverse3(m) + myinverse3_(m)"
        );
        let e = translate(
            "k.glsl",
            "//! id: line.g\n//! target: line\nfloat method(Scene scene) {\n    return lenght(scene.p1);\n}\n",
        )
        .unwrap_err();
        assert_eq!((e.path.as_str(), e.line), ("k.glsl", 4), "{e}");
        let e = translate("k.glsl", "#version 450\n").unwrap_err();
        assert_eq!(e.line, 1);
        let e = translate("k.glsl", "//! id: line.g\nfloat D(vec3 w) {\n    return 1.0;\n}\n").unwrap_err();
        assert_eq!(e.line, 2, "{e}");
        assert!(e.message.contains("`D` is the prelude's"), "{e}");
    }
}
