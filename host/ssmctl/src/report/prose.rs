//! The report's prose as templates: a section's text, captions and table cells are minijinja
//! templates over the section's computed values (its `summary.json` entry), so every number on
//! the page is a placeholder filled from a value, and a changed value changes the text.
//!
//! minijinja rather than askama: the values are already `serde_json` trees (the summary), which
//! minijinja reads as they are, and runtime templates add no proc macro to the build. Undefined
//! names are errors (a misspelt key cannot render as empty text), and values are HTML-escaped.

use minijinja::value::{Serde, Value as JinjaValue};
use minijinja::{AutoEscape, Environment, UndefinedBehavior};
use serde_json::Value;

/// The template environment with the report's number formats as filters:
/// `num` (4 significant digits, [`crate::report::num`]), `fixed(n)` (n decimals), `sci(n)`
/// (n decimals, exponent), `pct(n)` (a fraction as a percentage with n decimals, no sign),
/// `nums` (a list through `num`, comma-separated), `fixed_or(n, text)` (`fixed(n)`, or `text` for none),
/// `num_or(text)` (`num`, or `text`, default `-`, for none), `e` (Rust's `{:e}`), `dbg` (Rust's `{:?}` of a number or a list of numbers), `signed(n)` and `ssci(n)` (as `fixed` and
/// `sci` with a sign always), `plain` (Rust's `Display`: `31` for 31.0; a list joined by `, ` or
/// the given separator), `esc` (a string escaped as [`crate::report::esc`] does, which leaves `/`
/// as it is, for names the page printed so before it was a template).
pub struct Prose {
    env: Environment<'static>,
}

/// The name suffix of templates rendered as HTML.
const HTML: &str = ".html";

fn f(v: &JinjaValue) -> Result<f64, minijinja::Error> {
    // Strict mode refuses printing an undefined name, not passing it to a filter.
    if v.is_undefined() {
        return Err(minijinja::Error::from(minijinja::ErrorKind::UndefinedError));
    }
    if v.is_none() {
        return Ok(f64::NAN);
    }
    f64::try_from(v.clone())
        .map_err(|_| minijinja::Error::new(minijinja::ErrorKind::InvalidOperation, format!("{v} is not a number")))
}

/// A number as Rust's `Display` writes it (`31` for 31.0, `30.8`, `16000`): what `format!("{x}")`
/// gave before the text was a template.
fn plain(v: &JinjaValue) -> Result<String, minijinja::Error> {
    if let Some(i) = v.as_i64() {
        return Ok(i.to_string());
    }
    Ok(format!("{}", f(v)?))
}

impl Default for Prose {
    fn default() -> Self {
        Self::new()
    }
}

impl Prose {
    pub fn new() -> Self {
        let mut env = Environment::new();
        env.set_undefined_behavior(UndefinedBehavior::Strict);
        // Paragraphs are HTML (values escaped); captions and table cells are plain text that
        // `Report` escapes itself.
        env.set_auto_escape_callback(|name| if name.ends_with(HTML) { AutoEscape::Html } else { AutoEscape::None });
        env.add_filter("esc", |v: String| -> JinjaValue { JinjaValue::from_safe_string(crate::report::esc(&v)) });
        env.add_filter("num", |v: JinjaValue| -> Result<String, minijinja::Error> { Ok(crate::report::num(f(&v)?)) });
        env.add_filter("fixed", |v: JinjaValue, n: usize| -> Result<String, minijinja::Error> {
            Ok(format!("{:.n$}", f(&v)?))
        });
        env.add_filter("sci", |v: JinjaValue, n: usize| -> Result<String, minijinja::Error> {
            Ok(format!("{:.n$e}", f(&v)?))
        });
        env.add_filter("pct", |v: JinjaValue, n: usize| -> Result<String, minijinja::Error> {
            Ok(format!("{:.n$}", 100.0 * f(&v)?))
        });
        env.add_filter("dbg", |v: JinjaValue| -> Result<String, minijinja::Error> {
            if v.kind() == minijinja::value::ValueKind::Seq {
                let items: Vec<String> =
                    v.try_iter()?.map(|x| f(&x).map(|x| format!("{x:?}"))).collect::<Result<_, minijinja::Error>>()?;
                return Ok(format!("[{}]", items.join(", ")));
            }
            Ok(format!("{:?}", f(&v)?))
        });
        env.add_filter("e", |v: JinjaValue| -> Result<String, minijinja::Error> { Ok(format!("{:e}", f(&v)?)) });
        env.add_filter("fixed_or", |v: JinjaValue, n: usize, alt: String| -> Result<String, minijinja::Error> {
            if v.is_none() { Ok(alt) } else { Ok(format!("{:.n$}", f(&v)?)) }
        });
        env.add_filter("signed", |v: JinjaValue, n: usize| -> Result<String, minijinja::Error> {
            Ok(format!("{:+.n$}", f(&v)?))
        });
        env.add_filter("ssci", |v: JinjaValue, n: usize| -> Result<String, minijinja::Error> {
            Ok(format!("{:+.n$e}", f(&v)?))
        });
        env.add_filter("plain", |v: JinjaValue, sep: Option<String>| -> Result<String, minijinja::Error> {
            if v.kind() == minijinja::value::ValueKind::Seq {
                let items: Vec<String> = v.try_iter()?.map(|x| plain(&x)).collect::<Result<_, minijinja::Error>>()?;
                return Ok(items.join(sep.as_deref().unwrap_or(", ")));
            }
            plain(&v)
        });
        env.add_filter("num_or", |v: JinjaValue, alt: Option<String>| -> Result<String, minijinja::Error> {
            if v.is_none() { Ok(alt.unwrap_or_else(|| "-".into())) } else { Ok(crate::report::num(f(&v)?)) }
        });
        env.add_filter("nums", |v: JinjaValue| -> Result<String, minijinja::Error> {
            let items: Vec<String> =
                v.try_iter()?.map(|x| f(&x).map(crate::report::num)).collect::<Result<_, minijinja::Error>>()?;
            Ok(items.join(", "))
        });
        Self { env }
    }

