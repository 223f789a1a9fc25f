//! The driver's loop limit. lavapipe (gallivm) stops every loop after 65,535 body
//! executions per invocation, counted per nesting depth across the loops at that depth, and
//! returns whatever the truncated loop computed. The limit is probed once per device with
//! a tiny kernel (a counted loop of [`PROBE_TRIPS`] trips whose bound is read from the
//! scene, so no compiler folds it), and every method is checked against it before its
//! pipeline is made: a method whose static loop-body executions (`cost::OpCount::loop_trips`,
//! every loop of one invocation together: an upper bound of any depth's count) exceed the
//! limit (less a margin of two per loop entered, for nested loops) is refused with both
//! numbers. A method whose loops have no static trip count is run a second time in a
//! variant that counts its loop trips (`counting_source`), and a run where any
//! configuration reached half the limit (conservative: how the driver counts nested loops
//! is not the plain total) is an error, never a result.

use super::device::{Gpu, GpuError};
use crate::input::scene::{Config, GpuScene, Material};
use crate::kernel::methods::Method;
use crate::kernel::{KernelError, KernelFile};

/// Trips the probe asks for; a result below it is the limit.
pub const PROBE_TRIPS: u64 = 1 << 22;

const PROBE: &str = "//! id: ll.loop_probe
//! target: line
fn method(scene: Scene) -> f32 {
    let n = u32(scene.radius);
    var c = 0u;
    for (var i = 0u; i < n; i++) {
        c += 1u;
    }
    return f32(c);
}
";

impl Gpu {
    /// The most loop-body executions a loop completes on this device (None: no limit below
    /// [`PROBE_TRIPS`]). Probed on first use, then kept for the device's lifetime.
    pub fn loop_limit(&self) -> Result<Option<u64>, KernelError> {
        if let Some(l) = self.loop_limit.get() {
            return Ok(*l);
        }
        let kernel = KernelFile::parse("<linelight loop probe>", PROBE).expect("probe header is valid");
        let method = Method {
            label: kernel.id.clone(),
            kernel,
            params: Vec::new(),
            inner: None,
            judged: None,
        };
        let pipeline = self.pipeline_unchecked(&method)?;
        let config = Config {
            id: "probe".into(),
            p1: [0.0, 0.0, 1.0],
            p2: [1.0, 0.0, 1.0],
            radius: None,
            rect: None,
            material: Material::Diffuse,
            texture: None,
        };
        let mut scene = GpuScene::from(&config);
        scene.radius = PROBE_TRIPS as f32;
        let out = self
            .run(&pipeline, &[scene], 0, &mut |_| {})
            .map_err(|e| KernelError::plain("<linelight loop probe>", e.to_string()))?;
        let done = out.values.first().copied().unwrap_or(0.0) as u64;
        let limit = (done < PROBE_TRIPS).then_some(done);
        Ok(*self.loop_limit.get_or_init(|| limit))
    }

    /// Refuses a method whose loops would run past the device's limit. Returns the limit
    /// when the method has loops of no static trip count, whose trips must then be counted
    /// at run time (runner.rs).
    pub(crate) fn check_loops(&self, method: &Method) -> Result<Option<u64>, KernelError> {
        let Some(limit) = self.loop_limit()? else {
            return Ok(None);
        };
        // A module the op count cannot read is watched at run time.
        let Ok(cost) = crate::eval::cost::method_cost_of(method) else {
            return Ok(Some(limit / 2));
        };
        // Nested loops stop a little before the limit (the probe's 100 × 1000 loop stopped
        // after 65,405 inner trips): two trips of margin per loop entered.
        match cost.loop_trips {
            Some(trips) if trips.saturating_add(2 * cost.loops) > limit => Err(KernelError::plain(
                &method.kernel.path,
                format!(
                    "`{}` executes {trips} loop-body iterations per configuration, more than the {limit} \
                     this device ({}) runs before it silently stops a loop: its results would be wrong; \
                     lower its parameters (e.g. fewer samples)",
                    crate::input::names::clip(&method.label),
                    self.adapter.name
                ),
            )),
            Some(_) => Ok(None),
            // Counted at run time: a configuration whose trips reach half the limit is taken
            // as truncated (the driver's count for nested loops is not the plain total).
            None => Ok(Some(limit / 2)),
        }
    }
}

