//! `cargo run --release -p slod-demo`: both papers' experiments measured, printed beside the
//! papers' figures, with pictures, plots and `report.json` written to `out/`.
//!
//! Everything lives in the library (`slod_demo::run_cli`) so the tests run the same code.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let code = slod_demo::run_cli(
        &args,
        &mut std::io::stdout(),
        &mut std::io::stderr(),
        slod_demo::Progress::Auto,
    );
    std::process::exit(code);
}
