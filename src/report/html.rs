//! `report.html`: the report people open, one self-contained page. It is the Markdown report
//! (the same text, from the same analysed summary: nothing is computed here) turned into HTML
//! by `pulldown-cmark`, with every image the report set holds inlined as a `data:` URI, and for
//! renders the images side by side. All text is escaped; the page fetches nothing (its
//! Content-Security-Policy allows `data:` images, its own style and its one script only).

use base64::Engine as _;
use pulldown_cmark::{CowStr, Event, Options, Parser, Tag};
use sha2::Digest as _;

/// One piece of the page, in order.
pub enum Part<'a> {
    /// Markdown text, converted; images it names that are in the report set are inlined.
    Markdown(&'a str),
    /// Images side by side: one row per label, one column per heading.
    Gallery(Gallery),
}

/// A grid of the report set's images (renders: reference, then per method radiance,
/// relative error and FLIP), with an optional legend image below it.
pub struct Gallery {
    pub columns: Vec<String>,
    /// (row label, file names in column order).
    pub rows: Vec<(String, Vec<String>)>,
    pub legend: Option<String>,
}

/// The page's only script: once the page has loaded it records in the DOM
/// (`<html data-images=… data-violations=…>`) how many images decoded and which did not, and
/// any Content-Security-Policy violation (a fetch the page must not make). Nothing visible;
/// the browser test (tests/html_browser.rs) reads these back.
const CHECK_SCRIPT: &str = "(function(){var v=[];\
document.addEventListener('securitypolicyviolation',function(e){v.push(e.violatedDirective+' '+e.blockedURI);\
document.documentElement.setAttribute('data-violations',v.join('; '));});\
window.addEventListener('load',function(){var b=[],n=document.images.length;\
for(var i=0;i<n;i++){var m=document.images[i];if(!(m.complete&&m.naturalWidth>0)){b.push(m.alt||('image '+i));}}\
document.documentElement.setAttribute('data-violations',v.join('; '));\
document.documentElement.setAttribute('data-images',n+' images, '+b.length+' broken'+(b.length?': '+b.join(', '):''));});})();";

const STYLE: &str =
    "body{font-family:system-ui,-apple-system,'DejaVu Sans',sans-serif;margin:0;background:#fafafa;color:#1a1a1a}\
main{max-width:1200px;margin:0 auto;padding:1em 2em 3em;background:#fff}\
h1{border-bottom:2px solid #333}h2{border-bottom:1px solid #bbb;margin-top:2em}\
table{border-collapse:collapse;margin:0.8em 0;font-size:0.9em;display:block;overflow-x:auto}\
th,td{border:1px solid #ccc;padding:0.25em 0.5em;vertical-align:top}th{background:#f0f0f0}\
tr:nth-child(even) td{background:#fafafa}\
code{background:#f3f3f3;padding:0 0.2em;border-radius:3px;font-size:0.92em}\
pre{background:#f3f3f3;padding:0.6em;overflow-x:auto}\
img{max-width:100%;height:auto}\
blockquote{border-left:4px solid #c60;margin:0.8em 0;padding:0.2em 1em;background:#fff6ee}\
.gallery{display:grid;gap:0.5em 0.8em;align-items:start;margin:1em 0}\
.gallery .head{font-weight:bold}.gallery .label{font-weight:bold;align-self:center}\
.gallery img{image-rendering:pixelated;border:1px solid #999}";

/// The page's bytes: `title` in the head, then the parts. `files` is the report set the page
/// sits in; an image that names one of them is inlined (PNG base64, SVG base64 as
/// `image/svg+xml`), any other image is left as written (and the page's policy blocks it, so
/// the browser test fails on it).
pub fn page(title: &str, parts: &[Part], files: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut body = String::new();
    for part in parts {
        match part {
            Part::Markdown(md) => body += &markdown(md, files),
            Part::Gallery(g) => body += &gallery(g, files),
        }
    }
    let script_hash = base64::engine::general_purpose::STANDARD.encode(sha2::Sha256::digest(CHECK_SCRIPT.as_bytes()));
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'sha256-{script_hash}'\">\n\
         <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n{body}</main>\n<script>{CHECK_SCRIPT}</script>\n</body>\n</html>\n",
        escape(title)
    )
    .into_bytes()
}

