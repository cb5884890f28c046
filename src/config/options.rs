//! The `--opt` names as data: each technique, in its own file here,
//! declares its options (how each takes a value, an example value), a
//! one-line description, how its entries set a configuration and how it
//! prints its part of one. Parsing, printing, the unknown-option error's
//! list of known names, `--opt`'s help and the README's techniques table
//! are generated from these declarations; the tests check that every
//! declared spelling parses, that the README's table is the generated
//! one, and that printing a configuration and parsing the print gives it
//! back over random configurations.

use super::RenderConfig;

/// How an option takes a value after `=`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Value {
    /// None: the name alone.
    Flag,
    /// Optional: `name` or `name=META`.
    Optional(&'static str),
    /// Required: `name=META`.
    Required(&'static str),
}

/// One `--opt` option.
#[derive(Clone, Copy, Debug)]
pub struct Opt {
    /// Its name (before any `=`).
    pub name: &'static str,
    /// How it takes a value.
    pub value: Value,
    /// A value it accepts (for `Optional` and `Required`), used by the
    /// tests and the random configurations.
    pub example: &'static str,
}

/// A technique: its options and where its documentation lives.
#[derive(Clone, Copy, Debug)]
pub struct Technique {
    /// Its title in the techniques table.
    pub title: &'static str,
    /// Its page under `docs/techniques/`.
    pub page: &'static str,
    /// What it does, in one line.
    pub summary: &'static str,
    /// Its options (the culling strategies come from `cull_names`).
    pub options: &'static [Opt],
    /// Applies one of its entries to a configuration.
    pub parse: fn(&mut RenderConfig, &Entry) -> crate::error::Result<()>,
    /// Appends the entries that set its part of a configuration.
    pub print: fn(&RenderConfig, &mut Vec<String>),
    /// What it requires and what it cannot be combined with, each with
    /// its reason.
    pub rules: &'static [Rule],
}

/// A condition on a configuration.
pub type Check = fn(&RenderConfig) -> bool;

/// A configuration a technique refuses: when `when` holds, the
/// techniques in `with` that are on are refused in one error, `message`
/// with `{}` replaced by their names; with `with` empty, `when` alone is
/// refused with `message`.
#[derive(Debug)]
pub struct Rule {
    /// The technique's side of the condition.
    pub when: Check,
    /// What it excludes, each with the name the error gives it.
    pub with: &'static [(&'static str, Check)],
    /// The error (an `--opt` error).
    pub message: &'static str,
}

impl Rule {
    /// A rule refusing every configuration where `when` holds.
    pub const fn always(when: Check, message: &'static str) -> Rule {
        Rule {
            when,
            with: &[],
            message,
        }
    }

    /// This rule's error for `c`, if it refuses it.
    fn check(&self, c: &RenderConfig) -> crate::error::Result<()> {
        if !(self.when)(c) {
            return Ok(());
        }
        let on: Vec<&str> = self
            .with
            .iter()
            .filter_map(|(name, on)| on(c).then_some(*name))
            .collect();
        match (self.with.is_empty(), on.is_empty()) {
            (false, true) => Ok(()),
            _ => Err(crate::error::Error::config(
                "--opt",
                self.message.replace("{}", &on.join(", ")),
            )),
        }
    }
}

/// Every technique's rules against `c`, in [`TECHNIQUES`]' order: the
/// first that refuses it is the error.
pub fn check_rules(c: &RenderConfig) -> crate::error::Result<()> {
    TECHNIQUES
        .iter()
        .flat_map(|t| t.rules.iter())
        .try_for_each(|r| r.check(c))
}

/// Radial density masking is on (with a radius or `auto`).
fn rdm_on(c: &RenderConfig) -> bool {
    c.effort.rdm.is_some() || c.effort.rdm_auto
}

/// VRS foveation is on.
fn foveation_on(c: &RenderConfig) -> bool {
    c.effort.foveation != crate::view::foveation::Level::Off
}

/// The inset draws its four views in one scope.
fn four_views(c: &RenderConfig) -> bool {
    c.effort.inset.is_some_and(|i| i.four_views)
}

/// Parallel recording or per-draw data other than push constants.
fn submission_on(c: &RenderConfig) -> bool {
    c.submission.record_threads.is_some() || c.submission.per_draw != super::PerDraw::Push
}

const fn flag(name: &'static str) -> Opt {
    Opt {
        name,
        value: Value::Flag,
        example: "",
    }
}

const fn optional(name: &'static str, meta: &'static str, example: &'static str) -> Opt {
    Opt {
        name,
        value: Value::Optional(meta),
        example,
    }
}

const fn required(name: &'static str, meta: &'static str, example: &'static str) -> Opt {
    Opt {
        name,
        value: Value::Required(meta),
        example,
    }
}

/// The page whose options are the culling strategies.
pub const CULLING_PAGE: &str = "superfrustum";

mod aq;
mod culling;
mod foveation;
mod gpu_cull;
mod inset;
mod lms;
mod mffr;
mod msaa;
mod points;
mod rdm;
mod resolved_sky;
mod stencil;
mod stereo;
mod timewarp;

/// Every technique and its options, in the order the docs list them (and
/// [`print`] writes them: the stereo mode, MSAA and culling first).
pub const TECHNIQUES: &[Technique] = &[
    stereo::TECHNIQUE,
    msaa::TECHNIQUE,
    culling::TECHNIQUE,
    stencil::TECHNIQUE,
    foveation::TECHNIQUE,
    rdm::TECHNIQUE,
    mffr::TECHNIQUE,
    gpu_cull::TECHNIQUE,
    resolved_sky::TECHNIQUE,
    inset::TECHNIQUE,
    lms::TECHNIQUE,
    aq::TECHNIQUE,
    timewarp::TECHNIQUE,
    points::TECHNIQUE,
];

