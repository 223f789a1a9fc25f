//! The written digits of a translated kernel's float constants. naga's GLSL front end and
//! glslang store every float literal as an f32 (`0.7853981634` becomes `0.7853982`), so the
//! WGSL a GLSL or HLSL kernel is translated to carries f32-rounded constants, and the f64
//! column (src/eval/interp/digits.rs reads constants from the text) would inherit them. Here
//! every float literal written in the kernel and in what it includes (a `#define` too) is
//! tokenised, and each f32 literal of the translation is replaced by the written literal whose
//! f32 rounding has the same bits: the GPU gets the same f32, the f64 column the written
//! digits. When several written literals round to the same f32, the one on the translated
//! line's own source line wins. A constant that matches no written literal (one the front end
//! folded, `PI / 4.0`) is recovered when it is a short exact decimal (`0.5`, `2`, an integer
//! literal converted); otherwise it is reported, and the f64 column of that kernel is refused
//! (src/eval/interp): it may never carry a constant that went through f32.

use std::collections::HashMap;

/// A float constant of a translation whose written digits are lost.
#[derive(Clone, Debug, PartialEq)]
pub struct LostDigits {
    /// The translation's function it stands in (None: at module scope).
    pub function: Option<String>,
    /// `path:line: why`.
    pub message: String,
}

/// A float literal written in a source file.
#[derive(Clone, Debug)]
pub struct Literal {
    /// Its text, suffix dropped (`0.7853981634`).
    pub digits: String,
    pub value: f64,
    /// The kernel file's line it stands on (or that includes its file), 0 for the prelude.
    pub top: u32,
}

/// The float literals of `text` (comments skipped): each with its 1-based line.
pub fn literals(text: &str) -> Vec<(usize, String, f64)> {
    let mut out = Vec::new();
    let mut block = false;
    for (i, line) in text.lines().enumerate() {
        let b = line.as_bytes();
        let mut j = 0;
        while j < b.len() {
            if block {
                if b[j..].starts_with(b"*/") {
                    block = false;
                    j += 2;
                } else {
                    j += 1;
                }
                continue;
            }
            if b[j..].starts_with(b"//") {
                break;
            }
            if b[j..].starts_with(b"/*") {
                block = true;
                j += 2;
                continue;
            }
            let boundary = j == 0 || !(b[j - 1].is_ascii_alphanumeric() || b[j - 1] == b'_' || b[j - 1] == b'.');
            let starts = b[j].is_ascii_digit() || (b[j] == b'.' && b.get(j + 1).is_some_and(u8::is_ascii_digit));
            if !(boundary && starts) {
                j += 1;
                continue;
            }
            let start = j;
            while j < b.len() {
                let c = b[j];
                let sign = (c == b'+' || c == b'-') && matches!(b[j - 1], b'e' | b'E') && !is_hex(&b[start..j]);
                if c.is_ascii_alphanumeric() || c == b'.' || sign {
                    j += 1;
                } else {
                    break;
                }
            }
            let word = &line[start..j];
            if let Some((digits, v)) = float_literal(word) {
                out.push((i + 1, digits, v));
            }
        }
    }
    out
}

fn is_hex(b: &[u8]) -> bool {
    b.len() > 1 && b[0] == b'0' && (b[1] == b'x' || b[1] == b'X')
}

/// A decimal float literal of GLSL, HLSL or WGSL (`1.5`, `.5f`, `2e-3`, `1.0lf`, `3.0h`):
/// its digits and value. Integers and hexadecimal literals are not float literals.
fn float_literal(word: &str) -> Option<(String, f64)> {
    if is_hex(word.as_bytes()) {
        return None;
    }
    let digits = word.trim_end_matches(['f', 'F', 'h', 'H', 'l', 'L']);
    if !digits.contains(['.', 'e', 'E']) {
        return None;
    }
    let v: f64 = digits.parse().ok()?;
    Some((digits.to_string(), v))
}

/// The written literals of every file of a translated kernel, keyed by their f32 bits.
#[derive(Default)]
pub struct Written {
    by_bits: HashMap<u32, Vec<Literal>>,
    /// Constant expressions of the source (`PI / 4.0`, `1.0 / 3.0`), by the bits of their
    /// value folded in f32 step by step (naga) and folded in f64 then rounded (glslang).
    folds: HashMap<u32, Vec<Literal>>,
    /// Named constants (`static const float`, `const float`, `#define`): (f32, f64) values.
    names: HashMap<String, (f32, f64)>,
}

