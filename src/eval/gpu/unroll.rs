//! A small WGSL preprocessor: unrolls the loops marked `// @unroll`.
//!
//! Mesa lavapipe (and some GPU drivers) keep function-scope arrays in memory unless every
//! index is a constant, and do not unroll loops whose bounds come from module constants; an
//! unrolled loop whose counter is a `const` gives the driver constant indices throughout, so
//! the held patch, the bases and the accumulators live in registers (the bicubic fitness
//! kernel ran over 20× faster on lavapipe unrolled than as written).
//!
//! A marked loop must read `for (var X = A; X < B; X++) { // @unroll` (or `<=`), with `A`
//! and `B` integer expressions over literals, `u32` module constants of the source
//! (`const N: u32 = …;` lines, evaluated in order) and enclosing unrolled counters; its body
//! must not assign `X`. Each iteration becomes a block opening with `const X = ku;`. Unmarked
//! loops are left alone, so the file stays valid WGSL before and after.

use crate::error::{Error, Result};
use std::collections::HashMap;

/// Most lines an unrolled shader may have (a guard against runaway trip counts).
const MAX_LINES: usize = 200_000;

/// Unroll every marked loop of `src`.
pub fn unroll(src: &str) -> Result<String> {
    let lines: Vec<&str> = src.lines().collect();
    let mut env = HashMap::new();
    for line in &lines {
        // Constants the evaluator cannot read (hex, floats) are simply not available to
        // loop bounds.
        if let Some((name, expr)) = module_const(line) {
            if let Ok(value) = eval(expr, &env) {
                env.insert(name.to_owned(), value);
            }
        }
    }
    let mut out = Vec::new();
    expand(&lines, &env, &mut out)?;
    let mut text = out.join("\n");
    text.push('\n');
    Ok(text)
}

/// `(name, expression)` of a top-level `const NAME: u32 = EXPR;` line.
fn module_const(line: &str) -> Option<(&str, &str)> {
    let rest = line.strip_prefix("const ")?;
    let (name, rest) = rest.split_once(": u32 = ")?;
    let expr = rest.trim_end().strip_suffix(';')?;
    Some((name.trim(), expr))
}

/// A parsed loop header: counter, first value, comparison and bound.
struct Header<'a> {
    indent: &'a str,
    var: &'a str,
    init: &'a str,
    inclusive: bool,
    bound: &'a str,
}

fn header(line: &str) -> Option<Header<'_>> {
    let trimmed = line.trim_start();
    let indent = &line[..line.len() - trimmed.len()];
    let inner = trimmed
        .strip_prefix("for (var ")?
        .trim_end()
        .strip_suffix("{ // @unroll")?
        .trim_end()
        .strip_suffix(')')?;
    let mut parts = inner.split(';').map(str::trim);
    let (init, cond, step) = (parts.next()?, parts.next()?, parts.next()?);
    if parts.next().is_some() {
        return None;
    }
    let (var, init) = init.split_once('=')?;
    let var = var.trim();
    if step != format!("{var}++") {
        return None;
    }
    let cond = cond.strip_prefix(var)?.trim_start();
    let (inclusive, bound) = match cond.strip_prefix("<=") {
        Some(b) => (true, b),
        None => (false, cond.strip_prefix('<')?),
    };
    Some(Header {
        indent,
        var,
        init: init.trim(),
        inclusive,
        bound: bound.trim(),
    })
}

/// Net brace count of a line outside its `//` comment.
fn braces(line: &str) -> i64 {
    let code = line.split("//").next().unwrap_or("");
    code.matches('{').count() as i64 - code.matches('}').count() as i64
}

fn expand(lines: &[&str], env: &HashMap<String, i64>, out: &mut Vec<String>) -> Result<()> {
    let mut i = 0;
    while i < lines.len() {
        let marked = lines[i].trim_end().ends_with("// @unroll");
        let Some(h) = marked.then(|| header(lines[i])).flatten() else {
            if marked {
                return Err(Error::Gpu(format!(
                    "@unroll on a loop it cannot read: {}",
                    lines[i].trim()
                )));
            }
            out.push(lines[i].to_owned());
            i += 1;
            continue;
        };
        // The body runs to the line that closes the header's brace.
        let mut depth = 1;
        let mut end = i + 1;
        while end < lines.len() {
            depth += braces(lines[end]);
            if depth == 0 {
                break;
            }
            end += 1;
        }
        if depth != 0 {
            return Err(Error::Gpu(format!("unclosed @unroll loop: {}", lines[i].trim())));
        }
        let lo = eval(h.init, env)?;
        let hi = eval(h.bound, env)? + i64::from(h.inclusive);
        for k in lo..hi {
            if k < 0 {
                return Err(Error::Gpu(format!(
                    "negative counter in @unroll loop: {}",
                    lines[i].trim()
                )));
            }
            out.push(format!("{}{{", h.indent));
            out.push(format!("{}    const {} = {k}u;", h.indent, h.var));
            let mut inner = env.clone();
            inner.insert(h.var.to_owned(), k);
            expand(&lines[i + 1..end], &inner, out)?;
            out.push(format!("{}}}", h.indent));
            if out.len() > MAX_LINES {
                return Err(Error::Gpu("unrolled shader too large".into()));
            }
        }
        i = end + 1;
    }
    Ok(())
}

