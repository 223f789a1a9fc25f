//! Identifier renaming in WGSL text, token by token: the inner line method of a composite
//! is composed with its `method` and `override`s renamed, and only whole identifier tokens
//! that name them change, never comments, member names or longer identifiers.

use std::ops::Range;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Ident,
    Number,
    Punct,
}

#[derive(Clone, Copy, Debug)]
struct Token<'a> {
    kind: Kind,
    text: &'a str,
    start: usize,
}

/// One replaced token: where it was in the original text and where it is in the new.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rename {
    pub old_start: usize,
    pub old_len: usize,
    pub new_start: usize,
    pub new_len: usize,
}

/// Maps a byte offset in renamed text back to the original text. An offset inside a
/// renamed token maps into the original token, clamped to its length.
pub(crate) fn original_offset(renames: &[Rename], offset: usize) -> usize {
    match renames.iter().rev().find(|r| r.new_start <= offset) {
        None => offset,
        Some(r) if offset < r.new_start + r.new_len => r.old_start + (offset - r.new_start).min(r.old_len),
        Some(r) => r.old_start + r.old_len + (offset - r.new_start - r.new_len),
    }
}

/// Replaces every identifier token named in `renames` (old, new) except member names:
/// after `.` (member access), after `@` (attributes) and inside `struct` bodies.
pub(crate) fn rename_identifiers(text: &str, renames: &[(&str, String)]) -> (String, Vec<Rename>) {
    let mut out = String::with_capacity(text.len());
    let mut edits = Vec::new();
    let mut copied = 0;
    let mut prev: Option<Token> = None;
    // Brace depth inside a struct body; `struct` seen and its `{` not yet.
    let (mut struct_depth, mut struct_pending) = (0usize, false);
    for token in tokens(text) {
        match (token.kind, token.text) {
            (Kind::Ident, "struct") => struct_pending = true,
            (Kind::Punct, "{") if struct_pending || struct_depth > 0 => {
                struct_pending = false;
                struct_depth += 1;
            }
            (Kind::Punct, "}") if struct_depth > 0 => struct_depth -= 1,
            _ => {}
        }
        let member = prev.is_some_and(|p| p.kind == Kind::Punct && (p.text == "." || p.text == "@"));
        let new = renames.iter().find(|(old, _)| *old == token.text).map(|(_, new)| new);
        if let (Kind::Ident, Some(new), false, 0) = (token.kind, new, member, struct_depth) {
            out.push_str(&text[copied..token.start]);
            edits.push(Rename {
                old_start: token.start,
                old_len: token.text.len(),
                new_start: out.len(),
                new_len: new.len(),
            });
            out.push_str(new);
            copied = token.start + token.text.len();
        }
        prev = Some(token);
    }
    out.push_str(&text[copied..]);
    (out, edits)
}

/// Inserts `statement` at the start of every loop body (`for (…) {`, `while … {`,
/// `loop {`): the counting variant of a kernel (loops.rs).
pub(crate) fn instrument_loops(text: &str, statement: &str) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    let mut copied = 0;
    let (mut pending, mut parens) = (false, 0i32);
    let mut prev: Option<Token> = None;
    for token in tokens(text) {
        let member = prev.is_some_and(|p| p.kind == Kind::Punct && (p.text == "." || p.text == "@"));
        match (token.kind, token.text) {
            (Kind::Ident, "for" | "while" | "loop") if !member => {
                pending = true;
                parens = 0;
            }
            (Kind::Punct, "(") if pending => parens += 1,
            (Kind::Punct, ")") if pending => parens -= 1,
            (Kind::Punct, "{") if pending && parens == 0 => {
                let end = token.start + 1;
                out.push_str(&text[copied..end]);
                out.push_str(statement);
                copied = end;
                pending = false;
            }
            _ => {}
        }
        prev = Some(token);
    }
    out.push_str(&text[copied..]);
    out
}

