//! Progress when stderr is not a terminal (a CI log, a pipe): indicatif draws nothing there,
//! so a long sweep would print no line for minutes. A ticker prints the bar's state as one
//! plain line at a fixed interval until the bar is finished or dropped.

use indicatif::ProgressBar;
use std::io::IsTerminal;
use std::time::Duration;

/// The interval of plain progress lines.
pub const INTERVAL: Duration = Duration::from_secs(10);

/// When stderr is not a terminal, prints `pb`'s state to stderr every [`INTERVAL`].
pub fn plain_lines(pb: &ProgressBar) {
    if !std::io::stderr().is_terminal() {
        tick(pb, INTERVAL, |line| eprintln!("{line}"));
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
