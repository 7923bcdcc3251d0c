//! What the command prints. Standard output that goes away (`hikage inspect b | head -1`) ends
//! the printing quietly, as ripgrep and coreutils do, and any other failed write is an I/O
//! error (exit 3), never a panic. Text that comes from files (ids, paths, messages quoting
//! them) is printed with control characters escaped, so a hostile id cannot drive the terminal.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::Failure;

/// `println!` for the command's results: [`emit`] of the formatted text, returning its
/// failure from the enclosing function.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::output::emit(&format!($($arg)*))?
    };
}

/// Set once standard output is a closed pipe: nothing more is printed to it.
static CLOSED: AtomicBool = AtomicBool::new(false);

/// Prints `text` and a newline on standard output.
pub fn emit(text: &str) -> Result<(), Failure> {
    if CLOSED.load(Ordering::Relaxed) {
        return Ok(());
    }
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{}", printable(text)).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            CLOSED.store(true, Ordering::Relaxed);
            Ok(())
        }
        Err(e) => Err(Failure { code: 3, error: anyhow::anyhow!("writing to standard output: {e}") }),
    }
}

/// Prints `text` and a newline on standard error; a failure to do so is ignored (there is
/// nowhere left to report it).
pub fn emit_err(text: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{}", printable(text));
}

/// `text` with every control character but newline and tab written as an escape (`\u{1b}`).
pub fn printable(text: &str) -> String {
    if !text.chars().any(|c| c.is_control() && c != '\n' && c != '\t') {
        return text.to_string();
    }
    text.chars()
        .map(|c| if c.is_control() && c != '\n' && c != '\t' { c.escape_default().to_string() } else { c.to_string() })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(printable("job `a\u{1b}[2Jb\0`"), "job `a\\u{1b}[2Jb\\u{0}`");
        assert_eq!(printable("two\nlines\tand é"), "two\nlines\tand é");
    }
}
