//! Switch inputs filtered before the machine acts on them. A mechanical limit switch bounces for
//! a millisecond or two when it closes or opens, and a long cable picks up spikes: taken raw, one
//! noisy edge trips a limit fault and a bounce can look like a release. So a limit switch changes
//! state only once its raw level has held for the debounce time, each switch on its own. The
//! e-stop is asymmetric: it trips on its first asserted tick (never delay a stop) and counts as
//! released only after it has stayed released for the debounce time.
//!
//! The touch probe is debounced on both edges with the same time (a probe's contact chatters
//! like a switch's): a probe move trips on its debounced level (`super::probe`).
//!
//! The homing sequencer latches on the raw switch edge (as grbl does: a debounce delay at the
//! latch speed would move the home point); faults and jog-off see the filtered switches.
//!
//! Interrupt rate: one compare when every input is steady; while one is changing, a loop over
//! the changing bits only. Integer only, no division (the debounce in ticks is computed when the
//! config is installed).

use super::Inputs;
pub use crate::config::{InputFilterConfig, DEFAULT_SWITCH_DEBOUNCE_US, MAX_SWITCH_DEBOUNCE_US};

/// One input debounced over `ticks` samples: a new level is taken once it has been read on
/// `ticks` consecutive samples (optionally one level, the tripped one, at once).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Debouncer {
    stable: bool,
    count: u16,
    ticks: u16,
    /// The level taken at once, if any.
    instant: Option<bool>,
}

impl Debouncer {
    /// Both edges debounced over `ticks` samples (0: no debouncing), starting at `initial`.
    pub const fn new(ticks: u16, initial: bool) -> Self {
        Debouncer { stable: initial, count: 0, ticks, instant: None }
    }

    /// `true` (tripped) is taken at once; `false` only after `ticks` samples.
    pub const fn trips_at_once(release_ticks: u16, initial: bool) -> Self {
        Debouncer { stable: initial, count: 0, ticks: release_ticks, instant: Some(true) }
    }

    /// One sample; the debounced level.
    #[inline]
    pub fn update(&mut self, raw: bool) -> bool {
        if raw == self.stable {
            self.count = 0;
        } else if self.instant == Some(raw) {
            self.stable = raw;
            self.count = 0;
        } else {
            self.count += 1;
            if self.count >= self.ticks {
                self.stable = raw;
                self.count = 0;
            }
        }
        self.stable
    }

    pub const fn level(&self) -> bool {
        self.stable
    }
}

/// Up to 32 switches sampled as one word, each debounced over `ticks` samples on both edges.
/// Costs a compare per sample while no bit differs from its debounced level.
#[derive(Clone, Debug)]
pub struct DebouncedBank {
    stable: u32,
    /// Bits whose raw level differs from `stable` and are being timed.
    pending: u32,
    counts: [u16; 32],
    ticks: u16,
}

impl DebouncedBank {
    pub const fn new(ticks: u16, initial: u32) -> Self {
        DebouncedBank { stable: initial, pending: 0, counts: [0; 32], ticks }
    }

    /// One sample of every bit; the debounced word.
    #[inline]
    pub fn update(&mut self, raw: u32) -> u32 {
        let differ = raw ^ self.stable;
        if differ == 0 && self.pending == 0 {
            return self.stable;
        }
        // Bits back at their stable level stop timing.
        let mut bits = differ | self.pending;
        self.pending = 0;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let bit = 1u32 << i;
            if differ & bit == 0 {
                self.counts[i] = 0;
                continue;
            }
            self.counts[i] += 1;
            if self.counts[i] >= self.ticks {
                self.stable ^= bit;
                self.counts[i] = 0;
            } else {
                self.pending |= bit;
            }
        }
        self.stable
    }
}

/// Where the max switches sit in the limit bank's word (the min switches in bits 0..6).
const MAX_SHIFT: u32 = 8;

/// The machine's switch inputs through their debouncers: the limit switches as one bank (each
/// switch on its own), the e-stop tripping at once and releasing after the debounce, the probe
/// debounced on both edges.
#[derive(Clone, Debug)]
pub struct SwitchFilter {
    limits: DebouncedBank,
    estop: Debouncer,
    probe: Debouncer,
}

impl SwitchFilter {
    /// A filter that believes a new level after `debounce_ticks` ticks (0: pass-through).
    /// Starts with every switch open and the e-stop released.
    pub const fn new(debounce_ticks: u16) -> Self {
        SwitchFilter {
            limits: DebouncedBank::new(debounce_ticks, 0),
            estop: Debouncer::trips_at_once(debounce_ticks, false),
            probe: Debouncer::new(debounce_ticks, false),
        }
    }

    /// The probe input as the filter believes it now.
    pub const fn probe_level(&self) -> bool {
        self.probe.level()
    }

