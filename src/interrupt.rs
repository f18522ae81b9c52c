//! Stopping a run cleanly: SIGINT (Ctrl-C) and SIGTERM ask the training loop to finish its
//! step, write a checkpoint and exit with a message saying how to resume; a second signal
//! ends the process at once (exit 130).
//!
//! Signals are caught with `signal-hook`: its handler only sets an atomic flag (the one thing a
//! signal handler may safely do), it needs nothing but `libc`, which the build already has, and
//! it covers SIGTERM as well as SIGINT. A watcher thread prints that the stop was heard, since a
//! step or a CMF-SIM measurement can take a while to finish; a long stage (scene drawing, the
//! held-out evaluation, CMF-SIM) still running [`STAGE_GRACE`] later is stopped unfinished
//! through [`stop_flag`], which it checks in its loop, and the run ends within seconds from its
//! last checkpoint. A stage that does not return in time is left: [`STOP_DEADLINE`] after the
//! signal the process ends on its own as a stop does (`deadline`).
//!
//! Fault injection for tests (`COLORVISION_FAULT`, read by [`install_fault_injection`]): a
//! comma-separated list of `ACTION@POINT:STEP` (STEP counts the cortex's updates, so in a
//! continued run it goes on from the run it continued), with ACTION `abort` (the process dies there, as under SIGKILL) or
//! `interrupt` (as if SIGINT arrived there), POINT `step` (after the training step), `measured`
//! (after the step's measurements), `lock-written` (step 0: the run folder's first write, the
//! lock's temporary, before it becomes `.lock`), a stage of a checkpoint write
//! (`params-written`, `files-written`, `old-moved-aside`, `renamed`; see
//! `cortex::checkpoint::set_fault_hook`), or `write` / `rename`, where STEP counts the process's
//! file writes instead: `abort@write:4` dies once the 4th file's bytes are in its temporary,
//! before its rename; `abort@rename:4` once the 4th file (or checkpoint folder, or the lock) is
//! in place under its real name (`atomic_io::set_fault_hook`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

mod deadline;
pub use deadline::{during, stand_down, STOP_DEADLINE};

static INT: OnceLock<Arc<AtomicBool>> = OnceLock::new();
static TERM: OnceLock<Arc<AtomicBool>> = OnceLock::new();
static REQUESTED: AtomicBool = AtomicBool::new(false);
/// Set [`STAGE_GRACE`] after a stop was asked for (by the watcher thread): the flag the long
/// stages check in their loops ([`stop_flag`]).
static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// How long a stage (scene drawing, the held-out evaluation, CMF-SIM) may go on after a stop was
/// asked for before it stops unfinished: a step that ends sooner is finished and checkpointed.
pub const STAGE_GRACE: Duration = Duration::from_secs(3);

fn flag(cell: &OnceLock<Arc<AtomicBool>>) -> &Arc<AtomicBool> {
    cell.get_or_init(|| Arc::new(AtomicBool::new(false)))
}

/// Catches SIGINT and SIGTERM for the rest of the process (idempotent).
pub fn install() -> std::io::Result<()> {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    if INSTALLED.get().is_some() {
        return Ok(());
    }
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        for (signal, cell) in [(SIGINT, &INT), (SIGTERM, &TERM)] {
            let f = flag(cell);
            // Registered first, so it sees the flag as the previous signal left it: a second
            // signal ends the process at once.
            signal_hook::flag::register_conditional_shutdown(signal, 130, Arc::clone(f))?;
            signal_hook::flag::register(signal, Arc::clone(f))?;
        }
        std::thread::Builder::new()
            .name("colorvision-stop".into())
            .spawn(|| {
                while requested().is_none() {
                    std::thread::sleep(Duration::from_millis(100));
                }
                announce();
                std::thread::sleep(STAGE_GRACE);
                flag(&STOP).store(true, Ordering::SeqCst);
                std::thread::sleep(STOP_DEADLINE.saturating_sub(STAGE_GRACE));
                deadline::leave_if_running(requested().unwrap_or("a stop request"));
            })?;
    }
    let _ = INSTALLED.set(());
    Ok(())
}

/// Lets a closed pipe end the process quietly, as it ends `cat` or `grep`: `colorvision gather
/// results | head` then exits when `head` has read enough instead of panicking in `println!`
/// (Rust starts programs with SIGPIPE ignored, so a write to a closed pipe returns an error).
/// A training run killed this way leaves its folder as after any kill: every file written whole
/// (`atomic_io`), resumable from its last checkpoint.
pub fn default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: `signal` with SIG_DFL installs no handler code; it is called at start-up, before
    // any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// The signal that asked the run to stop, if one did.
