//! Building and running the native hosts (the C demo, the C++ host) against the static library
//! cargo built for the current test run, with the system's C and C++ compilers.
//!
//! Where the library is: cargo builds every crate type of `slod` (rlib, cdylib, staticlib) as a
//! dependency of this package and leaves them in `target/<profile>/deps`, the directory of the
//! test executable itself, so `deps/libslod.a` is always the one built for this run. The copy
//! in `target/<profile>/` is refreshed only when `slod` is a selected package
//! (`cargo test --workspace`), so it is only the fallback.
//!
//! Compilers: `$CC` / `$CXX` when set, else the first of `cc`, `gcc`, `clang` (C) or `c++`,
//! `g++`, `clang++` (C++) that answers `--version`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Libraries a Rust static library needs from the system on Linux (threads, dynamic loading,
/// math); the C runtime and libgcc come with the compiler driver.
pub const SYSTEM_LIBS: [&str; 3] = ["-lpthread", "-ldl", "-lm"];

/// Warnings the hosts must compile without.
pub const WARNINGS: [&str; 4] = ["-Wall", "-Wextra", "-Werror", "-pedantic"];

/// The repository root (the workspace directory).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// `target/<profile>/deps`: where the running test executable lies.
fn deps_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("current test executable");
    exe.parent().expect("executable directory").to_path_buf()
}

/// The `libslod.a` built for this test run (see the module docs).
pub fn static_library() -> PathBuf {
    let deps = deps_dir();
    let candidates = [
        deps.join("libslod.a"),
        deps.parent().unwrap_or(&deps).join("libslod.a"),
    ];
    for c in &candidates {
        if c.is_file() {
            return c.clone();
        }
    }
    panic!(
        "libslod.a not found in {:?}; it is built with the `slod` dependency of slod-tests",
        candidates
    );
}

/// A fresh directory for one test's build products, under `target/<profile>/native-hosts`.
pub fn scratch_dir(name: &str) -> PathBuf {
    let deps = deps_dir();
    let dir = deps
        .parent()
        .unwrap_or(&deps)
        .join("native-hosts")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch directory");
    dir
}

/// Which compiler.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lang {
    /// The C compiler (`$CC`).
    C,
    /// The C++ compiler (`$CXX`).
    Cxx,
}

/// Whether `program --version` runs.
pub fn available(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The compiler for `lang` (see the module docs); panics if none is installed.
pub fn compiler(lang: Lang) -> String {
    let (var, candidates): (&str, &[&str]) = match lang {
        Lang::C => ("CC", &["cc", "gcc", "clang"]),
        Lang::Cxx => ("CXX", &["c++", "g++", "clang++"]),
    };
    if let Ok(cc) = std::env::var(var) {
        if !cc.trim().is_empty() {
            return cc;
        }
    }
    candidates
        .iter()
        .find(|c| available(c))
        .map(|c| c.to_string())
        .unwrap_or_else(|| {
            panic!("no {lang:?} compiler: set ${var} or install one of {candidates:?}")
        })
}

/// Runs a command to completion, panicking if it cannot start.
pub fn run(cmd: &mut Command) -> Output {
    cmd.output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"))
}

/// Runs a command that must succeed; returns its stdout. On failure panics with both streams.
pub fn run_ok(cmd: &mut Command) -> String {
    let out = run(cmd);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cmd:?} failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Compiles and links `sources` into executable `out` against the static library, with `std`
/// (e.g. `-std=c11`) and every warning an error.
pub fn build_executable(lang: Lang, std: &str, sources: &[PathBuf], out: &Path) -> PathBuf {
    let mut cmd = Command::new(compiler(lang));
    cmd.arg(std)
        .args(WARNINGS)
        .arg("-O1")
        .arg("-I")
        .arg(repo_root().join("include"))
        .args(sources)
        .arg("-o")
        .arg(out)
        .arg(static_library())
        .args(SYSTEM_LIBS);
    run_ok(&mut cmd);
    out.to_path_buf()
}
