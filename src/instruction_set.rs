//! The CPU's vector instruction set, which a run's rounding depends on: recorded with each
//! checkpoint, compared when the run resumes.
//!
//! Training is bit-identical to itself at a fixed thread count on CPUs of one instruction set.
//! Across instruction sets it is not: the cortex's 3×3 convolutions take the direct AVX-512F
//! micro-kernels where the CPU has them and the GEMM lowering elsewhere
//! (`autodiff::ops::conv`), and faer's matrix products pick AVX-512F or AVX2 kernels the same
//! way at run time. Each path sums in its own order, so one seed trained on an AVX-512F CPU
//! and on an AVX2 one drifts apart within a few steps (`--preset main --cones LMSQ,Q:506
//! --seed 21`: one float apart at step 1) as two runs of one distribution do, and its CMF-SIM
//! margins differ.
//!
//! So a checkpoint records [`current`] (`run_state.instruction_set` in its `meta.json`), and a
//! run resumed on a CPU of another instruction set says that it continues the same training,
//! not bit for bit the unbroken run ([`change`]).

/// The instruction set that decides which kernels run here: `"x86-64 avx512f"`,
/// `"x86-64 avx2+fma"`, `"x86-64"` (neither), or the architecture's name elsewhere.
pub fn current() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return "x86-64 avx512f";
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            return "x86-64 avx2+fma";
        }
        "x86-64"
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        std::env::consts::ARCH
    }
}

/// The warning of a run resumed on instruction set `now` from a checkpoint written on
/// `recorded` (`None` in checkpoints older than the record: nothing to compare), or `None`
/// when they agree.
pub fn change(recorded: Option<&str>, now: &str) -> Option<String> {
    let recorded = recorded?;
    (recorded != now).then(|| {
        format!(
            "the checkpoint was written on a CPU with {recorded}, the run goes on with {now}: \
             the convolutions and matrix products round differently there, so it continues \
             the same training, not bit for bit the unbroken run (a CPU with {recorded} gives \
             that)"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_resume_on_another_instruction_set_warns_and_names_both() {
        let warning = change(Some("x86-64 avx2+fma"), "x86-64 avx512f").expect("a change");
        assert!(
            warning.contains("written on a CPU with x86-64 avx2+fma"),
            "{warning}"
        );
        assert!(warning.contains("goes on with x86-64 avx512f"), "{warning}");
        assert!(warning.contains("not bit for bit"), "{warning}");
        assert_eq!(change(Some(current()), current()), None);
        assert_eq!(change(None, current()), None);
    }

    #[test]
    fn this_cpu_has_a_named_instruction_set() {
        let now = current();
        assert!(!now.is_empty());
        // The name follows the kernels' own dispatch: the direct convolution exactly where
        // the name says AVX-512F.
        assert_eq!(
            now == "x86-64 avx512f",
            autodiff::ops::conv::direct_conv_available::<f32>(3),
            "{now}"
        );
    }
}