/// Evaluate an integer expression: literals (`3`, `3u`), names in `env`, `+ - * /`,
/// parentheses, `max(a, b)` and `min(a, b)`.
fn eval(expr: &str, env: &HashMap<String, i64>) -> Result<i64> {
    let tokens = tokens(expr)?;
    let mut p = Parser {
        tokens: &tokens,
        at: 0,
        env,
        expr,
    };
    let v = p.sum()?;
    if p.at != tokens.len() {
        return Err(p.fail());
    }
    Ok(v)
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(i64),
    Name(String),
    Op(char),
}

fn tokens(expr: &str) -> Result<Vec<Tok>> {
    let mut out = Vec::new();
    let chars: Vec<char> = expr.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() {
            let start = i;
            while i < chars.len() && chars[i].is_ascii_digit() {
                i += 1;
            }
            let digits: String = chars[start..i].iter().collect();
            if i < chars.len() && chars[i] == 'u' {
                i += 1;
            }
            let n = digits
                .parse()
                .map_err(|_| Error::Gpu(format!("@unroll: bad number in '{expr}'")))?;
            out.push(Tok::Num(n));
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(Tok::Name(chars[start..i].iter().collect()));
        } else if "+-*/(),".contains(c) {
            out.push(Tok::Op(c));
            i += 1;
        } else {
            return Err(Error::Gpu(format!("@unroll: unexpected '{c}' in '{expr}'")));
        }
    }
    Ok(out)
}

struct Parser<'a> {
    tokens: &'a [Tok],
    at: usize,
    env: &'a HashMap<String, i64>,
    expr: &'a str,
}

impl Parser<'_> {
    fn fail(&self) -> Error {
        Error::Gpu(format!("@unroll: cannot evaluate '{}'", self.expr))
    }

    fn eat(&mut self, op: char) -> bool {
        if self.tokens.get(self.at) == Some(&Tok::Op(op)) {
            self.at += 1;
            true
        } else {
            false
        }
    }

    fn sum(&mut self) -> Result<i64> {
        let mut v = self.product()?;
        loop {
            if self.eat('+') {
                v += self.product()?;
            } else if self.eat('-') {
                v -= self.product()?;
            } else {
                return Ok(v);
            }
        }
    }

    fn product(&mut self) -> Result<i64> {
        let mut v = self.atom()?;
        loop {
            if self.eat('*') {
                v *= self.atom()?;
            } else if self.eat('/') {
                let d = self.atom()?;
                v = v.checked_div(d).ok_or_else(|| self.fail())?;
            } else {
                return Ok(v);
            }
        }
    }

    fn atom(&mut self) -> Result<i64> {
        let tok = self.tokens.get(self.at).cloned().ok_or_else(|| self.fail())?;
        self.at += 1;
        match tok {
            Tok::Num(n) => Ok(n),
            Tok::Op('(') => {
                let v = self.sum()?;
                if self.eat(')') {
                    Ok(v)
                } else {
                    Err(self.fail())
                }
            }
            Tok::Name(f) if (f == "max" || f == "min") && self.eat('(') => {
                let a = self.sum()?;
                if !self.eat(',') {
                    return Err(self.fail());
                }
                let b = self.sum()?;
                if !self.eat(')') {
                    return Err(self.fail());
                }
                Ok(if f == "max" { a.max(b) } else { a.min(b) })
            }
            Tok::Name(n) => self.env.get(&n).copied().ok_or_else(|| self.fail()),
            Tok::Op(_) => Err(self.fail()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expressions_use_constants_and_counters() {
        let env: HashMap<String, i64> = [("DU".to_owned(), 3), ("j".to_owned(), 2)].into();
        assert_eq!(eval("DU + 1u", &env).unwrap(), 4);
        assert_eq!(eval("max(DU + 1u, 2u) * (j - 1)", &env).unwrap(), 4);
        assert_eq!(eval("min(7, 12 / 4)", &env).unwrap(), 3);
        assert!(eval("DV", &env).is_err());
        assert!(eval("3 +", &env).is_err());
    }

    #[test]
    fn nested_loops_unroll_with_outer_counters_in_bounds() {
        let src = "const N: u32 = 2u;\nconst M: u32 = N + 1u;\nfn f() {\n    for (var j = 1u; j < M; j++) { // @unroll\n        for (var k = 0u; k <= j; k++) { // @unroll\n            x[k] += y[j];\n        }\n    }\n    for (var i = 0u; i < n; i++) {\n    }\n}\n";
        let out = unroll(src).unwrap();
        assert_eq!(out.matches("const j = ").count(), 2);
        // k takes 0..=1 for j = 1 and 0..=2 for j = 2.
        assert_eq!(out.matches("const k = ").count(), 5);
        assert_eq!(out.matches("x[k] += y[j];").count(), 5);
        assert!(
            out.contains("    for (var i = 0u; i < n; i++) {"),
            "unmarked loops stay"
        );
        assert_eq!(out.lines().map(braces).sum::<i64>(), 0);
    }

    #[test]
    fn unreadable_markers_are_errors() {
        assert!(unroll("fn f() {\n    for (var i = 0u; i < 3u; i += 1u) { // @unroll\n    }\n}\n").is_err());
        assert!(unroll("fn f() {\n    for (var i = 0u; i < Q; i++) { // @unroll\n    }\n}\n").is_err());
    }
}
