//! Passes cargo's `TARGET` and `HOST` (given to build scripts only) on to the test code, which
//! builds a `cc::Build` at test time to find the C and C++ compilers for the C and C++ hosts.

fn main() {
    for var in ["TARGET", "HOST"] {
        let value =
            std::env::var(var).unwrap_or_else(|_| panic!("cargo sets {var} for build scripts"));
        println!("cargo:rustc-env={var}={value}");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
