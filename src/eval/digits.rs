//! A float constant's written digits, for the f64 evaluation of a kernel.
//!
//! naga stores every `f32` literal and every folded constant expression (`1.0 / PI`) as an
//! f32, so the f64 evaluation reads the text naga's span points at instead, and evaluates
//! it in f64: a literal (`0.3183098861`, `1.5e3f`), a named module constant, `+ - * /`,
//! parentheses and the conversions `f32(…)`/`f64(…)`. Anything else is an error: the f64
//! column may never carry a constant that went through f32.

/// Evaluates `text` in f64; `constant(name)` gives a module constant's f64 value.
pub fn eval(text: &str, constant: &dyn Fn(&str) -> Option<f64>) -> Result<f64, String> {
    let mut p = Parser {
        s: text.as_bytes(),
        i: 0,
        constant,
    };
    let v = p.expr()?;
    p.skip();
    if p.i != p.s.len() {
        return Err(format!("unexpected `{}`", &text[p.i..]));
    }
    Ok(v)
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    constant: &'a dyn Fn(&str) -> Option<f64>,
}

impl Parser<'_> {
    fn skip(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn eat(&mut self, c: u8) -> bool {
        self.skip();
        if self.s.get(self.i) == Some(&c) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn expr(&mut self) -> Result<f64, String> {
        let mut v = self.term()?;
        loop {
            if self.eat(b'+') {
                v += self.term()?;
            } else if self.eat(b'-') {
                v -= self.term()?;
            } else {
                return Ok(v);
            }
        }
    }

    fn term(&mut self) -> Result<f64, String> {
        let mut v = self.unary()?;
        loop {
            if self.eat(b'*') {
                v *= self.unary()?;
            } else if self.eat(b'/') {
                v /= self.unary()?;
            } else {
                return Ok(v);
            }
        }
    }

    fn unary(&mut self) -> Result<f64, String> {
        if self.eat(b'-') {
            return Ok(-self.unary()?);
        }
        if self.eat(b'+') {
            return self.unary();
        }
        self.primary()
    }

    fn primary(&mut self) -> Result<f64, String> {
        if self.eat(b'(') {
            let v = self.expr()?;
            return if self.eat(b')') {
                Ok(v)
            } else {
                Err("missing `)`".into())
            };
        }
        self.skip();
        let start = self.i;
        let c = *self.s.get(self.i).ok_or("unexpected end")?;
        if c.is_ascii_digit() || c == b'.' {
            while self.i < self.s.len() {
                let c = self.s[self.i];
                let exp_sign = (c == b'-' || c == b'+') && matches!(self.s[self.i - 1], b'e' | b'E');
                if c.is_ascii_alphanumeric() || c == b'.' || exp_sign {
                    self.i += 1;
                } else {
                    break;
                }
            }
            let word = std::str::from_utf8(&self.s[start..self.i]).map_err(|e| e.to_string())?;
            return number(word);
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            while self.i < self.s.len() && (self.s[self.i].is_ascii_alphanumeric() || self.s[self.i] == b'_') {
                self.i += 1;
            }
            let name = std::str::from_utf8(&self.s[start..self.i]).map_err(|e| e.to_string())?;
            if matches!(name, "f32" | "f64") && self.eat(b'(') {
                let v = self.expr()?;
                return if self.eat(b')') {
                    Ok(v)
                } else {
                    Err("missing `)`".into())
                };
            }
            return (self.constant)(name).ok_or_else(|| format!("`{name}` is not a float constant"));
        }
        Err(format!("unexpected `{}`", c as char))
    }
}

/// A WGSL decimal literal, suffix (`f`, `h`, `u`, `i`) dropped.
fn number(word: &str) -> Result<f64, String> {
    let digits = word.trim_end_matches(['f', 'h', 'u', 'i']);
    if digits.starts_with("0x") || digits.starts_with("0X") {
        return Err(format!("hexadecimal literal `{word}`"));
    }
    digits.parse::<f64>().map_err(|_| format!("`{word}` is not a number"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::approx_constant)] // the listing's own digits are the point
    fn written_digits_survive() {
        let pi = |n: &str| (n == "PI").then_some(std::f64::consts::PI);
        assert_eq!(eval("0.3183098861", &pi), Ok(0.3183098861));
        assert_eq!(eval("1.0 / PI", &pi), Ok(1.0 / std::f64::consts::PI));
        assert_eq!(
            eval("-(2.0 * PI) + 1e-3f", &pi),
            Ok(-(2.0 * std::f64::consts::PI) + 1e-3)
        );
        assert_eq!(eval("f32(2) * 1.5e+2", &pi), Ok(300.0));
        assert!(eval("sqrt(2.0)", &pi).is_err());
        assert!(eval("Q * 2.0", &pi).unwrap_err().contains("`Q`"));
    }
}
