//! What `run JOB.toml` streams, tagged with each segment's move entry so the run journal keeps
//! the job's cursor, and `run JOB.toml --resume` (or `--resume-line N`, N = the move's number
//! from 1): the moves before entry N are not sent; in their place the approach G-code resume
//! makes (Z up to the safe height, across, spindle and coolant as the job had them there, Z
//! down to the start of move N; [`crate::gcode::resume`]), then the job from move N to its end.

use crate::convert::{Program, ProgramItem};
use crate::gcode::resume::{Resume, ResumeAt};
use crate::job::Machine;
use crate::plan::{self, Output};
use crate::runner::Outputs;
use anyhow::{anyhow, bail, Result};
use motion::MAX_AXES;
use std::collections::VecDeque;

/// A TOML job ready to stream: the program run (resumed: the approach and the rest), its
/// outputs with their move cursors, and where the host model ends it.
pub struct TomlRun {
    pub program: Program,
    pub outputs: Vec<(Output, Option<usize>)>,
    pub expected: [i64; MAX_AXES],
    segments: u32,
    planned_ticks: u64,
    model_ticks: u64,
}

impl TomlRun {
    /// `program` (of the job `label` on `machine`) from its start, or from move `resume`.
    pub fn new(
        label: &str,
        machine: &Machine,
        program: &Program,
        resume: Option<usize>,
    ) -> Result<TomlRun> {
        let mut program = program.clone();
        if let Some(entry) = resume {
            if !program.commands.is_empty() {
                bail!(
                    "{label}: a job with timed feed commands ([[feed]]) runs from its start: its \
                     commands are stamped from the start"
                );
            }
            program.items = resumed_items(&program, ResumeAt::new(machine, entry)?)
                .map_err(|e| anyhow!("{label}: {e}"))?;
            if !program.items.iter().any(|i| matches!(i, ProgramItem::Move { .. })) {
                bail!("{label}: nothing to resume: no move at or after move {entry}");
            }
        }
        let summary = plan::simulate(&program, |_| {}).map_err(|e| anyhow!("{label}: {e}"))?;
        if !summary.finished {
            bail!("{label}: the model did not reach the job's end");
        }
        let mut expected = [0i64; MAX_AXES];
        expected.copy_from_slice(&summary.report.positions[..MAX_AXES]);
        let mut stream = plan::Stream::new(&program);
        let mut outputs = Vec::new();
        let (mut segments, mut planned_ticks) = (0u32, 0u64);
        while let Some(o) = stream.next() {
            let o = o.map_err(|e| anyhow!("{label}: {e}"))?;
            if let Output::Segment(s) = &o {
                segments += 1;
                planned_ticks += s.duration_ticks as u64;
            }
            outputs.push((o, stream.source().map(|s| s.cursor())));
        }
        let model_ticks = summary.report.ticks;
        Ok(TomlRun { program, outputs, expected, segments, planned_ticks, model_ticks })
    }

    pub fn segments(&self) -> u32 {
        self.segments
    }

    /// The outputs for the runner, each with its move's cursor for the journal.
    pub fn stream(&self) -> Outputs<'_> {
        let mut it = self.outputs.iter();
        Outputs::streamed(
            move || it.next().map(|&t| Ok(t)),
            self.segments,
            self.planned_ticks,
            self.model_ticks,
        )
    }
}

/// The program's items from the resume point on, the approach in front.
fn resumed_items(program: &Program, at: ResumeAt) -> Result<Vec<ProgramItem>, String> {
    let mut resume = Resume::new(at);
    let mut pos = [0i64; MAX_AXES];
    let mut out = VecDeque::new();
    for &item in &program.items {
        if let ProgramItem::Move { mv, .. } = &item {
            for (p, &d) in pos.iter_mut().zip(&mv.steps) {
                *p += d as i64;
            }
        }
        resume.filter(item, pos, &program.config, &mut out)?;
    }
    Ok(out.into())
}
