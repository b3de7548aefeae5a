//! A strict reader for the small YAML subset Autoware's map files use: block
//! mappings of `key: value`, one level of nesting, flow sequences `[a, b]`
//! and block sequences (`- a`), comments, quoted or plain scalars.
//!
//! Why not a YAML crate: the maintained serde YAML crates were deprecated or
//! forked in 2024, and these two files need a dozen lines of grammar. What the
//! subset does not cover (anchors, tags, flow mappings, block scalars,
//! several documents) is refused with its line, never misread.

/// A value: a scalar, a sequence of scalars or a nested mapping.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Value {
    /// A plain or quoted scalar (empty for a key with no value).
    Scalar(String),
    /// `[a, b]` or `- a` lines.
    Seq(Vec<String>),
    /// Indented `key: value` lines.
    Map(Vec<Entry>),
}

/// One `key: value` pair and its 1-based line.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Entry {
    pub(crate) key: String,
    pub(crate) line: u64,
    pub(crate) value: Value,
}

/// A parse error: 1-based line and message.
pub(crate) type Fail = (u64, String);

#[derive(Debug)]
enum Kind {
    /// `key: value` (value `None` when empty: a block follows or nothing).
    Pair(String, Option<Value>),
    /// `- scalar`.
    Item(String),
}

#[derive(Debug)]
struct Line {
    no: u64,
    indent: usize,
    kind: Kind,
}

/// Parses `text` into its top-level mapping, in file order (duplicate keys
/// are kept: callers say what a duplicate means).
pub(crate) fn parse(text: &str) -> Result<Vec<Entry>, Fail> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = Vec::new();
    let mut started = false;
    for (i, raw) in text.split('\n').enumerate() {
        let no = i as u64 + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        let body = strip_comment(raw);
        let body = body.trim_end();
        if body.trim_start().is_empty() {
            continue;
        }
        let indent = body.len() - body.trim_start_matches(' ').len();
        let rest = &body[indent..];
        if rest.starts_with('\t') {
            return Err((
                no,
                "a tab in the indentation (YAML indents with spaces)".into(),
            ));
        }
        if indent == 0 && (rest == "---" || rest.starts_with("--- ")) {
            if started {
                return Err((no, "a second YAML document: one is expected".into()));
            }
            if rest != "---" {
                return Err((no, "content after `---`: put it on the next line".into()));
            }
            continue;
        }
        if indent == 0 && rest == "..." {
            break;
        }
        if indent == 0 && rest.starts_with('%') {
            return Err((no, "YAML directives are not supported".into()));
        }
        started = true;
        let kind = if rest == "-" || rest.starts_with("- ") {
            let v = rest[1..].trim();
            match scalar(v, no)? {
                Value::Scalar(s) => Kind::Item(s),
                _ => return Err((no, "nested sequences are not supported".into())),
            }
        } else {
            let (key, after) = split_key(rest, no)?;
            let after = after.trim();
            let value = if after.is_empty() {
                None
            } else {
                Some(scalar(after, no)?)
            };
            Kind::Pair(key, value)
        };
        lines.push(Line { no, indent, kind });
    }
    let mut i = 0;
    let top = match lines.first() {
        None => return Ok(Vec::new()),
        Some(l) if l.indent != 0 => {
            return Err((l.no, "the first key is indented".into()));
        }
        Some(_) => block(&lines, &mut i, 0)?,
    };
    if let Some(l) = lines.get(i) {
        return Err((l.no, "indentation does not match any key above".into()));
    }
    Ok(top)
}

/// The mapping whose keys sit at `indent`, from `lines[*i]` on.
fn block(lines: &[Line], i: &mut usize, indent: usize) -> Result<Vec<Entry>, Fail> {
    let mut out = Vec::new();
    while let Some(l) = lines.get(*i) {
        if l.indent < indent {
            break;
        }
        if l.indent > indent {
            return Err((l.no, "unexpected indentation".into()));
        }
        let (key, inline) = match &l.kind {
            Kind::Pair(k, v) => (k.clone(), v.clone()),
            Kind::Item(_) => {
                return Err((l.no, "a `- item` where a `key: value` is expected".into()));
            }
        };
        *i += 1;
        let value = match inline {
            Some(v) => v,
            None => match lines.get(*i) {
                // A block sequence may sit at the key's own indentation.
                Some(n) if matches!(n.kind, Kind::Item(_)) && n.indent >= indent => {
                    let at = n.indent;
                    let mut items = Vec::new();
                    while let Some(n) = lines.get(*i) {
                        match &n.kind {
                            Kind::Item(s) if n.indent == at => items.push(s.clone()),
                            _ if n.indent > at => {
                                return Err((n.no, "unexpected indentation".into()));
                            }
                            _ => break,
                        }
                        *i += 1;
                    }
                    Value::Seq(items)
                }
                Some(n) if n.indent > indent => Value::Map(block(lines, i, n.indent)?),
                _ => Value::Scalar(String::new()),
            },
        };
        out.push(Entry {
            key,
            line: l.no,
            value,
        });
    }
    Ok(out)
}

