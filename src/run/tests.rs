//! The run marker names the checkpoint a continued run started from portably.

use super::*;

#[test]
fn a_path_is_named_from_a_folder_by_what_they_share() {
    let cases = [
        (
            "/a/runs/x",
            "/a/runs/y/checkpoints/step_1",
            "../y/checkpoints/step_1",
        ),
        (
            "/a/runs/x",
            "/a/runs/x/checkpoints/step_1",
            "checkpoints/step_1",
        ),
        ("/a/runs/x", "/b/c", "../../../b/c"),
        ("/a/./runs/x/", "/a/runs/../runs/y", "../y"),
        ("/a/runs/x", "/a/runs/x", ""),
    ];
    for (from, to, want) in cases {
        let got = relative_path(Path::new(from), Path::new(to));
        assert_eq!(got, PathBuf::from(want), "{to} from {from}");
    }
}

#[test]
fn a_relative_path_is_resolved_against_the_current_folder() {
    let here = std::env::current_dir().unwrap();
    let got = relative_path(Path::new("runs/x"), &here.join("runs/y"));
    assert_eq!(got, PathBuf::from("../y"));
}

#[test]
fn the_origin_checkpoint_is_read_from_the_run_folder_first_then_as_written() {
    let root = std::env::temp_dir().join(format!("cv_marker_{}", std::process::id()));
    let (run, origin) = (root.join("runs/b"), root.join("runs/a/checkpoints/step_5"));
    std::fs::create_dir_all(&run).unwrap();
    std::fs::create_dir_all(&origin).unwrap();
    let mode = RunMode::FULL;
    let marker = RunMarker::new(mode, Origin::Continue(&origin), &run);
    let written = PathBuf::from("../a/checkpoints/step_5");
    assert_eq!(marker.continued_from.as_ref(), Some(&written));
    assert_eq!(marker.origin_checkpoint(&run), Some(run.join(&written)));
    // as written where the run's folder holds nothing by that name: an absolute path, or a
    // record's path from the repository root
    for p in [origin.clone(), PathBuf::from("runs/a/checkpoints/step_5")] {
        let m = RunMarker {
            continued_from: Some(p.clone()),
            ..marker.clone()
        };
        assert_eq!(m.origin_checkpoint(&run), Some(p));
    }
    let fresh = RunMarker::new(mode, Origin::New, &run);
    assert_eq!(fresh.continued_from, None);
    assert_eq!(fresh.origin_checkpoint(&run), None);
    std::fs::remove_dir_all(root).ok();
}
