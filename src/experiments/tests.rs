//! Tests of the named experiments: the untrained baselines as run folders that gather reads.

use super::*;

/// The untrained baselines are run folders of no steps that `gather` reads, judged against
/// the paper's S-05: the ONS as percept is undefined, the cone activations one-dimensional
/// (whatever this small eye measures, the folder must say what the paper expects of it).
#[test]
fn an_untrained_baseline_is_a_run_folder_gather_reads_with_the_papers_figure() {
    let root = std::env::temp_dir().join(format!("cv_baseline_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let config = RunConfig::preset("tiny", "LMS").unwrap();
    let mut cone_eye = config.clone();
    cone_eye.retina.lateral_inhibition = None;
    let ons = identity_percept(&config, &root.join("ons"), "ons").unwrap();
    let cones = identity_percept(&cone_eye, &root.join("cones"), "cones").unwrap();
    let runs = crate::gather::gather(&root).unwrap();
    assert_eq!(runs.len(), 2);
    for (run, dimension, paper) in [(&runs[0], cones, "1"), (&runs[1], ons, "undefined")] {
        assert_eq!(run.status, crate::gather::Status::Done, "{}", run.folder);
        let summary = run.summary.as_ref().unwrap();
        assert_eq!((summary.steps, summary.dimension), (0, dimension));
        assert_eq!(summary.dimension_over_steps.len(), 1);
        let train_steps = run.settings.get("cortex.train.steps").map(String::as_str);
        assert_eq!(train_steps, Some("0"), "{}: one step count", run.folder);
        let reported = science::paper::reported_for_settings(&run.settings);
        assert_eq!(reported.map(|r| r.to_string()).as_deref(), Some(paper));
    }
    std::fs::remove_dir_all(&root).unwrap();
}
