//! Progress bars for long computations: an indicatif bar on stderr when stderr is a terminal,
//! nothing otherwise (pipes, files, tests and CI stay clean); and, for bounded work expected
//! to last over a minute, a line saying how long before it goes on ([`Work::map`]).

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

/// A progress bar that exists only when stderr is a terminal. Cleared when dropped.
#[derive(Debug)]
pub struct Progress(Option<ProgressBar>);

impl Progress {
    /// A bar of `total` steps labelled `label`; hidden when stderr is not a terminal.
    pub fn new(total: u64, label: &str) -> Self {
        if !std::io::stderr().is_terminal() {
            return Self(None);
        }
        let bar = ProgressBar::new(total);
        if let Ok(style) =
            ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({elapsed}, ETA {eta})")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(label.to_string());
        Self(Some(bar))
    }

    /// Prints `line` above the bar (only on a terminal, as the bar).
    pub fn say(&self, line: &str) {
        if let Some(bar) = &self.0 {
            bar.println(line);
        }
    }

    /// Advances the bar by `steps`.
    pub fn advance(&self, steps: u64) {
        if let Some(bar) = &self.0 {
            bar.inc(steps);
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}

/// How long a run may take before legwise says, before going on, what it will cost.
pub const ANNOUNCED_COST: Duration = Duration::from_secs(60);

/// The time a sample of the work must take before its rate is trusted for the estimate.
const SAMPLE_TIME: Duration = Duration::from_millis(500);

/// A bounded piece of work: `total` independent items, labelled for the progress bar and the
/// cost notice, done `passes` times at most (the notice counts them all).
#[derive(Debug, Clone, Copy)]
pub struct Work<'l> {
    /// What is being done (`monte carlo`, `workspace: casting rays`).
    pub label: &'l str,
    /// The items, run in parallel.
    pub total: usize,
    /// What one item is called in the notice (`trials`, `rays`).
    pub items: &'l str,
    /// How many times at most the whole work is repeated (1 for once).
    pub passes: usize,
}

impl Work<'_> {
    /// `f` of every index of `0..total`, in parallel (rayon), the results in index order, with
    /// a progress bar and the ETA on a terminal. The first items are timed (in chunks that
    /// double until one takes half a second); when the whole work promises to take longer
    /// than [`ANNOUNCED_COST`], a line on a terminal says how long before the rest runs
    /// ([`cost_notice`]).
    pub fn map<T: Send>(self, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
        let progress = Progress::new(self.total as u64, self.label);
        let mut results: Vec<T> = Vec::with_capacity(self.total);
        let started = Instant::now();
        let mut chunk = 2 * rayon::current_num_threads().max(1);
        let mut timing = true;
        while results.len() < self.total {
            let first = results.len();
            let end = if timing {
                (first + chunk).min(self.total)
            } else {
                self.total
            };
            results.par_extend((first..end).into_par_iter().map(|index| {
                let result = f(index);
                progress.advance(1);
                result
            }));
            if timing && (started.elapsed() >= SAMPLE_TIME || end == self.total) {
                timing = false;
                if let Some(notice) = cost_notice(&self, end, started.elapsed()) {
                    progress.say(&notice);
                }
            }
            chunk *= 2;
        }
        results
    }
}

/// What `work` will cost, from its first `done` items having taken `elapsed`, when that is
/// more than [`ANNOUNCED_COST`] (its passes counted): `monte carlo: 1000000 trials will take
/// about 2 h 05 min (8 ms each on 2 threads, timed on the first 64); Ctrl-C stops`.
pub fn cost_notice(work: &Work<'_>, done: usize, elapsed: Duration) -> Option<String> {
    if done == 0 || done >= work.total && work.passes <= 1 {
        return None;
    }
    let per_item = elapsed.as_secs_f64() / done as f64;
    let pass = per_item * work.total as f64;
    let whole = pass * work.passes.max(1) as f64;
    if whole <= ANNOUNCED_COST.as_secs_f64() {
        return None;
    }
    let passes = if work.passes > 1 {
        format!(
            ", {} a pass, at most {} passes",
            duration_text(pass),
            work.passes
        )
    } else {
        String::new()
    };
    Some(format!(
        "{}: {} {} will take about {}{passes} ({} each on {} threads, timed on the first \
         {done}); Ctrl-C stops",
        work.label,
        work.total,
        work.items,
        duration_text(whole),
        duration_text(per_item),
        rayon::current_num_threads()
    ))
}

