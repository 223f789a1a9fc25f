//! Keeping driver noise off the user's terminal.
//!
//! Mesa's Vulkan device-select layer probes for a Wayland display when the loader starts;
//! with `XDG_RUNTIME_DIR` unset, libwayland prints
//! `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` twice on stderr.
//! Pointing the variable at a private, empty directory makes the probe fail silently.

/// Sets the environment so drivers stay quiet. Call first thing in `main`, before any
/// thread starts: it changes the process environment.
pub fn quiet_driver_environment() {
    #[cfg(unix)]
    {
        // libwayland rejects an unset or relative value, and nothing else.
        let valid = std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| std::path::Path::new(&d).is_absolute());
        if !valid {
            if let Some(dir) = private_runtime_dir() {
                std::env::set_var("XDG_RUNTIME_DIR", dir);
            }
        }
    }
}

/// `$TMPDIR/linelight-runtime-<uid>`, mode 0700, owned by us: nothing another user could
/// put a socket in.
#[cfg(unix)]
fn private_runtime_dir() -> Option<std::path::PathBuf> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    let uid = std::fs::metadata("/proc/self").ok()?.uid();
    let dir = std::env::temp_dir().join(format!("linelight-runtime-{uid}"));
    // An existing directory is checked below, so the result of creating it does not matter.
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    let meta = std::fs::symlink_metadata(&dir).ok()?;
    let private = meta.is_dir() && meta.uid() == uid && meta.permissions().mode() & 0o077 == 0;
    (private && dir.is_absolute()).then_some(dir)
}
