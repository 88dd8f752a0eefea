//! `cv::FileStorage` documents (YAML, XML or JSON) as a tree of [`Node`]s, and OpenCV matrices
//! in them.

mod xml;
mod yaml;

use xml::parse_xml;
use yaml::parse_yaml;

/// A parsed `cv::FileStorage` value.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Node {
    /// A number or a string, as written.
    Scalar(String),
    /// A list.
    Seq(Vec<Node>),
    /// A map, in file order.
    Map(Vec<(String, Node)>),
}

impl Node {
    /// The value of `key` in a map.
    pub(super) fn get(&self, key: &str) -> Option<&Node> {
        match self {
            Node::Map(m) => m.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }
}

fn parse_number(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v: f64 = t.parse().map_err(|_| format!("`{t}` is not a number"))?;
    if !v.is_finite() {
        return Err(format!("`{t}` is not finite"));
    }
    Ok(v)
}

/// Values of an OpenCV matrix node (`rows`/`cols`/`data` map), or of a plain list of numbers.
pub(super) fn matrix_values(n: &Node) -> Result<Vec<f64>, String> {
    let flat = |d: &Node| -> Result<Vec<f64>, String> {
        match d {
            Node::Scalar(s) => s.split_whitespace().map(parse_number).collect(),
            Node::Seq(items) => items
                .iter()
                .map(|i| match i {
                    Node::Scalar(s) => parse_number(s),
                    _ => Err("nested lists are not numbers".to_string()),
                })
                .collect(),
            Node::Map(_) => Err("expected numbers, found a map".to_string()),
        }
    };
    match n {
        Node::Map(_) => {
            let data = n.get("data").ok_or("matrix has no `data`")?;
            let v = flat(data)?;
            let dim = |k: &str| -> Result<Option<usize>, String> {
                match n.get(k) {
                    None => Ok(None),
                    Some(Node::Scalar(s)) => s
                        .trim()
                        .parse::<usize>()
                        .map(Some)
                        .map_err(|_| format!("`{k}` is not a count: `{s}`")),
                    Some(_) => Err(format!("`{k}` is not a count")),
                }
            };
            if let (Some(r), Some(c)) = (dim("rows")?, dim("cols")?)
                && r.checked_mul(c) != Some(v.len())
            {
                return Err(format!(
                    "rows x cols = {r} x {c} but data has {} values",
                    v.len()
                ));
            }
            Ok(v)
        }
        other => flat(other),
    }
}

/// Parse an OpenCV FileStorage document (YAML, XML or JSON, detected from its first character).
pub(super) fn parse_filestorage(text: &str) -> Result<Node, String> {
    let t = text.trim_start();
    if t.starts_with('<') {
        parse_xml(t)
    } else if t.starts_with('{') {
        let v: serde_json::Value = serde_json::from_str(t).map_err(|e| format!("JSON: {e}"))?;
        Ok(json_node(&v))
    } else {
        parse_yaml(text)
    }
}

fn json_node(v: &serde_json::Value) -> Node {
    use serde_json::Value;
    match v {
        Value::Object(m) => Node::Map(m.iter().map(|(k, v)| (k.clone(), json_node(v))).collect()),
        Value::Array(a) => Node::Seq(a.iter().map(json_node).collect()),
        Value::String(s) => Node::Scalar(s.clone()),
        other => Node::Scalar(other.to_string()),
    }
}
