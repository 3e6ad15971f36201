//! The committed `include/slod.h` must be exactly what cbindgen generates from this crate now.

use std::path::PathBuf;

#[test]
fn header_matches_cbindgen_output() {
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_crate(&crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header");
    let mut rendered = Vec::new();
    bindings.write(&mut rendered);
    let path = crate_dir.join("../include/slod.h");
    if std::env::var_os("SLOD_BLESS").is_some() {
        std::fs::write(&path, &rendered).expect("write include/slod.h");
        return;
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == rendered,
        "include/slod.h differs from what cbindgen generates now; regenerate with\n  \
         SLOD_BLESS=1 cargo test -p slod --test header"
    );
}

#[test]
fn header_version_matches_crate_version() {
    let header = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../include/slod.h"))
        .expect("include/slod.h");
    let v: Vec<&str> = env!("CARGO_PKG_VERSION").split('.').collect();
    for (name, value) in ["MAJOR", "MINOR", "PATCH"].iter().zip(v) {
        let line = format!("#define SLOD_VERSION_{name} {value}");
        assert!(header.contains(&line), "header lacks `{line}`");
    }
    assert_eq!(
        slod::ffi::world::slod_version(),
        v_num(env!("CARGO_PKG_VERSION"))
    );
}

fn v_num(v: &str) -> u32 {
    let p: Vec<u32> = v.split('.').map(|x| x.parse().unwrap()).collect();
    p[0] * 1_000_000 + p[1] * 1_000 + p[2]
}
