//! Turns `shaders/modules.txt` (the shader modules and the files each concatenates, shared with
//! the web viewer's build) into `$OUT_DIR/shader_modules.rs`: one `&[&str]` const per module,
//! the files' `include_str!`s in order, included by `src/shaders.rs`.

use std::fmt::Write;
use std::path::Path;

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let manifest = dir.join("modules.txt");
    // Relative to the package root, for the same reason.
    println!("cargo:rerun-if-changed=shaders/modules.txt");
    let text = std::fs::read_to_string(&manifest)
        .unwrap_or_else(|e| panic!("{}: {e}", manifest.display()));
    let mut out = String::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (name, files) = line
            .split_once(':')
            .unwrap_or_else(|| panic!("{}:{}: not `name: files`", manifest.display(), n + 1));
        let files: Vec<&str> = files.split_whitespace().collect();
        assert!(
            !files.is_empty()
                && name
                    .trim()
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c == '_'),
            "{}:{}: a module needs a lower_case name and at least one file",
            manifest.display(),
            n + 1
        );
        writeln!(out, "/// `{}`: {}", name.trim(), files.join(" + ")).unwrap();
        write!(
            out,
            "pub(crate) const {}: &[&str] = &[",
            name.trim().to_uppercase()
        )
        .unwrap();
        for f in &files {
            let path = dir.join(f);
            assert!(path.is_file(), "{}:{}: no {f}", manifest.display(), n + 1);
            // Named from the package root, not by this checkout's absolute path, so that a
            // target directory copied from another checkout recompiles this checkout's shaders.
            write!(
                out,
                "include_str!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/shaders/{f}\")), "
            )
            .unwrap();
        }
        writeln!(out, "];").unwrap();
    }
    let out_dir = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    std::fs::write(Path::new(&out_dir).join("shader_modules.rs"), out).expect("write OUT_DIR");
}
