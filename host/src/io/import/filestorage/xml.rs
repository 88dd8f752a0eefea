//! A small XML reader for what `cv::FileStorage` writes.

use super::Node;

struct XmlElem {
    name: String,
    children: Vec<XmlElem>,
    text: String,
}

pub(super) fn parse_xml(text: &str) -> Result<Node, String> {
    let b = text.as_bytes();
    let mut pos = 0;
    let line_of = |p: usize| text[..p.min(text.len())].matches('\n').count() + 1;
    // Stack of open elements; a synthetic document root at the bottom.
    let mut stack = vec![XmlElem {
        name: String::new(),
        children: Vec::new(),
        text: String::new(),
    }];
    while pos < b.len() {
        if b[pos] != b'<' {
            let end = text[pos..].find('<').map_or(b.len(), |e| pos + e);
            if let Some(top) = stack.last_mut() {
                top.text.push_str(&xml_unescape(&text[pos..end]));
            }
            pos = end;
            continue;
        }
        let rest = &text[pos..];
        let skip_to = |pat: &str| rest.find(pat).map(|e| pos + e + pat.len());
        if rest.starts_with("<?") {
            pos = skip_to("?>").ok_or_else(|| format!("line {}: unclosed `<?`", line_of(pos)))?;
        } else if rest.starts_with("<!--") {
            pos =
                skip_to("-->").ok_or_else(|| format!("line {}: unclosed comment", line_of(pos)))?;
        } else if rest.starts_with("<!") {
            pos = skip_to(">").ok_or_else(|| format!("line {}: unclosed `<!`", line_of(pos)))?;
        } else {
            let end = skip_to(">").ok_or_else(|| format!("line {}: unclosed tag", line_of(pos)))?;
            let inner = &text[pos + 1..end - 1];
            if let Some(name) = inner.strip_prefix('/') {
                let name = name.trim();
                let done = stack.pop().filter(|_| !stack.is_empty()).ok_or_else(|| {
                    format!(
                        "line {}: closing tag </{name}> without an open element",
                        line_of(pos)
                    )
                })?;
                if done.name != name {
                    return Err(format!(
                        "line {}: closing tag </{name}> does not match <{}>",
                        line_of(pos),
                        done.name
                    ));
                }
                if let Some(parent) = stack.last_mut() {
                    parent.children.push(done);
                }
            } else {
                let self_closing = inner.ends_with('/');
                let inner = inner.trim_end_matches('/');
                let name = inner.split_whitespace().next().unwrap_or("").to_string();
                if name.is_empty() {
                    return Err(format!("line {}: empty tag", line_of(pos)));
                }
                let e = XmlElem {
                    name,
                    children: Vec::new(),
                    text: String::new(),
                };
                if self_closing {
                    if let Some(parent) = stack.last_mut() {
                        parent.children.push(e);
                    }
                } else {
                    stack.push(e);
                }
            }
            pos = end;
        }
    }
    if stack.len() != 1 {
        let open = stack.last().map(|e| e.name.clone()).unwrap_or_default();
        return Err(format!("unclosed element <{open}>"));
    }
    let doc = stack.pop().ok_or("empty document")?;
    let root = doc
        .children
        .into_iter()
        .find(|e| e.name == "opencv_storage")
        .ok_or("no <opencv_storage> element")?;
    Ok(xml_node(root))
}

fn xml_node(e: XmlElem) -> Node {
    if e.children.is_empty() {
        Node::Scalar(e.text.trim().to_string())
    } else if e.children.iter().all(|c| c.name == "_") {
        Node::Seq(e.children.into_iter().map(xml_node).collect())
    } else {
        Node::Map(
            e.children
                .into_iter()
                .map(|c| (c.name.clone(), xml_node(c)))
                .collect(),
        )
    }
}

fn xml_unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}
