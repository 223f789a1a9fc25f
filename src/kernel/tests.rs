//! Composition errors, checked without a device: each names the file and line that caused it.

use super::*;
use naga::valid::Capabilities;

fn kernel(path: &str, header: &str, body: &str) -> KernelFile {
    KernelFile::parse(path, &format!("//! id: test.k\n//! target: line\n{header}{body}")).unwrap()
}

#[test]
fn header_param_without_override_is_reported() {
    let k = kernel(
        "noparam.wgsl",
        "//! params: SAMPLES=4\n",
        "fn method(scene: Scene) -> f32 { return 0.0; }\n",
    );
    let e = compose(&k).unwrap_err();
    assert_eq!((e.path.as_str(), e.location.map(|l| l.0)), ("noparam.wgsl", Some(3)));
    assert!(e.to_string().contains("override SAMPLES"), "{e}");
}

#[test]
fn validation_error_names_its_file_and_line() {
    let k = kernel(
        "ret.wgsl",
        "",
        "fn method(scene: Scene) -> f32 {\n    return scene.flags;\n}\n",
    );
    let e = compose(&k).unwrap_err();
    assert_eq!(e.path, "ret.wgsl", "{e}");
    assert!(e.to_string().contains("ret.wgsl:4:"), "{e}");
}

#[test]
fn unclosed_kernel_is_blamed_on_the_kernel() {
    let k = kernel("open.wgsl", "", "fn method(scene: Scene) -> f32 {\n    return 1.0;\n");
    let e = compose(&k).unwrap_err();
    assert_eq!(e.path, "open.wgsl", "{e}");
}

#[test]
fn prelude_error_is_attributed_to_the_prelude() {
    let prelude = format!(
        "{}\nfn broken() -> f32 {{\n    return nope;\n}}\n",
        crate::kernel::PRELUDE
    );
    let line = prelude.lines().position(|l| l.contains("nope")).unwrap() + 1;
    let k = kernel("fine.wgsl", "", "fn method(scene: Scene) -> f32 { return 1.0; }\n");
    let e = compose_parts(&prelude, &k, None, Capabilities::default()).unwrap_err();
    assert_eq!(e.path, PRELUDE_PATH);
    assert!(e.to_string().contains(&format!("{PRELUDE_PATH}:{line}:12")), "{e}");
}

#[test]
fn redefinition_points_at_both_files() {
    let k = kernel(
        "dup.wgsl",
        "",
        "const PI: f32 = 3.0;\nfn method(scene: Scene) -> f32 { return PI; }\n",
    );
    let e = compose(&k).unwrap_err().to_string();
    assert!(
        e.contains("dup.wgsl:3:") && e.contains(&format!("{PRELUDE_PATH}:6:")),
        "{e}"
    );
}

#[test]
fn missing_or_wrong_method_is_reported() {
    let k = kernel("none.wgsl", "", "fn evaluate(scene: Scene) -> f32 { return 1.0; }\n");
    let e = compose(&k).unwrap_err().to_string();
    assert!(
        e.starts_with("none.wgsl: ") && e.contains("fn method(scene: Scene) -> f32"),
        "{e}"
    );

    let k = kernel(
        "sig.wgsl",
        "",
        "\nfn method(p: vec3<f32>) -> f32 {\n    return p.x;\n}\n",
    );
    let e = compose(&k).unwrap_err();
    assert_eq!(e.location.map(|l| l.0), Some(4), "{e}");
    assert!(e.to_string().contains("found `fn method(vec3<f32>) -> f32`"), "{e}");
}

#[test]
fn reserved_names_are_rejected() {
    let k = kernel(
        "ll.wgsl",
        "",
        "fn ll_main() {}\nfn method(scene: Scene) -> f32 { return 1.0; }\n",
    );
    let e = compose(&k).unwrap_err();
    assert_eq!((e.path.as_str(), e.location.map(|l| l.0)), ("ll.wgsl", Some(3)), "{e}");
}
