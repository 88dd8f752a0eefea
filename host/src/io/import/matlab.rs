//! A reader of the Matlab statements a toolbox results script holds: `name = literal;` with
//! numbers and bracketed lists (nothing is evaluated).

/// `name = expression;` statements of a Matlab script: (name, 1-based line, expression text).
/// Comments (`%` to end of line) are removed; `;` inside brackets does not end a statement.
pub(super) fn matlab_assignments(text: &str) -> Vec<(String, usize, String)> {
    // Strip comments line by line (a `%` inside a quoted string is not expected in these files).
    let mut chars: Vec<(char, usize)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.split('%').next().unwrap_or("");
        chars.extend(code.chars().map(|c| (c, i + 1)));
        chars.push(('\n', i + 1));
    }
    let mut out = Vec::new();
    let mut i = 0;
    let n = chars.len();
    while i < n {
        // Statement start: skip separators.
        while i < n && (chars[i].0.is_whitespace() || chars[i].0 == ';' || chars[i].0 == ',') {
            i += 1;
        }
        let start = i;
        let line = chars.get(i).map_or(0, |c| c.1);
        // Read to the end of the statement: `;`, `,` or newline at bracket depth 0.
        let mut depth = 0i32;
        while i < n {
            let c = chars[i].0;
            match c {
                '[' | '(' | '{' => depth += 1,
                ']' | ')' | '}' => depth -= 1,
                ';' | ',' | '\n' if depth <= 0 => break,
                _ => {}
            }
            i += 1;
        }
        let stmt: String = chars[start..i].iter().map(|c| c.0).collect();
        if let Some((lhs, rhs)) = stmt.split_once('=') {
            let name = lhs.trim();
            let is_ident = !name.is_empty()
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                && !name.starts_with(|c: char| c.is_ascii_digit());
            if is_ident && !rhs.starts_with('=') {
                out.push((name.to_string(), line, rhs.trim().to_string()));
            }
        }
    }
    out
}

/// The numbers of a Matlab literal: `3.5`, `[ 1 ; 2 ]`, `[1, 2 3]` (row/column structure ignored).
pub(super) fn matlab_numbers(expr: &str) -> Result<Vec<f64>, String> {
    let e = expr.trim();
    let inner = if let Some(rest) = e.strip_prefix('[') {
        rest.strip_suffix(']')
            .ok_or_else(|| format!("unbalanced brackets in `{e}`"))?
    } else {
        e
    };
    let mut v = Vec::new();
    for tok in inner
        .split(|c: char| c.is_whitespace() || c == ';' || c == ',')
        .filter(|t| !t.is_empty())
    {
        let x = match tok.to_ascii_lowercase().as_str() {
            "nan" => f64::NAN,
            "inf" => f64::INFINITY,
            "-inf" => f64::NEG_INFINITY,
            _ => tok
                .parse::<f64>()
                .map_err(|_| format!("`{tok}` is not a number (expressions are not evaluated)"))?,
        };
        v.push(x);
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matlab_statements() {
        let v = matlab_assignments("fc = [ 1 ; 2 ]; % c\nKK = [fc(1) 0;0 1];\nnx = 3;\n");
        let names: Vec<&str> = v.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(names, ["fc", "KK", "nx"]);
        assert_eq!(matlab_numbers(&v[0].2).unwrap(), vec![1.0, 2.0]);
        assert!(matlab_numbers(&v[1].2).is_err());
    }
}
