//! Bounded records of path pieces for the wire-stall retrace: the executed path (newest last)
//! and the pieces retraced so far (to replay forward).

use heapless::Deque;

/// Path pieces remembered for retracing. At the circle -> complex job's 6 s per segment this is
/// several minutes of cutting; older pieces are forgotten.
pub const HISTORY_LEN: usize = 64;

/// A straight piece between two absolute step positions (X, Y, beta, alpha), with the duration
/// and ramp of the job segment it belongs to: a part of it run over the same time and ramp
/// never exceeds the segment's axis rates or accelerations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    pub start: [i32; 4],
    pub end: [i32; 4],
    pub duration_ticks: u32,
    pub accel_q30: u32,
}

impl Piece {
    /// The part of this piece from `start` to `end` (points on it), over the share of the
    /// duration that keeps every axis at or below the piece's own rate:
    /// `max_i ceil(T |d'_i| / |d_i|)`. Feeder-task code (it divides).
    pub fn part(&self, start: [i32; 4], end: [i32; 4]) -> Piece {
        let full = sub(self.end, self.start);
        let part = sub(end, start);
        let t = self.duration_ticks as u64;
        let mut ticks = 1u64;
        for (&d, &p) in full.iter().zip(&part) {
            let (d, p) = (d.unsigned_abs() as u64, p.unsigned_abs() as u64);
            // An axis the part moves more than the piece (not on it): keep the whole time.
            let need = if p > d || (d == 0 && p != 0) {
                t
            } else if d == 0 {
                0
            } else {
                (t * p).div_ceil(d)
            };
            ticks = ticks.max(need);
        }
        Piece { start, end, duration_ticks: ticks.min(t.max(1)) as u32, accel_q30: self.accel_q30 }
    }

    /// Steps from `from` to this piece's `end`.
    pub fn steps_to_end(&self, from: [i32; 4]) -> [i32; 4] {
        sub(self.end, from)
    }
}

/// `a - b` per axis (positions stay within a few 1e5 steps; wrapping keeps it panic-free).
pub fn sub(a: [i32; 4], b: [i32; 4]) -> [i32; 4] {
    [
        a[0].wrapping_sub(b[0]),
        a[1].wrapping_sub(b[1]),
        a[2].wrapping_sub(b[2]),
        a[3].wrapping_sub(b[3]),
    ]
}

/// Sum of the absolute steps: the retrace distance measure (no square root, no division).
pub fn l1_steps(d: [i32; 4]) -> u64 {
    d.iter().map(|v| v.unsigned_abs() as u64).sum()
}

/// The executed path, oldest first, newest last; full -> the oldest piece is dropped.
#[derive(Clone, Debug, Default)]
pub struct History {
    pieces: Deque<Piece, HISTORY_LEN>,
}

impl History {
    pub const fn new() -> Self {
        History { pieces: Deque::new() }
    }

    /// Records an executed piece; pieces without steps are not kept.
    pub fn push(&mut self, p: Piece) {
        if p.start == p.end {
            return;
        }
        if self.pieces.is_full() {
            self.pieces.pop_front();
        }
        // Room was just made.
        let _ = self.pieces.push_back(p);
    }

    /// The newest piece, removed.
    pub fn pop(&mut self) -> Option<Piece> {
        self.pieces.pop_back()
    }

    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }
}

/// Pieces to run forward again, last pushed first (a stack).
#[derive(Clone, Debug, Default)]
pub struct Replay {
    pieces: heapless::Vec<Piece, { HISTORY_LEN + 2 }>,
}

impl Replay {
    pub const fn new() -> Self {
        Replay { pieces: heapless::Vec::new() }
    }

    /// False when full (the caller faults: more retraced than it can replay).
    pub fn push(&mut self, p: Piece) -> bool {
        p.start == p.end || self.pieces.push(p).is_ok()
    }

    pub fn pop(&mut self) -> Option<Piece> {
        self.pieces.pop()
    }

    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn piece(a: i32, b: i32) -> Piece {
        Piece { start: [a, 0, 0, 0], end: [b, 0, 0, 0], duration_ticks: 10, accel_q30: 1 }
    }

    #[test]
    fn history_is_bounded_and_newest_first() {
        let mut h = History::new();
        for k in 0..(HISTORY_LEN as i32 + 5) {
            h.push(piece(k, k + 1));
        }
        h.push(piece(7, 7));
        assert_eq!(h.len(), HISTORY_LEN);
        assert_eq!(h.pop(), Some(piece(HISTORY_LEN as i32 + 4, HISTORY_LEN as i32 + 5)));
        let mut last = None;
        while let Some(p) = h.pop() {
            last = Some(p);
        }
        // The five oldest were dropped.
        assert_eq!(last, Some(piece(5, 6)));
    }

    #[test]
    fn replay_is_a_stack_and_distances_add() {
        let mut r = Replay::new();
        assert!(r.push(piece(0, 3)));
        assert!(r.push(piece(3, 5)));
        assert!(r.push(piece(5, 5)));
        assert_eq!(r.len(), 2);
        assert_eq!(r.pop(), Some(piece(3, 5)));
        assert_eq!(piece(0, 3).steps_to_end([1, 2, 0, -4]), [2, -2, 0, 4]);
        assert_eq!(l1_steps([2, -2, 0, 4]), 8);
        // A third of a piece takes a third of its time (rounded up), the rest the remainder.
        let p = Piece {
            start: [0, 0, 0, 0],
            end: [300, -90, 0, 0],
            duration_ticks: 1000,
            accel_q30: 7,
        };
        assert_eq!(p.part([0, 0, 0, 0], [100, -30, 0, 0]).duration_ticks, 334);
        assert_eq!(p.part([100, -30, 0, 0], [300, -90, 0, 0]).duration_ticks, 667);
        // An axis off the piece keeps the whole duration.
        assert_eq!(p.part([0, 0, 0, 0], [1, 0, 0, 5]).duration_ticks, 1000);
    }
}
