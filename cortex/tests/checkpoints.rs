//! Checkpoints: resume is bit-identical, writes are atomic, a NaN loss
//! stops the run with a clear message and the last good checkpoint intact.

use cortex::checkpoint::{latest_checkpoint, read_meta};
use cortex::config::CortexConfig;
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{CortexError, DataSource, Trainer};
use std::path::PathBuf;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cortex-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn source(cfg: &CortexConfig) -> SyntheticSource {
    SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 5))
}

fn params_bits(t: &Trainer) -> Vec<(String, Vec<u32>)> {
    let p = &t.cortex.params;
    p.ids()
        .map(|id| {
            (
                p.name(id).to_string(),
                p.get(id).data().iter().map(|v| v.to_bits()).collect(),
            )
        })
        .collect()
}

#[test]
fn resume_is_bit_identical_to_an_uninterrupted_run() {
    let dir = resume_matches_uninterrupted(CortexConfig::tiny(), "adam");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn resume_with_sgd_momentum_and_the_guard_is_bit_identical() {
    let mut cfg = CortexConfig::tiny();
    cfg.train.optimizer = cortex::config::OptimizerName::Sgd;
    cfg.loss.outside_field_weight = 1.0;
    let dir = resume_matches_uninterrupted(cfg, "sgd");
    // The checkpoint keeps SGD's velocity, not Adam's moments.
    let optim = std::fs::read(
        latest_checkpoint(&dir)
            .unwrap()
            .unwrap()
            .join("optim.safetensors"),
    );
    let text = String::from_utf8_lossy(&optim.unwrap()).into_owned();
    assert!(text.contains("::sgd.velocity") && !text.contains("::adam."));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Trains `cfg` 7 steps at once and 4 + 3 steps through a checkpoint; the two end equal.
/// Returns the folder of the interrupted run (the caller removes it).
fn resume_matches_uninterrupted(cfg: CortexConfig, name: &str) -> PathBuf {
    let (k, m) = (4, 3);
    let dir_a = scratch(&format!("uninterrupted-{name}"));
    let dir_b = scratch(&format!("interrupted-{name}"));

    let mut a = Trainer::new(cfg.clone()).unwrap();
    let mut src_a = source(&cfg);
    a.run(&mut src_a, k + m, Some(&dir_a), |_, _| {}).unwrap();

    let mut b = Trainer::new(cfg.clone()).unwrap();
    let mut src_b = source(&cfg);
    b.run(&mut src_b, k, Some(&dir_b), |_, _| {}).unwrap();
    drop(b); // "kill"
    let ck = latest_checkpoint(&dir_b).unwrap().unwrap();
    assert_eq!(read_meta(&ck).unwrap().step, k);
    // a new process: same source (same mosaic), its stream somewhere else until restored
    let mut fresh_src = source(&cfg);
    fresh_src.next_batch(3);
    let mut b = Trainer::resume(&ck, Some(&mut fresh_src)).unwrap();
    assert_eq!(b.step_count(), k);
    b.run(&mut fresh_src, m, Some(&dir_b), |_, _| {}).unwrap();

    assert_eq!(b.step_count(), a.step_count());
    let (pa, pb) = (params_bits(&a), params_bits(&b));
    assert_eq!(pa.len(), pb.len());
    for ((na, va), (nb, vb)) in pa.iter().zip(&pb) {
        assert_eq!(na, nb);
        assert!(va == vb, "parameter {na} differs after resume");
    }
    // the final checkpoints hold the same parameters, bit for bit
    let load = |d: &PathBuf| {
        let f = latest_checkpoint(d)
            .unwrap()
            .unwrap()
            .join("params.safetensors");
        autodiff::ParamStore::<f32>::load_safetensors(f).unwrap().0
    };
    let (fa, fb) = (load(&dir_a), load(&dir_b));
    for id in fa.ids() {
        let other = fb.find(fa.name(id)).unwrap();
        assert!(
            fa.get(id).data() == fb.get(other).data(),
            "checkpointed {} differs",
            fa.name(id)
        );
    }
    let _ = std::fs::remove_dir_all(&dir_a);
    dir_b
}

#[test]
fn checkpoint_writes_are_atomic_and_leave_no_temporaries() {
    let cfg = CortexConfig::tiny();
    let dir = scratch("atomic");
    let mut t = Trainer::new(cfg.clone()).unwrap();
    let mut src = source(&cfg);
    t.run(&mut src, 2, Some(&dir), |_, _| {}).unwrap();
    // a crash in the middle of a write leaves only a hidden temporary: never picked up
    let stale = dir.join(".step_00000099.tmp-1");
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(stale.join("params.safetensors"), b"half").unwrap();
    let latest = latest_checkpoint(&dir).unwrap().unwrap();
    assert!(latest.ends_with("step_00000002"), "{latest:?}");
    // re-saving the same step replaces it whole
    let again = t.save_checkpoint(&dir, None).unwrap();
    assert_eq!(again, latest);
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".old")), "{names:?}");
    for f in ["params.safetensors", "optim.safetensors", "meta.json"] {
        assert!(latest.join(f).is_file(), "{f} missing");
    }
    Trainer::resume(&latest, None).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn nan_loss_stops_with_a_clear_message_and_keeps_the_last_good_checkpoint() {
    let mut cfg = CortexConfig::tiny();
    cfg.train.learning_rate = 1e30; // diverges within a few steps
    cfg.train.checkpoint_every_steps = 1;
    let dir = scratch("nan");
    let mut t = Trainer::new(cfg.clone()).unwrap();
    let mut src = source(&cfg);
    let err = t.run(&mut src, 50, Some(&dir), |_, _| {}).unwrap_err();
    let msg = err.to_string();
    println!("{msg}");
    let (step, last) = match &err {
        CortexError::NonFiniteLoss {
            step,
            last_checkpoint,
            ..
        } => (*step, last_checkpoint.clone()),
        CortexError::NonFiniteGradient {
            step,
            last_checkpoint,
            ..
        } => (*step, last_checkpoint.clone()),
        other => panic!("unexpected error {other}"),
    };
    assert!(
        msg.contains("training stopped") && msg.contains(&format!("step {step}")),
        "{msg}"
    );
    let latest = latest_checkpoint(&dir).unwrap().unwrap();
    assert_eq!(last.as_deref(), Some(latest.as_path()));
    assert!(msg.contains(&latest.display().to_string()), "{msg}");
    // the last good checkpoint is the step before the failure, and it loads
    let meta = read_meta(&latest).unwrap();
    assert_eq!(meta.step, step - 1);
    assert!(meta.last_loss.unwrap().is_finite());
    let resumed = Trainer::resume(&latest, None).unwrap();
    assert_eq!(resumed.step_count(), step - 1);
    // the in-memory parameters were not updated by the failed step
    assert_eq!(t.step_count(), step - 1);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn two_uninterrupted_runs_are_bit_identical() {
    let cfg = CortexConfig::tiny();
    let run = || {
        let mut t = Trainer::new(cfg.clone()).unwrap();
        let mut src = source(&cfg);
        t.run(&mut src, 5, None, |_, _| {}).unwrap();
        params_bits(&t)
    };
    let (a, b) = (run(), run());
    for ((na, va), (_, vb)) in a.iter().zip(&b) {
        assert!(
            va == vb,
            "parameter {na} differs between two identical runs"
        );
    }
}

#[test]
fn a_file_hashed_in_blocks_has_the_hash_of_its_bytes() {
    let dir = scratch("sha");
    std::fs::create_dir_all(&dir).unwrap();
    for len in [0usize, 1, (1 << 20) - 1, 1 << 20, (5 << 20) / 2] {
        let bytes: Vec<u8> = (0..len).map(|i| (i * 7 % 251) as u8).collect();
        let path = dir.join(format!("f{len}"));
        std::fs::write(&path, &bytes).unwrap();
        let streamed = cortex::checkpoint::sha256_file(&path).unwrap();
        assert_eq!(
            streamed,
            cortex::checkpoint::sha256_hex(&bytes),
            "{len} bytes"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// A tiny cortex trained `steps` steps into a fresh folder `name`: the folder, its newest
/// checkpoint and the trainer.
fn trained(name: &str, steps: u64) -> (PathBuf, PathBuf, Trainer) {
    let cfg = CortexConfig::tiny();
    let dir = scratch(name);
    let mut t = Trainer::new(cfg.clone()).unwrap();
    t.run(&mut source(&cfg), steps, Some(&dir), |_, _| {})
        .unwrap();
    let path = latest_checkpoint(&dir).unwrap().unwrap();
    (dir, path, t)
}

#[test]
fn a_checkpoint_kept_with_its_parameters_only_is_read_but_not_resumed() {
    let (dir, path, t) = trained("params-only", 2);
    let want = params_bits(&t);
    for f in ["optim.safetensors", "rule.safetensors"] {
        std::fs::remove_file(path.join(f)).unwrap();
    }
    assert!(cortex::checkpoint::is_params_only(&path));
    // A reading (and a continued run) loads the same parameters.
    let read = Trainer::continue_from(&path, None).unwrap();
    assert_eq!(params_bits(&read), want);
    let newest = cortex::checkpoint::latest_valid(&dir).unwrap().unwrap();
    assert_eq!(newest.path, path);
    // Resuming training refuses it, saying why.
    let msg = Trainer::resume(&path, None).err().unwrap().to_string();
    assert!(msg.contains("holds the parameters only"), "{msg}");
    let resumed = Trainer::resume_latest(&dir, None).unwrap();
    assert!(resumed.trainer.is_none() && resumed.skipped.len() == 1);
    // Its parameters are still checked: a damaged file is refused.
    let p = path.join("params.safetensors");
    let mut bytes = std::fs::read(&p).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&p, bytes).unwrap();
    let msg = Trainer::continue_from(&path, None)
        .err()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("SHA-256") && msg.contains("params.safetensors"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_missing_one_state_file_is_damaged_not_params_only() {
    let (dir, path, _) = trained("one-missing", 1);
    std::fs::remove_file(path.join("optim.safetensors")).unwrap();
    assert!(!cortex::checkpoint::is_params_only(&path));
    let msg = Trainer::continue_from(&path, None)
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("optim.safetensors"), "{msg}");
    let _ = std::fs::remove_dir_all(&dir);
}