impl Written {
    /// Adds the literals of `text`; `top(line)` is the kernel line each line stands for.
    pub fn add(&mut self, text: &str, top: &dyn Fn(usize) -> u32) {
        for (line, digits, value) in literals(text) {
            let bits = (value as f32).to_bits();
            let list = self.by_bits.entry(bits).or_default();
            list.push(Literal {
                digits,
                value,
                top: top(line),
            });
        }
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            let tokens = fold::tokens(code);
            if let Some((name, value)) = fold::named(&tokens, &self.names) {
                self.names.insert(name, value);
            }
            for (v32, v64) in fold::constant_subexpressions(&tokens, &self.names) {
                for bits in [v32.to_bits(), (v64 as f32).to_bits()] {
                    let list = self.folds.entry(bits).or_default();
                    if !list.iter().any(|l| l.value == v64 && l.top == top(i + 1)) {
                        list.push(Literal {
                            digits: format!("{v64:?}"),
                            value: v64,
                            top: top(i + 1),
                        });
                    }
                }
            }
        }
    }

    /// `wgsl` (a translation; `lines[i]` is the kernel line of its line i + 1) with each f32
    /// literal replaced by its written digits; and a message for each constant that matches
    /// no written literal and is not a short exact decimal.
    pub fn restore(&self, wgsl: &str, lines: &[u32], path: &str) -> (String, Vec<LostDigits>) {
        let mut out = String::with_capacity(wgsl.len());
        let mut lost = Vec::new();
        // The translation's function the line is in (naga's WGSL back end writes `fn NAME(`
        // and the closing `}` at the start of a line).
        let mut function: Option<String> = None;
        for (i, line) in wgsl.lines().enumerate() {
            let at = lines.get(i).copied().unwrap_or(0);
            if let Some(rest) = line.strip_prefix("fn ") {
                function = rest.split('(').next().map(|n| n.trim().to_string());
            }
            if line.trim_start().starts_with("//") {
                out.push_str(line);
                out.push('\n');
                continue;
            }
            let b = line.as_bytes();
            let mut j = 0;
            while j < b.len() {
                let boundary = j == 0 || !(b[j - 1].is_ascii_alphanumeric() || b[j - 1] == b'_' || b[j - 1] == b'.');
                if !(boundary && b[j].is_ascii_digit()) {
                    out.push(b[j] as char);
                    j += 1;
                    continue;
                }
                let start = j;
                while j < b.len() {
                    let c = b[j];
                    let sign = (c == b'+' || c == b'-') && matches!(b[j - 1], b'e' | b'E');
                    if c.is_ascii_alphanumeric() || c == b'.' || sign {
                        j += 1;
                    } else {
                        break;
                    }
                }
                let word = &line[start..j];
                match word.strip_suffix('f').and_then(|d| d.parse::<f32>().ok()) {
                    Some(x) => match self.digits_of(x, at) {
                        Ok(d) => {
                            out.push_str(&d);
                            out.push('f');
                        }
                        Err(message) => {
                            out.push_str(word);
                            let place = if at > 0 {
                                format!("{path}:{at}")
                            } else {
                                path.to_string()
                            };
                            lost.push(LostDigits {
                                function: function.clone(),
                                message: format!("{place}: {message}"),
                            });
                        }
                    },
                    None => out.push_str(word),
                }
            }
            out.push('\n');
            if line.starts_with('}') {
                function = None;
            }
        }
        (out, lost)
    }

    /// The written digits of the f32 `x`, found on kernel line `at`.
    fn digits_of(&self, x: f32, at: u32) -> Result<String, String> {
        let written = self.by_bits.get(&x.to_bits()).map(Vec::as_slice).unwrap_or(&[]);
        let folded = self.folds.get(&x.to_bits()).map(Vec::as_slice).unwrap_or(&[]);
        // A literal as written first; a folded expression only when no literal matches.
        let candidates = if written.is_empty() { folded } else { written };
        let mut values: Vec<&Literal> = Vec::new();
        for c in candidates {
            if !values.iter().any(|v| v.value == c.value) {
                values.push(c);
            }
        }
        let here: Vec<&&Literal> = values.iter().filter(|c| c.top == at && at > 0).collect();
        // A literal in a translated line of the kernel is the kernel's own text (its
        // `#define PI 3.14159265`): the prelude's constants keep their names in the
        // translation, so the prelude's literals yield to the kernel's.
        let own: Vec<&&Literal> = values.iter().filter(|c| c.top > 0).collect();
        match (values.as_slice(), here.as_slice(), own.as_slice()) {
            ([one], _, _) => return Ok(one.digits.clone()),
            (_, [one], _) => return Ok(one.digits.clone()),
            (_, _, [one]) if at > 0 => return Ok(one.digits.clone()),
            _ => {}
        }
        if values.len() > 1 {
            let shown: Vec<&str> = values.iter().map(|c| c.digits.as_str()).collect();
            return Err(format!(
                "the constant {x:?} (f32) may be any of the written literals {}: name one constant for it",
                shown.join(", ")
            ));
        }
        // No written literal: an integer converted, or a fold whose value is a short exact decimal.
        let exact = format!("{:?}", x as f64);
        let significant = exact.trim_start_matches(['-', '0', '.']).replace('.', "");
        let significant = significant.split(['e', 'E']).next().unwrap_or("").trim_end_matches('0');
        if significant.len() <= 7 {
            return Ok(exact);
        }
        Err(format!(
            "the constant {x:?} matches no literal written in the kernel or its includes: the front end \
             folded a constant expression in f32 (such as `PI / 4.0`), and its f64 value cannot be \
             recovered; write it as one literal or a named constant"
        ))
    }
}

