use super::*;

fn spec_file(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("cv_spec_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_grid_expands_to_every_combination_the_last_key_fastest() {
    let path = spec_file(
        "grid.toml",
        "[base]\npreset = \"tiny\"\nsteps = 20\n[grid]\ncones = [\"LMS\", \"LM\"]\nseed = [0, 1, 2]\n",
    );
    let e = expand(&path).unwrap();
    assert_eq!(e.command, "run");
    let got: Vec<(String, u64, u64, String)> = e
        .jobs
        .iter()
        .map(|j| {
            (
                j.config.cones.clone(),
                j.config.seed,
                j.config.steps,
                j.folder.clone(),
            )
        })
        .collect();
    let want = [
        ("LMS", 0, "000_cones=LMS_seed=0"),
        ("LMS", 1, "001_cones=LMS_seed=1"),
        ("LMS", 2, "002_cones=LMS_seed=2"),
        ("LM", 0, "003_cones=LM_seed=0"),
        ("LM", 1, "004_cones=LM_seed=1"),
        ("LM", 2, "005_cones=LM_seed=2"),
    ]
    .map(|(c, s, f)| (c.to_string(), s, 20, f.to_string()));
    assert_eq!(got, want);
    assert!(e.jobs.iter().enumerate().all(|(i, j)| j.index == i));
    // The seed reaches every component as a run with --seed would.
    assert_ne!(
        e.jobs[1].config.retina.mosaic_seed,
        e.jobs[0].config.retina.mosaic_seed
    );
}

#[test]
fn dotted_and_nested_grid_keys_reach_into_tables() {
    let path = spec_file(
        "nested.toml",
        "command = \"train\"\n[base]\npreset = \"tiny\"\n[grid]\n\"cortex.train.learning_rate\" = [0.01, 0.02]\n\
         [grid.schedule]\neval_batches = [2]\n",
    );
    let e = expand(&path).unwrap();
    assert_eq!(e.command, "train");
    let keys: Vec<&str> = e.axes.iter().map(|a| a.key.as_str()).collect();
    assert_eq!(
        keys,
        ["cortex.train.learning_rate", "schedule.eval_batches"]
    );
    let rates: Vec<f64> = e
        .jobs
        .iter()
        .map(|j| j.config.cortex.train.learning_rate)
        .collect();
    assert_eq!(rates, [0.01, 0.02]);
    assert!(e.jobs.iter().all(|j| j.config.schedule.eval_batches == 2));
    assert_eq!(e.jobs[1].folder, "001_learning_rate=0.02_eval_batches=2");
}

#[test]
fn bad_specs_name_the_file_and_the_key() {
    let cases = [
        // An unknown setting in the grid.
        (
            "[grid]\n\"cortex.train.learnin_rate\" = [0.1]\n",
            &["cortex.train.learnin_rate", "learnin_rate"][..],
        ),
        // An unknown key of the spec itself.
        ("[grid]\nseed = [0]\n[gird]\nx = 1\n", &["gird"]),
        // An empty grid, and an empty list.
        ("max_runs = 3\n", &["`grid`", "empty grid"]),
        ("[grid]\nseed = []\n", &["grid.seed", "empty list"]),
        // A value of the wrong type, and a value where a list belongs.
        (
            "[grid]\nseed = [\"one\"]\n",
            &["[grid] seed = \"one\"", "invalid type"],
        ),
        ("[grid]\nseed = 3\n", &["grid.seed", "seed = [3]"]),
        ("max_runs = \"ten\"\n[grid]\nseed = [0]\n", &["max_runs"]),
        // A value out of range, in the base settings.
        (
            "[base]\nsteps = 0\n[grid]\nseed = [0]\n",
            &["[base]", "steps"],
        ),
        // More runs than allowed.
        (
            "max_runs = 5\n[grid]\nseed = [0, 1, 2]\ncones = [\"LMS\", \"LM\"]\n",
            &["max_runs", "6 runs", "2 × 3"],
        ),
        ("command = \"fly\"\n[grid]\nseed = [0]\n", &["`command`"]),
        (
            "[grid]\nseed = [0]\n[slurm]\nconcurrency = 0\n",
            &["slurm.concurrency"],
        ),
        (
            "[grid]\nseed = [0]\n[slurm]\nmem_mib = \"2G\"\n",
            &["slurm.mem_mib"],
        ),
    ];
    for (i, (text, wants)) in cases.iter().enumerate() {
        let name = format!("bad{i}.toml");
        let err = expand(&spec_file(&name, text)).unwrap_err().to_string();
        assert!(err.contains(&name), "case {i}: {err}");
        for want in *wants {
            assert!(err.contains(want), "case {i}: `{want}` not in: {err}");
        }
        assert!(!err.contains('\n'), "case {i}: one line: {err}");
    }
}

#[test]
fn settings_that_only_clash_together_name_the_run() {
    // Each value resolves alone; run 1 says the steps twice, differently.
    let path = spec_file(
        "clash.toml",
        "[base]\npreset = \"tiny\"\n[grid]\nsteps = [5]\n\"cortex.train.steps\" = [5, 7]\n",
    );
    let err = expand(&path).unwrap_err().to_string();
    for want in [
        "clash.toml",
        "run 1:",
        "cortex.train.steps = 7",
        "disagrees",
    ] {
        assert!(err.contains(want), "`{want}` not in: {err}");
    }
}