/// A duration in seconds for people: `850 ms`, `42 s`, `3 min 20 s`, `2 h 05 min`.
pub fn duration_text(seconds: f64) -> String {
    if seconds < 1.0 {
        return format!("{:.0} ms", seconds * 1e3);
    }
    let whole = seconds.round() as u64;
    match whole {
        0..=59 => format!("{whole} s"),
        60..=3599 => format!("{} min {:02} s", whole / 60, whole % 60),
        _ => format!("{} h {:02} min", whole / 3600, (whole % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::{cost_notice, duration_text, Work};

    fn work(total: usize, passes: usize) -> Work<'static> {
        Work {
            label: "monte carlo",
            total,
            items: "trials",
            passes,
        }
    }

    #[test]
    fn durations_read_in_the_largest_sensible_unit() {
        assert_eq!(duration_text(0.0075), "8 ms");
        assert_eq!(duration_text(0.9994), "999 ms");
        assert_eq!(duration_text(1.0), "1 s");
        assert_eq!(duration_text(59.4), "59 s");
        assert_eq!(duration_text(60.0), "1 min 00 s");
        assert_eq!(duration_text(200.0), "3 min 20 s");
        assert_eq!(duration_text(3599.0), "59 min 59 s");
        assert_eq!(duration_text(3600.0), "1 h 00 min");
        assert_eq!(duration_text(7530.0), "2 h 05 min");
    }

    #[test]
    fn the_cost_is_said_only_beyond_a_minute_counting_every_pass() {
        // 64 trials in 0.48 s: 7.5 ms each, a million of them 2 h 05 min.
        let elapsed = Duration::from_millis(480);
        let notice = cost_notice(&work(1_000_000, 1), 64, elapsed).unwrap();
        assert!(
            notice.starts_with(
                "monte carlo: 1000000 trials will take about 2 h 05 min (8 ms each on "
            ),
            "{notice}"
        );
        assert!(
            notice.ends_with("timed on the first 64); Ctrl-C stops"),
            "{notice}"
        );
        // 8000 of them: exactly one minute, not said; 8001: said.
        assert_eq!(cost_notice(&work(8000, 1), 64, elapsed), None);
        assert!(cost_notice(&work(8001, 1), 64, elapsed).is_some());
        // 2000 a pass, 4 passes: 60 s in all, not said; 5 passes: 75 s, said with the pass.
        assert_eq!(cost_notice(&work(2000, 4), 64, elapsed), None);
        let passes = cost_notice(&work(2000, 5), 64, elapsed).unwrap();
        assert!(
            passes.contains("will take about 1 min 15 s, 15 s a pass, at most 5 passes ("),
            "{passes}"
        );
        // Nothing timed, or everything already done in one pass: nothing to say.
        assert_eq!(cost_notice(&work(1_000_000, 1), 0, elapsed), None);
        assert_eq!(
            cost_notice(&work(64, 1), 64, Duration::from_secs(600)),
            None
        );
        // Done once but to be repeated: the repeats are still to come.
        assert!(cost_notice(&work(64, 2), 64, Duration::from_secs(600)).is_some());
    }

    #[test]
    fn the_work_s_results_are_in_index_order_whatever_the_chunks() {
        for total in [0, 1, 5, 1000] {
            let results = work(total, 1).map(|i| i * i);
            assert_eq!(results, (0..total).map(|i| i * i).collect::<Vec<_>>());
        }
    }
}
