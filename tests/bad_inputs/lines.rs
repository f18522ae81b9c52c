//! Whole command lines the binary must refuse: each error names the option (or setting) and
//! says why, and nothing is written.

/// Whole command lines with an option or value the command cannot use: each must be refused
/// with an error naming it (and for a dropped option, saying why), not run without it. The
/// line with options before `train` repeats them after it so that, were the refusal lost, it
/// would end in seconds (a silent exit 0) instead of training the `main` preset.
pub const LINE_CASES: &[(&[&str], &[&str])] = &[
    // A held-out scene count that does not split into whole batches, halves of them.
    (
        &["convergence", "--run", "out", "--held-out-scenes", "4"],
        &["--held-out-scenes", "4"],
    ),
    (
        &["convergence", "--run", "out", "--held-out-scenes", "10"],
        &["--held-out-scenes", "10"],
    ),
    // A measurement of a run folder uses the run's own settings.
    (
        &["scope", "--run", "out", "--cones", "LM"],
        &["--cones", "own settings"],
    ),
    (
        &["scope", "--run", "out", "--set", "cortex.d.widths=[8]"],
        &["--set", "own settings"],
    ),
    (
        &["stiles-burch", "--run", "out", "--seed", "3"],
        &["--seed", "own settings"],
    ),
    // `simulate` and `gamut` train nothing.
    (
        &[
            "simulate", "--preset", "tiny", "--out", "out", "--steps", "5",
        ],
        &["--steps", "trains nothing"],
    ),
    (
        &["simulate", "--preset", "tiny", "--out", "out", "--resume"],
        &["--resume", "trains nothing"],
    ),
    (
        &["gamut", "--preset", "tiny", "--out", "out", "--force"],
        &["--force", "trains nothing"],
    ),
    // Options before the subcommand belong to the default `run`.
    (
        &[
            "--preset", "tiny", "--steps", "2", "train", "--preset", "tiny", "--steps", "1",
            "--out", "out",
        ],
        &["--steps", "before the subcommand"],
    ),
    (
        &[
            "--cones", "LM", "run", "--preset", "tiny", "--steps", "1", "--out", "out",
        ],
        &["--cones", "before the subcommand"],
    ),
];