    /// A new debounce time; the believed levels stay.
    pub fn set_ticks(&mut self, debounce_ticks: u16) {
        self.limits.ticks = debounce_ticks;
        self.estop.ticks = debounce_ticks;
        self.probe.ticks = debounce_ticks;
    }

    /// Every switch released, the e-stop closed and the probe steady, believed and not being
    /// timed: a tick that reads the same would change nothing.
    #[inline]
    pub fn quiet(&self) -> bool {
        self.limits.stable | self.limits.pending == 0
            && !self.estop.stable
            && self.estop.count == 0
            && self.probe.count == 0
    }

    /// `raw` with the switches and e-stop replaced by their filtered levels. Nearly every tick
    /// every input reads what the filter believes and nothing is being timed: then `raw` is the
    /// answer, after two compares.
    #[inline(always)]
    pub fn filter(&mut self, raw: &Inputs) -> Inputs {
        let word = raw.limit_min as u32 | (raw.limit_max as u32) << MAX_SHIFT;
        let steady = (word ^ self.limits.stable) | self.limits.pending == 0
            && raw.estop == self.estop.stable
            && self.estop.count == 0
            && raw.probe == self.probe.stable
            && self.probe.count == 0;
        if steady {
            return *raw;
        }
        self.settle(raw, word)
    }

