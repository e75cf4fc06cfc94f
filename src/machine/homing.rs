//! The homing sequencer: per axis, in the configured order, seek the switch at the search speed,
//! back off, approach again at the latch speed, set the origin where the switch closes, and pull
//! off the switch again.
//!
//! Moves are planned in the background (the planner divides); the tick only watches the switch
//! and the DDA: [`Homing::watch`] is a handful of compares.

use super::config::{BoardConfig, HomeAxis};
use crate::config::MAX_AXES;
use crate::planner::Move;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HomePhase {
    /// Toward the switch at the search speed, at most `max_travel_steps`.
    Seek,
    /// Away from the switch by `backoff_steps`; it must open.
    Backoff,
    /// Toward the switch at the latch speed, at most twice the backoff.
    Latch,
    /// Off the switch again by `backoff_steps`, so the next axis does not start with a closed
    /// limit switch; it must open.
    PullOff,
}

/// What the tick must do after [`Homing::watch`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HomeEvent {
    None,
    /// Stop at once (the switch closed during a seek); the next move follows in the background.
    Stop,
    /// The switch closed during the latch approach: this axis's origin is here. Stop at once.
    Latched {
        axis: u8,
    },
    /// The move ended without the switch closing.
    NotFound {
        axis: u8,
    },
    /// The switch stayed closed after backing off.
    Stuck {
        axis: u8,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Homing {
    /// Index into `home_order` of the axis being homed.
    k: u8,
    count: u8,
    order: [u8; MAX_AXES],
    axis_cfg: HomeAxis,
    phase: HomePhase,
    /// A move must be planned and queued (background work).
    need_move: bool,
    /// The current move is in the DDA.
    moving: bool,
}

impl Homing {
    pub const fn idle() -> Self {
        Homing {
            k: 0,
            count: 0,
            order: [0; MAX_AXES],
            axis_cfg: HomeAxis::UNUSED,
            phase: HomePhase::Seek,
            need_move: false,
            moving: false,
        }
    }

    /// Starts the sequence over every axis of `cfg.home_order`.
    pub fn start(cfg: &BoardConfig) -> Self {
        let count = cfg.home_count.min(MAX_AXES as u8);
        let mut h = Homing { count, order: cfg.home_order, ..Homing::idle() };
        h.begin_axis(cfg);
        h
    }

    fn begin_axis(&mut self, cfg: &BoardConfig) {
        self.phase = HomePhase::Seek;
        self.moving = false;
        self.need_move = self.k < self.count;
        if let Some(&a) = self.order.get(self.k as usize) {
            if let Some(h) = cfg.home.get(a as usize) {
                self.axis_cfg = *h;
            }
        }
    }

    /// Every axis homed.
    pub fn is_done(&self) -> bool {
        self.k >= self.count
    }

    pub fn needs_move(&self) -> bool {
        self.need_move
    }

    /// The axis being homed, if any.
    pub fn axis(&self) -> Option<u8> {
        if self.is_done() {
            None
        } else {
            self.order.get(self.k as usize).copied()
        }
    }

    pub fn phase(&self) -> HomePhase {
        self.phase
    }

    /// The axis and side (true = max) of the switch homing uses now: the tick does not treat it
    /// as a tripped limit.
    pub fn switch(&self) -> Option<(u8, bool)> {
        self.axis().map(|a| (a, self.axis_cfg.toward_max))
    }

    /// The move the current phase needs (taken once; the caller plans and queues it).
    pub fn take_move(&mut self) -> Option<Move> {
        if !self.need_move {
            return None;
        }
        let axis = self.axis()? as usize;
        let h = &self.axis_cfg;
        let toward: i64 = if h.toward_max { 1 } else { -1 };
        let (len, feed_hz) = match self.phase {
            HomePhase::Seek => (toward * h.max_travel_steps as i64, h.search_hz),
            HomePhase::Backoff | HomePhase::PullOff => {
                (-toward * h.backoff_steps as i64, h.search_hz)
            }
            HomePhase::Latch => (toward * 2 * h.backoff_steps as i64, h.latch_hz),
        };
        let mut steps = [0i32; MAX_AXES];
        // Validated: travel <= 2^30, twice the backoff <= 2^30.
        *steps.get_mut(axis)? = len.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        self.need_move = false;
        self.moving = true;
        Some(Move { steps, feed_hz })
    }

    /// One tick's look at the homing switch (`pressed`) and whether the DDA went idle (the move
    /// ended). Compares only.
    #[inline]
    pub fn watch(&mut self, cfg: &BoardConfig, pressed: bool, dda_idle: bool) -> HomeEvent {
        let Some(axis) = self.axis() else { return HomeEvent::None };
        if !self.moving {
            return HomeEvent::None;
        }
        match self.phase {
            HomePhase::Seek if pressed => {
                self.phase = HomePhase::Backoff;
                self.moving = false;
                self.need_move = true;
                HomeEvent::Stop
            }
            HomePhase::Backoff if dda_idle => {
                if pressed {
                    self.moving = false;
                    return HomeEvent::Stuck { axis };
                }
                self.phase = HomePhase::Latch;
                self.moving = false;
                self.need_move = true;
                HomeEvent::None
            }
            HomePhase::Latch if pressed => {
                self.phase = HomePhase::PullOff;
                self.moving = false;
                self.need_move = true;
                HomeEvent::Latched { axis }
            }
            HomePhase::PullOff if dda_idle => {
                if pressed {
                    self.moving = false;
                    return HomeEvent::Stuck { axis };
                }
                self.k += 1;
                self.begin_axis(cfg);
                HomeEvent::None
            }
            HomePhase::Seek | HomePhase::Latch if dda_idle => {
                self.moving = false;
                HomeEvent::NotFound { axis }
            }
            _ => HomeEvent::None,
        }
    }

    /// Stops the sequence (abort or fault).
    pub fn cancel(&mut self) {
        *self = Homing::idle();
    }
}
