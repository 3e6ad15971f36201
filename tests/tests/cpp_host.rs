//! Proof that C and C++ engines can use slod through its header: `include/slod.h` compiles alone
//! as C11 and as C++17, and the C++17 host `tests/cpp/host.cpp` (slod.h plus the RAII wrapper
//! slod.hpp) compiles with every warning an error, links against the static library built for
//! this run, drives a cloth and a crowd, and checks what it gets back (its exit code).

use std::process::Command;

use slod_tests::native::{
    Lang, assert_memcheck_clean, build_executable, cc_build, compiler_command, memcheck, repo_root,
    run, run_ok, scratch_dir,
};

/// Compiles a one-line translation unit including `header` as `lang`/`std`.
fn compile_alone(lang: Lang, std: &str, header: &str, name: &str) {
    let dir = scratch_dir(name);
    let ext = if lang == Lang::C { "c" } else { "cpp" };
    let src = dir.join(format!("only_header.{ext}"));
    std::fs::write(
        &src,
        format!("#include \"{header}\"\nint main(void) {{ return 0; }}\n"),
    )
    .expect("write source");
    run_ok(
        compiler_command(&cc_build(lang, std))
            .arg("-c")
            .arg(&src)
            .arg("-o")
            .arg(dir.join("only_header.o")),
    );
}

#[test]
fn header_compiles_alone_as_c11() {
    compile_alone(Lang::C, "c11", "slod.h", "header-c11");
}

#[test]
fn header_compiles_alone_as_cxx17() {
    compile_alone(Lang::Cxx, "c++17", "slod.h", "header-cxx17");
}

#[test]
fn wrapper_compiles_alone_as_cxx17() {
    compile_alone(Lang::Cxx, "c++17", "slod.hpp", "wrapper-cxx17");
}

#[test]
fn cpp_host_drives_a_cloth_and_a_crowd() {
    let exe = host();
    let rig = repo_root().join("assets/gltf/GDQuest_GDBot.glb");
    let out = run_ok(Command::new(&exe).arg(&rig));
    assert!(out.contains("cpp host ok"), "{out}");
}

/// The host built once per test binary.
fn host() -> std::path::PathBuf {
    static EXE: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    EXE.get_or_init(|| {
        let dir = scratch_dir("cpp-host");
        build_executable(
            Lang::Cxx,
            "c++17",
            &[repo_root().join("tests/cpp/host.cpp")],
            &dir.join("host"),
        )
    })
    .clone()
}

/// The C++ host, including its lifetime checks (a World moved into a variable declared after
/// its handles, handles outliving their World), is clean under valgrind memcheck.
#[test]
fn cpp_host_is_clean_under_valgrind() {
    let Some(mut valgrind) = memcheck() else {
        return;
    };
    let rig = repo_root().join("assets/gltf/GDQuest_GDBot.glb");
    let out = run(valgrind.arg(host()).arg(&rig));
    let stdout = assert_memcheck_clean(&out);
    assert!(stdout.contains("cpp host ok"), "{stdout}");
}