/// The line without a `#` comment (one at the start or after a space,
/// outside quotes).
fn strip_comment(s: &str) -> &str {
    let b = s.as_bytes();
    let mut quote = None;
    for (i, &c) in b.iter().enumerate() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == b'"' || c == b'\'' => quote = Some(c),
            None if c == b'#' && (i == 0 || b[i - 1] == b' ' || b[i - 1] == b'\t') => {
                return &s[..i];
            }
            None => {}
        }
    }
    s
}

/// `key` and the text after its `:`.
fn split_key(s: &str, no: u64) -> Result<(String, &str), Fail> {
    if s.starts_with('"') || s.starts_with('\'') {
        let (key, used) = quoted(s, no)?;
        let rest = s[used..].trim_start();
        let after = rest
            .strip_prefix(':')
            .ok_or_else(|| (no, format!("expected `:` after the key {key:?}")))?;
        if !(after.is_empty() || after.starts_with(' ')) {
            return Err((no, "expected a space after `:`".into()));
        }
        return Ok((key, after));
    }
    if s.starts_with(['{', '[', '&', '*', '!', '?', '|', '>', '@', '`']) {
        return Err((no, format!("unsupported YAML syntax: `{s}`")));
    }
    let b = s.as_bytes();
    for (k, &c) in b.iter().enumerate() {
        if c == b':' && (k + 1 == b.len() || b[k + 1] == b' ') {
            let key = s[..k].trim_end();
            if key.is_empty() {
                return Err((no, "an empty key".into()));
            }
            return Ok((key.to_string(), &s[k + 1..]));
        }
    }
    Err((no, format!("expected `key: value`, found `{s}`")))
}

/// A scalar or a flow sequence.
fn scalar(v: &str, no: u64) -> Result<Value, Fail> {
    if let Some(inner) = v.strip_prefix('[') {
        let inner = inner
            .strip_suffix(']')
            .ok_or_else(|| (no, "a `[` sequence must close with `]` on its line".into()))?;
        if inner.trim().is_empty() {
            return Ok(Value::Seq(Vec::new()));
        }
        let mut items = Vec::new();
        for part in inner.split(',') {
            let p = part.trim();
            if p.is_empty() {
                return Err((no, "an empty item in `[...]`".into()));
            }
            match plain_or_quoted(p, no)? {
                s if p.starts_with(['[', '{']) => {
                    return Err((no, format!("nested collections are not supported: `{s}`")));
                }
                s => items.push(s),
            }
        }
        return Ok(Value::Seq(items));
    }
    Ok(Value::Scalar(plain_or_quoted(v, no)?))
}

fn plain_or_quoted(v: &str, no: u64) -> Result<String, Fail> {
    if v.starts_with('"') || v.starts_with('\'') {
        let (s, used) = quoted(v, no)?;
        if !v[used..].trim().is_empty() {
            return Err((no, format!("text after the quoted value {s:?}")));
        }
        return Ok(s);
    }
    if v.starts_with(['{', '&', '*', '!', '|', '>', '@', '`', '%']) {
        return Err((no, format!("unsupported YAML syntax: `{v}`")));
    }
    if v.contains(['[', ']', '{', '}']) {
        return Err((no, format!("unsupported YAML syntax: `{v}`")));
    }
    Ok(v.to_string())
}

/// A quoted string at the start of `s` and the bytes it used: `'…'` with
/// `''` for a quote, `"…"` with `\"` and `\\` escapes.
fn quoted(s: &str, no: u64) -> Result<(String, usize), Fail> {
    let q = s.as_bytes()[0] as char;
    let mut out = String::new();
    let mut it = s.char_indices().skip(1).peekable();
    while let Some((k, c)) = it.next() {
        if c == q {
            if q == '\'' && it.peek().is_some_and(|&(_, n)| n == '\'') {
                it.next();
                out.push('\'');
                continue;
            }
            return Ok((out, k + 1));
        }
        if q == '"' && c == '\\' {
            match it.next() {
                Some((_, '"')) => out.push('"'),
                Some((_, '\\')) => out.push('\\'),
                Some((_, '/')) => out.push('/'),
                Some((_, e)) => {
                    return Err((no, format!("unsupported escape `\\{e}` in a quoted string")));
                }
                None => break,
            }
            continue;
        }
        out.push(c);
    }
    Err((no, "a quoted string is not closed on its line".into()))
}

