//! The layout of DESIGN.md §1–2: every top-level entry exists, and every `systems/*.rs` is
//! declared in `systems/mod.rs` (the compiler would silently ignore one that is not).

use std::path::Path;

#[test]
fn top_level_layout_is_complete() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for entry in
        ["Cargo.toml", "src", "systems", "scenes", "tests", "benches", "README.md", "src/lib.rs", "systems/mod.rs"]
    {
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
