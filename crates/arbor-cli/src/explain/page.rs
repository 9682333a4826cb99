//! The self-contained explain page: the page's HTML, styles and scripts
//! (three.js included) wrapped around the data `arbor explain` gathered.
//!
//! Everything is inline so the file opens from disk with no server and no
//! network. three.js ships as ES modules that import each other by relative
//! path, which cannot be resolved from a page on file://; the page keeps
//! their sources as inert text, and a small classic script turns them into
//! blob URLs named by an import map before the page's own module runs.

/// The page's styles.
const STYLE: &str = include_str!("../../assets/explain/page.css");
/// The page's markup: the panels and their controls.
const BODY: &str = include_str!("../../assets/explain/body.html");
/// Turns the inert module sources into blob URLs and an import map.
const LOADER: &str = include_str!("../../assets/explain/loader.js");
/// The page's behaviour (an ES module importing `three`).
const APP: &str = include_str!("../../assets/explain/app.js");
/// The nested levels' panels (a module run before [`APP`], which tells it
/// each pick).
const LEVELS: &str = include_str!("../../assets/explain/levels.js");
/// three.js, vendored by scripts/vendor-three.sh (unmodified).
const THREE_CORE: &str = include_str!("../../assets/explain/three/three.core.js");
/// The part of three.js that imports `./three.core.js`.
const THREE_MODULE: &str = include_str!("../../assets/explain/three/three.module.js");
/// three.js's orbit, zoom and pan controls; they import `three`.
const ORBIT_CONTROLS: &str = include_str!("../../assets/explain/three/OrbitControls.js");
/// three.js's licence, carried into every page beside its code.
const THREE_LICENSE: &str = include_str!("../../assets/explain/three/LICENSE");

/// The relative import by which `three.module.js` reaches `three.core.js`,
/// and the bare name the import map gives that module instead.
const CORE_RELATIVE: &str = "'./three.core.js'";
const CORE_MAPPED: &str = "'three/core'";

/// The whole page for `data_json` (the document of docs/explain-data.md).
pub fn page_html(data_json: &str) -> String {
    let three_module = THREE_MODULE.replace(CORE_RELATIVE, CORE_MAPPED);
    let mut page = String::with_capacity(
        STYLE.len()
            + BODY.len()
            + APP.len()
            + LEVELS.len()
            + THREE_CORE.len()
            + three_module.len()
            + ORBIT_CONTROLS.len()
            + data_json.len()
            + 4096,
    );
    page.push_str(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>arbor explain</title>\n<style>\n",
    );
    page.push_str(STYLE);
    page.push_str("</style>\n</head>\n<body>\n");
    page.push_str(BODY);
    let data = json_script_safe(data_json);
    for (attrs, text) in [
        (r#"id="arbor-data" type="application/json""#, data.as_str()),
        (r#"id="three-core-src" type="text/plain""#, THREE_CORE),
        (r#"id="three-module-src" type="text/plain""#, &three_module),
        (r#"id="three-orbit-src" type="text/plain""#, ORBIT_CONTROLS),
        (r#"id="three-license" type="text/plain""#, THREE_LICENSE),
        ("", LOADER),
        (r#"type="module""#, LEVELS),
        (r#"type="module""#, APP),
    ] {
        push_script(&mut page, attrs, text);
    }
    page.push_str("</body>\n</html>\n");
    page
}

/// Appends `<script ATTRS>TEXT</script>`. The assets are checked by the
/// tests below never to contain a sequence that would end or re-open a
/// script element; the data is escaped by [`json_script_safe`].
fn push_script(page: &mut String, attrs: &str, text: &str) {
    page.push_str("<script");
    if !attrs.is_empty() {
        page.push(' ');
        page.push_str(attrs);
    }
    page.push('>');
    page.push_str(text);
    page.push_str("</script>\n");
}

/// JSON placed inside a `<script>` element must not contain `</`, which
/// would end the element early, nor `<!--`, which changes how the browser
/// looks for its end; both can only occur inside JSON strings, where `<\/`
/// and `<\u0021--` mean the same to JSON.parse.
fn json_script_safe(json: &str) -> String {
    json.replace("</", "<\\/").replace("<!--", "<\\u0021--")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_cannot_close_its_script_element() {
        let page = page_html(r#"{"label":"</script><b><!--"}"#);
        let data_start = page.find("id=\"arbor-data\"").unwrap();
        let data_end = data_start + page[data_start..].find("</script>").unwrap();
        assert!(page[data_start..data_end].contains(r#"<\/script><b><\u0021--"#));
    }

    #[test]
    fn no_asset_can_end_or_reopen_its_script_element() {
        for (name, text) in [
            ("app.js", APP),
            ("levels.js", LEVELS),
            ("loader.js", LOADER),
            ("three.core.js", THREE_CORE),
            ("three.module.js", THREE_MODULE),
            ("OrbitControls.js", ORBIT_CONTROLS),
            ("LICENSE", THREE_LICENSE),
        ] {
            let lower = text.to_ascii_lowercase();
            for bad in ["</script", "<script", "<!--"] {
                assert!(!lower.contains(bad), "{name} contains {bad}");
            }
        }
    }

    #[test]
    fn every_script_element_is_closed_once() {
        let page = page_html("{}");
        let opened = page.matches("<script").count();
        assert_eq!(opened, 8);
        assert_eq!(page.matches("</script>").count(), opened);
    }

    #[test]
    fn three_module_reaches_the_core_through_the_import_map() {
        assert!(
            THREE_MODULE.contains(CORE_RELATIVE),
            "three.js changed how it imports its core"
        );
        let page = page_html("{}");
        assert!(!page.contains(CORE_RELATIVE));
        assert!(page.contains(&format!("from {CORE_MAPPED}")));
        assert!(LOADER.contains(CORE_MAPPED.trim_matches('\'')));
        // No other relative import is left that a blob URL could not resolve.
        for module in [THREE_CORE, ORBIT_CONTROLS, APP, LEVELS] {
            assert!(!module.contains("from './"));
            assert!(!module.contains("from \"./"));
        }
    }

    #[test]
    fn the_page_carries_three_js_licence() {
        let page = page_html("{}");
        assert!(THREE_LICENSE.contains("MIT License"));
        assert!(page.contains(THREE_LICENSE));
    }
}