/// One `--opt` entry: the whole text, and its name and value split at
/// the first `=`.
#[derive(Clone, Copy, Debug)]
pub struct Entry<'a> {
    /// The entry as written (`lod=2`).
    pub item: &'a str,
    /// Before the `=` (`lod`).
    pub name: &'a str,
    /// After the `=`, if there is one (`2`).
    pub value: Option<&'a str>,
}

impl<'a> Entry<'a> {
    /// Splits `item` at its first `=`.
    pub fn new(item: &'a str) -> Entry<'a> {
        match item.split_once('=') {
            Some((name, value)) => Entry {
                item,
                name,
                value: Some(value),
            },
            None => Entry {
                item,
                name: item,
                value: None,
            },
        }
    }

    /// The value as a number within `lo..=hi`; else one error naming the
    /// entry, the expected form `name=META` and what the value is.
    pub fn number(
        &self,
        (lo, hi): (f64, f64),
        meta: &str,
        what: &str,
    ) -> crate::error::Result<f64> {
        match self.value.unwrap_or_default().parse::<f64>() {
            Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
            _ => Err(crate::error::Error::config(
                "--opt",
                format!(
                    "'{}': expected {}={meta} with {lo} <= {meta} <= {hi} ({what})",
                    self.item, self.name
                ),
            )),
        }
    }
}

/// Applies one entry to `c` through the technique that declares its name
/// (a culling strategy's name goes to the culling technique). An unknown
/// name, a value given to a flag and a missing required value are each
/// one error naming the entry.
pub fn apply(c: &mut RenderConfig, item: &str, cull_names: &[&str]) -> crate::error::Result<()> {
    use crate::error::Error;
    let e = Entry::new(item);
    if cull_names.contains(&item) {
        return (culling::TECHNIQUE.parse)(c, &e);
    }
    let found = TECHNIQUES
        .iter()
        .find_map(|t| t.options.iter().find(|o| o.name == e.name).map(|o| (t, o)));
    let Some((t, o)) = found else {
        return Err(Error::config(
            "--opt",
            format!(
                "unknown optimization '{item}' (known: {})",
                known_list(cull_names)
            ),
        ));
    };
    match (o.value, e.value) {
        (Value::Flag, Some(_)) => Err(Error::config(
            "--opt",
            format!("'{item}': {} takes no value", o.name),
        )),
        (Value::Required(meta), None) => Err(Error::config(
            "--opt",
            format!("'{item}': expected {}={meta}", o.name),
        )),
        _ => (t.parse)(c, &e),
    }
}

/// The `--opt` list that gives `c` back: every technique's entries in
/// [`TECHNIQUES`]' order.
pub fn print(c: &RenderConfig) -> String {
    let mut out = Vec::new();
    for t in TECHNIQUES {
        (t.print)(c, &mut out);
    }
    out.join(",")
}

impl Opt {
    /// How the option is written in lists and help: `name`, `name[=META]`
    /// or `name=META`.
    pub fn spelling(&self) -> String {
        match self.value {
            Value::Flag => self.name.to_string(),
            Value::Optional(meta) => format!("{}[={meta}]", self.name),
            Value::Required(meta) => format!("{}={meta}", self.name),
        }
    }

    /// The option as an `--opt` entry: with its example value unless it
    /// is a flag.
    pub fn example_entry(&self) -> String {
        match self.value {
            Value::Flag => self.name.to_string(),
            _ => format!("{}={}", self.name, self.example),
        }
    }
}

/// Every declared option.
pub fn all() -> impl Iterator<Item = &'static Opt> {
    TECHNIQUES.iter().flat_map(|t| t.options.iter())
}

/// The known names for the unknown-option error: every option's
/// spelling, then the culling strategies.
pub fn known_list(cull_names: &[&str]) -> String {
    all()
        .map(Opt::spelling)
        .chain(cull_names.iter().map(|s| s.to_string()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `--opt`'s long help: one line per technique.
pub fn help(cull_names: &[&str]) -> String {
    let mut out = String::from(
        "Comma-separated optimizations (applied after --config; two entries that set the same thing differently are refused):\n",
    );
    for t in TECHNIQUES {
        out.push_str(&format!(
            "  {}: {}\n",
            options_text(t, cull_names, ", ", false),
            t.summary
        ));
    }
    out
}

/// A technique's options as text, each spelling wrapped in backticks for
/// markdown (`|` escaped there).
fn options_text(t: &Technique, cull_names: &[&str], sep: &str, markdown: bool) -> String {
    let spellings: Vec<String> = if t.page == CULLING_PAGE {
        cull_names
            .iter()
            .filter(|n| **n != "none")
            .map(|n| n.to_string())
            .collect()
    } else {
        t.options.iter().map(Opt::spelling).collect()
    };
    spellings
        .iter()
        .map(|s| {
            if markdown {
                format!("`{}`", s.replace('|', "\\|"))
            } else {
                s.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(sep)
}

/// The README's techniques table (header and rows), one row per
/// technique linking its page.
pub fn markdown_table(cull_names: &[&str]) -> String {
    let mut out = String::from("| technique | `--opt` | what it does |\n|---|---|---|\n");
    for t in TECHNIQUES {
        out.push_str(&format!(
            "| [{}](docs/techniques/{}.md) | {} | {} |\n",
            t.title,
            t.page,
            options_text(t, cull_names, ", ", true),
            t.summary
        ));
    }
    out
}

#[cfg(test)]
mod tests;
