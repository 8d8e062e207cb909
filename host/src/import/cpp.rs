//! Literal tables in C++ source. Some published problem sets keep their scenes in code, not
//! in data files (VAMP-MR builds its tables and bins in `vamp_env_factory.cpp`); to read them
//! from the user's checkout rather than keep a copy, this reads enough of C++'s lexical
//! grammar to find a function's body, an `if` branch or `case` block, a variable's
//! initializer and a call's arguments, and evaluates numeric expressions made of literals,
//! `M_PI` constants, `+ - * /`, brace lists and vector constructors. Anything else is an
//! error naming what was looked for: a changed source is refused, never half read.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// A token, or a bracketed group of them.
#[derive(Clone, Debug, PartialEq)]
pub enum Tree {
    /// An identifier or keyword.
    Ident(String),
    /// A number literal's value.
    Num(f64),
    /// A string or character literal's content, escapes kept as written.
    Str(String),
    /// Any other character.
    Punct(char),
    /// `(`, `[` or `{` and what it encloses.
    Group(char, Vec<Tree>),
}

/// The value of an expression.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A number.
    Num(f64),
    /// A brace list, or a vector constructor's arguments (`Eigen::Vector3d(x, y, z)`).
    List(Vec<Value>),
    /// A call of any other function: its qualified name and evaluated arguments.
    Call(String, Vec<Value>),
}

impl Value {
    /// The number this is.
    pub fn num(&self) -> Result<f64, String> {
        match self {
            Value::Num(x) => Ok(*x),
            other => Err(format!("expected a number, found {}", other.kind())),
        }
    }

    /// `k` numbers (a list of them, or a vector constructor's).
    pub fn numbers(&self, k: usize) -> Result<Vec<f64>, String> {
        let Value::List(items) = self.unbraced(false) else {
            return Err(format!("expected {k} numbers, found {}", self.kind()));
        };
        if items.len() != k {
            return Err(format!("expected {k} numbers, found {}", items.len()));
        }
        items.iter().map(Value::num).collect()
    }

    /// Rows of `k` numbers each (`{{ {..}, {..} }}`, `{ Vector3d(..), .. }`).
    pub fn rows(&self, k: usize) -> Result<Vec<Vec<f64>>, String> {
        let Value::List(items) = self.unbraced(true) else {
            return Err(format!(
                "expected rows of {k} numbers, found {}",
                self.kind()
            ));
        };
        (items.iter().enumerate())
            .map(|(i, row)| row.numbers(k).map_err(|e| format!("row {i}: {e}")))
            .collect()
    }

    /// Without the outer braces of `std::array`'s aggregate initialisation (`{{ .. }}`): of a
    /// list of numbers, or with `rows`, of a list of rows.
    fn unbraced(&self, rows: bool) -> &Value {
        match self {
            Value::List(items) if items.len() == 1 => match &items[0] {
                inner @ Value::List(x)
                    if !rows || x.iter().all(|v| matches!(v, Value::List(_))) =>
                {
                    inner.unbraced(rows)
                }
                _ => self,
            },
            v => v,
        }
    }

    fn kind(&self) -> String {
        match self {
            Value::Num(x) => format!("the number {x}"),
            Value::List(items) => format!("a list of {}", items.len()),
            Value::Call(name, _) => format!("a call of {name}"),
        }
    }
}

/// The token trees of a C++ source text. Comments and preprocessor lines are skipped. Errors
/// name the line.
pub fn parse(text: &str) -> Result<Vec<Tree>, String> {
    let mut lexer = Lexer {
        chars: text.chars().collect(),
        at: 0,
        line: 1,
    };
    let (trees, close) = lexer.group()?;
    match close {
        None => Ok(trees),
        Some(c) => Err(format!("line {}: unmatched {c:?}", lexer.line)),
    }
}

struct Lexer {
    chars: Vec<char>,
    at: usize,
    line: usize,
}

