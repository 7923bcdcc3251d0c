//! Where things are in a `pipeline.ron`: the line and column of each job and of each field a
//! job (or `limits`) writes, so a setting that parses but is out of range is reported at its
//! place (`pipeline.ron:10:24: job `t`: directions must be 1 to 256, found 0`), as syntax
//! errors are.
//!
//! The text has already parsed as a pipeline when this runs, so the scanner only needs RON's
//! lexical rules (comments, strings, raw strings, chars) and its brackets; anything it cannot
//! follow leaves the place unknown, never an error.

use std::collections::BTreeMap;

/// A 1-based line and column (in characters).
pub type Place = (usize, usize);

/// The places in a pipeline file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spans {
    /// Per job, in order: where it starts and where each of its fields is named.
    pub jobs: Vec<Fields>,
    /// The fields of `limits: (…)`.
    pub limits: Fields,
    /// The fields of `tolerances: (…)`.
    pub tolerances: Fields,
}

/// Where a value starts and where each field inside it is named.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fields {
    /// The value's first token.
    pub start: Option<Place>,
    /// Field name → place of the name.
    pub fields: BTreeMap<String, Place>,
}

impl Fields {
    /// The place of field `name`, else the value's start.
    pub fn place(&self, name: &str) -> Option<Place> {
        self.fields.get(name).copied().or(self.start)
    }

    /// The place of the field a setting message names first (`directions must be …`), else the
    /// value's start.
    pub fn place_of(&self, message: &str) -> Option<Place> {
        let first = message.split(|c: char| !(c.is_alphanumeric() || c == '_')).next().unwrap_or("");
        self.fields.get(first).copied().or(self.start)
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Token {
    Ident(String),
    Punct(char),
    Other,
}

/// The places of `text`, as far as the scanner can follow it.
pub fn scan(text: &str) -> Spans {
    let tokens = tokenize(text);
    let mut p = Parser { tokens: &tokens, at: 0 };
    let mut spans = Spans::default();
    // `#![enable(…)]` attributes, then the pipeline struct (its name optional).
    while p.peek_punct('#') {
        p.at += 1;
        p.eat_punct('!');
        p.skip_value();
    }
    if matches!(p.peek(), Some(Token::Ident(_))) {
        p.at += 1;
    }
    if !p.eat_punct('(') {
        return spans;
    }
    while let Some((name, _)) = p.field_name() {
        match name.as_str() {
            "jobs" if p.eat_punct('[') => {
                while !p.peek_punct(']') && p.at < tokens.len() {
                    spans.jobs.push(p.fields_of_value());
                    p.eat_punct(',');
                }
                p.eat_punct(']');
            }
            "limits" => spans.limits = p.fields_of_value(),
            "tolerances" => spans.tolerances = p.fields_of_value(),
            _ => p.skip_value(),
        }
        p.eat_punct(',');
    }
    spans
}

struct Parser<'a> {
    tokens: &'a [(Token, Place)],
    at: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at).map(|t| &t.0)
    }

    fn peek_punct(&self, c: char) -> bool {
        self.peek() == Some(&Token::Punct(c))
    }

    fn eat_punct(&mut self, c: char) -> bool {
        let found = self.peek_punct(c);
        self.at += found as usize;
        found
    }

    /// `ident :` at the cursor: the name and its place, consumed.
    fn field_name(&mut self) -> Option<(String, Place)> {
        match (self.tokens.get(self.at), self.tokens.get(self.at + 1)) {
            (Some((Token::Ident(name), place)), Some((Token::Punct(':'), _))) => {
                self.at += 2;
                Some((name.clone(), *place))
            }
            _ => None,
        }
    }

    /// A value `Name(field: …, …)` or `(…)`: its start and its fields' places, consumed.
    fn fields_of_value(&mut self) -> Fields {
        let mut out = Fields { start: self.tokens.get(self.at).map(|t| t.1), ..Fields::default() };
        if matches!(self.peek(), Some(Token::Ident(_))) {
            self.at += 1;
        }
        if !self.eat_punct('(') {
            self.skip_value();
            return out;
        }
        while !self.peek_punct(')') && self.at < self.tokens.len() {
            match self.field_name() {
                Some((name, place)) => {
                    out.fields.insert(name, place);
                    self.skip_value();
                }
                None => self.skip_value(),
            }
            self.eat_punct(',');
        }
        self.eat_punct(')');
        out
    }

    /// Skips one value: a name, a bracketed group, or both (`Some(…)`), or one token.
    fn skip_value(&mut self) {
        if matches!(self.peek(), Some(Token::Ident(_))) {
            self.at += 1;
            if !matches!(self.peek(), Some(Token::Punct('(' | '[' | '{'))) {
                return;
            }
        }
        match self.peek() {
            Some(Token::Punct(open @ ('(' | '[' | '{'))) => {
                let mut depth = 0usize;
                let _ = open;
                while let Some(t) = self.peek() {
                    match t {
                        Token::Punct('(' | '[' | '{') => depth += 1,
                        Token::Punct(')' | ']' | '}') => depth -= 1,
                        _ => {}
                    }
                    self.at += 1;
                    if depth == 0 {
                        break;
                    }
                }
            }
            Some(Token::Punct(',' | ')' | ']' | '}')) | None => {}
            Some(_) => {
                // A literal, possibly signed or a range of tokens up to the next separator.
                while !matches!(self.peek(), Some(Token::Punct(',' | ')' | ']' | '}')) | None) {
                    self.at += 1;
                }
            }
        }
    }
}

