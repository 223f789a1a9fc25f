//! Exit statuses and what decides them: an outcome of a run (pass, a tolerance failed, a
//! claim went stale) or the kind of error that stopped it (bad input, a GPU failing at run
//! time). README "Exit status" and docs/exit-codes.md document the codes.

use crate::kernel::KernelError;
use crate::measure::gpu::GpuError;

/// How a command ended; [`Status::code`] is its exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// 0: done; a sweep whose checks pass and whose claims hold.
    Ok,
    /// 1: a sweep's tolerance check failed, or the CI gate found a regression; `diff`: B is
    /// less accurate than A.
    ToleranceFail,
    /// 2: bad input or a refused run (case, kernel, configuration, method spec, usage, no
    /// adapter, an output that cannot be written, a memory estimate or loop limit exceeded).
    BadInput,
    /// 3: a claim (`[[claims]]`) does not hold in this run.
    StaleClaim,
    /// 4: the GPU failed at run time: the device could not be opened or was lost, or a
    /// dispatch or readback failed (out of memory, timeout). Not the input's fault: the same
    /// command may pass on another device or a second try.
    GpuFailure,
}

impl Status {
    pub fn code(self) -> u8 {
        match self {
            Status::Ok => 0,
            Status::ToleranceFail => 1,
            Status::BadInput => 2,
            Status::StaleClaim => 3,
            Status::GpuFailure => 4,
        }
    }
}

/// The status an error ends the command with. A GPU failure at run time anywhere in the
/// error's chain makes it [`Status::GpuFailure`]; a kernel the driver refused is the
/// kernel's fault (bad input), as are a missing adapter and loops past the driver's limit; everything else is bad input.
pub fn status_of(e: &anyhow::Error) -> Status {
    for cause in e.chain() {
        if cause.downcast_ref::<KernelError>().is_some() {
            return Status::BadInput;
        }
        if let Some(g) = cause.downcast_ref::<GpuError>() {
            return match g {
                GpuError::NoAdapter { .. } | GpuError::LoopLimit { .. } => Status::BadInput,
                GpuError::Device { .. } | GpuError::Run { .. } => Status::GpuFailure,
            };
        }
    }
    Status::BadInput
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[test]
    fn a_gpu_failure_at_run_time_is_not_bad_input() {
        let run: anyhow::Result<()> = Err(GpuError::Run {
            method: "line.x".into(),
            message: "device lost".into(),
        }
        .into());
        let e = run.context("sweep of case `c`").unwrap_err();
        assert_eq!(status_of(&e), Status::GpuFailure);
        assert_eq!(status_of(&e).code(), 4);
        let none: anyhow::Error = GpuError::NoAdapter {
            requested: None,
            found: Vec::new(),
        }
        .into();
        assert_eq!(status_of(&none), Status::BadInput);
        assert_eq!(status_of(&anyhow::anyhow!("case.toml:3: bad key")).code(), 2);
        let codes: Vec<u8> = [
            Status::Ok,
            Status::ToleranceFail,
            Status::BadInput,
            Status::StaleClaim,
            Status::GpuFailure,
        ]
        .map(Status::code)
        .to_vec();
        assert_eq!(codes, [0, 1, 2, 3, 4]);
    }
}