/// `name`'s bytes as a `data:` URI, when the set holds it and it is an image.
fn data_uri(name: &str, files: &[(String, Vec<u8>)]) -> Option<String> {
    let mime = match name.rsplit('.').next()? {
        "png" => "image/png",
        "svg" => "image/svg+xml",
        _ => return None,
    };
    let (_, bytes) = files.iter().find(|(n, _)| n == name)?;
    Some(format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

/// Markdown to HTML. Raw HTML in the text is escaped like any text, except the `<sub>` tags
/// the report writes itself (the claim lines).
fn markdown(md: &str, files: &[(String, Vec<u8>)]) -> String {
    let events = Parser::new_ext(md, Options::ENABLE_TABLES).map(|e| match e {
        Event::Html(s) | Event::InlineHtml(s) if matches!(s.trim(), "<sub>" | "</sub>") => Event::InlineHtml(s),
        Event::Html(s) | Event::InlineHtml(s) => Event::Text(s),
        Event::Start(Tag::Image {
            link_type,
            dest_url,
            title,
            id,
        }) => {
            let dest_url = data_uri(&dest_url, files).map_or(dest_url, CowStr::from);
            Event::Start(Tag::Image {
                link_type,
                dest_url,
                title,
                id,
            })
        }
        e => e,
    });
    let mut out = String::new();
    pulldown_cmark::html::push_html(&mut out, events);
    out
}

fn gallery(g: &Gallery, files: &[(String, Vec<u8>)]) -> String {
    let img = |name: &str| match data_uri(name, files) {
        Some(uri) => format!("<img src=\"{uri}\" alt=\"{0}\" title=\"{0}\">", escape(name)),
        None => format!("<img src=\"{0}\" alt=\"{0}\">", escape(name)),
    };
    let mut s = format!(
        "<div class=\"gallery\" style=\"grid-template-columns:auto repeat({}, minmax(0, 1fr))\">\n<div></div>",
        g.columns.len()
    );
    for c in &g.columns {
        s += &format!("<div class=\"head\">{}</div>", escape(c));
    }
    s += "\n";
    for (label, names) in &g.rows {
        s += &format!("<div class=\"label\"><code>{}</code></div>", escape(label));
        for k in 0..g.columns.len() {
            match names.get(k) {
                Some(n) => s += &format!("<div>{}</div>", img(n)),
                None => s += "<div></div>",
            }
        }
        s += "\n";
    }
    s += "</div>\n";
    if let Some(l) = &g.legend {
        s += &format!("<p>{}</p>\n", img(l));
    }
    s
}

/// Text for an HTML element or a quoted attribute (`&`, `<`, `>`, `"` and `'` escaped).
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    pulldown_cmark_escape::escape_html(&mut o, s).expect("writing to a String cannot fail");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(parts: &[Part], files: &[(String, Vec<u8>)]) -> String {
        String::from_utf8(page("t <x>", parts, files)).unwrap()
    }

    #[test]
    fn text_is_escaped_but_the_reports_sub_tags_are_kept() {
        let html = text(
            &[Part::Markdown(
                "# A <script>alert(1)</script> & b\n\n<img src=x onerror=alert(1)>\n\n`<b>` <sub>claim</sub>\n",
            )],
            &[],
        );
        assert!(!html.contains("<script>alert"), "{html}");
        assert!(!html.contains("<img src=x"), "{html}");
        assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt; &amp; b"), "{html}");
        assert!(html.contains("<code>&lt;b&gt;</code>"), "{html}");
        assert!(html.contains("<sub>claim</sub>"), "{html}");
        assert!(html.contains("<title>t &lt;x&gt;</title>"), "{html}");
        // The page's one script, and the policy that admits it and nothing else.
        assert_eq!(html.matches("<script>").count(), 1);
        assert!(html.contains("default-src 'none'; img-src data:"));
    }

    #[test]
    fn images_of_the_set_are_inlined_and_tables_convert() {
        let png = vec![0x89, b'P', b'N', b'G', 1, 2, 3];
        let files = vec![
            ("a.png".to_string(), png.clone()),
            ("c.svg".to_string(), b"<svg/>".to_vec()),
        ];
        let html = text(
            &[
                Part::Markdown("| a | b |\n|---|---:|\n| `x` | 1 |\n\n![a map](a.png) ![c](c.svg) ![gone](b.png)\n"),
                Part::Gallery(Gallery {
                    columns: vec!["radiance".into()],
                    rows: vec![("m<1>".into(), vec!["a.png".into()])],
                    legend: Some("c.svg".into()),
                }),
            ],
            &files,
        );
        let b64 = base64::engine::general_purpose::STANDARD.encode(&png);
        assert!(html.contains(&format!("src=\"data:image/png;base64,{b64}\"")), "{html}");
        assert!(html.contains("src=\"data:image/svg+xml;base64,PHN2Zy8+\""), "{html}");
        // Not in the set: left as written, so the browser blocks it and the check sees it.
        assert!(html.contains("src=\"b.png\""), "{html}");
        assert!(
            html.contains("<table>") && html.contains("<td><code>x</code></td>"),
            "{html}"
        );
        assert!(html.contains("<code>m&lt;1&gt;</code>"), "{html}");
        assert_eq!(html.matches(&format!("base64,{b64}")).count(), 2);
    }
}
