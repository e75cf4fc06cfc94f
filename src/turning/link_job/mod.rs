//! The Z-slide job of the link firmware: a coefficient table uploaded in chunks
//! ([`ZTableUpload`], checked whole: byte count, CRC-32, [`CoefficientTable::try_new`]) into a
//! [`LinkTable`], and the job itself ([`ZJob`]), a [`StepSource`] the machine runs through
//! `Machine::tick_with` (started by `MachineCommand::StartSource(TURNING_JOB)`).
//!
//! Per tick the board first hands the job its spindle reading ([`ZJob::sense`]: the sim spindle's
//! encoder in QEMU, the timer encoder or resolver on the F405), then the machine ticks the job:
//! X feeds at the job's rate (commanded X in inches Q24, exact: the X axis steps follow it, at
//! most one rise every other tick, DIR a tick before a reversed rise), [`ZGen::update`] gives the
//! Z command at that X and spindle angle, and the Z output follows it: the Z axis's steps (the
//! same pin rules) or the DAC code ([`ZJob::dac_code`]). The generator (a table evaluation: the
//! dearest part of a tick) updates every `2^k` ticks, k from [`update_shift`]: at 20 kHz or
//! faster, every 4th tick at the default 100 kHz; each tick between takes its command forward by
//! the command's own velocity and acceleration ([`ZUpdate::shifted`]). The command's X is the
//! commanded X (the counters trail it by less than a step, plus the pin stage's tick): on the
//! generator's ticks the Z trace is the turning scenario's to 4 * 2^-32 in (same library code),
//! between them within one encoder count of angle of it (the scenario reads the encoder every
//! tick), which the tests check.
//!
//! Faults (`ZSlideLimit`, `EncoderIndex`, `ResolverLoss`, `SpindleStopped`, a DAC code out of
//! range) latch in the generator and reach the machine through
//! [`ZJob::take_sensor_faults`] -> `Inputs::sensor_faults` (one tick later: the inputs are read
//! before the tick), so the machine's one fault model reacts (hold: X stops, Z stays frozen).
//!
//! Interrupt rate ([`ZJob::sense`], the [`StepSource`] impl): integer only, no division, bounded.

mod job;
mod run;
mod spec;
mod step_source;
mod update_rate;
mod upload;

pub use job::{ZJob, SENSE_REFRESH_TICKS};
pub use run::ZPrepared;
pub use spec::{ZJobSpec, ZOutputSpec, ZStartError};
pub use update_rate::{update_shift, Z_UPDATE_MIN_HZ};
pub use upload::{
    table_link_bytes, LinkTable, ZTableError, ZTableHeader, ZTableUpload, LINK_TABLE_ROWS,
    MAX_TABLE_BYTES,
};

#[cfg(test)]
mod tests;
