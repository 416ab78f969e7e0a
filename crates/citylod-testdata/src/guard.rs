//! Running one fuzz case on a thread of its own under a time limit, catching its panic with what it said and where
//! (on the case's thread or a rayon worker it started): what the readers' mutation tests share.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Mutex, Once};
use std::time::Duration;

/// Where the panic hook puts what a panic said, and where.
static PANICS: Mutex<Vec<String>> = Mutex::new(Vec::new());
/// Quiet cases running: while > 0 a panic is recorded rather than printed (the case's report says it).
static QUIET: AtomicUsize = AtomicUsize::new(0);

fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.load(Ordering::SeqCst) == 0 {
                return default(info);
            }
            let msg = panic_text(info.payload());
            let at = info.location().map(|l| l.to_string()).unwrap_or_default();
            PANICS.lock().unwrap().push(format!("{msg} (at {at})"));
        }));
    });
}

/// The text a panic's payload carries (empty for a payload of another type).
pub fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_default()
}

/// Panics recorded since the last call that no case's outcome took: panics the code under test caught itself (the
/// GeoParquet reader guards the parquet crate so), which print nothing while quiet but are said here.
pub fn take_caught_panics() -> Vec<String> {
    std::mem::take(&mut *PANICS.lock().unwrap())
}

/// Runs `f` on a thread of its own and waits up to `hang` for it: `Ok(Ok(what it gave))`, `Ok(Err(what its panic
/// said, and where))`, or `Err(the time waited)` when it did not answer (a hang). With `quiet`, a panic is only
/// recorded, not printed.
pub fn guarded<T: Send + 'static>(
    hang: Duration,
    quiet: bool,
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<Result<T, String>, Duration> {
    install_hook();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        if quiet {
            QUIET.fetch_add(1, Ordering::SeqCst);
        }
        let got = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
        if quiet {
            QUIET.fetch_sub(1, Ordering::SeqCst);
        }
        let _ = tx.send(got);
    });
    let got = rx.recv_timeout(hang).map_err(|_| hang)?;
    Ok(got.map_err(|payload| {
        let mut said = take_caught_panics();
        if said.is_empty() {
            said.push(panic_text(payload.as_ref()));
        }
        said.join(" | ")
    }))
}
