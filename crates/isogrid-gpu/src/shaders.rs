//! The WGSL source of each shader module: the files of `shaders/` that it concatenates, in order,
//! as `shaders/modules.txt` lists them (build.rs turns each line into one const here). That list is
//! the one place a composition is written; the web viewer's build reads it too (web/build.mjs), so
//! that the browser runs the same sources. Pass a const to `wgpu_util::module`, which concatenates
//! the parts.

include!(concat!(env!("OUT_DIR"), "/shader_modules.rs"));

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// Every composition goes through the manifest: no source file of the crate includes a shader
    /// file by itself, and every `.wgsl` file belongs to at least one module.
    #[test]
    fn shader_sources_come_only_from_the_manifest() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let manifest = std::fs::read_to_string(root.join("shaders/modules.txt")).unwrap();
        let mut stack = vec![root.join("src")];
        let mut checked = 0;
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else if path.extension().is_some_and(|e| e == "rs") {
                    let text = std::fs::read_to_string(&path).unwrap();
                    let includes_shader = text
                        .lines()
                        .any(|l| l.contains(concat!("include", "_str!")) && l.contains(".wgsl"));
                    assert!(
                        !includes_shader,
                        "{} includes a file itself: compose shader modules in shaders/modules.txt",
                        path.display()
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 10);
        for entry in std::fs::read_dir(root.join("shaders")).unwrap() {
            let name = entry.unwrap().file_name().into_string().unwrap();
            if name.ends_with(".wgsl") {
                assert!(
                    manifest.split_whitespace().any(|w| w == name),
                    "shaders/{name} is in no module of shaders/modules.txt"
                );
            }
        }
        assert_eq!(super::CELLS.len(), 5);
        assert!(super::SHADE[0].starts_with("// Declarations shared by every isogrid-gpu shader"));
    }
}
