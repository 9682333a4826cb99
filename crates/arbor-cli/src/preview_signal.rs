//! SIGUSR1 asks a running render for its picture so far (as Mitsuba's
//! SIGHUP does): the signal only sets a flag, which the preview writer
//! polls. No crate of ours catches signals other than Ctrl-C, so this
//! declares the one C library call it needs.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set by the signal handler, cleared by [`take`].
static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Whether a preview was asked for since the last call.
pub fn take() -> bool {
    REQUESTED.swap(false, Ordering::Relaxed)
}

/// From now on SIGUSR1 requests a preview instead of ending the process.
#[cfg(target_os = "linux")]
pub fn install() {
    /// SIGUSR1 on Linux (every architecture Rust supports there but MIPS
    /// and SPARC, which arbor does not build for).
    const SIGUSR1: i32 = 10;
    extern "C" fn on_signal(_: i32) {
        // Only an atomic store: nothing else is safe in a signal handler.
        REQUESTED.store(true, Ordering::Relaxed);
    }
    extern "C" {
        fn signal(signum: i32, handler: extern "C" fn(i32)) -> usize;
    }
    // SAFETY: `signal` is the C library's; the handler only stores to an
    // atomic, which is async-signal-safe.
    unsafe {
        signal(SIGUSR1, on_signal);
    }
}

/// Elsewhere SIGUSR1 keeps its default meaning.
#[cfg(not(target_os = "linux"))]
pub fn install() {}
