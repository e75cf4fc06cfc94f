//! `--log-csv FILE`: one row per board `Status`, for plotting and for the end-to-end test's
//! status-rate and queue checks.

use motion::protocol::Status;
use motion::Rate;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

pub struct CsvLog {
    out: BufWriter<File>,
    axes: Vec<(String, f64)>,
}

impl CsvLog {
    /// Creates `path` and writes the header. `axes` = (name, steps per mm) in axis order.
    pub fn create(path: &Path, axes: Vec<(String, f64)>) -> io::Result<CsvLog> {
        let file = File::create(path).map_err(|e| {
            io::Error::new(e.kind(), format!("cannot create {}: {e}", path.display()))
        })?;
        let mut log = CsvLog { out: BufWriter::new(file), axes };
        let mut head = String::from("wall_ms,board_tick,state");
        for (name, _) in &log.axes {
            head.push_str(&format!(",{name}_steps"));
        }
        for (name, _) in &log.axes {
            head.push_str(&format!(",{name}_mm"));
        }
        head.push_str(",override,queue_depth,credits,job_segments_done");
        head.push_str(
            ",usart_overruns,frames_bad,responses_dropped,tick_overruns,steps_deferred,\
             starve_holds,host_retransmits,host_bad_frames_in",
        );
        writeln!(log.out, "{head}")?;
        Ok(log)
    }

    /// One row; `job_done` = segments done since the job started; `host` = the host link's
    /// (retransmissions, garbled frames in) then.
    pub fn row(
        &mut self,
        wall_ms: u64,
        s: &Status,
        job_done: u32,
        host: (u64, u64),
    ) -> io::Result<()> {
        let mut line = format!("{wall_ms},{},{:?}", s.tick, s.state);
        for (i, _) in self.axes.iter().enumerate() {
            line.push_str(&format!(",{}", s.positions[i]));
        }
        for (i, (_, spm)) in self.axes.iter().enumerate() {
            line.push_str(&format!(",{:.4}", s.positions[i] as f64 / spm));
        }
        let ovr = Rate::from_bits(s.override_bits).to_num::<f64>();
        line.push_str(&format!(",{ovr:.4},{},{},{job_done}", s.queue_depth, s.credits));
        let c = &s.counters;
        line.push_str(&format!(
            ",{},{},{},{},{},{},{},{}",
            c.usart_overruns,
            c.frames_bad,
            c.responses_dropped,
            c.tick_overruns,
            c.steps_deferred,
            c.starve_holds,
            host.0,
            host.1
        ));
        writeln!(self.out, "{line}")
    }

    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}