pub fn requested() -> Option<&'static str> {
    if flag(&INT).load(Ordering::SeqCst) {
        Some("SIGINT")
    } else if flag(&TERM).load(Ordering::SeqCst) {
        Some("SIGTERM")
    } else if REQUESTED.load(Ordering::SeqCst) {
        Some("a stop request")
    } else {
        None
    }
}

/// Says, once, that a stop was asked for and what happens next (from the watcher thread, or
/// from the training loop when it notices first).
pub fn announce() {
    static ANNOUNCED: AtomicBool = AtomicBool::new(false);
    if let Some(what) = requested() {
        if !ANNOUNCED.swap(true, Ordering::SeqCst) {
            eprintln!(
                "\ncolorvision: {what} received: finishing the current step, then writing a \
                 checkpoint; a stage still running in {} s stops unfinished, and the process \
                 leaves by {} s (send it again to stop at once, without one)",
                STAGE_GRACE.as_secs(),
                STOP_DEADLINE.as_secs()
            );
        }
    }
}

/// Asks the run to stop as a signal would (fault injection, embedding programs).
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// The flag a stop request sets [`STAGE_GRACE`] after it was made (once signals are caught,
/// [`install`]), for the stages that check it in their loops (scene drawing, the held-out
/// evaluation, CMF-SIM: `retina`, `science` and `colorimetry` take a plain `&AtomicBool`).
pub fn stop_flag() -> &'static AtomicBool {
    flag(&STOP)
}

/// A fault to inject: what, where, at which step.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fault {
    /// `abort` or `interrupt`.
    pub action: String,
    /// `step`, `measured` or a checkpoint-write stage.
    pub point: String,
    /// The step.
    pub step: u64,
}

static FAULTS: OnceLock<Vec<Fault>> = OnceLock::new();

/// Parses `ACTION@POINT:STEP`.
pub fn parse_fault(text: &str) -> Result<Fault, String> {
    let bad = || format!("COLORVISION_FAULT `{text}` is not ACTION@POINT:STEP");
    let (action, rest) = text.split_once('@').ok_or_else(bad)?;
    let (point, step) = rest.split_once(':').ok_or_else(bad)?;
    if !matches!(action, "abort" | "interrupt") {
        return Err(format!(
            "COLORVISION_FAULT action `{action}` is not abort or interrupt"
        ));
    }
    Ok(Fault {
        action: action.to_string(),
        point: point.to_string(),
        step: step.parse().map_err(|_| bad())?,
    })
}

/// Reads `COLORVISION_FAULT` (see the module docs) and arms it.
pub fn install_fault_injection() -> Result<(), String> {
    let Ok(text) = std::env::var("COLORVISION_FAULT") else {
        return Ok(());
    };
    let faults = text.split(',').map(parse_fault).collect::<Result<_, _>>()?;
    let _ = FAULTS.set(faults);
    cortex::checkpoint::set_fault_hook(fault_point);
    atomic_io::set_fault_hook(file_step);
    Ok(())
}

/// Counts the process's file writes and renames (`atomic_io`'s fault points) and triggers the
/// faults armed at `write:N` / `rename:N`.
fn file_step(stage: &'static str) {
    use std::sync::atomic::AtomicU64;
    static WRITES: AtomicU64 = AtomicU64::new(0);
    static RENAMES: AtomicU64 = AtomicU64::new(0);
    let count = match stage {
        "write" => &WRITES,
        "rename" => &RENAMES,
        _ => return,
    };
    fault_point(stage, count.fetch_add(1, Ordering::SeqCst) + 1);
}

/// Triggers the armed faults that are at `point` of `step`.
pub fn fault_point(point: &'static str, step: u64) {
    let Some(faults) = FAULTS.get() else {
        return;
    };
    for f in faults.iter().filter(|f| f.point == point && f.step == step) {
        if f.action == "abort" {
            eprintln!("colorvision: fault injection: abort at {point} of step {step}");
            std::process::abort();
        }
        request();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_parse_and_bad_ones_are_refused() {
        assert_eq!(
            parse_fault("abort@params-written:12").unwrap(),
            Fault {
                action: "abort".into(),
                point: "params-written".into(),
                step: 12
            }
        );
        for bad in ["abort", "kill@step:3", "abort@step:x", "abort@step"] {
            assert!(parse_fault(bad).is_err(), "{bad}");
        }
    }
}
