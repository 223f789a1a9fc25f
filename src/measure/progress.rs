//! Progress bars, one style for every long-running step (sweep, scan, chain, bench, fit). When
//! stderr is not a terminal (a CI log, a pipe) indicatif draws nothing there, so a long run
//! would print no line for minutes: a ticker prints the bar's state as one plain line at a
//! fixed interval until the bar is finished or dropped.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Duration;

/// The bar template of every step but the scan's: what, bar, count, rate, time left.
pub const TEMPLATE: &str = "{msg:>28} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})";

/// The interval of plain progress lines (`LINELIGHT_PROGRESS_SECONDS`, src/tuning.rs).
fn interval() -> Duration {
    crate::tuning::tuning().progress_interval
}

/// A bar of `len` steps named `what` in [`TEMPLATE`]'s style, with plain lines off-terminal.
pub fn bar(len: u64, what: &str) -> ProgressBar {
    styled(len, what, TEMPLATE)
}

/// [`bar`] with another template (the scan's, which counts in millions).
pub fn styled(len: u64, what: &str, template: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    plain_lines(&pb);
    pb
}

/// When stderr is not a terminal, prints `pb`'s state to stderr every interval.
pub fn plain_lines(pb: &ProgressBar) {
    if !std::io::stderr().is_terminal() {
        tick(pb, interval(), |line| eprintln!("{line}"));
    }
}

/// One line of a bar's state: `what: done/total (elapsed s)`.
fn line(pb: &ProgressBar) -> String {
    let total = pb.length().map_or("?".into(), |l| l.to_string());
    format!(
        "{}: {}/{} ({:.0} s)",
        pb.message(),
        pb.position(),
        total,
        pb.elapsed().as_secs_f64()
    )
}

/// Calls `sink` with the bar's state every `every` until it is finished or dropped.
fn tick(pb: &ProgressBar, every: Duration, sink: impl Fn(String) + Send + 'static) {
    let weak = pb.downgrade();
    std::thread::spawn(move || loop {
        std::thread::sleep(every);
        match weak.upgrade() {
            Some(pb) if !pb.is_finished() => sink(line(&pb)),
            _ => return,
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    #[test]
    fn lines_come_at_the_interval_until_the_bar_finishes() {
        let pb = ProgressBar::hidden();
        pb.set_length(10);
        pb.set_message("measuring");
        pb.set_position(3);
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = lines.clone();
        tick(&pb, Duration::from_millis(20), move |l| sink.lock().unwrap().push(l));
        std::thread::sleep(Duration::from_millis(150));
        pb.finish_and_clear();
        let n = lines.lock().unwrap().len();
        assert!(n >= 3, "{n} lines");
        assert!(
            lines.lock().unwrap()[0].starts_with("measuring: 3/10 ("),
            "{:?}",
            lines.lock().unwrap()
        );
        std::thread::sleep(Duration::from_millis(100));
        assert!(lines.lock().unwrap().len() <= n + 1, "stops once finished");
    }
}
