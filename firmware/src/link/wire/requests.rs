//! The board's side of wire's link requests: its target trait filled for the link
//! firmware's [`Target`].

use super::*;
use crate::link::milling;
use crate::link::target::Target;
use motion::wire::link_messages::WireTarget;
use rtic::Mutex;

impl<M: Mutex<T = Motion>> WireTarget for Target<'_, M> {
    fn arm_wire(&mut self, params: &WireJobParams) -> Result<(), ErrorCode> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        // An armed force job owns the next segment job.
        let empty = empty && !self.with(|m| milling::live(m));
        self.motion.get_mut().lock(|m| arm(m, empty, params))
    }
}
