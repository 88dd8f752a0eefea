//! A small, tolerant YAML reader for what `cv::FileStorage` writes.

use super::Node;

struct YLine {
    no: usize,
    indent: usize,
    text: String,
}

/// Remove a `#` comment (one at the start or after whitespace, outside quotes).
fn strip_yaml_comment(line: &str) -> &str {
    let mut quote = None;
    let mut prev_space = true;
    for (i, c) in line.char_indices() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '"' || c == '\'' => quote = Some(c),
            None if c == '#' && prev_space => return &line[..i],
            None => {}
        }
        prev_space = c.is_whitespace();
    }
    line
}

pub(super) fn parse_yaml(text: &str) -> Result<Node, String> {
    let mut lines = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let l = strip_yaml_comment(raw.trim_end_matches('\r')).trim_end();
        let body = l.trim_start_matches([' ', '\t']);
        if body.is_empty() || (body.starts_with('%') && l.len() == body.len()) {
            continue;
        }
        if body == "---" || body.starts_with("--- ") || body == "..." {
            // Document markers; `--- !!tag` keeps nothing useful either.
            continue;
        }
        lines.push(YLine {
            no: i + 1,
            indent: l.len() - body.len(),
            text: body.to_string(),
        });
    }
    if lines.is_empty() {
        return Err("empty file".into());
    }
    let mut i = 0;
    let node = yaml_block(&mut lines, &mut i)?;
    if i < lines.len() {
        return Err(format!("line {}: unexpected indentation", lines[i].no));
    }
    Ok(node)
}

fn is_seq_item(t: &str) -> bool {
    t == "-" || t.starts_with("- ")
}

fn yaml_block(lines: &mut [YLine], i: &mut usize) -> Result<Node, String> {
    if is_seq_item(&lines[*i].text) {
        yaml_seq(lines, i)
    } else {
        yaml_map(lines, i)
    }
}

/// Split `key: value` at the first `:` followed by a space or the end, outside quotes.
fn split_key(t: &str) -> Option<(String, &str)> {
    let mut quote = None;
    let b = t.as_bytes();
    for (i, c) in t.char_indices() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '"' || c == '\'' => quote = Some(c),
            None if c == ':' && (i + 1 == b.len() || b[i + 1] == b' ' || b[i + 1] == b'\t') => {
                return Some((unquote(&t[..i]), t[i + 1..].trim()));
            }
            None => {}
        }
    }
    None
}

fn unquote(s: &str) -> String {
    let s = s.trim();
    for q in ['"', '\''] {
        if s.len() >= 2 && s.starts_with(q) && s.ends_with(q) {
            return s[1..s.len() - 1].to_string();
        }
    }
    s.to_string()
}

/// Drop a leading tag such as `!!opencv-matrix` or `!<tag:yaml.org,2002:opencv-matrix>`.
fn strip_tag(v: &str) -> &str {
    if v.starts_with('!') {
        match v.find(char::is_whitespace) {
            Some(p) => v[p..].trim_start(),
            None => "",
        }
    } else {
        v
    }
}

/// A value on the rest of a line: a flow collection (joined with the following lines until its
/// brackets balance) or a scalar. Advances `i` past the lines used.
fn yaml_inline(lines: &[YLine], i: &mut usize, first: &str) -> Result<Node, String> {
    let no = lines[*i].no;
    *i += 1;
    if first.starts_with('[') || first.starts_with('{') {
        let mut text = first.to_string();
        while !flow_balanced(&text) {
            let Some(l) = lines.get(*i) else {
                return Err(format!("line {no}: unclosed `{}`", &first[..1]));
            };
            text.push(' ');
            text.push_str(&l.text);
            *i += 1;
        }
        let mut p = FlowParser {
            s: text.as_bytes(),
            pos: 0,
        };
        let n = p.value().map_err(|m| format!("line {no}: {m}"))?;
        p.skip_ws();
        if p.pos != p.s.len() {
            return Err(format!(
                "line {no}: unexpected text after the closing bracket"
            ));
        }
        Ok(n)
    } else {
        Ok(Node::Scalar(unquote(first)))
    }
}

fn flow_balanced(t: &str) -> bool {
    let mut depth = 0i32;
    let mut quote = None;
    for c in t.chars() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None => match c {
                '"' | '\'' => quote = Some(c),
                '[' | '{' => depth += 1,
                ']' | '}' => depth -= 1,
                _ => {}
            },
        }
    }
    depth <= 0
}

fn yaml_map(lines: &mut [YLine], i: &mut usize) -> Result<Node, String> {
    let ind = lines[*i].indent;
    let mut map = Vec::new();
    while *i < lines.len() && lines[*i].indent >= ind {
        let (no, indent) = (lines[*i].no, lines[*i].indent);
        if indent > ind {
            return Err(format!("line {no}: unexpected indentation"));
        }
        let text = lines[*i].text.clone();
        if is_seq_item(&text) {
            return Err(format!(
                "line {no}: list item where a `key: value` was expected"
            ));
        }
        let (key, rest) =
            split_key(&text).ok_or_else(|| format!("line {no}: expected `key: value`"))?;
        let rest = strip_tag(rest);
        let value = if rest.is_empty() {
            *i += 1;
            match lines.get(*i) {
                Some(l) if l.indent > ind || (l.indent == ind && is_seq_item(&l.text)) => {
                    yaml_block(lines, i)?
                }
                _ => Node::Scalar(String::new()),
            }
        } else {
            yaml_inline(lines, i, rest)?
        };
        map.push((key, value));
    }
    Ok(Node::Map(map))
}

