//! Standard output of the command line. `println!` panics when the reader has gone
//! (`motionctl polar dump F | head`); [`outln!`](crate::outln) instead notes the closed pipe and
//! drops the rest of the output, so the command ends quietly with exit 0 as `head` expects. Any
//! other write error (a full disk behind a redirect) is kept and turned into a failing exit by
//! [`finish`]: output is never lost silently.
//!
//! A closed pipe never stops a command that drives the machine: only its printing ends.

use std::fmt;
use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::sync::Mutex;

static CLOSED: AtomicBool = AtomicBool::new(false);
static FAILED: Mutex<Option<String>> = Mutex::new(None);

/// Writes formatted text to stdout (use [`outln!`](crate::outln) / [`out!`](crate::out)).
pub fn write(args: fmt::Arguments<'_>) {
    if CLOSED.load(Relaxed) {
        return;
    }
    let mut stdout = io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        CLOSED.store(true, Relaxed);
        if e.kind() != io::ErrorKind::BrokenPipe {
            if let Ok(mut f) = FAILED.lock() {
                f.get_or_insert_with(|| e.to_string());
            }
        }
    }
}

/// True once stdout has gone (a listing may stop producing lines nobody reads).
pub fn closed() -> bool {
    CLOSED.load(Relaxed)
}

/// The write error that is not a closed pipe, if any: the command must fail with it.
pub fn finish() -> Result<(), String> {
    match FAILED.lock().ok().and_then(|mut f| f.take()) {
        Some(e) => Err(format!("writing to standard output: {e}")),
        None => Ok(()),
    }
}

/// `println!` for the command line's stdout: quiet on a closed pipe.
#[macro_export]
macro_rules! outln {
    () => { $crate::out::write(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::out::write(format_args!("{}\n", format_args!($($arg)*))) };
}

/// `print!` for the command line's stdout: quiet on a closed pipe.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::out::write(format_args!($($arg)*)) };
}