impl Lexer {
    fn peek(&self, k: usize) -> Option<char> {
        self.chars.get(self.at + k).copied()
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek(0)?;
        self.at += 1;
        if c == '\n' {
            self.line += 1;
        }
        Some(c)
    }

    /// Trees up to a closing bracket (returned) or the end (`None`).
    fn group(&mut self) -> Result<(Vec<Tree>, Option<char>), String> {
        let mut trees = Vec::new();
        let mut line_start = true;
        while let Some(c) = self.peek(0) {
            let start_line = self.line;
            match c {
                '\n' => {
                    self.bump();
                    line_start = true;
                    continue;
                }
                c if c.is_whitespace() => {
                    self.bump();
                    continue;
                }
                '/' if self.peek(1) == Some('/') => self.skip_line(),
                '/' if self.peek(1) == Some('*') => {
                    self.at += 2;
                    while !(self.peek(0) == Some('*') && self.peek(1) == Some('/')) {
                        if self.bump().is_none() {
                            return Err(format!("line {start_line}: unterminated comment"));
                        }
                    }
                    self.at += 2;
                }
                '#' if line_start => self.skip_line(),
                '(' | '[' | '{' => {
                    self.bump();
                    let (inner, close) = self.group()?;
                    let want = match c {
                        '(' => ')',
                        '[' => ']',
                        _ => '}',
                    };
                    if close != Some(want) {
                        return Err(format!("line {start_line}: {c:?} not closed by {want:?}"));
                    }
                    trees.push(Tree::Group(c, inner));
                }
                ')' | ']' | '}' => {
                    self.bump();
                    return Ok((trees, Some(c)));
                }
                '"' | '\'' => trees.push(Tree::Str(self.quoted(c)?)),
                'R' if self.peek(1) == Some('"') => {
                    self.bump();
                    trees.push(Tree::Str(self.raw()?));
                }
                c if c.is_ascii_digit()
                    || (c == '.' && self.peek(1).is_some_and(|d| d.is_ascii_digit())) =>
                {
                    trees.push(Tree::Num(self.number()?));
                }
                c if c.is_alphabetic() || c == '_' => {
                    let mut id = String::new();
                    while let Some(c) = self.peek(0).filter(|c| c.is_alphanumeric() || *c == '_') {
                        id.push(c);
                        self.bump();
                    }
                    trees.push(Tree::Ident(id));
                }
                c => {
                    self.bump();
                    trees.push(Tree::Punct(c));
                }
            }
            line_start = false;
        }
        Ok((trees, None))
    }

    /// A preprocessor line (with its continuations) or a `//` comment.
    fn skip_line(&mut self) {
        while let Some(c) = self.peek(0) {
            if c == '\n' {
                break;
            }
            if c == '\\' && self.peek(1) == Some('\n') {
                self.bump();
            }
            self.bump();
        }
    }

    fn quoted(&mut self, quote: char) -> Result<String, String> {
        let line = self.line;
        self.bump();
        let mut s = String::new();
        loop {
            match self.bump() {
                None | Some('\n') => return Err(format!("line {line}: unterminated literal")),
                Some('\\') => {
                    s.push('\\');
                    s.extend(self.bump());
                }
                Some(c) if c == quote => return Ok(s),
                Some(c) => s.push(c),
            }
        }
    }

    /// `R"delim( ... )delim"`, after the `R`.
    fn raw(&mut self) -> Result<String, String> {
        let line = self.line;
        self.bump();
        let mut delim = String::new();
        while let Some(c) = self.bump() {
            if c == '(' {
                break;
            }
            delim.push(c);
        }
        let end: Vec<char> = format!("){delim}\"").chars().collect();
        let mut s = String::new();
        loop {
            if self.chars.get(self.at..self.at + end.len()) == Some(&end[..]) {
                self.at += end.len();
                return Ok(s);
            }
            match self.bump() {
                Some(c) => s.push(c),
                None => return Err(format!("line {line}: unterminated raw string")),
            }
        }
    }