/// Implicit-LOD sampling rewritten to level 0: every `textureSample(t, s, coords[, layer][, offset])`
/// becomes `textureSampleLevel(t, s, coords[, layer], 0.0[, offset])` (naga allows implicit
/// LOD only in fragment shaders; a compute kernel's textures have one level). `arrayed`: the
/// texture names whose calls carry an array layer. Lines are kept.
pub(crate) fn sample_level_zero(text: &str, arrayed: &[&str]) -> String {
    let tokens = tokens(text);
    let mut out = String::with_capacity(text.len() + 32);
    let mut copied = 0;
    for (i, t) in tokens.iter().enumerate() {
        let member = i > 0 && matches!(tokens[i - 1].text, "." | "@");
        if t.kind != Kind::Ident || t.text != "textureSample" || member {
            continue;
        }
        if tokens.get(i + 1).map(|t| t.text) != Some("(") {
            continue;
        }
        let layer = tokens
            .get(i + 2)
            .is_some_and(|a| a.kind == Kind::Ident && arrayed.contains(&a.text));
        // The end of argument `after` (0-based) at depth 1: where `, 0.0` goes.
        let after = if layer { 3 } else { 2 };
        let (mut depth, mut arg, mut at) = (0i32, 0usize, None);
        for u in &tokens[i + 1..] {
            match u.text {
                "(" | "[" => depth += 1,
                ")" | "]" => {
                    depth -= 1;
                    if depth == 0 {
                        if arg == after {
                            at = Some(u.start);
                        }
                        break;
                    }
                }
                "," if depth == 1 => {
                    if arg == after {
                        at = Some(u.start);
                        break;
                    }
                    arg += 1;
                }
                _ => {}
            }
        }
        let Some(at) = at else {
            continue;
        };
        out.push_str(&text[copied..t.start]);
        out.push_str("textureSampleLevel");
        out.push_str(&text[t.start + t.text.len()..at]);
        out.push_str(", 0.0");
        copied = at;
    }
    out.push_str(&text[copied..]);
    out
}

/// Where `text` declares a function `name` (`fn name`), as the range of the name.
pub(crate) fn find_fn(text: &str, name: &str) -> Option<Range<usize>> {
    let tokens = tokens(text);
    tokens
        .windows(2)
        .find(|w| w[0].kind == Kind::Ident && w[0].text == "fn" && w[1].kind == Kind::Ident && w[1].text == name)
        .map(|w| w[1].start..w[1].start + name.len())
}