/// Constant expressions in a line of source: literals, named constants, `+ - * /`, brackets.
mod fold {
    use std::collections::HashMap;

    #[derive(Clone, Debug, PartialEq)]
    pub enum Tok {
        Num(f64),
        Name(String),
        Op(char),
        Other,
    }

    pub fn tokens(code: &str) -> Vec<Tok> {
        let b = code.as_bytes();
        let (mut out, mut j) = (Vec::new(), 0);
        while j < b.len() {
            let c = b[j];
            if c.is_ascii_whitespace() {
                j += 1;
            } else if c.is_ascii_digit() || (c == b'.' && b.get(j + 1).is_some_and(u8::is_ascii_digit)) {
                let start = j;
                while j < b.len() {
                    let d = b[j];
                    let sign = (d == b'+' || d == b'-') && matches!(b[j - 1], b'e' | b'E');
                    if d.is_ascii_alphanumeric() || d == b'.' || sign {
                        j += 1;
                    } else {
                        break;
                    }
                }
                let word = &code[start..j];
                let digits = word.trim_end_matches(['f', 'F', 'h', 'H', 'l', 'L', 'u', 'U']);
                out.push(match digits.parse::<f64>() {
                    Ok(v) if !super::is_hex(word.as_bytes()) => Tok::Num(v),
                    _ => Tok::Other,
                });
            } else if c.is_ascii_alphabetic() || c == b'_' {
                let start = j;
                while j < b.len() && (b[j].is_ascii_alphanumeric() || b[j] == b'_') {
                    j += 1;
                }
                out.push(Tok::Name(code[start..j].to_string()));
            } else {
                out.push(if b"+-*/()=;#".contains(&c) {
                    Tok::Op(c as char)
                } else {
                    Tok::Other
                });
                j += 1;
            }
        }
        out
    }

    /// `const float NAME = expr;`, `static const float NAME = expr;`, `#define NAME expr`.
    pub fn named(t: &[Tok], names: &HashMap<String, (f32, f64)>) -> Option<(String, (f32, f64))> {
        let name_at = |i: usize| match t.get(i) {
            Some(Tok::Name(n)) => Some(n.clone()),
            _ => None,
        };
        if t.first() == Some(&Tok::Op('#')) && name_at(1).as_deref() == Some("define") {
            let name = name_at(2)?;
            return Some((name, eval(&t[3..], names)?));
        }
        if !t.iter().any(|x| *x == Tok::Name("const".into())) {
            return None;
        }
        let eq = t.iter().position(|x| *x == Tok::Op('='))?;
        let end = t.iter().position(|x| *x == Tok::Op(';')).unwrap_or(t.len());
        let name = name_at(eq.checked_sub(1)?)?;
        Some((name, eval(t.get(eq + 1..end)?, names)?))
    }

    /// Every sub-range of a run of constant tokens that is a whole expression with an operator.
    pub fn constant_subexpressions(t: &[Tok], names: &HashMap<String, (f32, f64)>) -> Vec<(f32, f64)> {
        let constant = |x: &Tok| match x {
            Tok::Num(_) => true,
            Tok::Name(n) => names.contains_key(n),
            Tok::Op(c) => "+-*/()".contains(*c),
            Tok::Other => false,
        };
        let mut out = Vec::new();
        let mut i = 0;
        while i < t.len() {
            if !constant(&t[i]) {
                i += 1;
                continue;
            }
            let start = i;
            while i < t.len() && constant(&t[i]) && i - start < 64 {
                i += 1;
            }
            for a in start..i {
                for b in a + 3..=i {
                    if let Some(v) = eval(&t[a..b], names) {
                        out.push(v);
                    }
                }
            }
        }
        out
    }

