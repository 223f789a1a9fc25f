//! HLSL kernels: a `.hlsl` file defines `float method(Scene scene)` under the same `//!`
//! header as a WGSL kernel, on kernels/prelude.hlsl (the scene, constants, the global `Minv`,
//! row-major, and stand-ins for the WGSL prelude's helpers). glslang's HLSL front end
//! (`glslangValidator -D -V -Od -g`, Debian's `glslang-tools`) compiles prelude + kernel + a
//! small entry point to SPIR-V; naga's SPIR-V front end reads it, and naga's WGSL back end
//! writes the kernel's own functions back as WGSL, which then goes the WGSL path (like a GLSL
//! kernel, src/kernel/glsl.rs).
//!
//! - Lines: naga drops `OpLine` and its spans are byte offsets into the SPIR-V, so the
//!   `OpLine`s glslang writes with `-g` are read here first (opcode 8; `OpNoLine` 317) and
//!   removed (naga refuses an `OpLine` between types), keeping a map from each remaining
//!   instruction's offset to its HLSL line. glslang gives no line to a function's parameters
//!   and its entry; those lines take the function's declaration.
//! - Parameters: glslang passes every argument through a pointer. An `in` parameter becomes a
//!   value again (with a local copy, since HLSL may assign to it); `out`/`inout` stay pointers.
//! - Matrices: glslang stores an HLSL matrix's rows where SPIR-V (and WGSL) keep columns, so
//!   the kernel is wrapped: its `method` sees `Minv` and `scene.minv` transposed, and
//!   `mul(Minv, v)` is M⁻¹·v as written.
//! - Constants: glslang folds constant expressions; src/kernel/written.rs restores the
//!   written digits for the f64 column.

use super::include::Expanded;
use super::HeaderError;
use naga::{Expression as E, Handle, Statement as S};
use std::collections::HashMap;

pub const HLSL_PRELUDE: &str = include_str!("../../kernels/prelude.hlsl");

/// Calls `method` so that glslang keeps it (it drops functions its entry point never calls).
const ENTRY: &str = "static Scene ll_entry_scene;\n[numthreads(1, 1, 1)]\nvoid main()\n{\n    \
                     Minv = ll_entry_scene.minv;\n    ll_entry_scene.radius = method(ll_entry_scene);\n}\n";

