//! GLSL kernels: a `.glsl` file defines `float method(Scene scene)` under the same `//!`
//! header as a WGSL kernel. It is composed with kernels/prelude.glsl (the scene, constants and
//! helper prototypes under the WGSL prelude's names) and an empty entry point, parsed by naga's
//! GLSL front end, and written back as WGSL by naga's WGSL back end. The kernel's own
//! declarations (functions, constants, structs) become the WGSL kernel text, which then goes
//! the WGSL path: the harness's WGSL prelude, validation, GPU, op counts. Front-end errors name
//! the GLSL file's own line and column; each line of the translation keeps the GLSL line it
//! came from (`kernel::Origin`), so later errors and attribution name GLSL lines too.
//! Specialization constants become the overrides the header's `params` set.

use super::include::Expanded;
use super::HeaderError;

pub const GLSL_PRELUDE: &str = include_str!("../../kernels/prelude.glsl");

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
    "ll_texel_bilinear",
    "ll_texel_cube",
    "I_line",
    "main",
    "main_1",
];

/// The WGSL kernel text of a GLSL kernel without includes: see [`translate_expanded`].
pub fn translate(path: &str, text: &str) -> Result<(String, Vec<u32>), HeaderError> {
    let (wgsl, lines, _) = translate_expanded(path, &Expanded::plain(path, text))?;
    Ok((wgsl, lines))
}