    /// A decimal number with C++'s suffixes (`f`, `F`, `l`, `u`, ...) and digit separators.
    fn number(&mut self) -> Result<f64, String> {
        let mut s = String::new();
        while let Some(c) = self.peek(0) {
            let exponent_sign = (c == '+' || c == '-') && s.ends_with(['e', 'E']);
            if !(c.is_alphanumeric() || c == '.' || c == '\'' || c == '_' || exponent_sign) {
                break;
            }
            s.push(c);
            self.bump();
        }
        let digits: String = s.chars().filter(|&c| c != '\'').collect();
        let plain = digits.trim_end_matches(['f', 'F', 'l', 'L', 'u', 'U']);
        if plain.starts_with("0x") || plain.starts_with("0X") {
            return i64::from_str_radix(&plain[2..], 16)
                .map(|v| v as f64)
                .map_err(|_| format!("line {}: number {s:?} not understood", self.line));
        }
        plain
            .parse::<f64>()
            .map_err(|_| format!("line {}: number {s:?} not understood", self.line))
    }
}

fn is_ident(t: &Tree, name: &str) -> bool {
    matches!(t, Tree::Ident(s) if s == name)
}

fn is_group(t: &Tree, open: char) -> bool {
    matches!(t, Tree::Group(c, _) if *c == open)
}

fn inner(t: &Tree) -> &[Tree] {
    match t {
        Tree::Group(_, v) => v,
        _ => &[],
    }
}

/// Every token list of `trees` and of every group inside, outermost first.
fn each_level<'a>(trees: &'a [Tree], visit: &mut dyn FnMut(&'a [Tree]) -> bool) -> bool {
    if visit(trees) {
        return true;
    }
    trees
        .iter()
        .any(|t| matches!(t, Tree::Group(..)) && each_level(inner(t), visit))
}

/// A function's definition: its parameter list and its body.
#[derive(Clone, Copy, Debug)]
pub struct Definition<'a> {
    /// The parameter list, inside its parentheses.
    pub params: &'a [Tree],
    /// The body, inside its braces.
    pub body: &'a [Tree],
}

/// The first definition of function `name` (at any depth).
pub fn function<'a>(trees: &'a [Tree], name: &str) -> Option<Definition<'a>> {
    let mut found = None;
    each_level(trees, &mut |level| {
        for (i, t) in level.iter().enumerate() {
            let Some(Tree::Group('(', params)) = level.get(i + 1) else {
                continue;
            };
            if !is_ident(t, name) {
                continue;
            }
            // Qualifiers and a trailing return type may sit between `)` and `{`.
            for next in &level[i + 2..] {
                match next {
                    Tree::Group('{', body) => {
                        found = Some(Definition { params, body });
                        return true;
                    }
                    Tree::Punct(';' | ',' | '=') | Tree::Group(..) => break,
                    _ => {}
                }
            }
        }
        false
    });
    found
}

/// The block of the first `if (...)` (at any depth) whose condition holds the string literal
/// `key` (`if (config.environment_name == "panda_four")`).
pub fn branch<'a>(trees: &'a [Tree], key: &str) -> Option<&'a [Tree]> {
    let mut found = None;
    each_level(trees, &mut |level| {
        for w in level.windows(3) {
            let holds = inner(&w[1])
                .iter()
                .any(|t| matches!(t, Tree::Str(s) if s == key));
            if is_ident(&w[0], "if") && is_group(&w[1], '(') && holds && is_group(&w[2], '{') {
                found = Some(inner(&w[2]));
                return true;
            }
        }
        false
    });
    found
}

