//! The board's side of turning's link requests: its target trait filled for the link
//! firmware's [`Target`].

use super::*;
use crate::link::target::Target;
use motion::turning::link_job::{ZJobSpec, ZTableHeader};
use motion::turning::link_messages::TurningTarget;
use rtic::Mutex;

impl<M: Mutex<T = Motion>> TurningTarget for Target<'_, M> {
    fn z_table_begin(&mut self, h: &ZTableHeader) -> Result<(), ZNak> {
        let active = self.with(|m| m.machine.runs(TURNING_JOB));
        self.link.z.begin(h, active)
    }
    fn z_table_chunk(&mut self, index: u16, bytes: &[u8]) -> Result<(), ZNak> {
        let active = self.with(|m| m.machine.runs(TURNING_JOB));
        self.link.z.chunk(index, bytes, active)
    }
    fn z_table_end(&mut self, crc: u32) -> Result<(), ZNak> {
        // Checked outside the lock; the install (a copy) inside it.
        let active = self.with(|m| m.machine.runs(TURNING_JOB));
        let table = self.link.z.end(crc, active)?;
        let copy = table.clone();
        self.motion.get_mut().lock(|m| install(m, table))?;
        self.link.z.installed(copy);
        Ok(())
    }
    fn start_z(&mut self, spec: &ZJobSpec) -> Result<(), ZNak> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        let (tick_hz, speed, active) = self.with(|m| {
            let tick_hz = m.machine.config().link.machine.tick_hz;
            (tick_hz, m.z.sensed_speed_turn_q32_per_tick(), m.machine.runs(TURNING_JOB))
        });
        // The generator is built here, outside the lock (see `turning`).
        let prepared = self.link.z.prepare(spec, tick_hz, speed, active)?;
        self.motion.get_mut().lock(|m| start(m, empty, prepared))
    }
}
