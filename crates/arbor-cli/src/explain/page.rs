//! The self-contained explain page: the page's HTML, styles and scripts
//! (three.js included) wrapped around the data `arbor explain` gathered.
//!
//! Stub: the page itself is being written; this only wraps the data so the
//! command can be built and tested meanwhile.

/// The whole page for `data_json` (the document of docs/explain-data.md).
pub fn page_html(data_json: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>arbor explain</title></head>\n<body>\n<script id=\"arbor-data\" type=\"application/json\">{}</script>\n</body></html>\n",
        script_safe(data_json)
    )
}

/// JSON placed inside a `<script>` element must not contain `</`, which
/// would end the element early; `<\/` means the same to JSON.parse.
fn script_safe(json: &str) -> String {
    json.replace("</", "<\\/")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_cannot_close_its_script_element() {
        let page = page_html(r#"{"label":"</script><b>"}"#);
        assert_eq!(page.matches("</script>").count(), 1);
        assert!(page.contains(r#"<\/script><b>"#));
    }
}
