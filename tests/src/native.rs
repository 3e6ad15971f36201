//! Building and running the native hosts (the C demo, the C++ host) against the static library
//! cargo built for the current test run, with the system's C and C++ compilers.
//!
//! Where the library is: cargo builds every crate type of `slod` (rlib, cdylib, staticlib) as a
//! dependency of this package and leaves them in `target/<profile>/deps`, the directory of the
//! test executable itself, so `deps/libslod.a` is always the one built for this run. The copy
//! in `target/<profile>/` is refreshed only when `slod` is a selected package
//! (`cargo test --workspace`), so it is only the fallback.
//!
//! Compilers: the `cc` crate's choice for the target this test run was built for (`$CC` / `$CXX`
//! and their target-specific variants when set, else the platform's default), with its default
//! flags for that target; `build.rs` hands cargo's `TARGET` and `HOST` to this code for it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Libraries a Rust static library needs from the system on Linux (threads, dynamic loading,
/// math); the C runtime and libgcc come with the compiler driver.
pub const SYSTEM_LIBS: [&str; 3] = ["-lpthread", "-ldl", "-lm"];

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

/// A `cc` build for `lang` and the target of this test run: language standard `std` (e.g.
/// `c11`), every warning an error (`-Wall -Wextra -Werror -pedantic`), `-O1`, no debug info, `include/` on the
/// include path. It prints nothing for cargo (this is not a build script).
pub fn cc_build(lang: Lang, std: &str) -> cc::Build {
    let mut build = cc::Build::new();
    build
        .target(env!("TARGET"))
        .host(env!("HOST"))
        .cpp(lang == Lang::Cxx)
        .std(std)
        .opt_level(1)
        .debug(false)
        .warnings(true) // -Wall -Wextra
        .warnings_into_errors(true) // -Werror
        .flag("-pedantic")
        .include(repo_root().join("include"))
        // Where cc puts its compiler-detection probes (this crate's build-script directory).
        .out_dir(env!("OUT_DIR"))
        .cargo_metadata(false)
        .cargo_warnings(false);
    build
}

/// The compiler command of `build` with all its flags; panics if there is no compiler.
pub fn compiler_command(build: &cc::Build) -> Command {
    build
        .try_get_compiler()
        .unwrap_or_else(|e| panic!("no C/C++ compiler for {}: {e}", env!("TARGET")))
        .to_command()
}
/// Whether this runs under CI (`CI=true`, as `.ci/run` and most CI services set it).
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v.eq_ignore_ascii_case("true") || v == "1")
}

/// A `valgrind` memcheck command (errors and definite/possible leaks fail it), or `None` when
/// valgrind is not installed outside CI (a note is printed). Under CI a missing valgrind panics:
/// there the memcheck run may not be skipped.
pub fn memcheck() -> Option<Command> {
    memcheck_failing_on("definite,possible")
}

/// [`memcheck`] failing only on errors and the given leak kinds (`definite` for a Rust test
/// binary, whose harness leaves its own threads' bookkeeping "possibly lost" at exit).
pub fn memcheck_failing_on(leak_kinds: &str) -> Option<Command> {
    if !available("valgrind") {
        assert!(
            !under_ci(),
            "CI=true but valgrind is not installed: under CI the memcheck run may not be skipped"
        );
        println!("note: valgrind is not installed; skipping the memcheck run (CI installs it)");
        return None;
    }
    let mut cmd = Command::new("valgrind");
    cmd.args(["--error-exitcode=1", "--leak-check=full"]);
    cmd.arg(format!("--show-leak-kinds={leak_kinds}"));
    cmd.arg(format!("--errors-for-leak-kinds={leak_kinds}"));
    // One documented false positive (crossbeam-epoch's tagged pointers), see the file.
    cmd.arg(format!(
        "--suppressions={}",
        repo_root().join("tests/valgrind.supp").display()
    ));
    Some(cmd)
}

/// Asserts that a memcheck run succeeded with no errors; returns its stdout.
pub fn assert_memcheck_clean(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "valgrind reported errors ({}):\n{stderr}",
        out.status
    );
    assert!(stderr.contains("ERROR SUMMARY: 0 errors"), "{stderr}");
    String::from_utf8_lossy(&out.stdout).into_owned()
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
/// (e.g. `c11`) and every warning an error (see [`cc_build`]).
pub fn build_executable(lang: Lang, std: &str, sources: &[PathBuf], out: &Path) -> PathBuf {
    let mut cmd = compiler_command(&cc_build(lang, std));
    cmd.args(sources)
        .arg("-o")
        .arg(out)
        .arg(static_library())
        .args(SYSTEM_LIBS);
    run_ok(&mut cmd);
    out.to_path_buf()
}
