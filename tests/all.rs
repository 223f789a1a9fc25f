//! The integration tests, one binary (`cargo test --release --test all`; one module a test
//! file beside this one, so `cargo test --release --test all method_bounds::` runs one file):
//! one link of the library instead of one a file, and one GPU device for the GPU tests.
//! Cargo.toml sets `autotests = false`, so a new `tests/*.rs` file is a module here, not a
//! binary of its own: `every_test_file_is_a_module_here` fails until it is listed.
//!
//! The modules run as threads of one process: a test passes what it changes to the child
//! process it starts (`Command::env`, `Command::current_dir`), never to this process.

mod common;

mod bench;
mod bounds;
mod cli;
mod committed_reports;
mod compiled;
mod composite;
mod defects;
mod derived;
mod engines;
mod envelope;
mod eval_reference;
mod evaluator;
mod findings;
mod fit_resume;
mod gate;
mod ggx_feed;
mod ggx_fresnel;
mod ggx_reference;
mod glsl;
mod gpu_methods;
mod guards;
mod hlsl;
mod html_browser;
mod kernel_lib;
mod kernel_textures;
mod layering;
mod ltc_aniso;
mod ltc_aniso_resolution;
mod ltc_fit;
mod ltc_lookup;
mod ltc_sw;
mod method_bounds;
mod mrp_specular;
mod promises;
mod properties;
mod reference_independent;
mod render;
mod render_gate;
mod robustness;
mod scale;
mod scan;
mod scene_contract;
mod ship;
mod texture_case;
mod texture_kernels;
mod texture_reference;
mod tube_models;

/// Every `tests/*.rs` file is declared above (with `autotests = false` an undeclared file
/// would silently not run), and every module declared is a file.
#[test]
fn every_test_file_is_a_module_here() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().into_string().unwrap();
            let stem = name.strip_suffix(".rs")?.to_string();
            (stem != "all").then_some(stem)
        })
        .collect();
    files.sort();
    let this = include_str!("all.rs");
    let mut declared: Vec<String> = this
        .lines()
        .filter_map(|l| Some(l.strip_prefix("mod ")?.strip_suffix(';')?.to_string()))
        .filter(|m| m != "common")
        .collect();
    declared.sort();
    assert_eq!(files, declared, "tests/*.rs and the `mod` lines of tests/all.rs");
}
