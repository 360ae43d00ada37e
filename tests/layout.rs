//! The layout of ARCHITECTURE.md: every top-level entry exists, every `systems/*.rs` is
//! declared in `systems/mod.rs` (the compiler would silently ignore one that is not), the
//! folders depend on each other in one direction only, and no file points outside the
//! repository.

use std::path::Path;

#[test]
fn top_level_layout_is_complete() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for entry in [
        "Cargo.toml",
        "src",
        "systems",
        "scenes",
        "tests",
        "benches",
        "README.md",
        "ARCHITECTURE.md",
        "src/lib.rs",
        "systems/mod.rs",
    ] {
        assert!(root.join(entry).exists(), "missing {entry}");
    }
}

#[test]
fn every_system_file_is_declared() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("systems");
    let module = std::fs::read_to_string(dir.join("mod.rs")).expect("systems/mod.rs");
    for entry in std::fs::read_dir(&dir).expect("systems/") {
        let path = entry.expect("entry").path();
        let stem = path.file_stem().and_then(|s| s.to_str()).expect("utf-8 name");
        if stem != "mod" && path.extension().is_some_and(|e| e == "rs") {
            assert!(module.contains(&format!("mod {stem};")), "systems/{stem}.rs is not declared in systems/mod.rs");
        }
    }
}

/// The parts of the crate from the bottom up (ARCHITECTURE.md, "Code map"): each may use only
/// those before it.
const LAYERS: &[&str] =
    &["rng", "math", "error", "model", "collision", "sim", "solver", "systems", "io", "scene", "cli"];

/// The part a source file belongs to: its folder under `src/`, `systems`, or its own name.
fn part_of(root: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(root).expect("under the root");
    let mut parts = rel.iter().map(|p| p.to_string_lossy().into_owned());
    let top = parts.next().expect("a component");
    if top == "systems" {
        return top;
    }
    let next = parts.next().expect("a file under src/");
    next.trim_end_matches(".rs").to_string()
}

#[test]
fn folders_depend_on_each_other_in_one_direction() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    collect_files(&root.join("src"), &mut files);
    collect_files(&root.join("systems"), &mut files);
    files.retain(|f| f.extension().is_some_and(|e| e == "rs"));
    let rank = |part: &str| LAYERS.iter().position(|l| *l == part);
    let mut checked = 0;
    for file in files {
        let part = part_of(root, &file);
        let Some(own) = rank(&part) else { continue }; // lib.rs and main.rs see everything
        let text = std::fs::read_to_string(&file).expect("utf-8 source");
        for (at, _) in text.match_indices("crate::") {
            let name: String = text[at + 7..].chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
            if let Some(used) = rank(&name) {
                assert!(used <= own, "{} ({part}) uses crate::{name}, a later part", file.display());
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "the scan found the crate's paths ({checked})");
}

#[test]
fn nothing_points_outside_the_repository() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in ["src", "systems", "tests", "benches", "examples", "scenes", "docs", ".ci", ".cargo", "python"] {
        collect_files(&root.join(dir), &mut files);
    }
    files.extend(["README.md", "ARCHITECTURE.md", "BENCH.md", "pyproject.toml"].map(|f| root.join(f)));
    // Built from pieces, so this file does not match itself.
    let outside = [
        ["../", "shared"].concat(),
        ["PHYSICS", ".md"].concat(),
        ["CONTRACTS", ".md"].concat(),
        ["BENCHMARKS", ".md"].concat(),
        ["DESIGN", ".md"].concat(),
        ["STYLE", ".md"].concat(),
    ];
    for file in files {
        let Ok(text) = std::fs::read_to_string(&file) else { continue }; // images
        for needle in &outside {
            assert!(
                !text.contains(needle.as_str()),
                "{} names {needle}, which is not in the repository",
                file.display()
            );
        }
    }
}

fn collect_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries {
        let path = entry.expect("entry").path();
        if path.is_dir() { collect_files(&path, out) } else { out.push(path) }
    }
}