    #[cold]
    #[inline(never)]
    fn settle(&mut self, raw: &Inputs, word: u32) -> Inputs {
        let limits = self.limits.update(word);
        Inputs {
            limit_min: limits as u8,
            limit_max: (limits >> MAX_SHIFT) as u8,
            estop: self.estop.update(raw.estop),
            probe: self.probe.update(raw.probe),
            ..*raw
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_one(d: &mut Debouncer, raw: &[u8]) -> Vec<u8> {
        raw.iter().map(|&r| d.update(r != 0) as u8).collect()
    }

    #[test]
    fn a_bouncing_close_is_taken_after_the_last_bounce() {
        // 3 ticks (3 ms at 1 kHz): bounces shorter than that are ignored.
        let mut d = Debouncer::new(3, false);
        let raw = [0, 1, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1];
        let out = run_one(&mut d, &raw);
        assert_eq!(out, [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]);
    }

    #[test]
    fn zero_ticks_passes_every_level_through() {
        let mut d = Debouncer::new(0, false);
        let raw = [0, 1, 0, 1, 1, 0];
        assert_eq!(run_one(&mut d, &raw), raw);
    }

    #[test]
    fn one_level_trips_at_once_and_releases_only_after_the_debounce() {
        let mut d = Debouncer::trips_at_once(2, false);
        let raw = [0, 1, 0, 1, 0, 0, 1, 0, 0, 0];
        // Trips on the first high sample; chatter keeps it tripped; two clear samples release.
        assert_eq!(run_one(&mut d, &raw), [0, 1, 1, 1, 1, 0, 1, 1, 0, 0]);
        assert!(!d.level());
    }

    #[test]
    fn a_bank_debounces_each_bit_on_its_own() {
        let mut b = DebouncedBank::new(2, 0);
        // Bit 0 closes cleanly; bit 1 bounces once and then closes; bit 2 only glitches.
        let raw = [0b000, 0b111, 0b001, 0b011, 0b011, 0b001, 0b001, 0b000, 0b000];
        let out: Vec<u32> = raw.iter().map(|&r| b.update(r)).collect();
        assert_eq!(out, [0b000, 0b000, 0b001, 0b001, 0b011, 0b011, 0b001, 0b001, 0b000]);
        // Quiet: nothing pending.
        assert_eq!(b.pending, 0);
    }

    fn inp(min: u8, max: u8, estop: bool) -> Inputs {
        Inputs { limit_min: min, limit_max: max, estop, ..Inputs::QUIET }
    }

    /// Runs `levels` (one per tick) through a filter of `ticks`; the filtered (min, estop) each tick.
    fn run(ticks: u16, levels: &[(u8, bool)]) -> Vec<(u8, bool)> {
        let mut f = SwitchFilter::new(ticks);
        levels
            .iter()
            .map(|&(m, e)| {
                let o = f.filter(&inp(m, 0, e));
                (o.limit_min, o.estop)
            })
            .collect()
    }

    #[test]
    fn a_switch_closes_after_holding_the_debounce_time() {
        let out = run(3, &[(1, false); 5]);
        let mins: Vec<u8> = out.iter().map(|o| o.0).collect();
        // Believed on the third tick of the steady level.
        assert_eq!(mins, [0, 0, 1, 1, 1]);
    }

    #[test]
    fn bounces_shorter_than_the_debounce_are_ignored_both_ways() {
        // Closes for 2 ticks, opens, closes for 2: never 3 in a row.
        let chatter = [(1, false), (1, false), (0, false), (1, false), (1, false), (0, false)];
        assert!(run(3, &chatter).iter().all(|o| o.0 == 0), "chatter tripped the switch");
        // Closed and believed; a bounce open of 2 ticks does not release it.
        let mut levels = vec![(1u8, false); 4];
        levels.extend([(0, false), (0, false), (1, false), (1, false)]);
        let out = run(3, &levels);
        assert!(out[2..].iter().all(|o| o.0 == 1), "{out:?}");
    }

    #[test]
    fn each_switch_counts_on_its_own() {
        let mut f = SwitchFilter::new(3);
        // X min closes at tick 0, Y min chatters meanwhile: X is believed at tick 2.
        let seq = [0b01, 0b11, 0b01, 0b11, 0b01];
        let out: Vec<u8> = seq.iter().map(|&m| f.filter(&inp(m, 0, false)).limit_min).collect();
        assert_eq!(out, [0, 0, 1, 1, 1]);
    }

    #[test]
    fn max_switches_are_filtered_like_min_switches() {
        let mut f = SwitchFilter::new(2);
        let a = f.filter(&inp(0, 0b100, false));
        let b = f.filter(&inp(0, 0b100, false));
        assert_eq!((a.limit_max, b.limit_max), (0, 0b100));
    }

    #[test]
    fn the_estop_trips_at_once_and_releases_only_after_the_debounce() {
        let mut levels = vec![(0u8, true)];
        // Bounces released/asserted, then steady released for 3 ticks.
        levels.extend([(0, false), (0, false), (0, true), (0, false), (0, false), (0, false)]);
        let out: Vec<bool> = run(3, &levels).iter().map(|o| o.1).collect();
        assert_eq!(out, [true, true, true, true, true, true, false]);
    }

    #[test]
    fn zero_ticks_is_the_raw_input() {
        let levels = [(1, true), (0, false), (1, false), (0, true)];
        assert_eq!(run(0, &levels), levels.to_vec());
    }

    #[test]
    fn debounce_ticks_round_up_and_validate() {
        let c = InputFilterConfig::DEFAULT;
        assert_eq!(c.debounce_ticks(100_000), 200);
        assert_eq!(c.debounce_ticks(30_000), 60);
        assert_eq!(InputFilterConfig { switch_debounce_us: 1 }.debounce_ticks(50_000), 1);
        assert_eq!(InputFilterConfig { switch_debounce_us: 0 }.debounce_ticks(50_000), 0);
        assert!(c.validate().is_ok());
        let e = InputFilterConfig { switch_debounce_us: MAX_SWITCH_DEBOUNCE_US + 1 }.validate();
        assert_eq!(e.unwrap_err().field, "switch_debounce_us");
    }
}

#[cfg(test)]
mod machine_tests {
    use crate::machine::{homed, BoardConfig, Inputs, MachineCommand, MachineState, Refusal};
    use crate::protocol::FaultCode;

    /// The e-stop through the whole machine: a one-tick spike trips it; a release that bounces
    /// keeps `ClearFault` refused until the input has stayed released for the debounce.
    #[test]
    fn an_estop_spike_trips_and_a_bouncing_release_does_not_clear() {
        let cfg = BoardConfig::safe_default();
        let debounce = cfg.link.inputs.debounce_ticks(cfg.link.machine.tick_hz) as u32;
        assert_eq!(debounce, 100, "2 ms at the safe default's 50 kHz");
        let (mut m, mut dda, _) = homed(cfg);
        let estop = |on: bool| Inputs { estop: on, ..Inputs::QUIET };
        m.tick(&mut dda, &estop(true));
        assert_eq!(m.state(), MachineState::Fault);
        assert!(m.faults().has(FaultCode::EStop));
        // Released, with a one-tick bounce every 40 ticks for 400 ticks.
        for t in 0..400u32 {
            m.tick(&mut dda, &estop(t % 40 == 39));
            let r = m.command(MachineCommand::ClearFault, &mut dda);
            assert_eq!(r, Err(Refusal::CauseActive(FaultCode::EStop)), "cleared at tick {t}");
        }
        // Steady release: refused for debounce - 1 ticks, accepted on the debounce-th.
        for t in 1..debounce {
            m.tick(&mut dda, &estop(false));
            let r = m.command(MachineCommand::ClearFault, &mut dda);
            assert!(r.is_err(), "cleared after {t} ticks of release");
        }
        m.tick(&mut dda, &estop(false));
        assert!(m.command(MachineCommand::ClearFault, &mut dda).is_ok());
    }

    proptest::proptest! {
        /// The debounced level changes only after exactly `n` consecutive samples of the new
        /// level, and always then.
        #[test]
        fn matches_a_run_length_model(
            n in 1u16..8,
            raw in proptest::collection::vec(proptest::prelude::any::<bool>(), 0..200),
        ) {
            let mut d = super::Debouncer::new(n, false);
            let mut state = false;
            let mut run = 0usize;
            for &r in &raw {
                if r == state { run = 0 } else { run += 1 }
                if run == n as usize { state = r; run = 0; }
                proptest::prop_assert_eq!(d.update(r), state);
            }
        }
    }
}
