//! Rust work beside Python: the work runs on a thread of its own with the GIL released, while
//! the calling thread — the one holding Python — serves what the work needs from Python (one
//! decoder call per batch, progress reports) and checks Python's signals every [`POLL_MS`] ms.
//!
//! So Python is only ever called on the thread that called into Rust, never from a rayon worker
//! (which could deadlock on the GIL), whatever thread inside the work asks for a decode. On
//! Ctrl-C (or an exception in the decoder or the progress callback) the stop flag is set —
//! CMF-SIM ends before its next primary set, the scene pool before its next tile — every later
//! decode request is refused at once, and that Python exception, with its traceback, is what
//! the caller gets once the work has ended. A panic in the work becomes a `RuntimeError`.

use crate::arrays::{check_finite, f32_array, read_f32, shape_text};
use crate::errors::panic_error;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::Duration;

/// How often the calling thread checks Python's signals while Rust works, ms.
pub const POLL_MS: u64 = 100;

/// What the work asks of the Python thread.
pub enum Request {
    /// Decode `shows` ONS frames `(shows, n, n)`; the percepts `(shows, C, n, n)` or why not.
    Decode {
        /// The frames.
        ons: Vec<f32>,
        /// How many.
        shows: usize,
        /// Where the answer goes.
        reply: Sender<Result<Vec<f32>, String>>,
    },
    /// A progress report: a line for the log and its figures for a callback.
    Progress {
        /// One line for the log.
        line: String,
        /// Named figures (the callback's dict).
        figures: Vec<(&'static str, f64)>,
    },
}

/// A Python decoder with its percept geometry.
pub struct PyDecoder<'a, 'py> {
    /// The callable: `(N, n, n)` float32 → `(N, C, n, n)`.
    pub callable: &'a Bound<'py, PyAny>,
    /// Channels C.
    pub channels: usize,
    /// Cones per side n.
    pub n: usize,
}

/// Runs `work` on its own thread while this thread serves its requests (module docs). The work
/// gets the sender of its requests and the stop flag.
pub fn run_beside_python<T: Send>(
    py: Python<'_>,
    decoder: Option<&PyDecoder<'_, '_>>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(Sender<Request>, &AtomicBool) -> T + Send,
) -> PyResult<T> {
    let (tx, rx) = mpsc::channel::<Request>();
    let stop = AtomicBool::new(false);
    let mut failure: Option<PyErr> = None;
    let outcome = std::thread::scope(|scope| {
        let stop = &stop;
        let worker = scope.spawn(move || catch_unwind(AssertUnwindSafe(|| work(tx, stop))));
        serve(py, rx, decoder, progress, stop, &mut failure);
        worker.join()
    });
    if let Some(e) = failure {
        return Err(e);
    }
    match outcome {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(payload)) | Err(payload) => Err(panic_error(payload)),
    }
}

/// Serves requests until the work drops its sender (module docs).
fn serve(
    py: Python<'_>,
    rx: Receiver<Request>,
    decoder: Option<&PyDecoder<'_, '_>>,
    progress: Option<&Bound<'_, PyAny>>,
    stop: &AtomicBool,
    failure: &mut Option<PyErr>,
) {
    let mut rx = Some(rx);
    loop {
        let receiver = rx.take().expect("the receiver is put back every turn");
        let (receiver, message) = py.allow_threads(move || {
            let m = receiver.recv_timeout(Duration::from_millis(POLL_MS));
            (receiver, m)
        });
        rx = Some(receiver);
        let fail = |e: PyErr, failure: &mut Option<PyErr>| {
            stop.store(true, Ordering::SeqCst);
            failure.get_or_insert(e);
        };
        match message {
            Ok(Request::Decode { ons, shows, reply }) => {
                let answer = match (decoder, failure.is_some()) {
                    (_, true) => Err("stopped".to_string()),
                    (None, false) => Err("no decoder to call".to_string()),
                    (Some(d), false) => decode(py, d, ons, shows).map_err(|e| {
                        let why = e.to_string();
                        fail(e, failure);
                        why
                    }),
                };
                let _ = reply.send(answer);
            }
            Ok(Request::Progress { line, figures }) => {
                if failure.is_none() {
                    if let Err(e) = report(py, progress, &line, &figures) {
                        fail(e, failure);
                    }
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
        // After every turn, not only when none came: progress reports or decoder calls that
        // arrive faster than POLL_MS would otherwise hold a Ctrl-C back until they slow down.
        if failure.is_none() {
            if let Err(e) = py.check_signals() {
                fail(e, failure);
            }
        }
    }
}

/// One call of the Python decoder, its answer checked: `(shows, C, n, n)`, finite.
pub fn decode(
    py: Python<'_>,
    d: &PyDecoder<'_, '_>,
    ons: Vec<f32>,
    shows: usize,
) -> PyResult<Vec<f32>> {
    let frames = f32_array(py, ons, &[shows, d.n, d.n])?;
    let out = d.callable.call1((frames,))?;
    let percepts = read_f32(py, &out, "the decoder's output")?;
    let want = [shows, d.channels, d.n, d.n];
    if percepts.shape != want {
        return Err(PyValueError::new_err(format!(
            "the decoder returned percepts of shape {} for ONS of shape {}; expected {} \
             (N, C, n, n) with the C = {} channels it returned before",
            shape_text(&percepts.shape),
            shape_text(&[shows, d.n, d.n]),
            shape_text(&want),
            d.channels
        )));
    }
    check_finite(&percepts.values, &want, "the decoder's percept")?;
    Ok(percepts.values)
}

/// Hands a progress report to `callback(dict)`, or logs its line on the `colorvision` logger.
fn report(
    py: Python<'_>,
    callback: Option<&Bound<'_, PyAny>>,
    line: &str,
    figures: &[(&'static str, f64)],
) -> PyResult<()> {
    match callback {
        Some(f) => {
            let d = PyDict::new(py);
            d.set_item("message", line)?;
            for (k, v) in figures {
                d.set_item(*k, *v)?;
            }
            f.call1((d,))?;
        }
        None => {
            py.import("logging")?
                .call_method1("getLogger", ("colorvision",))?
                .call_method1("info", (line,))?;
        }
    }
    Ok(())
}

/// The work's side of a decode: sends the frames to the Python thread and waits for the
/// percepts (the batch function of a `science::observer::ExternalDecoder`).
pub fn decode_via(
    tx: &Sender<Request>,
    ons: &[f32],
    shows: usize,
    out: &mut [f32],
) -> Result<(), String> {
    let (reply, answer) = mpsc::channel();
    tx.send(Request::Decode {
        ons: ons.to_vec(),
        shows,
        reply,
    })
    .map_err(|_| "the Python thread is gone".to_string())?;
    let percepts = answer
        .recv()
        .map_err(|_| "the Python thread did not answer".to_string())??;
    if percepts.len() != out.len() {
        return Err(format!(
            "{} percept values for {} expected",
            percepts.len(),
            out.len()
        ));
    }
    out.copy_from_slice(&percepts);
    Ok(())
}
