//! Program lines: taken from the receive buffer under back-pressure, run through the
//! interpreter, their moves and events into the pipeline.

use super::Bridge;
use crate::grbl::pipeline::Out;
use crate::grbl::program::Step;
use crate::grbl::protocol::{error, Line};
use crate::job::{Feed, Item, MoveCmd, Target};
use anyhow::Result;

/// Segments waiting on the host before the bridge stops taking lines (the sender then waits
/// for its `ok`s, as with a full grbl planner).
const HOST_QUEUE_MAX: usize = 48;

impl Bridge<'_> {
    pub(super) fn lines(&mut self) -> Result<()> {
        while self.rx.has_line() {
            // As grbl's probe cycle: the next line waits until the probe move has ended.
            if self.probe.is_some()
                || self.motion.queued_segments() > HOST_QUEUE_MAX
                || self.motion.out.len() > 4 * HOST_QUEUE_MAX
            {
                break;
            }
            match self.rx.pop_line() {
                Some(Line::Overflow) => self.error(error::OVERFLOW),
                Some(Line::Text(t)) => self.line(&t)?,
                None => break,
            }
        }
        Ok(())
    }

    pub(super) fn line(&mut self, text: &str) -> Result<()> {
        let t = text.trim();
        if t.is_empty() || t == "%" {
            self.ok();
            return Ok(());
        }
        if t.starts_with('$') {
            return self.dollar(t);
        }
        if self.alarm.is_some() || (self.jog && self.moving()) {
            self.error(error::SYSTEM_GC_LOCK);
            return Ok(());
        }
        match self.gcode(t) {
            None => self.answer("ok".into()),
            Some(n) => self.error(n),
        }
        Ok(())
    }

    /// A program line: `None` when it ran (its `[MSG:]`s said), else grbl's error number
    /// (after any alarm it raised).
    pub(super) fn gcode(&mut self, t: &str) -> Option<u8> {
        if self.prog.ended() {
            self.new_program();
        }
        self.jog = false;
        let block = match self.prog.run(t) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("motionctl: `{t}`: {} (error:{})", e.message, e.code);
                return Some(e.code);
            }
        };
        // Every target checked before any is queued: a block runs whole or not at all.
        let mut from = self.motion.pos_mm.clone();
        for s in &block.steps {
            let (Step::Item(Item::Move(MoveCmd { target: Target::Absolute(t), .. }))
            | Step::Item(Item::Probe {
                mv: MoveCmd { target: Target::Absolute(t), .. }, ..
            })) = s
            else {
                continue;
            };
            let to: Vec<f64> = t.iter().zip(&from).map(|(t, p)| t.unwrap_or(*p)).collect();
            if let Err(e) = self.motion.check(&from, &to) {
                return Some(self.refuse_move(e));
            }
            from = to;
        }
        for s in block.steps {
            match s {
                Step::Item(Item::Move(MoveCmd { target: Target::Absolute(t), feed, .. })) => {
                    if let Feed::MmPerMin(f) = feed {
                        self.feed_now = f;
                    } else {
                        self.feed_now = self.rapid_mm_min();
                    }
                    if let Err(e) = self.motion.push_move(&t, feed, self.check) {
                        return Some(self.refuse_move(e));
                    }
                }
                Step::Item(Item::Probe {
                    kind,
                    mv: MoveCmd { target: Target::Absolute(t), feed, .. },
                }) => {
                    if let Some(n) = self.queue_probe(kind, &t, feed) {
                        return Some(n);
                    }
                }
                Step::Item(Item::Move(_)) => {}
                Step::Item(Item::Outputs(o)) if !self.check => {
                    self.motion.push_event(Out::Outputs(o))
                }
                Step::Item(Item::Pause) if !self.check => self.motion.push_event(Out::Pause),
                Step::Item(Item::Dwell(d)) if !self.check => self.motion.push_event(Out::Dwell(d)),
                _ => {}
            }
        }
        for m in block.messages {
            self.say(&format!("[MSG:{m}]"));
        }
        // G10 L2/L20 write origins grbl keeps across resets (and program ends).
        if t.to_ascii_uppercase().contains("G10") && !self.prog.ended() {
            self.kept = self.prog.persistent();
        }
        None
    }

    pub(super) fn rapid_mm_min(&self) -> f64 {
        self.machine.axes.iter().map(|a| a.max_rate_mm_s * 60.0).fold(f64::INFINITY, f64::min)
    }
}
