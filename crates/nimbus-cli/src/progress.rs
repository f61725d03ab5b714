//! Progress of the long commands on standard error, one implementation for
//! all of them (on `indicatif`): a bar with the work done, the time taken
//! and an ETA, or a spinner with the time taken where the amount of work is
//! not known. It is drawn only when standard error is a terminal: logs,
//! pipes and tests see nothing of it, and standard output never does.
//!
//! Library computations report their progress through callbacks
//! (`nimbus_physics::transport::monte_carlo::trace`, `cumulus::build`, …);
//! the commands forward them here.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressFinish, ProgressStyle};
use std::borrow::Cow;
use std::io::IsTerminal;
use std::time::Duration;

/// A bar: `nimbus: animate: frames [#####     ] 12/48 (25 %), 3s, ETA 9s`.
const BAR_TEMPLATE: &str =
    "nimbus: {prefix} [{bar:30}] {human_pos}/{human_len} ({percent} %), {elapsed}, ETA {eta} {msg}";

/// A spinner, for work of unknown amount: `nimbus: render ⠋ 4s`.
const SPINNER_TEMPLATE: &str = "nimbus: {prefix} {spinner} {elapsed} {msg}";

/// Redraws per second at most.
const REFRESH_HZ: u8 = 8;

/// One progress display on standard error; cleared when finished or dropped
/// (an error line is then never printed after a half-drawn bar).
#[derive(Debug)]
pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A bar for `total` units of work, named by `label` (the command and
    /// its unit of work, e.g. "slab fit: photons").
    pub fn new(label: &str, total: u64) -> Self {
        let bar = ProgressBar::with_draw_target(Some(total), draw_target())
            .with_style(style(BAR_TEMPLATE).progress_chars("#>-"))
            .with_prefix(label.to_owned())
            .with_finish(ProgressFinish::AndClear);
        Self { bar }
    }

    /// A spinner with the time taken, for work whose amount is not known
    /// (one frame's precomputation and rendering).
    pub fn spinner(label: &str) -> Self {
        let bar = ProgressBar::with_draw_target(None, draw_target())
            .with_style(style(SPINNER_TEMPLATE))
            .with_prefix(label.to_owned())
            .with_finish(ProgressFinish::AndClear);
        if !bar.is_hidden() {
            // Redrawn by a thread: the work blocks the one that made it.
            bar.enable_steady_tick(Duration::from_millis(125));
        }
        Self { bar }
    }

    /// Reports `done` units of work done in all (from any thread).
    pub fn update(&self, done: u64) {
        self.bar.set_position(done);
    }

    /// Shows `message` after the bar (the step under way).
    pub fn set_message(&self, message: impl Into<Cow<'static, str>>) {
        self.bar.set_message(message);
    }

    /// Writes `line` to standard error above the bar (whether or not the
    /// bar is drawn).
    pub fn eprintln(&self, line: &str) {
        self.bar.suspend(|| eprintln!("{line}"));
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Standard error when it is a terminal, otherwise nowhere.
fn draw_target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr_with_hz(REFRESH_HZ)
    } else {
        ProgressDrawTarget::hidden()
    }
}

/// The style of `template`; the templates are constants that the tests
/// parse, so the fallback is never used.
fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_templates_parse() {
        for template in [BAR_TEMPLATE, SPINNER_TEMPLATE] {
            if let Err(error) = ProgressStyle::with_template(template) {
                panic!("{template}: {error}");
            }
        }
    }

    #[test]
    fn a_bar_counts_its_work_and_clears_when_finished() {
        let progress = Progress::new("test: units", 10);
        progress.update(4);
        assert_eq!(progress.bar.position(), 4);
        assert_eq!(progress.bar.length(), Some(10));
        assert_eq!(progress.bar.prefix(), "test: units");
        progress.finish();
        assert!(progress.bar.is_finished());
    }
}