/// RON's tokens, with their places: identifiers, brackets and separators; strings, chars,
/// numbers and comments reduced to `Other` or dropped.
fn tokenize(text: &str) -> Vec<(Token, Place)> {
    let chars: Vec<char> = text.chars().collect();
    let mut tokens = Vec::new();
    let (mut i, mut line, mut col) = (0usize, 1usize, 1usize);
    // Advances over `n` characters, keeping the place.
    let advance = |i: &mut usize, line: &mut usize, col: &mut usize, n: usize| {
        for _ in 0..n {
            if *i < chars.len() {
                if chars[*i] == '\n' {
                    *line += 1;
                    *col = 1;
                } else {
                    *col += 1;
                }
                *i += 1;
            }
        }
    };
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        let place = (line, col);
        if c.is_whitespace() {
            advance(&mut i, &mut line, &mut col, 1);
        } else if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                advance(&mut i, &mut line, &mut col, 1);
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0usize;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    advance(&mut i, &mut line, &mut col, 2);
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    advance(&mut i, &mut line, &mut col, 2);
                    if depth == 0 {
                        break;
                    }
                } else {
                    advance(&mut i, &mut line, &mut col, 1);
                }
            }
        } else if c == 'r' && matches!(next, Some('"' | '#')) && raw_string_len(&chars[i..]).is_some() {
            let n = raw_string_len(&chars[i..]).unwrap_or(1);
            advance(&mut i, &mut line, &mut col, n);
            tokens.push((Token::Other, place));
        } else if c == '"' || c == '\'' {
            let mut j = i + 1;
            while j < chars.len() && chars[j] != c {
                j += if chars[j] == '\\' { 2 } else { 1 };
            }
            let n = j + 1 - i;
            advance(&mut i, &mut line, &mut col, n);
            tokens.push((Token::Other, place));
        } else if c.is_alphabetic() || c == '_' {
            let mut j = i;
            while j < chars.len() && (chars[j].is_alphanumeric() || chars[j] == '_' || chars[j] == '#') {
                j += 1;
            }
            let name: String = chars[i..j].iter().collect();
            let n = j - i;
            advance(&mut i, &mut line, &mut col, n);
            tokens.push((Token::Ident(name.trim_start_matches("r#").to_string()), place));
        } else if "()[]{},:#!".contains(c) {
            advance(&mut i, &mut line, &mut col, 1);
            tokens.push((Token::Punct(c), place));
        } else {
            advance(&mut i, &mut line, &mut col, 1);
            tokens.push((Token::Other, place));
        }
    }
    tokens
}

/// The length of a raw string `r#"…"#` at the start of `chars`, if it is one.
fn raw_string_len(chars: &[char]) -> Option<usize> {
    let hashes = chars[1..].iter().take_while(|&&c| c == '#').count();
    if chars.get(1 + hashes) != Some(&'"') {
        return None;
    }
    let mut j = 2 + hashes;
    while j < chars.len() {
        if chars[j] == '"' && chars[j + 1..].iter().take(hashes).filter(|&&c| c == '#').count() == hashes {
            return Some(j + 1 + hashes);
        }
        j += 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jobs_and_fields_are_found_past_comments_strings_and_nesting() {
        let text = "#![enable(implicit_some)]\n(\n  output: \"b(\", // a comment (\n  limits: (max_dimension: 0),\n  /* block ( */ jobs: [\n    Heightfield(id: \"x\", input: r#\"a\"b\"#, texel_size: (1, 2)),\n    Horizon(\n      id: \"t\",\n      directions: 0,\n    ),\n  ],\n)";
        let s = scan(text);
        assert_eq!(s.limits.fields.get("max_dimension"), Some(&(4, 12)));
        assert_eq!(s.jobs.len(), 2);
        assert_eq!(s.jobs[0].start, Some((6, 5)));
        assert_eq!(s.jobs[0].fields.get("texel_size"), Some(&(6, 43)));
        assert_eq!(s.jobs[1].fields.get("directions"), Some(&(9, 7)));
        assert_eq!(s.jobs[1].place_of("directions must be 1 to 256, found 0"), Some((9, 7)));
        assert_eq!(s.jobs[1].place_of("a tiled bake needs max_distance"), Some((7, 5)));
    }
}