/// The WGSL kernel text of a GLSL kernel (its includes expanded): its `//!` header lines,
/// then its translated declarations; for each line of that text, the kernel line it came
/// from ([`crate::kernel::Origin::lines`]); and the constants whose written digits are lost
/// (src/kernel/written.rs).
pub fn translate_expanded(
    path: &str,
    expanded: &Expanded,
) -> Result<(String, Vec<u32>, Vec<super::written::LostDigits>), HeaderError> {
    let err = |line: usize, message: String| HeaderError {
        path: path.to_string(),
        line,
        message,
    };
    let text = &expanded.files[0].1;
    // `#version` as engines write it: the kernel follows the prelude, which sets 450, so the
    // line is blanked (its number kept); a version naga cannot read is refused.
    let mut body = String::with_capacity(expanded.text.len());
    for (i, l) in expanded.text.lines().enumerate() {
        let directive = l.trim_start().strip_prefix('#').map(str::trim_start);
        if let Some(v) = directive.and_then(|d| d.strip_prefix("version")) {
            let number: Option<u32> = v.split_whitespace().next().and_then(|n| n.parse().ok());
            if !number.is_some_and(|n| (100..=460).contains(&n)) {
                let (file, line) = expanded.locate(i + 1).unwrap_or((path, 1));
                return Err(HeaderError {
                    path: file.to_string(),
                    line: line as usize,
                    message: format!(
                        "`{}`: a GLSL kernel's version is 100 to 460 (it is read as 450, the prelude's)",
                        crate::input::names::clip(l.trim())
                    ),
                });
            }
            body.push('\n');
            continue;
        }
        body.push_str(&const_in_as_in(l));
        body.push('\n');
    }
    let source = format!("{GLSL_PRELUDE}\n#line 1\n{body}\nvoid main() {{}}\n");
    let prelude_lines = GLSL_PRELUDE.lines().count() + 2;
    // The kernel's own 1-based line holding `span` (for an included file's, its `#include`),
    // 0 for the prelude's.
    let glsl_line = |span: naga::Span| -> u32 {
        let line = span.location(&source).line_number as usize;
        let k = line.saturating_sub(prelude_lines);
        k.checked_sub(1)
            .and_then(|i| expanded.lines.get(i))
            .map_or(0, |f| f.top)
    };
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Compute);
    let module = naga::front::glsl::Frontend::default()
        .parse(&options, &source)
        .map_err(|errors| {
            let first = errors.errors.first();
            let message = first.map_or("GLSL parse error".to_string(), |e| e.kind.to_string());
            // An error without a position (the front end's lexer gives none for a character
            // it does not know) is the kernel's: the prelude is known to parse.
            let Some((line, col)) = first.filter(|e| e.meta.is_defined()).map(|e| {
                let loc = e.meta.location(&source);
                (loc.line_number as usize, loc.line_position)
            }) else {
                return match unknown_character(text) {
                    Some((line, col, c)) => err(
                        line,
                        format!("{col}: {message}: {c:?} is not a GLSL character (naga GLSL front end)"),
                    ),
                    None => err(1, format!("{message} (naga GLSL front end, at no position it names)")),
                };
            };
            if line > prelude_lines {
                match expanded.locate(line - prelude_lines) {
                    Some((file, l)) => HeaderError {
                        path: file.to_string(),
                        line: l as usize,
                        message: format!("{col}: {message} (naga GLSL front end)"),
                    },
                    None => err(
                        1,
                        format!("{message} (naga GLSL front end, after the kernel's last line)"),
                    ),
                }
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
            return Err(err(
                declaration_line(text, name),
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
    let (mut out, mut lines) = (String::new(), Vec::new());
    for (i, l) in text.lines().enumerate() {
        if l.trim_start().starts_with("//!") {
            out.push_str(&format!("{}\n", l.trim_start()));
            lines.push(i as u32 + 1);
        }
    }
    out.push_str(&format!(
        "// Translated from {path} by naga's GLSL front end and WGSL back end.\n\n"
    ));
    lines.extend([0, 0]);
    let drop = |n: &str| PRELUDE_NAMES.contains(&n);
    let (items, item_lines) = own_items(&wgsl, &module, text, &glsl_line, &drop);
    out.push_str(&prelude_names(&items));
    lines.extend(item_lines);
    let mut written = super::written::Written::default();
    written.add(GLSL_PRELUDE, &|_| 0);
    for (i, (_, t)) in expanded.files.iter().enumerate() {
        // A line's kernel line: its own in the kernel file; an included file's, its `#include`.
        let tops: std::collections::HashMap<u32, u32> = expanded
            .lines
            .iter()
            .filter(|f| f.file == i)
            .map(|f| (f.line, f.top))
            .collect();
        written.add(t, &|l| tops.get(&(l as u32)).copied().unwrap_or(0));
    }
    let (out, lost) = written.restore(&out, &lines, path);
    Ok((out, lines, lost))
}

/// `line` with each parameter qualifier `const in` read as `in` (three.js writes
/// `const in vec3 N`; naga's GLSL front end has no `const` parameters, and a value
/// parameter is read-only either way): `const` becomes as many spaces, so columns keep.
fn const_in_as_in(line: &str) -> std::borrow::Cow<'_, str> {
    let word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out: Option<String> = None;
    let mut from = 0;
    while let Some(i) = line[from..].find("const").map(|i| i + from) {
        let before = line[..i].chars().next_back();
        let rest = &line[i + 5..];
        let gap = rest.len() - rest.trim_start().len();
        let is_in = gap > 0 && rest[gap..].starts_with("in") && !rest[gap + 2..].starts_with(word);
        if !before.is_some_and(word) && is_in {
            out.get_or_insert_with(|| line.to_string())
                .replace_range(i..i + 5, "     ");
        }
        from = i + 5;
    }
    out.map_or(std::borrow::Cow::Borrowed(line), std::borrow::Cow::Owned)
}

/// The first character outside GLSL's character set that is not in a comment: its 1-based
/// line and column, and the character.
fn unknown_character(text: &str) -> Option<(usize, usize, char)> {
    let glsl =
        |c: char| c.is_ascii_alphanumeric() || c.is_ascii_whitespace() || "_.+-/*%<>[](){}^|&~=!:;,?#\\".contains(c);
    let mut block = false;
    for (i, line) in text.lines().enumerate() {
        let mut chars = line.char_indices().peekable();
        while let Some((at, c)) = chars.next() {
            let next = chars.peek().map(|&(_, n)| n);
            if block {
                if c == '*' && next == Some('/') {
                    block = false;
                    chars.next();
                }
                continue;
            }
            match (c, next) {
                ('/', Some('/')) => break,
                ('/', Some('*')) => {
                    block = true;
                    chars.next();
                }
                _ if !glsl(c) => return Some((i + 1, line[..at].chars().count() + 1, c)),
                _ => {}
            }
        }
    }
    None
}

/// The 1-based line of `text` that declares `name` (its first non-comment mention
/// followed by `(` or a space), 1 when none does.
fn declaration_line(text: &str, name: &str) -> usize {
    text.lines()
        .position(|l| {
            !l.trim_start().starts_with("//") && (l.contains(&format!("{name}(")) || l.contains(&format!("{name} ")))
        })
        .map_or(1, |i| i + 1)
}

/// The top-level items of naga's WGSL output that the kernel declared (not the prelude's):
/// an item starts at column 0 and a block item ends at a `}` line at column 0. Each output
/// line is mapped to a GLSL line through the spans of the expressions it names: naga's
/// WGSL back end calls expression `N` of a function `_eN`, and writes the functions in
/// the module's order. A line that names none (a `var`, an argument's store, a bare
/// `return 0f;`) takes the line before it, and a function's first lines its declaration.
pub(super) fn own_items(
    wgsl: &str,
    module: &naga::Module,
    text: &str,
    glsl_line: &dyn Fn(naga::Span) -> u32,
    drop: &dyn Fn(&str) -> bool,
) -> (String, Vec<u32>) {
    let (mut out, mut map) = (String::new(), Vec::new());
    let mut functions = module.functions.iter();
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
        let function = if line.starts_with("fn ") {
            functions.next().map(|(_, f)| f)
        } else {
            None
        };
        let name = item_name(line);
        let declared = function
            .and_then(|f| f.name.as_deref())
            .or(name)
            .map_or(0, |n| declaration_line(text, n) as u32);
        let spans: Vec<u32> = function.map_or_else(Vec::new, |f| {
            f.expressions
                .iter()
                .map(|(h, _)| glsl_line(f.expressions.get_span(h)))
                .collect()
        });
        let mut item = vec![line.to_string()];
        if line.trim_end().ends_with('{') {
            for l in lines.by_ref() {
                item.push(l.to_string());
                if l == "}" {
                    break;
                }
            }
        }
        if name.is_some_and(drop) || line.starts_with('@') {
            continue;
        }
        let mut last = declared;
        for l in &item {
            let named = expression_names(l)
                .filter_map(|n| spans.get(n).copied())
                .filter(|&g| g > 0);
            let defined = l
                .trim_start()
                .strip_prefix("let _e")
                .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next()?.parse::<usize>().ok())
                .and_then(|n| spans.get(n).copied())
                .filter(|&g| g > 0);
            last = defined.or(named.min()).unwrap_or(last);
            out.push_str(l);
            out.push('\n');
            map.push(last);
        }
        out.push('\n');
        map.push(0);
    }
    (out, map)
}

/// The expression indices `N` of the `_eN` names on a line of naga's WGSL output.
fn expression_names(line: &str) -> impl Iterator<Item = usize> + '_ {
    line.match_indices("_e").filter_map(move |(i, _)| {
        let before = line[..i].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            return None;
        }
        let digits: String = line[i + 2..].chars().take_while(char::is_ascii_digit).collect();
        let after = line[i + 2 + digits.len()..].chars().next();
        if digits.is_empty() || after.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            return None;
        }
        digits.parse().ok()
    })
}

/// naga's namer appends `_` to names that end in a digit; the WGSL prelude's `Scene.p1`,
/// `Scene.p2` and `inverse3` keep theirs.
pub(super) fn prelude_names(wgsl: &str) -> String {
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
    fn const_in_parameters_read_as_in_with_their_columns() {
        assert_eq!(
            const_in_as_in("float f(const in vec3 n, in float x)"),
            "float f(      in vec3 n, in float x)"
        );
        assert_eq!(const_in_as_in("const int N = 3;"), "const int N = 3;");
        assert_eq!(const_in_as_in("const inout_t x;"), "const inout_t x;");
        assert_eq!(const_in_as_in("myconst in"), "myconst in");
        assert_eq!(
            const_in_as_in("f(const\tin float a, const in float b)"),
            "f(     \tin float a,       in float b)"
        );
    }

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
        let e = translate("k.glsl", "\n#version 500\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("100 to 460"), "{e}");
        let e = translate("k.glsl", "//! id: line.g\nfloat D(vec3 w) {\n    return 1.0;\n}\n").unwrap_err();
        assert_eq!(e.line, 2, "{e}");
        assert!(e.message.contains("`D` is the prelude's"), "{e}");
    }
}