/// The error for a key given twice at one level, if any.
pub(crate) fn check_unique(entries: &[Entry]) -> Result<(), Fail> {
    let mut seen: std::collections::HashMap<&str, u64> = std::collections::HashMap::new();
    for e in entries {
        if let Some(first) = seen.insert(&e.key, e.line) {
            return Err((
                e.line,
                format!("`{}` is listed twice (lines {first} and {})", e.key, e.line),
            ));
        }
    }
    Ok(())
}

/// A finite number from a scalar.
pub(crate) fn number(e: &Entry, s: &str) -> Result<f64, Fail> {
    let t = s.trim();
    // Rust parses `inf` and `NaN`; YAML spells them `.inf`/`.nan`; neither
    // is a coordinate.
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err((e.line, format!("`{}`: `{t}` is not a finite number", e.key))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &str) -> Value {
        Value::Scalar(v.into())
    }

    #[test]
    fn reads_metadata_and_projector_layouts() {
        let text = "# written by pointcloud_divider\n---\nx_resolution: 20.0\ny_resolution: 20 # m\n\
                    A.pcd: [1200, 2500] # -> 1200 <= x < 1220\n\"B b.pcd\": [ 1220 , '2500' ]\n\
                    C.pcd:\n  - 1240\n  - 2500\nD.pcd:\n- 1\n- 2\nmap_origin:\n  latitude: 35.5 \r\n  longitude: '139.5'\n";
        let e = parse(text).unwrap();
        let keys: Vec<_> = e.iter().map(|e| (e.key.as_str(), e.line)).collect();
        assert_eq!(
            keys,
            [
                ("x_resolution", 3),
                ("y_resolution", 4),
                ("A.pcd", 5),
                ("B b.pcd", 6),
                ("C.pcd", 7),
                ("D.pcd", 10),
                ("map_origin", 13)
            ]
        );
        assert_eq!(e[1].value, s("20"));
        assert_eq!(e[2].value, Value::Seq(vec!["1200".into(), "2500".into()]));
        assert_eq!(e[3].value, Value::Seq(vec!["1220".into(), "2500".into()]));
        assert_eq!(e[4].value, Value::Seq(vec!["1240".into(), "2500".into()]));
        assert_eq!(e[5].value, Value::Seq(vec!["1".into(), "2".into()]));
        let Value::Map(m) = &e[6].value else {
            panic!("{:?}", e[6].value)
        };
        assert_eq!(m[0].value, s("35.5"));
        assert_eq!(m[1].value, s("139.5"));
        assert_eq!(m[1].line, 15);
        assert_eq!(parse("").unwrap(), Vec::new());
        assert_eq!(parse("# only\n\n").unwrap(), Vec::new());
    }

    #[test]
    fn refuses_what_it_does_not_read_with_the_line() {
        for (text, line, what) in [
            ("a: 1\n\tb: 2\n", 2, "tab"),
            ("a: 1\n  b: 2\n", 2, "indentation"),
            ("a: [1, 2\n", 1, "close"),
            ("a: {x: 1}\n", 1, "unsupported"),
            ("a: &x 1\n", 1, "unsupported"),
            ("a: |\n  text\n", 1, "unsupported"),
            ("a: 1\n---\nb: 2\n", 2, "second"),
            ("a: \"open\n", 1, "not closed"),
            ("just text\n", 1, "key: value"),
            ("a:\n  - 1\n  - [2]\n", 3, "nested"),
            ("- 1\n", 1, "item"),
            ("  a: 1\n", 1, "indented"),
            ("a: [1, , 2]\n", 1, "empty item"),
            ("a:\n  b:\n    c: 1\n   d: 2\n", 4, "indentation"),
        ] {
            let (l, msg) = parse(text).unwrap_err();
            assert_eq!(l, line, "{text:?}: {msg}");
            assert!(msg.contains(what), "{text:?}: {msg}");
        }
        let e = parse("a: 1\nb: 2\na: 3\n").unwrap();
        let (l, msg) = check_unique(&e).unwrap_err();
        assert_eq!(l, 3);
        assert!(msg.contains("lines 1 and 3"), "{msg}");
    }

    #[test]
    fn comments_and_quotes() {
        let e = parse("'it''s#1.pcd': \"x # y\" # c\nk: a#b\n").unwrap();
        assert_eq!(e[0].key, "it's#1.pcd");
        assert_eq!(e[0].value, s("x # y"));
        assert_eq!(e[1].value, s("a#b"));
        let e = parse("k:\n").unwrap();
        assert_eq!(e[0].value, s(""));
        let e = parse("k: 1\n...\nnot yaml at all {\n").unwrap();
        assert_eq!(e.len(), 1);
    }
}
