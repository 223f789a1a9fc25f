//! report.html in a real browser: a sweep's and a render's page opened in headless
//! Chromium, which must log no console error (a policy violation, a script error, a failed
//! load), and whose every image must have decoded. The page records that itself once loaded
//! (`<html data-images=… data-violations=…>`, src/report/html.rs), read back with
//! `--dump-dom`. Without Chromium the test fails under CI=true (scripts/ensure-chromium
//! installs it) and elsewhere skips with a visible line.

use crate::common;

use common::case::{CROSSING, LENGTH_BINS};
use common::{case, linelight, skip_or_fail, stderr, write};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A title and a claim whose text must stay text, with a bin and a map to draw.
fn tiny() -> String {
    case("tiny_html")
        .title("tiny <html> & report")
        .methods(&["line.ltc2023", "line.ltc2017"])
        .compare("line.ltc2017", "line.ltc2023")
        .axis("elevation", CROSSING)
        .diffuse(300)
        .table(LENGTH_BINS)
        .table(
            r#"[[maps]]
x = { axis = "length", edges = [0.1, 1.0, 10.0] }
y = { axis = "elevation", edges = [-10.0, 0.0, 45.0, 90.0] }
methods = ["line.ltc2017"]
[[claims]]
id = "some-error"
expect = 'p99("line.ltc2017", "diffuse") >= 0.0'
text = "**A claim <b>with markup</b> that must stay text.** p99 {sci(p99(\"line.ltc2017\", \"diffuse\"))}."
"#,
        )
        .to_string()
}

const SCENE: &str = r#"
name = "tiny_floor"
methods = ["line.ltc2017", "line.ltc2023"]
[render]
width = 40
height = 24
camera = { position = [0.0, -3.0, 1.5], look_at = [0.0, 0.5, 0.0], fov_deg = 60.0 }
light = { p1 = [-0.8, 0.6, 0.4], p2 = [0.9, 0.2, 0.7] }
material = { kind = "ggx", alpha_ramp = [0.1, 0.6] }
"#;

/// Debian's `chromium` (or another Chromium/Chrome build) on PATH.
fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome", "google-chrome-stable"]
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
        .find(|p| p.is_file())
}

/// Opens `page` headless and returns (the DOM after load, Chromium's log).
fn open(browser: &Path, page: &Path, profile: &Path) -> (String, String) {
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    let o = Command::new(browser)
        .args([
            "--headless",
            // As root (CI, this machine) Chromium refuses to start without it.
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-extensions",
            "--disable-background-networking",
            "--enable-logging=stderr",
            "--v=0",
            // Lets the load event and its handler finish before the DOM is dumped.
            "--virtual-time-budget=10000",
            &format!("--user-data-dir={}", profile.display()),
            "--dump-dom",
            &url,
        ])
        .output()
        .expect("chromium starts");
    let log = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "chromium failed on {url}: {log}");
    (String::from_utf8_lossy(&o.stdout).into_owned(), log)
}

/// The value of `<html NAME="…">` in the dumped DOM.
fn html_attribute(dom: &str, name: &str) -> Option<String> {
    let start = dom.find("<html")?;
    let tag = &dom[start..start + dom[start..].find('>')?];
    let at = tag.find(&format!("{name}=\""))? + name.len() + 2;
    Some(tag[at..at + tag[at..].find('"')?].to_string())
}

/// The page renders without a console error and every one of its `expect_images` images loads.
fn check_page(browser: &Path, page: &Path, expect_images: usize, scratch: &Path) {
    let html = std::fs::read_to_string(page).unwrap();
    // Self-contained: nothing the page could fetch.
    for needle in ["src=\"http", "src=\"//", "href=\"http", "<link", "@import", "url("] {
        assert!(!html.contains(needle), "{}: `{needle}` in the page", page.display());
    }
    let (dom, log) = open(browser, page, &scratch.join(format!("profile-{expect_images}")));
    let console: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Refused") || l.contains("Uncaught"))
        .collect();
    assert!(
        console.is_empty(),
        "{}: console messages:\n{}",
        page.display(),
        console.join("\n")
    );
    let images = html_attribute(&dom, "data-images").unwrap_or_else(|| {
        panic!(
            "{}: the page's load check did not run; DOM head: {}",
            page.display(),
            &dom[..dom.len().min(600)]
        )
    });
    assert_eq!(
        images,
        format!("{expect_images} images, 0 broken"),
        "{}",
        page.display()
    );
    assert_eq!(
        html_attribute(&dom, "data-violations").as_deref(),
        Some(""),
        "{}",
        page.display()
    );
}

