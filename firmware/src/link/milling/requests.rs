//! The board's side of milling's link requests: its target trait filled for the link
//! firmware's [`Target`].

use super::*;
use crate::link::target::Target;
use crate::link::wire;
use motion::milling::link_messages::MillingTarget;
use rtic::Mutex;

impl<M: Mutex<T = Motion>> MillingTarget for Target<'_, M> {
    fn arm_force(&mut self, params: &ForceJobParams) -> Result<(), ErrorCode> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        self.motion.get_mut().lock(|m| {
            let wire_live = wire::live(m);
            arm(m, empty, wire_live, params)
        })
    }
}