    /// HTML `template` (named `name` in errors) over `values`, the values escaped: for
    /// [`crate::report::Report::para`] and section intros.
    pub fn html(&self, name: &str, template: &str, values: &Value) -> Result<String, String> {
        self.env
            .render_named_str(&format!("{name}{HTML}"), template, JinjaValue::from(Serde(values)))
            .map_err(|e| format!("report template `{name}`: {e:#}"))
    }

    /// Plain-text `template` over `values`: for captions and table cells, which
    /// [`crate::report::Report`] escapes.
    pub fn text(&self, name: &str, template: &str, values: &Value) -> Result<String, String> {
        self.env
            .render_named_str(name, template, JinjaValue::from(Serde(values)))
            .map_err(|e| format!("report template `{name}`: {e:#}"))
    }
}

impl Prose {
    /// Table rows: each item of `items` through the cell templates `cells` (plain text).
    pub fn rows(&self, name: &str, cells: &[&str], items: &[Value]) -> Result<Vec<Vec<String>>, String> {
        items.iter().map(|r| cells.iter().map(|c| self.text(name, c, r)).collect()).collect()
    }
}

/// Names written with digits: a method, the invariant objects named by their dimension and a
/// figure of the paper; and the constants of formulas written out in the text (the unit
/// multiplier of a shift, a real multiplier crossing +1, the delay embedding rule p = 2d + 1).
const NAMES_WITH_DIGITS: [&str; 12] = [
    "0-1 test",
    "2-torus",
    "3-torus",
    "2-tori",
    "3-tori",
    "x (1 + spread",
    "(1 + k_ij",
    "by 2 k_ij",
    "paper's figure 2",
    "structural multiplier 1 (",
    "multiplier through +1",
    "p = 2d + 1",
];

/// The numbers written in `text`: runs of digits (with a decimal point, an exponent and a
/// leading minus) that are not part of a name (`rho_1`, `x2`, `2D`, a monomial's `^3`,
/// `degree-1`) or a unit (`1/s`).
pub fn numbers_in(text: &str) -> Vec<String> {
    let text = NAMES_WITH_DIGITS.iter().fold(text.to_string(), |t, n| t.replace(n, "name"));
    let text = text.as_str();
    let b = text.as_bytes();
    let name = |c: u8| c.is_ascii_alphabetic() || c == b'_';
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        // A digit after a letter, `^`, `/` (a path, `docs/decisions/0001`) or a digit is not a number's start.
        if !b[i].is_ascii_digit()
            || (i > 0 && (name(b[i - 1]) || b"^/".contains(&b[i - 1]) || b[i - 1].is_ascii_digit()))
        {
            i += 1;
            continue;
        }
        // A hyphen after a letter joins a word (`degree-1`), not a sign.
        if i > 1 && b[i - 1] == b'-' && name(b[i - 2]) {
            i += 1;
            continue;
        }
        let start = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
        let mut j = i;
        while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.') {
            j += 1;
        }
        if j + 1 < b.len() && (b[j] == b'e' || b[j] == b'E') {
            let k = if b[j + 1] == b'-' || b[j + 1] == b'+' { j + 2 } else { j + 1 };
            if k < b.len() && b[k].is_ascii_digit() {
                j = k;
                while j < b.len() && b[j].is_ascii_digit() {
                    j += 1;
                }
            }
        }
        let token = text[start..j].trim_end_matches('.');
        let unit = j < b.len() && b[j] == b'/' && b.get(j + 1).is_some_and(|c| c.is_ascii_alphabetic());
        if !(unit || j < b.len() && name(b[j])) {
            out.push(token.to_string());
        }
        i = j;
    }
    out
}

/// `values` with every number moved (`x -> x + 0.2345 |x| + 0.1`, which has no fixed point,
/// integers to the next integer up of that, an unsigned zero kept, so that a branch on "any of these?" stays): a rendering of
/// it differs from the original's in every number that comes from a value (but such zeros),
/// and equals it in every number typed into a template.
pub fn perturbed(values: &Value) -> Value {
    match values {
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                Value::from(if u == 0 { 0 } else { u + 1 + u / 4 })
            } else if let Some(i) = n.as_i64() {
                Value::from(i - 1 - i.abs() / 4)
            } else {
                Value::from(n.as_f64().map_or(0.0, |x| x + 0.2345 * x.abs() + 0.1))
            }
        }
        Value::Array(a) => Value::Array(a.iter().map(perturbed).collect()),
        Value::Object(o) => Value::Object(o.iter().map(|(k, v)| (k.clone(), perturbed(v))).collect()),
        other => other.clone(),
    }
}

/// The numbers of `a` that are also, at the same place, in `b`: those that did not follow the
/// values (typed into a template), as `(position, number)`. Both texts must have the same
/// number of numbers.
pub fn unmoved(a: &str, b: &str) -> Result<Vec<(usize, String)>, String> {
    let (na, nb) = (numbers_in(a), numbers_in(b));
    if na.len() != nb.len() {
        return Err(format!("{} numbers before, {} after the values moved:\n{na:?}\n{nb:?}", na.len(), nb.len()));
    }
    Ok(na.into_iter().zip(nb).enumerate().filter(|(_, (x, y))| x == y).map(|(i, (x, _))| (i, x)).collect())
}
