//! The simulated machine I/O of the QEMU board. QEMU models no GPIO: no switch is ever open
//! (the fault paths these inputs drive are exercised by the scenario firmware's `fault_*`
//! scenarios instead) and the outputs go nowhere: the spindle, its direction, the coolant and the
//! wire power live in the machine's outputs, which `Status` reports (`Status::outputs`,
//! `Status::wire_power`), so the host still sees every switch in order. Two inputs are
//! simulated for the host:
//!
//! * the wire-stall switch, set with `Sim(Inject)` (announced by `CAP_SIM_INPUTS`), to test the
//!   wire-stall retrace end to end;
//! * the copy-mode encoders: two counters slew toward the host's `Sim(Encoders)` target at one
//!   count per `SIM_TICKS_PER_COUNT` ticks (`motion::polar::copy_link::SimEncoderSlew`, like
//!   a template moved at a bounded speed), drive simulated A/B lines, and the board reads them
//!   back through the same software quadrature decoder a board without encoder timers would
//!   use (`board_drivers::quadrature::SoftDecoder`).

use core::convert::Infallible;
use core::sync::atomic::{AtomicBool, AtomicI32, Ordering::Relaxed};

use board_contract::RawInputs;
use board_drivers::quadrature::{levels, Quadrature, SoftDecoder};
use motion::machine::Outputs;
use motion::polar::copy_link::SimEncoderSlew;

/// The simulated wire-stall switch (`Sim(Inject)`): written by the USART task, read by the tick.
static SIM_WIRE_STALL: AtomicBool = AtomicBool::new(false);

pub struct MachineIo;

impl board_contract::MachineIo for MachineIo {
    /// The host drives the simulated inputs (`Sim(Inject)`).
    const SIM_INPUTS: bool = true;
    /// Simulated: the spindle direction and coolant are kept in the machine's outputs and
    /// reported in `Status::outputs`.
    const PROGRAM_OUTPUTS: bool = true;
    /// Simulated, like the other program outputs.
    const MIST: bool = true;

    /// Sets the simulated wire-stall switch from the next tick on; true (honoured).
    fn inject_wire_stall(stalled: bool) -> bool {
        SIM_WIRE_STALL.store(stalled, Relaxed);
        true
    }

    #[inline]
    fn read(&mut self) -> RawInputs {
        RawInputs { wire_stall: SIM_WIRE_STALL.load(Relaxed), ..RawInputs::default() }
    }

    #[inline]
    fn write(&mut self, _o: &Outputs) {}
}

/// The simulated encoders' target counts (`Sim(Encoders)`): written by the USART task, read by
/// the tick.
static SIM_ENCODER_TARGET: [AtomicI32; 2] = [AtomicI32::new(0), AtomicI32::new(0)];

/// A simulated A or B line: the level the simulated encoder drives, read as an `InputPin`.
pub struct SimLine(bool);

impl embedded_hal::digital::ErrorType for SimLine {
    type Error = Infallible;
}

impl embedded_hal::digital::InputPin for SimLine {
    #[inline]
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0)
    }
    #[inline]
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0)
    }
}

/// One simulated encoder: its lines and the decoder reading them.
struct SimEncoder {
    decoder: SoftDecoder<SimLine, SimLine>,
}

impl SimEncoder {
    fn new() -> Self {
        let (a, b) = levels(0);
        SimEncoder { decoder: SoftDecoder::new(SimLine(a), SimLine(b)) }
    }

    /// Drives the lines to `count`'s levels and decodes them (one count per tick at most, so
    /// the decoder never sees a skipped state).
    #[inline]
    fn follow(&mut self, count: i32) -> i32 {
        let (a, b) = levels(count);
        let (pa, pb) = self.decoder.pins_mut();
        (pa.0, pb.0) = (a, b);
        self.decoder.update()
    }
}

/// Copy-mode encoders under QEMU (see the module docs).
pub struct CopyEncoders {
    slew: SimEncoderSlew,
    arm: SimEncoder,
    carriage: SimEncoder,
    /// The decoded counts of the last tick.
    decoded: [i32; 2],
}

impl CopyEncoders {
    pub fn new() -> Self {
        CopyEncoders {
            slew: SimEncoderSlew::new(),
            arm: SimEncoder::new(),
            carriage: SimEncoder::new(),
            decoded: [0; 2],
        }
    }
}

impl Default for CopyEncoders {
    fn default() -> Self {
        Self::new()
    }
}

impl board_contract::CopyEncoders for CopyEncoders {
    /// Copy jobs are possible (announced as `CAP_COPY_JOB`).
    const ROUTED: bool = true;

    /// Sets the simulated encoders' target from the next tick on; true (honoured).
    fn set_sim_target(counts: [i32; 2]) -> bool {
        for (t, c) in SIM_ENCODER_TARGET.iter().zip(counts) {
            t.store(c, Relaxed);
        }
        true
    }

    /// One tick: (arm, carriage) counts. Two loads, a countdown, two clamped adds, two decodes;
    /// two loads and four compares while the encoders rest on their target.
    #[inline]
    fn read(&mut self) -> [i32; 2] {
        let target = [SIM_ENCODER_TARGET[0].load(Relaxed), SIM_ENCODER_TARGET[1].load(Relaxed)];
        // Encoders at rest on their target (a hardware counter that does not count): nothing
        // to drive or decode.
        if target == self.slew.counts && self.decoded == target {
            return self.decoded;
        }
        let [arm, carriage] = self.slew.tick(target);
        self.decoded = [self.arm.follow(arm), self.carriage.follow(carriage)];
        self.decoded
    }
}
