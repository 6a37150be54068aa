//! The `reproduce` report: an HTML page (figures and tables, readable in a browser) and a
//! `summary.json` with every number the page shows. Sections are appended by capability.

use serde_json::{Map, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// An HTML report under construction plus its machine-readable summary.
pub struct Report {
    dir: PathBuf,
    body: String,
    /// Contents list: (anchor, title, whether the entry is wrapped in the timing markers).
    toc: Vec<(String, String, bool)>,
    pub summary: Map<String, Value>,
}

/// Start and end markers of the page's wall-clock parts (the timing section and its
/// contents-list entry): `cargo xtask compare-report` drops the text between them, so
/// reports of different runs, or one that predates the timings, compare equal.
pub const TIMINGS_BEGIN: &str = "<!-- timings -->";
pub const TIMINGS_END: &str = "<!-- /timings -->";

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// `f` over `items` on the rayon pool, collected in input order: the serial loop's values
/// whatever the pool size (each task depends only on its item), and the first error in input
/// order.
pub fn par_map<T: Sync, U: Send, E: Send>(
    items: &[T],
    f: impl Fn(&T) -> Result<U, E> + Sync + Send,
) -> Result<Vec<U>, E> {
    use rayon::prelude::*;
    let out: Vec<Result<U, E>> = items.par_iter().map(f).collect();
    out.into_iter().collect()
}

/// Formats a number compactly for tables (4 significant digits, exponent when needed).
pub fn num(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "NaN".into()
        } else if v > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) { format!("{v:.3e}") } else { format!("{}", (v * 1e4).round() / 1e4) }
}

impl Report {
    pub fn new(dir: &Path) -> std::io::Result<Self> {
        crate::output::create_dir(dir)?;
        Ok(Self { dir: dir.to_path_buf(), body: String::new(), toc: Vec::new(), summary: Map::new() })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// An empty report writing into the same folder: a section built in it (e.g. on another
    /// thread) is added to this report by [`Report::append`], in the order of the appends.
    pub fn part(&self) -> Self {
        Self { dir: self.dir.clone(), body: String::new(), toc: Vec::new(), summary: Map::new() }
    }

    /// An empty report writing its files into `dir` (a cache unit's scratch folder, see
    /// [`cache`]), to be appended to this one.
    pub fn part_in(&self, dir: &Path) -> Self {
        Self { dir: dir.to_path_buf(), body: String::new(), toc: Vec::new(), summary: Map::new() }
    }

    /// The HTML, contents entries and summary keys of a part (as [`cache`] stores them).
    pub fn into_parts(self) -> (String, Vec<(String, String, bool)>, Map<String, Value>) {
        (self.body, self.toc, self.summary)
    }

    /// Sets what [`Report::into_parts`] returned, on an empty part.
    pub fn set_parts(&mut self, body: String, toc: Vec<(String, String, bool)>, summary: Map<String, Value>) {
        self.body = body;
        self.toc = toc;
        self.summary = summary;
    }

    /// Appends a [`Report::part`]: its HTML after this report's, its contents entries, its
    /// summary keys (a key both already have is an error: no section overwrites another's).
    pub fn append(&mut self, part: Report) -> Result<(), String> {
        if let Some(k) = part.summary.keys().find(|k| self.summary.contains_key(*k)) {
            return Err(format!("report: summary key `{k}` written by two sections"));
        }
        self.body.push_str(&part.body);
        self.toc.extend(part.toc);
        self.summary.extend(part.summary);
        Ok(())
    }

    /// Starts a section with an anchor in the table of contents.
    pub fn section(&mut self, id: &str, title: &str, intro: &str) {
        self.toc.push((id.into(), title.into(), false));
        let _ = write!(self.body, "<h2 id=\"{}\">{}</h2>\n<p>{}</p>\n", esc(id), esc(title), intro);
    }

    /// Starts the timing section: like [`Report::section`], but the section (up to
    /// [`Report::end_timings`]) and its contents entry sit between [`TIMINGS_BEGIN`] and
    /// [`TIMINGS_END`].
    pub fn timings_section(&mut self, id: &str, title: &str, intro: &str) {
        self.toc.push((id.into(), title.into(), true));
        self.body.push_str(TIMINGS_BEGIN);
        self.body.push('\n');
        let _ = write!(self.body, "<h2 id=\"{}\">{}</h2>\n<p>{}</p>\n", esc(id), esc(title), intro);
    }

    /// Ends the timing section started by [`Report::timings_section`].
    pub fn end_timings(&mut self) {
        self.body.push_str(TIMINGS_END);
        self.body.push('\n');
    }

    /// A paragraph of trusted HTML (callers escape user text with [`esc`]).
    pub fn para(&mut self, html: &str) {
        let _ = writeln!(self.body, "<p>{html}</p>");
    }

    /// A table; cells are escaped.
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>]) {
        self.body.push_str("<table>\n<tr>");
        for h in header {
            let _ = write!(self.body, "<th>{}</th>", esc(h));
        }
        self.body.push_str("</tr>\n");
        for r in rows {
            self.body.push_str("<tr>");
            for c in r {
                let _ = write!(self.body, "<td>{}</td>", esc(c));
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</table>\n");
    }

    /// An image already written under the report folder (path relative to it).
    pub fn figure(&mut self, rel: &str, caption: &str) {
        let _ = write!(
            self.body,
            "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>\n",
            esc(rel),
            esc(caption),
            esc(caption)
        );
    }

    /// Writes `index.html` and `summary.json`.
    pub fn finish(&self, title: &str) -> std::io::Result<()> {
        let mut html = String::new();
        let _ = write!(
            html,
            "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>\
body{{font-family:sans-serif;max-width:72em;margin:2em auto;padding:0 1em;line-height:1.4}}\
table{{border-collapse:collapse;margin:0.5em 0 1em}}td,th{{border:1px solid #bbb;padding:2px 8px;text-align:right;font-size:90%}}\
th{{background:#eee}}figure{{display:inline-block;margin:0.5em}}img{{max-width:100%;border:1px solid #ddd}}\
figcaption{{font-size:85%;color:#444}}code{{background:#f4f4f4}}</style></head><body>\n<h1>{t}</h1>\n<ul>",
            t = esc(title)
        );
        for (id, name, timings) in &self.toc {
            let (begin, end) = if *timings { (TIMINGS_BEGIN, TIMINGS_END) } else { ("", "") };
            let _ = write!(html, "{begin}<li><a href=\"#{}\">{}</a></li>{end}", esc(id), esc(name));
        }
        html.push_str("</ul>\n");
        html.push_str(&self.body);
        html.push_str("<p><small>Numbers on this page are also in <a href=\"summary.json\">summary.json</a>.</small></p></body></html>\n");
        crate::output::write_atomic(&self.dir.join("index.html"), html.as_bytes())?;
        let json = serde_json::to_string_pretty(&Value::Object(self.summary.clone())).map_err(std::io::Error::other)?;
        crate::output::write_atomic(&self.dir.join("summary.json"), json.as_bytes())
    }
}

pub mod auto_table;
pub mod bifurcations;
pub mod cache;
pub mod chaos;
pub mod global;
pub mod normal_form;
pub mod own_plant;
pub mod prose;
pub mod reproduce;
pub mod sloshing;
pub mod tasks;
pub mod verdict;