    /// The value of a whole expression: folded in f32 step by step, and in f64.
    pub fn eval(t: &[Tok], names: &HashMap<String, (f32, f64)>) -> Option<(f32, f64)> {
        let mut p = (t, 0usize);
        let v = expr(&mut p, names)?;
        (p.1 == t.len()).then_some(v)
    }

    type P<'a> = (&'a [Tok], usize);

    fn expr(p: &mut P, n: &HashMap<String, (f32, f64)>) -> Option<(f32, f64)> {
        let mut v = term(p, n)?;
        while let Some(Tok::Op(c @ ('+' | '-'))) = p.0.get(p.1).cloned() {
            p.1 += 1;
            let r = term(p, n)?;
            v = if c == '+' {
                (v.0 + r.0, v.1 + r.1)
            } else {
                (v.0 - r.0, v.1 - r.1)
            };
        }
        Some(v)
    }

    fn term(p: &mut P, n: &HashMap<String, (f32, f64)>) -> Option<(f32, f64)> {
        let mut v = unary(p, n)?;
        while let Some(Tok::Op(c @ ('*' | '/'))) = p.0.get(p.1).cloned() {
            p.1 += 1;
            let r = unary(p, n)?;
            v = if c == '*' {
                (v.0 * r.0, v.1 * r.1)
            } else {
                (v.0 / r.0, v.1 / r.1)
            };
        }
        Some(v)
    }

    fn unary(p: &mut P, n: &HashMap<String, (f32, f64)>) -> Option<(f32, f64)> {
        match p.0.get(p.1)? {
            Tok::Op('-') => {
                p.1 += 1;
                unary(p, n).map(|(a, b)| (-a, -b))
            }
            Tok::Op('(') => {
                p.1 += 1;
                let v = expr(p, n)?;
                (p.0.get(p.1)? == &Tok::Op(')')).then(|| p.1 += 1)?;
                Some(v)
            }
            Tok::Num(x) => {
                p.1 += 1;
                Some((*x as f32, *x))
            }
            Tok::Name(name) => {
                p.1 += 1;
                n.get(name).copied()
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_are_tokenised_and_restored() {
        let lits = literals("x = 0.78539816339744830961 + 2.0f * a1.5; // 9.9\n/* 3.5 */ y = 1e-3 + 0x1e5 + 7;");
        let digits: Vec<&str> = lits.iter().map(|(_, d, _)| d.as_str()).collect();
        assert_eq!(digits, ["0.78539816339744830961", "2.0", "1e-3"]);
        let mut w = Written::default();
        w.add(
            "const float A = 0.78539816339744830961;\nfloat B = 0.7853981634;\n",
            &|l| l as u32,
        );
        // Two written literals with the same f32: the one on the line wins; elsewhere, refused.
        let (s, lost) = w.restore("let a = 0.7853982f;\nlet b = (x * 0.7853982f);\n", &[1, 2], "k");
        assert_eq!(s, "let a = 0.78539816339744830961f;\nlet b = (x * 0.7853981634f);\n");
        assert!(lost.is_empty());
        let (_, lost) = w.restore("let c = 0.7853982f;\n", &[7], "k");
        assert!(
            lost[0]
                .message
                .starts_with("k:7: the constant 0.7853982 (f32) may be any of"),
            "{lost:?}"
        );
        // A folded constant with no literal is reported; a short exact decimal is not.
        let (s, lost) = w.restore("let d = 1.5707964f + 2f + 0.5f + 1e-7u;\n", &[3], "k");
        assert_eq!(s, "let d = 1.5707964f + 2.0f + 0.5f + 1e-7u;\n");
        assert_eq!(lost.len(), 1);
        assert!(lost[0].message.contains("folded"), "{lost:?}");
        // A constant expression of the source is folded in f64 where the front end folded it.
        let mut w = Written::default();
        w.add(
            "static const float PI = 3.14159265358979323846;\n#define THIRD (1.0 / 3.0)\n",
            &|_| 0,
        );
        w.add("float a = x * (PI / 4.0) + THIRD;\n", &|_| 1);
        let (s, lost) = w.restore("let a = x * 0.7853982f + 0.33333334f;\n", &[1], "k");
        assert!(lost.is_empty(), "{lost:?}");
        let quarter = std::f64::consts::PI / 4.0;
        assert_eq!(s, format!("let a = x * {quarter:?}f + {:?}f;\n", 1.0 / 3.0));
    }
}
