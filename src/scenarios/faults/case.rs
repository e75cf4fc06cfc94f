//! The injected causes of the fault suite, their report names and the end each one documents.

use crate::machine::MachineState;
use crate::protocol::FaultCode;

/// The injected cause.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Case {
    EStop,
    LimitMin(u8),
    LimitMax(u8),
    /// A limit trips, ClearFault is refused while the axis sits on the switch, JogOff moves it
    /// off, then ClearFault returns to Ready with the position kept.
    LimitJogOff,
    HomingOk,
    HomingNotFound,
    SoftLimitQueue,
    SoftLimitRun,
    /// The host stops feeding after two segments of a stream at speed: the machine holds on
    /// the path (no fault), and resumes by itself when the host feeds again.
    QueueStarved,
    /// While X moves, its max switch input chatters (noise on the cable, a bouncing contact)
    /// in bursts shorter than the debounce: no fault, the move ends where it was planned.
    LimitNoise,
    LinkLoss,
    TickOverrun,
    ConfigMissing,
    Sensor(FaultCode),
    /// The sim plant follows the steps (a few ticks behind) until X jams: the machine's
    /// following-error monitor trips after its debounce.
    FollowingError,
    /// The polar machine (`polar::job::board_config`) homes: the arm against its end-stop, the
    /// carriage onto its minimum-radius switch; both origins land on the switch points.
    HomingPolar,
}

/// Every case, in the order the scenario list runs them.
pub const CASES: [Case; 23] = [
    Case::EStop,
    Case::LimitMin(0),
    Case::LimitMax(0),
    Case::LimitMin(1),
    Case::LimitMax(1),
    Case::LimitJogOff,
    Case::HomingOk,
    Case::HomingNotFound,
    Case::SoftLimitQueue,
    Case::SoftLimitRun,
    Case::QueueStarved,
    Case::LimitNoise,
    Case::LinkLoss,
    Case::TickOverrun,
    Case::ConfigMissing,
    Case::Sensor(FaultCode::ForceSaturated),
    Case::Sensor(FaultCode::ForceStuck),
    Case::Sensor(FaultCode::SpindleStopped),
    Case::Sensor(FaultCode::EncoderIndex),
    Case::Sensor(FaultCode::ResolverLoss),
    Case::Sensor(FaultCode::SensorFault),
    Case::FollowingError,
    Case::HomingPolar,
];

impl Case {
    pub const fn name(self) -> &'static str {
        match self {
            Case::EStop => "fault_estop",
            Case::LimitMin(0) => "fault_limit_x_min",
            Case::LimitMax(0) => "fault_limit_x_max",
            Case::LimitMin(_) => "fault_limit_y_min",
            Case::LimitMax(_) => "fault_limit_y_max",
            Case::LimitJogOff => "fault_limit_jog_off",
            Case::HomingOk => "fault_homing_ok",
            Case::HomingNotFound => "fault_homing_not_found",
            Case::SoftLimitQueue => "fault_soft_limit_queue",
            Case::SoftLimitRun => "fault_soft_limit_run",
            Case::QueueStarved => "queue_starved",
            Case::LimitNoise => "limit_noise",
            Case::LinkLoss => "fault_link_loss",
            Case::TickOverrun => "fault_tick_overrun",
            Case::ConfigMissing => "fault_config_missing",
            Case::Sensor(FaultCode::ForceSaturated) => "fault_force_saturated",
            Case::Sensor(FaultCode::ForceStuck) => "fault_force_stuck",
            Case::Sensor(FaultCode::SpindleStopped) => "fault_spindle_stopped",
            Case::Sensor(FaultCode::EncoderIndex) => "fault_encoder_index",
            Case::Sensor(FaultCode::ResolverLoss) => "fault_resolver_loss",
            Case::Sensor(_) => "fault_sensor",
            Case::FollowingError => "fault_following_error",
            Case::HomingPolar => "fault_homing_polar",
        }
    }

    /// The state the case ends in and the fault code it reports (`None`: no fault).
    pub const fn expected(self) -> (MachineState, Option<FaultCode>) {
        use MachineState::{Fault, Ready};
        let (state, code) = match self {
            Case::EStop => (Fault, FaultCode::EStop),
            Case::LimitMin(_) | Case::LimitMax(_) => (Fault, FaultCode::LimitSwitch),
            // Jogged off and cleared: the fault it recovered from.
            Case::LimitJogOff => (Ready, FaultCode::LimitSwitch),
            Case::HomingOk | Case::HomingPolar | Case::QueueStarved | Case::LimitNoise => {
                return (Ready, None)
            }
            Case::HomingNotFound => (Fault, FaultCode::HomingFailed),
            // Refused at the queue: nothing changes, the refusal names the soft limit.
            Case::SoftLimitQueue => (Ready, FaultCode::SoftLimit),
            Case::SoftLimitRun => (Fault, FaultCode::SoftLimit),
            Case::LinkLoss => (Fault, FaultCode::LinkLost),
            Case::TickOverrun => (Fault, FaultCode::TickOverrun),
            Case::ConfigMissing => (Fault, FaultCode::ConfigMissing),
            Case::Sensor(code) => (Fault, code),
            Case::FollowingError => (Fault, FaultCode::FollowingError),
        };
        (state, Some(code))
    }
}