/// The block of `case ...::label: { ... }` (at any depth).
pub fn case<'a>(trees: &'a [Tree], label: &str) -> Option<&'a [Tree]> {
    let mut found = None;
    each_level(trees, &mut |level| {
        for (i, t) in level.iter().enumerate() {
            if !is_ident(t, "case") {
                continue;
            }
            // The label ends at a ':' that is not part of a '::'.
            let mut j = i + 1;
            let mut last = None;
            while j < level.len() {
                match &level[j] {
                    Tree::Punct(':') if level.get(j + 1) == Some(&Tree::Punct(':')) => j += 2,
                    Tree::Punct(':') => break,
                    Tree::Ident(s) => {
                        last = Some(s.as_str());
                        j += 1
                    }
                    _ => break,
                }
            }
            if last == Some(label) && level.get(j) == Some(&Tree::Punct(':')) {
                if let Some(body) = level.get(j + 1).filter(|b| is_group(b, '{')) {
                    found = Some(inner(body));
                    return true;
                }
            }
        }
        false
    });
    found
}

/// Every identifier in `trees`, at any depth.
pub fn identifiers(trees: &[Tree]) -> Vec<&str> {
    let mut out = Vec::new();
    each_level(trees, &mut |level| {
        out.extend(level.iter().filter_map(|t| match t {
            Tree::Ident(s) => Some(s.as_str()),
            _ => None,
        }));
        false
    });
    out
}

/// The arguments of every call of `name` in `trees` (at any depth), each as its tokens. A
/// definition (`name(...) {`) is not a call.
pub fn calls<'a>(trees: &'a [Tree], name: &str) -> Vec<Vec<&'a [Tree]>> {
    let mut out = Vec::new();
    each_level(trees, &mut |level| {
        for (i, t) in level.iter().enumerate() {
            let args = level.get(i + 1).filter(|p| is_group(p, '('));
            let definition = level.get(i + 2).is_some_and(|b| is_group(b, '{'));
            if let (true, Some(args), false) = (is_ident(t, name), args, definition) {
                out.push(split_commas(inner(args)));
            }
        }
        false
    });
    out
}

fn split_commas(tokens: &[Tree]) -> Vec<&[Tree]> {
    if tokens.is_empty() {
        return Vec::new();
    }
    tokens.split(|t| *t == Tree::Punct(',')).collect()
}

/// The value given to variable `name` in `trees` (this level only: `T name = expr;`,
/// `T name(args);`, or a parameter's default `T name = expr`).
pub fn variable(trees: &[Tree], name: &str) -> Result<Value, String> {
    for (i, t) in trees.iter().enumerate() {
        if !is_ident(t, name)
            || !matches!(
                trees.get(i.wrapping_sub(1)),
                Some(Tree::Ident(_) | Tree::Punct('>' | '&'))
            )
        {
            continue;
        }
        match trees.get(i + 1) {
            Some(Tree::Punct('=')) => {
                let rest = &trees[i + 2..];
                let end = (rest.iter())
                    .position(|t| matches!(t, Tree::Punct(';' | ',')))
                    .unwrap_or(rest.len());
                return eval(&rest[..end]).map_err(|e| format!("variable {name}: {e}"));
            }
            Some(Tree::Group('(', args)) => {
                let Some(Tree::Ident(ty)) = trees.get(i - 1) else {
                    continue;
                };
                return call(ty, args).map_err(|e| format!("variable {name}: {e}"));
            }
            _ => {}
        }
    }
    Err(format!("variable {name} not found"))
}

/// Evaluates an expression.
pub fn eval(tokens: &[Tree]) -> Result<Value, String> {
    let mut at = 0;
    let v = sum(tokens, &mut at)?;
    if at != tokens.len() {
        return Err(format!("unexpected {}", describe(&tokens[at])));
    }
    Ok(v)
}

fn describe(t: &Tree) -> String {
    match t {
        Tree::Ident(s) => format!("identifier {s}"),
        Tree::Num(x) => format!("number {x}"),
        Tree::Str(s) => format!("string {s:?}"),
        Tree::Punct(c) => format!("{c:?}"),
        Tree::Group(c, _) => format!("group {c:?}"),
    }
}

fn arith(op: char, a: Value, b: Value) -> Result<Value, String> {
    let (a, b) = (a.num()?, b.num()?);
    Ok(Value::Num(match op {
        '+' => a + b,
        '-' => a - b,
        '*' => a * b,
        _ => a / b,
    }))
}