/// Every module-scope function of `text`: its name and the range of its whole declaration,
/// from `fn` (or the attributes before it) to its closing brace.
pub(crate) fn fn_decls(text: &str) -> Vec<(String, Range<usize>)> {
    let tokens = tokens(text);
    let mut out = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < tokens.len() {
        let t = tokens[i];
        match (t.kind, t.text) {
            (Kind::Punct, "{") => depth += 1,
            (Kind::Punct, "}") => depth = depth.saturating_sub(1),
            (Kind::Ident, "fn") if depth == 0 => {
                if let Some(name) = tokens.get(i + 1).filter(|n| n.kind == Kind::Ident) {
                    // `@attr` or `@attr(...)` right before `fn` belongs to the declaration.
                    let mut start = i;
                    while start >= 2 && tokens[start - 1].kind == Kind::Ident && tokens[start - 2].text == "@" {
                        start -= 2;
                    }
                    let body = tokens[i..].iter().position(|t| t.text == "{").map(|p| i + p);
                    let mut end = None;
                    let mut d = 0usize;
                    for (j, t) in tokens.iter().enumerate().skip(body.unwrap_or(tokens.len())) {
                        match t.text {
                            "{" => d += 1,
                            "}" => {
                                d -= 1;
                                if d == 0 {
                                    end = Some(j);
                                    break;
                                }
                            }
                            _ => {}
                        }
                    }
                    let Some(end) = end else {
                        break;
                    };
                    out.push((name.text.to_string(), tokens[start].start..tokens[end].start + 1));
                    i = end + 1;
                    continue;
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// `text` with `range` blanked: only its newlines stay, so every line keeps its number.
pub(crate) fn blank(text: &str, range: Range<usize>) -> String {
    let hole: String = text[range.clone()].chars().filter(|&c| c == '\n').collect();
    format!("{}{hole}{}", &text[..range.start], &text[range.end..])
}

/// Identifiers, numbers and single punctuation characters; whitespace and comments
/// (line comments and nested block comments) are skipped. WGSL has no string literals.
fn tokens(text: &str) -> Vec<Token<'_>> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let word_end = |mut j: usize, extra: &dyn Fn(char) -> bool| {
        while let Some(c) = text[j..].chars().next() {
            if !(c.is_alphanumeric() || c == '_' || extra(c)) {
                break;
            }
            j += c.len_utf8();
        }
        j
    };
    while let Some(c) = text[i..].chars().next() {
        let next = bytes.get(i + 1).copied();
        let (kind, end) = if c.is_whitespace() {
            i += c.len_utf8();
            continue;
        } else if c == '/' && next == Some(b'/') {
            i = text[i..].find('\n').map_or(text.len(), |n| i + n);
            continue;
        } else if c == '/' && next == Some(b'*') {
            i = block_comment_end(text, i);
            continue;
        } else if c.is_ascii_digit() || (c == '.' && next.is_some_and(|b| b.is_ascii_digit())) {
            // `1.5e3f`, `0x1p4`, `2u`: the suffix and exponent letters are not identifiers.
            (Kind::Number, word_end(i + 1, &|c| c == '.'))
        } else if c.is_alphabetic() || c == '_' {
            (Kind::Ident, word_end(i + c.len_utf8(), &|_| false))
        } else {
            (Kind::Punct, i + c.len_utf8())
        };
        out.push(Token {
            kind,
            text: &text[i..end],
            start: i,
        });
        i = end;
    }
    out
}

/// The end of the block comment starting at `start` (WGSL block comments nest).
fn block_comment_end(text: &str, start: usize) -> usize {
    let mut depth = 0;
    let mut i = start;
    while i < text.len() {
        if text[i..].starts_with("/*") {
            depth += 1;
            i += 2;
        } else if text[i..].starts_with("*/") {
            depth -= 1;
            i += 2;
            if depth == 0 {
                return i;
            }
        } else {
            i += text[i..].chars().next().map_or(1, char::len_utf8);
        }
    }
    text.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn function_declarations_span_their_bodies() {
        let text = "// fn c() {}\nfn a(x: f32) -> f32 {\n    if (x > 0.0) { return x; }\n    return -x;\n}\n@must_use fn b() -> f32 { return 1.0; }\n";
        let decls = fn_decls(text);
        let names: Vec<&str> = decls.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        assert!(text[decls[0].1.clone()].starts_with("fn a(") && text[decls[0].1.clone()].ends_with("-x;\n}"));
        assert_eq!(&text[decls[1].1.clone()], "@must_use fn b() -> f32 { return 1.0; }");
        let blanked = blank(text, decls[0].1.clone());
        assert_eq!(blanked.lines().count(), text.lines().count());
        assert_eq!(fn_decls(&blanked).len(), 1);
    }

    fn rename(text: &str) -> String {
        let renames = [
            ("method", "ll_line_method".to_string()),
            ("N", "ll_inner_N".to_string()),
        ];
        rename_identifiers(text, &renames).0
    }

    #[test]
    fn renames_whole_identifiers_only() {
        let text = "// fn method(scene) uses N\n/* method /* N */ method */\n\
                    override N: u32 = 2u;\nstruct S { N: f32, method: u32 }\n\
                    fn method_2(s: S) -> f32 { return s.N + f32(N) + 1.5e3f; }\n\
                    fn method(scene: Scene) -> f32 { let methods = N; return method_2(S(1.0, N)); }\n";
        let expected = "// fn method(scene) uses N\n/* method /* N */ method */\n\
                        override ll_inner_N: u32 = 2u;\nstruct S { N: f32, method: u32 }\n\
                        fn method_2(s: S) -> f32 { return s.N + f32(ll_inner_N) + 1.5e3f; }\n\
                        fn ll_line_method(scene: Scene) -> f32 { let methods = ll_inner_N; \
                        return method_2(S(1.0, ll_inner_N)); }\n";
        assert_eq!(rename(text), expected);
    }

    #[test]
    fn offsets_map_back_to_the_original() {
        let text = "fn method() {}\nlet x = N;";
        let (new, edits) = rename_identifiers(text, &[("method", "ll_line_method".into()), ("N", "ll_inner_N".into())]);
        assert_eq!(new, "fn ll_line_method() {}\nlet x = ll_inner_N;");
        for (new_at, old_at) in [(0, 0), (3, 3), (5, 5), (17, 9), (30, 22), (31, 23), (41, 24)] {
            assert_eq!(original_offset(&edits, new_at), old_at, "{new_at}");
        }
    }

    #[test]
    fn implicit_lod_sampling_becomes_level_zero() {
        let text = "let a = textureSample(t, s, uv);\nlet b = textureSample(arr, s, f(uv, 1.0), 2, vec2(1, 0));\n// textureSample(t, s, uv)\nlet c = textureSampleLevel(t, s, uv, 1.0);\n";
        assert_eq!(
            sample_level_zero(text, &["arr"]),
            "let a = textureSampleLevel(t, s, uv, 0.0);\nlet b = textureSampleLevel(arr, s, f(uv, 1.0), 2, 0.0, vec2(1, 0));\n// textureSample(t, s, uv)\nlet c = textureSampleLevel(t, s, uv, 1.0);\n"
        );
    }

    #[test]
    fn finds_function_declarations() {
        let text = "// fn I_line\nfn I_line_x() {}\nfn  I_line(p1: vec3<f32>) {}";
        assert_eq!(find_fn(text, "I_line"), Some(34..40));
        assert_eq!(find_fn("let I_line = 1;", "I_line"), None);
    }
}
