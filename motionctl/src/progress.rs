//! The operator's view of a run: a progress bar (segments executed, with acknowledged ones, the
//! G-code line executing and the time left by the plan) and a live state line, on stderr.
//! Without a terminal, a plain line every few seconds.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use motion::protocol::Status;
use motion::Rate;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// How often the plain (non-terminal) progress line is printed.
const PLAIN_EVERY: Duration = Duration::from_secs(5);

pub struct Progress {
    multi: MultiProgress,
    bar: ProgressBar,
    line: ProgressBar,
    fancy: bool,
    plain: bool,
    last_plain: Instant,
    total: u64,
    axes: Vec<(String, f64)>,
}

impl Progress {
    /// `axes` = (name, steps per mm). `enabled = false` prints nothing but `println`s.
    pub fn new(total: u64, axes: Vec<(String, f64)>, enabled: bool) -> Progress {
        let fancy = enabled && std::io::stderr().is_terminal();
        let target = if fancy {
            ProgressDrawTarget::stderr_with_hz(10)
        } else {
            ProgressDrawTarget::hidden()
        };
        let multi = MultiProgress::with_draw_target(target);
        let bar = multi.add(ProgressBar::new(total));
        let style = ProgressStyle::with_template(
            "{bar:40.cyan/blue} {pos}/{len} segments done, {msg} [{elapsed_precise}]",
        )
        .map(|s| s.progress_chars("=> "));
        if let Ok(style) = style {
            bar.set_style(style);
        }
        let line = multi.add(ProgressBar::new_spinner());
        if let Ok(style) = ProgressStyle::with_template("{msg}") {
            line.set_style(style);
        }
        Progress {
            multi,
            bar,
            line,
            fancy,
            plain: enabled && !fancy,
            last_plain: Instant::now(),
            total,
            axes,
        }
    }

    /// "Moving X 12.3000 Y 4.0000 mm, override 1.00, queue 17"
    pub fn state_line(&self, s: &Status) -> String {
        let mut t = format!("{:?}", s.state);
        for (i, (name, spm)) in self.axes.iter().enumerate() {
            t.push_str(&format!(" {name} {:.4}", s.positions[i] as f64 / spm));
        }
        let ovr = Rate::from_bits(s.override_bits).to_num::<f64>();
        t.push_str(&format!(" mm, override {ovr:.2}, queue {}", s.queue_depth));
        t
    }

    /// `line`: the G-code line executing; `eta_s`: seconds left by the plan (none while the
    /// override is 0).
    pub fn update(
        &mut self,
        acked: u64,
        done: u64,
        status: Option<&Status>,
        line: Option<usize>,
        eta_s: Option<f64>,
    ) {
        if !(self.fancy || self.plain) {
            return;
        }
        let mut msg = format!("{acked} acknowledged");
        if let Some(l) = line {
            msg.push_str(&format!(", line {l}"));
        }
        msg.push_str(&format!(", ETA {}", eta_text(eta_s)));
        self.bar.set_position(done.min(self.total));
        let state = status.map(|s| self.state_line(s)).unwrap_or_default();
        if self.fancy {
            self.bar.set_message(msg);
            self.line.set_message(state);
        } else if self.last_plain.elapsed() >= PLAIN_EVERY {
            self.last_plain = Instant::now();
            eprintln!("motionctl: {done}/{} segments done, {msg}; {state}", self.total);
        }
    }

    /// Prints a line above the bars.
    pub fn println(&self, msg: &str) {
        if self.fancy {
            let _ = self.multi.println(msg);
        } else {
            eprintln!("{msg}");
        }
    }

    /// Runs `f` with the bars hidden: a question for the operator on the terminal.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        if self.fancy {
            self.multi.suspend(f)
        } else {
            f()
        }
    }

    pub fn finish(&self) {
        self.line.finish_and_clear();
        self.bar.finish_and_clear();
    }
}

/// "1:02:03", "4:05" or "-" (unknown).
pub fn eta_text(seconds: Option<f64>) -> String {
    let Some(s) = seconds.filter(|s| s.is_finite() && *s >= 0.0) else {
        return "-".into();
    };
    let s = s.round().min(u32::MAX as f64) as u64;
    let (h, m, s) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 {
        format!("{h}:{m:02}:{s:02}")
    } else {
        format!("{m}:{s:02}")
    }
}

#[cfg(test)]
mod tests {
    use super::eta_text;

    #[test]
    fn eta_reads_as_hours_minutes_seconds() {
        assert_eq!(eta_text(Some(0.4)), "0:00");
        assert_eq!(eta_text(Some(65.0)), "1:05");
        assert_eq!(eta_text(Some(3723.0)), "1:02:03");
        assert_eq!(eta_text(None), "-");
        assert_eq!(eta_text(Some(f64::NAN)), "-");
    }
}
