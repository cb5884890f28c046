//! The `--opt` names as data: each technique with its options, how each
//! option takes a value, an example value and a one-line description.
//! The unknown-option error's list of known names, `--opt`'s help and the
//! README's techniques table are generated from these declarations; the
//! tests check that every declared spelling parses, that the README's
//! table is the generated one, and that printing a configuration and
//! parsing the print gives it back over random configurations.

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

/// Every technique and its options, in the order the docs list them.
pub const TECHNIQUES: &[Technique] = &[
    Technique {
        title: "Multiview / two-pass",
        page: "multiview",
        summary: "both eyes in one multiview rendering scope (the default), or one scope per eye",
        options: &[flag("multiview"), flag("two-pass")],
    },
    Technique {
        title: "MSAA and the raster floor",
        page: "msaa",
        summary: "4× (the default) or one sample; what an empty frame costs and the parts vergence skips",
        options: &[flag("msaa4"), flag("msaa"), flag("no-msaa")],
    },
    Technique {
        title: "Stereo culling on the CPU",
        page: CULLING_PAGE,
        summary: "culls both eyes against one combined frustum (or the alternatives) over a BVH",
        options: &[],
    },
    Technique {
        title: "HMD stencil mask",
        page: "stencil-mask",
        summary: "never shades the pixels the lenses hide",
        options: &[flag("stencil-mask")],
    },
    Technique {
        title: "Foveated shading",
        page: "foveation",
        summary: "coarser shading rate away from the gaze (VK_KHR_fragment_shading_rate)",
        options: &[
            optional("foveation", "off|low|medium|high|auto", "high"),
            required("gaze", "X:Y", "0.25:-0.5"),
        ],
    },
    Technique {
        title: "Radial density masking",
        page: "rdm",
        summary: "skips every other 2×2 quad in the periphery and fills it from its neighbours",
        options: &[optional("rdm", "R|auto", "0.4"), flag("rdm-nofill")],
    },
    Technique {
        title: "Monoscopic far field",
        page: "mffr",
        summary: "renders what lies beyond a disparity of one pixel once, for both eyes",
        options: &[
            optional("mffr", "D", "12.5"),
            flag("mffr-depth-shift"),
            flag("mffr-alternate-eye"),
            flag("mffr-no-split"),
        ],
    },
    Technique {
        title: "GPU-driven culling, occlusion, LOD",
        page: "gpu-cull",
        summary: "culls on the GPU with indirect draws, two-phase hierarchical-Z occlusion, per-instance level of detail by projected error",
        options: &[
            flag("gpu-cull"),
            flag("occlusion"),
            optional("lod", "PX", "2"),
            flag("lod-cache"),
        ],
    },
    Technique {
        title: "Sky after the resolve",
        page: "resolved-sky",
        summary: "draws the sky once per pixel under the resolved 4× image",
        options: &[flag("resolved-sky")],
    },
    Technique {
        title: "Multi-resolution foveated rendering (inset)",
        page: "inset",
        summary: "full resolution around the gaze, a smaller wide view elsewhere, optionally at one sample, accumulated, upsampled and sharpened over frames; four views to runtimes that take them",
        options: &[
            optional("inset", "F", "0.6"),
            required("inset-fov", "DEG", "15"),
            required("inset-views", "2|4", "4"),
            flag("inset-wide-1x"),
            optional("inset-taa", "A", "0.25"),
            flag("inset-taa-jitter"),
            flag("inset-taau"),
            optional("inset-sharpen", "S", "0.5"),
            flag("inset-taau-lanczos"),
            flag("inset-catmull-rom"),
            flag("inset-wide-all"),
            flag("inset-composite"),
        ],
    },
    Technique {
        title: "Lens-matched shading",
        page: "lms",
        summary: "renders each quadrant with a clip-space w scaling that matches the lens's falling pixel density",
        options: &[optional("lms", "K", "0.25"), flag("lms-emulated")],
    },
    Technique {
        title: "Adaptive quality",
        page: "aq",
        summary: "moves the render scale (and the inset's periphery) to hold the frame budget",
        options: &[flag("aq"), flag("aq-scale-only")],
    },
    Technique {
        title: "Timewarp, measured",
        page: "timewarp",
        summary: "warps frames to newer poses offline and measures the error against rendering them",
        options: &[
            required("timewarp", "K", "2"),
            flag("timewarp-rotation"),
            flag("timewarp-fill"),
        ],
    },
    Technique {
        title: "Point-cloud rendering",
        page: "points",
        summary: "compute rasterization of an octree-chosen point budget, composited with the meshes; eye-dome lighting",
        options: &[
            required("points-budget", "N", "5000"),
            required("point-size", "PX", "3"),
            flag("points-pipeline"),
            optional("edl", "S", "1.5"),
        ],
    },
];

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