fn yaml_seq(lines: &mut [YLine], i: &mut usize) -> Result<Node, String> {
    let ind = lines[*i].indent;
    let mut seq = Vec::new();
    while *i < lines.len() && lines[*i].indent == ind && is_seq_item(&lines[*i].text) {
        let text = lines[*i].text.clone();
        let item = text[1..].trim_start();
        let item = strip_tag(item);
        if item.is_empty() {
            *i += 1;
            match lines.get(*i) {
                Some(l) if l.indent > ind => seq.push(yaml_block(lines, i)?),
                _ => seq.push(Node::Scalar(String::new())),
            }
        } else if !item.starts_with('[') && !item.starts_with('{') && split_key(item).is_some() {
            // Compact nested map `- key: value`: re-read this line as a map at the item's column.
            let offset = text.len() - item.len();
            lines[*i].indent = ind + offset;
            lines[*i].text = item.to_string();
            seq.push(yaml_map(lines, i)?);
        } else {
            seq.push(yaml_inline(lines, i, item)?);
        }
    }
    Ok(Node::Seq(seq))
}

struct FlowParser<'a> {
    s: &'a [u8],
    pos: usize,
}

impl FlowParser<'_> {
    fn skip_ws(&mut self) {
        while self.pos < self.s.len() && (self.s[self.pos] as char).is_whitespace() {
            self.pos += 1;
        }
    }

    fn value(&mut self) -> Result<Node, String> {
        self.skip_ws();
        match self.s.get(self.pos) {
            Some(b'[') => {
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    self.skip_ws();
                    if self.s.get(self.pos) == Some(&b']') {
                        self.pos += 1;
                        return Ok(Node::Seq(items));
                    }
                    items.push(self.value()?);
                    self.skip_ws();
                    match self.s.get(self.pos) {
                        Some(b',') => self.pos += 1,
                        Some(b']') => {}
                        _ => return Err("expected `,` or `]` in a list".into()),
                    }
                }
            }
            Some(b'{') => {
                self.pos += 1;
                let mut map = Vec::new();
                loop {
                    self.skip_ws();
                    if self.s.get(self.pos) == Some(&b'}') {
                        self.pos += 1;
                        return Ok(Node::Map(map));
                    }
                    let key = self.scalar(b":")?;
                    if self.s.get(self.pos) != Some(&b':') {
                        return Err("expected `key: value` in a `{ }` map".into());
                    }
                    self.pos += 1;
                    let v = self.value()?;
                    map.push((key, v));
                    self.skip_ws();
                    match self.s.get(self.pos) {
                        Some(b',') => self.pos += 1,
                        Some(b'}') => {}
                        _ => return Err("expected `,` or `}` in a map".into()),
                    }
                }
            }
            Some(_) => Ok(Node::Scalar(self.scalar(b"")?)),
            None => Err("missing value".into()),
        }
    }

    /// A plain or quoted scalar, ending before `,`, `]`, `}` or any of `extra`.
    fn scalar(&mut self, extra: &[u8]) -> Result<String, String> {
        self.skip_ws();
        if let Some(&q) = self.s.get(self.pos).filter(|&&c| c == b'"' || c == b'\'') {
            let start = self.pos + 1;
            let end = self.s[start..]
                .iter()
                .position(|&c| c == q)
                .ok_or("unclosed quote")?
                + start;
            self.pos = end + 1;
            return Ok(String::from_utf8_lossy(&self.s[start..end]).into_owned());
        }
        let start = self.pos;
        while self.pos < self.s.len() {
            let c = self.s[self.pos];
            if c == b',' || c == b']' || c == b'}' || extra.contains(&c) {
                break;
            }
            self.pos += 1;
        }
        Ok(String::from_utf8_lossy(&self.s[start..self.pos])
            .trim()
            .to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::super::matrix_values;
    use super::*;

    #[test]
    fn yaml_reader_handles_filestorage_shapes() {
        let t = "%YAML:1.0\n---\na: 3\nm: !!opencv-matrix\n   rows: 1\n   cols: 3\n   dt: d\n   data: [ 1., 2.,\n       3. ]\n\
                 s:\n  - 1\n  - { x: 2 }\n  - k: 4\n    j: 5\n";
        let n = parse_yaml(t).unwrap();
        assert_eq!(n.get("a"), Some(&Node::Scalar("3".into())));
        assert_eq!(
            matrix_values(n.get("m").unwrap()).unwrap(),
            vec![1.0, 2.0, 3.0]
        );
        let Some(Node::Seq(s)) = n.get("s") else {
            panic!("seq")
        };
        assert_eq!(s.len(), 3);
        assert_eq!(s[2].get("j"), Some(&Node::Scalar("5".into())));
    }
}