#[test]
fn sweep_and_render_pages_open_in_chromium_with_every_image_loaded() {
    let t = tempfile::tempdir().unwrap();
    let case = write(t.path(), "tiny.toml", &tiny());
    let out = t.path().join("reports");
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let sweep_page = out.join("tiny_html/report.html");
    let sweep_html = std::fs::read_to_string(&sweep_page).unwrap();
    // The title and the claim's text are escaped text, not markup.
    assert!(
        sweep_html.contains("<title>tiny &lt;html&gt; &amp; report</title>"),
        "title not escaped"
    );
    assert!(sweep_html.contains("&lt;b&gt;with markup&lt;/b&gt;") && !sweep_html.contains("<b>with"));
    // "What to ship" before the findings, both before the tables.
    let at = |s: &str| sweep_html.find(s).unwrap_or_else(|| panic!("`{s}` missing"));
    assert!(at("What to ship") < at("Findings") && at("Findings") < at("Error against the reference"));
    // Every image is one of the set's SVGs (a heat map under maps/, a speed chart), inline.
    let set = out.join("tiny_html");
    assert!(set.join("speed_accuracy__diffuse.svg").is_file());
    assert!(set.join("maps/line.ltc2017__diffuse__length_elevation.svg").is_file());
    assert_eq!(sweep_html.matches("src=\"data:image/svg+xml;base64,").count(), 2);

    let scene = write(t.path(), "scene.toml", SCENE);
    let renders = t.path().join("renders");
    let o = linelight(&["render", scene.to_str().unwrap(), "--out", renders.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let render_page = renders.join("tiny_floor/report.html");
    let render_html = std::fs::read_to_string(&render_page).unwrap();
    // The reference, then radiance, relative error and FLIP per method, and the legend.
    assert_eq!(render_html.matches("src=\"data:image/png;base64,").count(), 1 + 3 * 2);
    assert_eq!(render_html.matches("src=\"data:image/svg+xml;base64,").count(), 1);
    assert!(render_html.contains("class=\"gallery\""));

    let Some(browser) = chromium() else {
        skip_or_fail(
            "html_browser",
            "no Chromium on PATH (scripts/ensure-chromium installs Debian's `chromium`)",
        );
        return;
    };
    check_page(&browser, &sweep_page, 2, t.path());
    check_page(&browser, &render_page, 8, t.path());
}

#[test]
fn a_page_with_a_broken_image_fails_the_check() {
    // The check can fail: a page whose image is not in its set (left as a relative link, which
    // the page's policy blocks) is caught by the console log or the image count.
    let Some(browser) = chromium() else {
        skip_or_fail(
            "html_browser",
            "no Chromium on PATH (scripts/ensure-chromium installs Debian's `chromium`)",
        );
        return;
    };
    let t = tempfile::tempdir().unwrap();
    let html = linelight::report::html::page(
        "broken",
        &[linelight::report::html::Part::Markdown("![gone](gone.png)\n")],
        &[],
    );
    let page = t.path().join("report.html");
    std::fs::write(&page, html).unwrap();
    let (dom, log) = open(&browser, &page, &t.path().join("profile"));
    let images = html_attribute(&dom, "data-images").expect("the load check ran");
    assert_eq!(images, "1 images, 1 broken: gone");
    let violations = html_attribute(&dom, "data-violations").unwrap_or_default();
    assert!(
        violations.contains("img-src") || log.contains("Refused to load"),
        "the blocked load is seen: {violations} / {log}"
    );
}
