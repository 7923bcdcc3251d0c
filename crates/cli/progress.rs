//! Progress bars for long steps, drawn on stderr only when it is a terminal.

use std::sync::Mutex;

use hikage_bake::Observer;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// One bar per job, replaced as jobs advance.
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
}

impl Bars {
    pub fn new() -> Self {
        Bars { bar: Mutex::new(None) }
    }

    /// Prints a line on stderr, above the bar if one is drawn.
    fn suspended(&self, line: &str) {
        let line = crate::output::printable(line);
        match self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            Some(b) => b.suspend(|| crate::output::emit_err(&line)),
            None => crate::output::emit_err(&line),
        }
    }

    pub fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

impl Observer for Bars {
    fn job_started(&self, index: usize, total: usize, id: &str, kind: &str) {
        let bar = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{prefix:>9} {msg:<32} [{bar:30}] {percent:>3}% {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(format!("[{}/{}]", index + 1, total));
        bar.set_message(crate::output::printable(&format!("{kind} {id}")));
        if let Some(old) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).replace(bar) {
            old.finish_and_clear();
        }
    }

    fn progress(&self, _id: &str, done: u64, total: u64) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.set_length(total.max(1));
            b.set_position(done);
        }
    }

    fn waiting_for_lock(&self, lock: &std::path::Path) {
        self.suspended(&format!("waiting for {}: another hikage is writing this bundle", lock.display()));
    }

    fn warning(&self, message: &str) {
        self.suspended(&format!("warning: {message}"));
    }

    fn job_finished(&self, _id: &str, skipped: bool) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            if skipped {
                b.set_message(format!("{} (unchanged)", b.message()));
            }
            b.set_position(b.length().unwrap_or(1));
        }
    }
}
