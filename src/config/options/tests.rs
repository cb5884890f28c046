//! The declarations against the parser, the printer and the README.

use super::*;
use crate::config::{cull_names, RenderConfig};
use proptest::prelude::*;

#[test]
fn every_declared_spelling_parses() {
    let names = cull_names();
    for o in all() {
        let mut entries = vec![o.example_entry()];
        if !matches!(o.value, Value::Required(_)) {
            entries.push(o.name.to_string());
        }
        for e in entries {
            let mut c = RenderConfig::default();
            c.apply_opts(&e, &names)
                .unwrap_or_else(|err| panic!("'{e}' is declared but refused: {err}"));
        }
    }
}

#[test]
fn the_unknown_option_error_lists_every_declared_name() {
    let names = cull_names();
    let e = RenderConfig::default()
        .apply_opts("warp-speed", &names)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&known_list(&names)), "{e}");
    for o in all() {
        assert!(e.contains(&o.spelling()), "{} missing: {e}", o.name);
    }
}

#[test]
fn the_readme_table_is_the_generated_one() {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"));
    let readme = crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES).unwrap();
    let table = markdown_table(&cull_names());
    assert!(
        readme.contains(&table),
        "README.md's techniques table differs from the declarations; it should read:\n{table}"
    );
    for t in TECHNIQUES {
        let page = format!(
            "{}/docs/techniques/{}.md",
            env!("CARGO_MANIFEST_DIR"),
            t.page
        );
        assert!(std::path::Path::new(&page).is_file(), "{page}");
    }
}

#[test]
fn the_help_names_every_option() {
    let h = help(&cull_names());
    for o in all() {
        assert!(h.contains(&o.spelling()), "{}", o.name);
    }
}

proptest! {
    /// parse(print(c)) == c for configurations made of random declared
    /// entries (lists the parser refuses, such as two settings of one
    /// thing, are skipped).
    #[test]
    fn printing_and_parsing_give_the_configuration_back(
        picks in prop::collection::vec((0usize..1000, any::<bool>()), 0..8),
        cull in 0usize..16,
    ) {
        let names = cull_names();
        let opts: Vec<&Opt> = all().collect();
        let mut entries: Vec<String> = picks
            .iter()
            .map(|&(k, bare)| {
                let o = opts[k % opts.len()];
                match (o.value, bare) {
                    (Value::Optional(_), true) | (Value::Flag, _) => o.name.to_string(),
                    _ => o.example_entry(),
                }
            })
            .collect();
        entries.push(names[cull % names.len()].to_string());
        let list = entries.join(",");
        let mut c = RenderConfig::default();
        if c.apply_opts(&list, &names).is_ok() {
            let printed = c.opt_string();
            let mut back = RenderConfig::default();
            back.apply_opts(&printed, &names).unwrap();
            prop_assert_eq!(back, c, "{} -> {}", list, printed);
        }
    }
}

#[test]
fn every_rule_names_what_it_refuses() {
    for t in TECHNIQUES {
        for r in t.rules {
            assert_eq!(
                r.message.contains("{}"),
                !r.with.is_empty(),
                "{}: {}",
                t.page,
                r.message
            );
            assert!(
                r.message.contains("leave")
                    || r.message.contains("add")
                    || r.message.contains("cannot")
                    || r.message.contains("needs")
                    || r.message.contains("give"),
                "{}",
                r.message
            );
        }
    }
    let mut c = RenderConfig::default();
    c.apply_opts("superfrustum,lms,timewarp=2,mffr", &cull_names())
        .unwrap();
    let e = check_rules(&c).unwrap_err().to_string();
    assert!(
        e.contains("mffr, timewarp") && e.contains("with lms"),
        "{e}"
    );
}
