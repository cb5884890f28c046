//! `resolved-sky`: the sky drawn once per pixel after the resolve
//! ([`crate::render::passes`]).

use super::{flag, four_views, Entry, Rule, Technique};
use crate::config::RenderConfig;
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Sky after the resolve",
    page: "resolved-sky",
    summary: "draws the sky once per pixel under the resolved 4× image",
    options: &[flag("resolved-sky")],
    parse,
    print,
    rules: &[
        Rule::always(
            |c| c.effort.resolved_sky && c.frame.msaa == 1,
            "resolved-sky draws the sky after the MSAA resolve: it needs msaa4 (leave out no-msaa)",
        ),
        Rule {
            when: |c| c.effort.resolved_sky,
            with: &[("inset-views=4", four_views)],
            message: "resolved-sky draws the sky under the forward views' resolved image; {} composites that image its own way: leave it out with resolved-sky",
        },
        Rule {
            when: |c| c.effort.resolved_sky,
            with: &[
                ("timewarp", |c| c.simulator.timewarp.is_some()),
                ("--record-threads", |c| c.submission.record_threads.is_some()),
            ],
            message: "resolved-sky is measured on its own and with the culling and masking passes; {} is not combined with it (timewarp reprojects the frame, --record-threads records the sky inside its secondaries): leave it out with resolved-sky",
        },
    ],
};

fn parse(c: &mut RenderConfig, _: &Entry) -> Result<()> {
    c.effort.resolved_sky = true;
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.effort.resolved_sky {
        out.push("resolved-sky".into());
    }
}