/// Names of the HLSL prelude, dropped from the translation (the WGSL prelude has them).
const PRELUDE_NAMES: &[&str] = &[
    "PI",
    "Scene",
    "FLAG_LTC",
    "FLAG_RADIUS",
    "FLAG_RECT",
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

/// The kernel's `method` and its `Minv`, renamed: the wrapper `method` transposes (module doc).
const METHOD: &str = "hlsl_method";
const MINV: &str = "hlsl_Minv";

/// The environment variable that names the glslang binary (default `glslangValidator`).
use crate::tuning::GLSLANG as GLSLANG_ENV;

/// The WGSL kernel text of an HLSL kernel and, for each of its lines, the kernel line it came
/// from; with the constants whose written digits are lost (src/kernel/written.rs).
pub fn translate(
    path: &str,
    expanded: &Expanded,
) -> Result<(String, Vec<u32>, Vec<super::written::LostDigits>), HeaderError> {
    let err = |line: usize, message: String| HeaderError {
        path: path.to_string(),
        line,
        message,
    };
    let source = format!("{HLSL_PRELUDE}\n{}{ENTRY}", expanded.text);
    let prelude_lines = HLSL_PRELUDE.lines().count() + 1;
    // The kernel line (the line of the kernel file, or its `#include`) of a composed line.
    let kernel_line = |composed: u32| -> u32 {
        let k = (composed as usize).saturating_sub(prelude_lines);
        k.checked_sub(1)
            .and_then(|i| expanded.lines.get(i))
            .map_or(0, |f| f.top)
    };
    let words = compile(path, &source, &|composed| {
        let k = composed.saturating_sub(prelude_lines);
        match expanded.locate(k) {
            Some((file, line)) => (file.to_string(), line as usize),
            None if composed <= prelude_lines => ("kernels/prelude.hlsl".to_string(), composed),
            None => (format!("{path} (the harness's HLSL entry point)"), 1),
        }
    })?;
    let (stripped, offsets) = strip_lines(&words);
    let bytes: Vec<u8> = stripped.iter().flat_map(|w| w.to_le_bytes()).collect();
    let mut module = naga::front::spv::parse_u8_slice(&bytes, &naga::front::spv::Options::default())
        .map_err(|e| err(1, format!("naga cannot read glslang's SPIR-V: {e}")))?;
    let line_at = |span: naga::Span| -> u32 {
        let Some(r) = span.to_range() else { return 0 };
        let i = offsets.partition_point(|&(o, _)| o <= r.start);
        i.checked_sub(1).map_or(0, |i| kernel_line(offsets[i].1))
    };

    // Names without glslang's mangling (`Fpo(f1;f1;`); the entry's own are dropped.
    let outs = out_params(&source);
    for (_, f) in module.functions.iter_mut() {
        let name = f.name.as_deref().unwrap_or("");
        let plain = name.split('(').next().unwrap_or("").to_string();
        f.name = Some(match plain.as_str() {
            n if n.starts_with('@') => "ll_entry".to_string(),
            "method" => METHOD.to_string(),
            _ => plain,
        });
    }
    for (_, g) in module.global_variables.iter_mut() {
        if g.name.as_deref() == Some("Minv") {
            g.name = Some(MINV.to_string());
        }
    }
    let mut by_name: HashMap<String, usize> = HashMap::new();
    for (_, f) in module.functions.iter() {
        *by_name.entry(f.name.clone().unwrap_or_default()).or_default() += 1;
    }
    if let Some((name, _)) = by_name
        .iter()
        .find(|(n, &c)| c > 1 && !n.starts_with("ll_") && *n != "main")
    {
        return Err(err(
            declaration_line(&expanded.files[0].1, name),
            format!("`{name}` is declared more than once: overloads are not supported in a kernel"),
        ));
    }
    by_value(&mut module, &outs);

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

    let text = &expanded.files[0].1;
    let (mut out, mut lines) = (String::new(), Vec::new());
    for (i, l) in text.lines().enumerate() {
        if l.trim_start().starts_with("//!") {
            out.push_str(&format!("{}\n", l.trim_start()));
            lines.push(i as u32 + 1);
        }
    }
    out.push_str(&format!(
        "// Translated from {path} by glslang's HLSL front end, naga's SPIR-V front end and WGSL back end.\n\n"
    ));
    lines.extend([0, 0]);
    let drop = |n: &str| PRELUDE_NAMES.contains(&n) || n.starts_with("ll_");
    let (items, item_lines) = super::glsl::own_items(&wgsl, &module, text, &line_at, &drop);
    out.push_str(&super::glsl::prelude_names(&items));
    lines.extend(item_lines);
    let wrapper = format!(
        "// HLSL keeps a matrix's rows where WGSL keeps its columns: the kernel reads M⁻¹ as written.\n\
         fn method(scene: Scene) -> f32 {{\n    {MINV} = transpose(Minv);\n    var hlsl_scene = scene;\n    \
         hlsl_scene.minv = transpose(scene.minv);\n    return {METHOD}(hlsl_scene);\n}}\n"
    );
    lines.extend(std::iter::repeat_n(0, wrapper.lines().count()));
    out.push_str(&wrapper);
    let mut written = super::written::Written::default();
    written.add(HLSL_PRELUDE, &|_| 0);
    for (i, (_, t)) in expanded.files.iter().enumerate() {
        // A line's kernel line: its own in the kernel file; an included file's, its `#include`.
        let tops: HashMap<u32, u32> = expanded
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

/// The 1-based line of `text` that declares `name`, 1 when none does.
fn declaration_line(text: &str, name: &str) -> usize {
    text.lines()
        .position(|l| !l.trim_start().starts_with("//") && l.contains(&format!("{name}(")))
        .map_or(1, |i| i + 1)
}

/// Runs glslang on `source`; its errors are mapped to file:line by `locate(composed line)`.
fn compile(path: &str, source: &str, locate: &dyn Fn(usize) -> (String, usize)) -> Result<Vec<u32>, HeaderError> {
    let tool = &crate::tuning::tuning().glslang;
    let dir = crate::io::Scratch::new("linelight-hlsl").map_err(|e| HeaderError {
        path: path.to_string(),
        line: 1,
        message: format!("cannot make a scratch folder for glslang: {e}"),
    })?;
    let output = dir.path.join("kernel.spv");
    let input = dir.path.join("kernel.hlsl");
    let run = dir.write("kernel.hlsl", source.as_bytes()).and_then(|_| {
        std::process::Command::new(tool)
            .args(["--quiet", "-D", "-V", "-Od", "-g", "-e", "main", "-S", "comp", "-o"])
            .arg(&output)
            .arg(&input)
            .output()
    });
    let out = match run {
        Ok(out) => out,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(HeaderError {
                path: path.to_string(),
                line: 1,
                message: format!(
                    "an HLSL kernel needs glslang's HLSL front end, and `{tool}` is not installed \
                     (Debian/Ubuntu: apt-get install glslang-tools; scripts/ensure-glslang; or set {GLSLANG_ENV})"
                ),
            })
        }
        Err(e) => {
            return Err(HeaderError {
                path: path.to_string(),
                line: 1,
                message: format!("cannot run `{tool}`: {e}"),
            })
        }
    };
    if !out.status.success() {
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        let first = text
            .lines()
            .find(|l| l.starts_with("ERROR: "))
            .unwrap_or("glslang failed");
        let input_name = input.display().to_string();
        // `ERROR: /tmp/…/kernel.hlsl:12: 'lenght' : no matching overloaded function found`
        if let Some(rest) = first.strip_prefix("ERROR: ").and_then(|r| r.strip_prefix(&input_name)) {
            if let Some((line, message)) = rest.strip_prefix(':').and_then(|r| r.split_once(':')) {
                if let Ok(line) = line.trim().parse::<usize>() {
                    let (file, line) = locate(line);
                    return Err(HeaderError {
                        path: file,
                        line,
                        message: format!("{} (glslang HLSL front end)", message.trim()),
                    });
                }
            }
        }
        return Err(HeaderError {
            path: path.to_string(),
            line: 1,
            message: format!(
                "{} (glslang HLSL front end, at no line it names)",
                first.trim_start_matches("ERROR: ").replace(&input_name, "kernel")
            ),
        });
    }
    let bytes = crate::io::read_regular(&output, "glslang's SPIR-V", crate::limits::MAX_TEXT_INPUT).map_err(|e| {
        HeaderError {
            path: path.to_string(),
            line: 1,
            message: format!("glslang wrote no SPIR-V: {e}"),
        }
    })?;
    if bytes.len() % 4 != 0 || bytes.len() < 20 {
        return Err(HeaderError {
            path: path.to_string(),
            line: 1,
            message: "glslang's SPIR-V is truncated".into(),
        });
    }
    Ok(bytes
        .chunks(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}

/// The SPIR-V without `OpLine`/`OpNoLine`, and for each instruction left, its offset as naga's
/// spans give it and the line (of the compiled source) in force there, 0 for none. naga 30
/// counts the words it reads one by one, but reads the interface of `OpEntryPoint` and the
/// operands of `OpExecutionMode` and `OpTypeFunction` in a batch that it does not count, so
/// its offsets fall behind the binary's by those words.
fn strip_lines(words: &[u32]) -> (Vec<u32>, Vec<(usize, u32)>) {
    const OP_LINE: u32 = 8;
    const OP_NO_LINE: u32 = 317;
    const OP_FUNCTION_END: u32 = 56;
    const OP_ENTRY_POINT: u32 = 15;
    const OP_EXECUTION_MODE: u32 = 16;
    const OP_TYPE_FUNCTION: u32 = 33;
    let header = words.len().min(5);
    let mut out = words[..header].to_vec();
    let mut map = Vec::new();
    let mut line = 0;
    let mut uncounted = 0;
    let mut i = header;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        let op = words[i] & 0xffff;
        if count == 0 || i + count > words.len() {
            out.extend_from_slice(&words[i..]);
            break;
        }
        match op {
            OP_LINE => line = words.get(i + 2).copied().unwrap_or(0),
            OP_NO_LINE => line = 0,
            _ => {
                map.push((out.len() * 4 - uncounted, line));
                out.extend_from_slice(&words[i..i + count]);
                uncounted += 4 * match op {
                    OP_EXECUTION_MODE | OP_TYPE_FUNCTION => count.saturating_sub(3),
                    OP_ENTRY_POINT => {
                        // The name (a nul-terminated string from word 3) is counted, the rest not.
                        let name = words[i + 3.min(count)..i + count]
                            .iter()
                            .position(|w| w.to_le_bytes().contains(&0))
                            .map_or(count.saturating_sub(3), |k| k + 1);
                        count.saturating_sub(3 + name)
                    }
                    _ => 0,
                };
                if op == OP_FUNCTION_END {
                    line = 0;
                }
            }
        }
        i += count;
    }
    (out, map)
}

/// For each function declared in `source` (at brace depth 0), whether each parameter is
/// `out` or `inout`.
fn out_params(source: &str) -> HashMap<String, Vec<bool>> {
    let code: String = strip_comments(source);
    let mut out = HashMap::new();
    let b = code.as_bytes();
    let (mut depth, mut i) = (0i32, 0);
    let mut prev_word = String::new();
    while i < b.len() {
        let c = b[i];
        if c == b'{' {
            depth += 1;
        } else if c == b'}' {
            depth -= 1;
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            let word = &code[start..i];
            let mut j = i;
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            if depth == 0 && b.get(j) == Some(&b'(') && !prev_word.is_empty() && prev_word != "return" {
                // Parameters up to the matching `)`.
                let (mut k, mut level, mut params, mut cur) = (j + 1, 1, Vec::new(), String::new());
                while k < b.len() && level > 0 {
                    match b[k] {
                        b'(' => level += 1,
                        b')' => level -= 1,
                        _ => {}
                    }
                    if level == 1 && b[k] == b',' || level == 0 {
                        params.push(std::mem::take(&mut cur));
                    } else {
                        cur.push(b[k] as char);
                    }
                    k += 1;
                }
                let flags: Vec<bool> = params
                    .iter()
                    .filter(|p| !p.trim().is_empty() && p.trim() != "void")
                    .map(|p| {
                        p.split(|c: char| !(c.is_alphanumeric() || c == '_'))
                            .any(|w| w == "out" || w == "inout")
                    })
                    .collect();
                out.entry(word.to_string()).or_insert(flags);
            }
            prev_word = word.to_string();
            continue;
        }
        if !c.is_ascii_whitespace() {
            prev_word.clear();
        }
        i += 1;
    }
    out
}

fn strip_comments(source: &str) -> String {
    let mut out = String::with_capacity(source.len());
    let mut chars = source.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, chars.peek()) {
            ('/', Some('/')) => {
                for d in chars.by_ref() {
                    if d == '\n' {
                        out.push('\n');
                        break;
                    }
                }
            }
            ('/', Some('*')) => {
                chars.next();
                let mut last = ' ';
                for d in chars.by_ref() {
                    if d == '\n' {
                        out.push('\n');
                    }
                    if last == '*' && d == '/' {
                        break;
                    }
                    last = d;
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// glslang passes every argument through a pointer; each `in` parameter becomes a value again:
/// the function copies it into a local variable (HLSL may assign to it) and its callers pass
/// the pointee.
fn by_value(module: &mut naga::Module, outs: &HashMap<String, Vec<bool>>) {
    // The parameters of each function that are `in` and arrive as pointers.
    let mut converted: HashMap<Handle<naga::Function>, Vec<usize>> = HashMap::new();
    for (h, f) in module.functions.iter() {
        let name = f.name.clone().unwrap_or_default();
        let source_name = if name == METHOD { "method" } else { name.as_str() };
        let flags = outs.get(source_name);
        let list: Vec<usize> = f
            .arguments
            .iter()
            .enumerate()
            .filter(|(i, a)| {
                matches!(module.types[a.ty].inner, naga::TypeInner::Pointer { .. })
                    && !flags.and_then(|f| f.get(*i)).copied().unwrap_or(false)
            })
            .map(|(i, _)| i)
            .collect();
        converted.insert(h, list);
    }
    let handles: Vec<Handle<naga::Function>> = module.functions.iter().map(|(h, _)| h).collect();
    for h in handles {
        let list = converted[&h].clone();
        let types = &module.types;
        let f = &mut module.functions[h];
        let mut prologue = naga::Block::new();
        for &i in &list {
            let naga::TypeInner::Pointer { base, .. } = types[f.arguments[i].ty].inner else {
                continue;
            };
            f.arguments[i].ty = base;
            let local = f.local_variables.append(
                naga::LocalVariable {
                    name: f.arguments[i].name.clone(),
                    ty: base,
                    init: None,
                },
                naga::Span::UNDEFINED,
            );
            let old: Vec<Handle<naga::Expression>> = f
                .expressions
                .iter()
                .filter(|(_, e)| matches!(e, E::FunctionArgument(k) if *k as usize == i))
                .map(|(e, _)| e)
                .collect();
            let span = old
                .first()
                .map_or(naga::Span::UNDEFINED, |&e| f.expressions.get_span(e));
            let value = f.expressions.append(E::FunctionArgument(i as u32), span);
            for e in old {
                f.expressions[e] = E::LocalVariable(local);
                prologue.push(S::Store { pointer: e, value }, span);
            }
        }
        let mut body = std::mem::take(&mut f.body);
        pass_values(&mut body, &mut f.expressions, &converted);
        prologue.append(&mut body);
        f.body = prologue;
    }
    for ep in module.entry_points.iter_mut() {
        let mut body = std::mem::take(&mut ep.function.body);
        pass_values(&mut body, &mut ep.function.expressions, &converted);
        ep.function.body = body;
    }
}

/// Each call to a converted function loads its converted arguments.
fn pass_values(
    block: &mut naga::Block,
    expressions: &mut naga::Arena<naga::Expression>,
    converted: &HashMap<Handle<naga::Function>, Vec<usize>>,
) {
    let old = std::mem::take(block);
    for (mut st, span) in old.span_into_iter() {
        match &mut st {
            S::Call {
                function, arguments, ..
            } => {
                for &i in converted.get(function).map(Vec::as_slice).unwrap_or(&[]) {
                    if let Some(arg) = arguments.get_mut(i) {
                        // The call's line: the argument's own span is its variable's declaration.
                        let load = expressions.append(E::Load { pointer: *arg }, span);
                        block.push(S::Emit(naga::Range::new_from_bounds(load, load)), span);
                        *arg = load;
                    }
                }
            }
            S::Block(b) => pass_values(b, expressions, converted),
            S::If { accept, reject, .. } => {
                pass_values(accept, expressions, converted);
                pass_values(reject, expressions, converted);
            }
            S::Switch { cases, .. } => {
                for c in cases {
                    pass_values(&mut c.body, expressions, converted);
                }
            }
            S::Loop { body, continuing, .. } => {
                pass_values(body, expressions, converted);
                pass_values(continuing, expressions, converted);
            }
            _ => {}
        }
        block.push(st, span);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_parameters_are_found() {
        let o = out_params("float D(float3 w) { return f(w); }\nvoid b(float3 n, out float3 b1, inout float3 b2);\n");
        assert_eq!(o["D"], [false]);
        assert_eq!(o["b"], [false, true, true]);
        assert!(!o.contains_key("f"));
    }

    #[test]
    fn op_lines_are_read_and_removed() {
        // header, OpString %1 "a", OpLine %1 7 0, OpNop, OpNoLine, OpNop
        let words = [
            0x0723_0203,
            0,
            0,
            0,
            0,
            (3 << 16) | 7,
            1,
            0x61,
            (4 << 16) | 8,
            1,
            7,
            0,
            (1 << 16),
            (1 << 16) | 317,
            (1 << 16),
        ];
        let (out, map) = strip_lines(&words);
        assert_eq!(out.len(), 5 + 3 + 1 + 1);
        assert_eq!(map, [(20, 0), (32, 7), (36, 0)]);
    }
}
