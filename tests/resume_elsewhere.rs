//! A run resumed where it cannot continue bit for bit says so: each checkpoint records the
//! worker threads and the CPU's instruction set it was written with (`run_state` in its
//! `meta.json`), and a resume on another of either warns, names both, and goes on.

mod common;

use common::{command, scratch_dir, text};
use cortex::checkpoint::{read_meta, sha256_hex};
use std::path::Path;

fn run(dir: &Path, args: &[&str], threads: &str) -> String {
    let o = command(dir, args, None)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .expect("the binary runs");
    assert!(o.status.success(), "{args:?}: {}", text(&o));
    text(&o)
}

/// Rewrites the checkpoint's `run_state.instruction_set` to `set` and seals the metadata
/// again as the cortex does (the SHA-256 of its pretty JSON with the hash left out).
fn forge_instruction_set(checkpoint: &Path, set: &str) {
    let mut meta = read_meta(checkpoint).unwrap();
    let state = meta
        .run_state
        .as_mut()
        .expect("a run's checkpoint has a run state");
    state["instruction_set"] = serde_json::Value::from(set);
    meta.meta_sha256 = None;
    let hash = sha256_hex(serde_json::to_string_pretty(&meta).unwrap().as_bytes());
    meta.meta_sha256 = Some(hash);
    std::fs::write(
        checkpoint.join("meta.json"),
        serde_json::to_string_pretty(&meta).unwrap(),
    )
    .unwrap();
}

#[test]
fn a_resume_on_another_cpu_or_thread_count_warns_and_goes_on() {
    let dir = scratch_dir("resume_elsewhere", "warn");
    let train = ["train", "--preset", "tiny", "--steps", "2", "--out", "r"];
    run(&dir, &train, "1");
    let checkpoint = dir.join("r/checkpoints/step_00000002");
    let meta = read_meta(&checkpoint).unwrap();
    let state = meta.run_state.unwrap();
    let here = colorvision::instruction_set::current();
    assert_eq!(state["instruction_set"], here, "{state}");
    assert_eq!(state["threads"], 1, "{state}");

    // Here, on one thread: nothing to say.
    let copy = |name: &str| {
        let to = dir.join(name);
        let _ = std::fs::remove_dir_all(&to);
        let o = std::process::Command::new("cp")
            .args(["-r", "r"])
            .arg(&to)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(o.status.success());
        to
    };
    copy("same");
    let said = run(&dir, &["resume", "same", "--steps", "3"], "1");
    assert!(!said.contains("warning"), "{said}");

    // Another thread count.
    copy("threads");
    let said = run(&dir, &["resume", "threads", "--steps", "3"], "2");
    assert!(said.contains("written with 1 worker thread(s)"), "{said}");

    // Another instruction set: the checkpoint says it was written elsewhere.
    let elsewhere = copy("elsewhere");
    forge_instruction_set(&elsewhere.join("checkpoints/step_00000002"), "x86-64 sse2");
    let said = run(&dir, &["resume", "elsewhere", "--steps", "3"], "1");
    assert!(
        said.contains("written on a CPU with x86-64 sse2")
            && said.contains(&format!("goes on with {here}"))
            && said.contains("not bit for bit"),
        "{said}"
    );
    assert!(elsewhere.join("checkpoints/step_00000003").is_dir());
    std::fs::remove_dir_all(&dir).unwrap();
}