fn sum(t: &[Tree], at: &mut usize) -> Result<Value, String> {
    let mut v = product(t, at)?;
    while let Some(Tree::Punct(op @ ('+' | '-'))) = t.get(*at) {
        *at += 1;
        v = arith(*op, v, product(t, at)?)?;
    }
    Ok(v)
}

fn product(t: &[Tree], at: &mut usize) -> Result<Value, String> {
    let mut v = unary(t, at)?;
    while let Some(Tree::Punct(op @ ('*' | '/'))) = t.get(*at) {
        *at += 1;
        v = arith(*op, v, unary(t, at)?)?;
    }
    Ok(v)
}

fn unary(t: &[Tree], at: &mut usize) -> Result<Value, String> {
    match t.get(*at) {
        Some(Tree::Punct('-')) => {
            *at += 1;
            Ok(Value::Num(-unary(t, at)?.num()?))
        }
        Some(Tree::Punct('+')) => {
            *at += 1;
            unary(t, at)
        }
        _ => primary(t, at),
    }
}

fn primary(t: &[Tree], at: &mut usize) -> Result<Value, String> {
    let Some(first) = t.get(*at) else {
        return Err("expression ends early".to_string());
    };
    *at += 1;
    match first {
        Tree::Num(x) => Ok(Value::Num(*x)),
        Tree::Group('(', e) => eval(e),
        Tree::Group('{', items) => Ok(Value::List(
            (split_commas(items).into_iter())
                // A trailing comma leaves an empty last item.
                .filter(|item| !item.is_empty())
                .map(eval)
                .collect::<Result<_, _>>()?,
        )),
        Tree::Ident(first) => {
            let mut name = first.clone();
            while let (Some(Tree::Punct(':')), Some(Tree::Punct(':')), Some(Tree::Ident(next))) =
                (t.get(*at), t.get(*at + 1), t.get(*at + 2))
            {
                name = format!("{name}::{next}");
                *at += 3;
            }
            if let Some(Tree::Group('(', args)) = t.get(*at) {
                *at += 1;
                return call(&name, args);
            }
            match name.as_str() {
                "M_PI" => Ok(Value::Num(PI)),
                "M_PI_2" => Ok(Value::Num(FRAC_PI_2)),
                "M_PI_4" => Ok(Value::Num(FRAC_PI_4)),
                _ => Err(format!("identifier {name} has no value here")),
            }
        }
        other => Err(format!("unexpected {}", describe(other))),
    }
}

