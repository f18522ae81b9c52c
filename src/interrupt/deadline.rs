//! The deadline of a stop: a stage that does not check the stop flag often enough (a training
//! step of a very wide cortex, CMF-SIM at the top of its ranges) would keep a stopped process
//! running for minutes. [`STOP_DEADLINE`] after the first SIGINT/SIGTERM, a process still
//! running leaves on its own, as a stop does: no write is left half done (the writes under way
//! end first and no new one starts, `atomic_io::close_writes`), its run-folder locks are
//! released, it says what it was doing and what is kept ([`during`]), and it exits with 130.
//! Every file of a run folder is written atomically, so the folder is as the last completed
//! write left it: resumable from its last checkpoint.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// How long after a stop was asked for a process still running leaves on its own:
/// [`super::STAGE_GRACE`] for the stage to finish and a second for it to notice the stop flag
/// and return.
pub const STOP_DEADLINE: Duration = Duration::from_secs(4);

/// How long the leaving process waits for the writes under way (a checkpoint of a large cortex
/// takes a few seconds on a slow disk).
const WRITES_LIMIT: Duration = Duration::from_secs(30);

/// What the process is doing, and what a stop now leaves behind (said when it leaves).
static DOING: Mutex<Option<(&'static str, String)>> = Mutex::new(None);

/// Set by whichever of the command's own end ([`stand_down`]) and the deadline
/// ([`leave_if_running`]) comes first; the other then does nothing.
static LEAVING: AtomicBool = AtomicBool::new(false);

/// Records that the process is in `stage` (said as "stopped by SIGTERM during STAGE") and
/// what a stop there leaves (`kept`: what was written, how to go on).
pub fn during(stage: &'static str, kept: impl Into<String>) {
    *DOING.lock().unwrap_or_else(|e| e.into_inner()) = Some((stage, kept.into()));
}

/// The command has ended (its result is about to be said): the deadline no longer applies.
/// Called by the program's `main`; if the deadline has already struck, waits for it to end
/// the process.
pub fn stand_down() {
    if LEAVING.swap(true, Ordering::SeqCst) {
        loop {
            std::thread::park();
        }
    }
}

/// Called by the watcher thread at the deadline: unless the command has ended meanwhile, ends
/// the process as a stop does (module docs).
pub(super) fn leave_if_running(signal: &'static str) {
    if LEAVING.swap(true, Ordering::SeqCst) {
        return;
    }
    let tidy = atomic_io::close_writes(WRITES_LIMIT);
    crate::run::lock::release_held();
    let (stage, kept) = DOING
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
        .unwrap_or(("the command", "every file written so far is whole".into()));
    let unfinished = if tidy {
        String::new()
    } else {
        " (a write was still under way: its temporary is removed when the folder is used again)"
            .into()
    };
    eprintln!("\ncolorvision: error: stopped by {signal} during {stage}; {kept}{unfinished}");
    std::process::exit(130);
}