/// The counting variant of a composed kernel: every loop body (`for`, `while`, `loop`)
/// starts by adding one to a private counter, and the entry point stores the counter
/// instead of the method's value (which it still computes: the loops depend on it).
pub(crate) fn counting_source(source: &str) -> String {
    format!(
        "{}\nvar<private> ll_trips: u32;\n",
        count_trips(source).replace(
            "ll_results[ll_i] = method(ll_scene);",
            "_ = method(ll_scene);\n    ll_results[ll_i] = f32(ll_trips);"
        )
    )
}

/// `source` with every loop body adding one to `ll_trips` (a `var<private> u32` the caller
/// declares): the scan counts trips in the same dispatch as the values.
pub(crate) fn count_trips(source: &str) -> String {
    crate::kernel::rename::instrument_loops(source, " ll_trips += 1u; ")
}

/// The refusal of a run in which `cut` of `of` configurations reached `limit` loop trips
/// (half the device's limit): their values may have been cut short by the driver.
pub(crate) fn truncated(method: &str, cut: u64, of: u64, first: Option<u64>, limit: u64) -> GpuError {
    let first = first.map_or(String::new(), |f| format!(" (the first is number {f})"));
    GpuError::LoopLimit {
        method: method.to_string(),
        message: format!(
            "on {cut} of {of} configurations{first} its loops ran {limit} or more iterations, half this \
             device's loop limit, near which the driver silently stops loops: those results may be \
             truncated and are not reported; lower the method's parameters"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counting_variant_counts_every_loop_body() {
        let src = "fn f() { for (var i = 0u; i < 3u; i++) { x(); } while (a > b) { y(); } loop { if c { break; } continuing { z(); } } }\n\
                   ll_results[ll_i] = method(ll_scene);";
        let counted = counting_source(src);
        assert_eq!(counted.matches("ll_trips += 1u;").count(), 3, "{counted}");
        assert!(counted.contains("i++) { ll_trips += 1u;"), "{counted}");
        assert!(counted.contains("ll_results[ll_i] = f32(ll_trips);"), "{counted}");
        assert!(counted.contains("var<private> ll_trips: u32;"));
    }

    #[test]
    fn gpu_lavapipe_loop_limit_is_probed_and_a_truncating_run_is_refused() {
        let gpu = crate::measure::gpu::test_gpu();
        let limit = gpu.loop_limit().unwrap().expect("lavapipe stops long loops");
        assert!(limit > 1000 && limit < PROBE_TRIPS, "{limit}");
        // A data-dependent loop: fine below half the limit, refused at it.
        let kernel = KernelFile::parse(
            "dyn.wgsl",
            "//! id: line.dyn\n//! target: line\nfn method(scene: Scene) -> f32 {\n    var c = 0u;\n    \
             for (var i = 0u; i < u32(scene.radius); i++) { c += 1u; }\n    return f32(c);\n}\n",
        )
        .unwrap();
        let method = Method {
            label: "line.dyn".into(),
            kernel,
            params: Vec::new(),
            inner: None,
            judged: None,
        };
        let pipeline = gpu.pipeline(&method).unwrap();
        let config = Config {
            id: "c".into(),
            p1: [0.0, 0.0, 1.0],
            p2: [1.0, 0.0, 1.0],
            radius: None,
            rect: None,
            material: Material::Diffuse,
            texture: None,
        };
        let mut scene = GpuScene::from(&config);
        scene.radius = 100.0;
        let out = gpu.run(&pipeline, &[scene], 0, &mut |_| {}).unwrap();
        assert_eq!(out.values, vec![100.0]);
        scene.radius = (limit + 10) as f32;
        let e = gpu.run(&pipeline, &[scene], 0, &mut |_| {}).unwrap_err().to_string();
        assert!(e.contains("not reported"), "{e}");
    }
}