/// A call: vector constructors and unit vectors are lists, any other call is kept by name.
fn call(name: &str, args: &[Tree]) -> Result<Value, String> {
    let args: Vec<Value> = (split_commas(args).into_iter())
        .map(eval)
        .collect::<Result<_, _>>()?;
    let short = name.rsplit("::").next().unwrap_or(name);
    let unit = |k: usize| {
        Value::List(
            (0..3)
                .map(|i| Value::Num(f64::from(u8::from(i == k))))
                .collect(),
        )
    };
    Ok(match short {
        "Vector3d" | "Vector3f" => Value::List(args),
        "UnitX" => unit(0),
        "UnitY" => unit(1),
        "UnitZ" => unit(2),
        _ => Value::Call(name.to_string(), args),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOURCE: &str = r#"
#include <array>
#define TWICE(x) \
    ((x) * 2)
namespace scene {
// A comment with "quotes" and (brackets.
void add_table(PlanInstance &instance, const std::string &prefix, double thickness = 0.02)
{
    const double z = 0.05;
    const std::array<std::array<double, 3>, 2> rows = {{{0.0, -1.5e-1, 2.0F},
                                                        {0.75, 0.0, 1'000.0}}};
    const Eigen::Vector3d size(0.5, 0.5, 0.5);
    /* block comment ) */
    auto q = quaternion_from_rpy(0.0, M_PI_2, -2.0 * M_PI / 3.0);
}

void setup(const Config &config)
{
    switch (config.variant)
    {
    case Variant::Pair:
    {
        const std::array<double, 2> yaws = {M_PI, 0.0};
        break;
    }
    }
    if (config.name == "two" || config.name == "two_rod")
    {
        add_table(instance, "table");
    }
    else if (config.name == "four")
    {
        attach(instance, 0, "rod", 0.015, Eigen::Vector3d(0.0, 0.0, -0.005));
    }
}
}  // namespace scene
"#;

    #[test]
    fn finds_tables_branches_cases_and_calls() {
        let trees = parse(SOURCE).unwrap();
        let definition = function(&trees, "add_table").unwrap();
        let table = definition.body;
        assert_eq!(variable(table, "z").unwrap(), Value::Num(0.05));
        assert_eq!(
            variable(table, "rows").unwrap().rows(3).unwrap(),
            vec![vec![0.0, -0.15, 2.0], vec![0.75, 0.0, 1000.0]]
        );
        assert_eq!(
            variable(table, "size").unwrap().numbers(3).unwrap(),
            vec![0.5; 3]
        );
        let Value::Call(name, args) = variable(table, "q").unwrap() else {
            panic!("a call")
        };
        assert_eq!(name, "quaternion_from_rpy");
        assert_eq!(args[1], Value::Num(FRAC_PI_2));
        assert!((args[2].num().unwrap() + 2.0 * PI / 3.0).abs() < 1e-15);
        // A parameter's default value.
        assert_eq!(
            variable(definition.params, "thickness").unwrap(),
            Value::Num(0.02)
        );

        let setup = function(&trees, "setup").unwrap().body;
        let pair = case(setup, "Pair").unwrap();
        assert_eq!(
            variable(pair, "yaws").unwrap().numbers(2).unwrap(),
            vec![PI, 0.0]
        );
        assert!(case(setup, "Quad").is_none());
        let two = branch(setup, "two_rod").unwrap();
        assert!(identifiers(two).contains(&"add_table"));
        assert_eq!(calls(two, "add_table").len(), 1);
        // The definition of add_table is not a call.
        assert_eq!(calls(&trees, "add_table").len(), 1);
        let four = branch(setup, "four").unwrap();
        let attach = calls(four, "attach");
        assert_eq!(attach.len(), 1);
        assert_eq!(attach[0].len(), 5);
        assert_eq!(eval(attach[0][3]).unwrap(), Value::Num(0.015));
        assert_eq!(
            eval(attach[0][4]).unwrap().numbers(3).unwrap(),
            vec![0.0, 0.0, -0.005]
        );
        assert!(branch(setup, "six").is_none());
    }

    #[test]
    fn refuses_what_it_cannot_read() {
        assert!(parse("void f() { (] }").unwrap_err().contains("line 1"));
        assert!(parse("a\n\"open")
            .unwrap_err()
            .contains("line 2: unterminated"));
        assert!(parse("x = 0x1g;").unwrap_err().contains("not understood"));
        let trees = parse("void f() { double a = b + 1; double c = 1 + ; }").unwrap();
        let body = function(&trees, "f").unwrap().body;
        assert!(variable(body, "a")
            .unwrap_err()
            .contains("identifier b has no value"));
        assert!(variable(body, "c").unwrap_err().contains("ends early"));
        assert!(variable(body, "d").unwrap_err().contains("not found"));
        // One row, and numbers in double braces.
        let one = eval(&parse("{{{1, 2}}}").unwrap()).unwrap();
        assert_eq!(one.rows(2).unwrap(), vec![vec![1.0, 2.0]]);
        assert_eq!(
            eval(&parse("{{1, 2}}").unwrap())
                .unwrap()
                .numbers(2)
                .unwrap(),
            [1.0, 2.0]
        );
        let v = eval(&parse("{1, 2}").unwrap()).unwrap();
        assert!(v
            .numbers(3)
            .unwrap_err()
            .contains("expected 3 numbers, found 2"));
        assert!(v.rows(2).unwrap_err().contains("row 0"));
    }
}
