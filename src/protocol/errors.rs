//! Numbered codes that cross the link: NAK error codes, segment-check sub-codes and fault codes.
//!
//! Each enum is defined once, by [`coded_enum!`], together with its table of
//! `(code, name, description)`; the link carries the code byte, and [`markdown_table`] renders the
//! tables for documentation, so the docs can never drift from the code.

use crate::segment::SegmentError;

/// Defines a `#[repr(u8)]` enum whose link form is its code byte, plus its documentation table.
macro_rules! coded_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $Name:ident {
            $($Var:ident = $code:literal => ($name:literal, $desc:literal),)+
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[repr(u8)]
        $vis enum $Name {
            $(#[doc = $desc] $Var = $code,)+
        }

        impl $Name {
            /// `(code, name, description)` of every variant, in code order.
            pub const TABLE: &'static [(u8, &'static str, &'static str)] =
                &[$(($code, $name, $desc),)+];
            /// Every variant, in code order.
            pub const ALL: &'static [$Name] = &[$($Name::$Var,)+];

            /// The code byte sent on the link.
            pub const fn code(self) -> u8 {
                self as u8
            }

            /// The variant with this code byte, if any.
            pub const fn from_code(code: u8) -> Option<Self> {
                match code {
                    $($code => Some($Name::$Var),)+
                    _ => None,
                }
            }

            pub const fn name(self) -> &'static str {
                match self {
                    $($Name::$Var => $name,)+
                }
            }

            pub const fn description(self) -> &'static str {
                match self {
                    $($Name::$Var => $desc,)+
                }
            }
        }

        impl core::fmt::Display for $Name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl serde::Serialize for $Name {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_u8(self.code())
            }
        }

        impl<'de> serde::Deserialize<'de> for $Name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let code = <u8 as serde::Deserialize>::deserialize(d)?;
                $Name::from_code(code).ok_or_else(|| {
                    <D::Error as serde::de::Error>::custom(concat!("unknown ", stringify!($Name)))
                })
            }
        }
    };
}

coded_enum! {
    /// Why the board refused a request (the NAK table). A NAK means the request changed nothing
    /// on the board (except `Internal`, which a correct firmware never sends). "Link-level" codes are not tied to a request: their NAK carries
    /// `NakDetail::Expected` with the board's next expected seq instead.
    pub enum ErrorCode {
        Malformed = 1 => ("Malformed",
            "The frame passed its CRC but did not decode as a request (postcard error, unknown variant or trailing bytes). Tied to the request if its seq could be read, else link-level."),
        Crc = 2 => ("Crc",
            "Link-level: the frame's CRC-32 did not match; the frame was discarded."),
        Framing = 3 => ("Framing",
            "Link-level: invalid COBS encoding, or a frame too short to hold a CRC; the frame was discarded."),
        Overflow = 4 => ("Overflow",
            "Link-level: a frame longer than MAX_FRAME; the bytes up to the next 0x00 were discarded."),
        Version = 5 => ("Version",
            "Hello with a protocol version the board does not speak; the session is unchanged."),
        Sequence = 6 => ("Sequence",
            "seq is ahead of the board's next expected seq (a request was lost): not executed. Resend from `expected`."),
        QueueFull = 7 => ("QueueFull",
            "QueueSegments carries more segments than the board has credits (free queue slots); none queued."),
        InvalidSegment = 8 => ("InvalidSegment",
            "A segment failed its checks (detail: index in the batch, SegmentReason, axis); none of the batch was queued."),
        InvalidConfig = 9 => ("InvalidConfig",
            "SetConfig failed validation (detail: field name and axis; LinkConfig::validate on the host gives the reason); config unchanged."),
        OutOfState = 10 => ("OutOfState",
            "The request is not allowed in the current motion state (detail: the state); nothing changed."),
        OutOfRange = 11 => ("OutOfRange",
            "A parameter is outside its range (override above 2.0, status period below MIN_STATUS_PERIOD_MS); nothing changed."),
        Unsupported = 12 => ("Unsupported",
            "The board does not implement this request (e.g. Hold on a board without CAP_HOLD_RESUME)."),
        NoSession = 13 => ("NoSession",
            "No session: send Hello first. Also the answer after the board has reset, so the host must reconnect."),
        Stale = 14 => ("Stale",
            "seq is older than the board's retransmission memory, or the board executed a different request under it; its result is unknown."),
        Internal = 15 => ("Internal",
            "The board failed a request that passed every check (a firmware bug). The one NAK that may have changed something: part of a QueueSegments batch may be queued; read Status."),
        // -- Z-slide job --
        InvalidTable = 16 => ("InvalidTable",
            "A Z table upload step was refused (detail: NakDetail::Turning with the reason and the chunk index expected); the active table is unchanged."),
    }
}

coded_enum! {
    /// Which segment check failed, in an `InvalidSegment` NAK.
    pub enum SegmentReason {
        Duration = 1 => ("Duration", "duration_ticks is 0 or above MAX_SEGMENT_TICKS."),
        AxisRate = 2 => ("AxisRate", "An axis moves more than one step per tick, or faster than its max_rate_hz."),
        UnusedAxis = 3 => ("UnusedAxis", "An axis at or above axis_count moves."),
        JunctionRate = 4 => ("JunctionRate", "Entry or exit rate above 1.0."),
        Accel = 5 => ("Accel", "accel_per_tick is zero."),
        Empty = 6 => ("Empty", "No axis moves."),
        SoftLimit = 7 => ("SoftLimit", "The segment would end outside the axis soft limits (counting every segment queued before it)."),
    }
}

coded_enum! {
    /// Faults the board reports (unsolicited `Fault` frames, and bit `code` of `Status::faults`).
    pub enum FaultCode {
        EStop = 1 => ("EStop", "Emergency stop input asserted."),
        LimitSwitch = 2 => ("LimitSwitch", "A hardware limit switch tripped."),
        SoftLimit = 3 => ("SoftLimit", "An axis reached its soft limit."),
        QueueUnderrun = 4 => ("QueueUnderrun", "The queue ran dry while moving: a segment ended with no successor, or event blocks came late."),
        TickOverrun = 5 => ("TickOverrun", "The DDA tick interrupt missed its deadline."),
        LinkLost = 6 => ("LinkLost", "No valid frame from the host within the link timeout."),
        ConfigMissing = 7 => ("ConfigMissing", "Motion requested before a valid configuration was set."),
        SensorFault = 8 => ("SensorFault", "A sensor reading is out of range or missing."),
        ForceSaturated = 9 => ("ForceSaturated", "A force channel sits at the ADC's end of range."),
        ForceStuck = 10 => ("ForceStuck", "A force channel has not changed while the tool cuts."),
        ForceTrip = 11 => ("ForceTrip", "Cutting force above the trip level."),
        SpindleStopped = 12 => ("SpindleStopped", "The spindle stopped or slowed below its minimum during a cut."),
        EncoderIndex = 13 => ("EncoderIndex", "Encoder counts between index pulses differ from counts per revolution."),
        ResolverLoss = 14 => ("ResolverLoss", "Resolver sin/cos amplitude out of range (signal lost)."),
        ZSlideLimit = 15 => ("ZSlideLimit", "The Z-slide command needs more speed or acceleration than the slide has."),
        WireStall = 16 => ("WireStall", "The wire stayed stalled through the whole retrace distance."),
        FollowingError = 17 => ("FollowingError", "Measured position too far from the commanded one."),
        HomingFailed = 18 => ("HomingFailed", "A homing switch was not found within the axis's travel, or did not release on back-off."),
        ConfigCorrupt = 19 => ("ConfigCorrupt", "The stored configuration is unusable (CRC, version or validation failed): safe defaults until a valid configuration is set."),
        WatchdogReset = 20 => ("WatchdogReset", "The board restarted because its watchdog expired (the tick or the control task stopped running); any job was lost."),
        SegmentRejected = 21 => ("SegmentRejected", "The board refused a queued segment when preparing it for the DDA although the queue had accepted it: the job stopped, positions kept."),
        BoardSetup = 22 => ("BoardSetup", "A board peripheral refused its configuration at start-up (the spindle encoder timer): jobs that need it cannot run; check the board and restart it."),
        TickRate = 23 => ("TickRate", "The stored tick rate is not one this board's timer can make: safe defaults until a configuration with a supported rate is set."),
        Panicked = 24 => ("Panicked", "The firmware stopped on an internal error and restarted; `motionctl status` and the boot log name the source location. Any job was lost."),
        ProbeInitial = 25 => ("ProbeInitial", "A probe move (G38.x) started with the probe already in the state that ends it (in contact for G38.2/G38.3, open for G38.4/G38.5; grbl ALARM:4): nothing moved."),
        ProbeFail = 26 => ("ProbeFail", "A G38.2 or G38.4 probe move ended without the probe changing state (no contact within travel; grbl ALARM:5)."),
    }
}

impl FaultCode {
    /// This fault's bit in `Status::faults` (bit n is fault code n; bit 0 is unused).
    pub const fn bit(self) -> u32 {
        1 << (self as u8 as u32 % 32)
    }
}

impl SegmentReason {
    /// The reason and the axis it concerns, if any.
    pub const fn from_error(e: SegmentError) -> (SegmentReason, Option<u8>) {
        match e {
            SegmentError::Duration => (SegmentReason::Duration, None),
            SegmentError::AxisRate { axis } => (SegmentReason::AxisRate, Some(axis)),
            SegmentError::UnusedAxis { axis } => (SegmentReason::UnusedAxis, Some(axis)),
            SegmentError::JunctionRate => (SegmentReason::JunctionRate, None),
            SegmentError::Accel => (SegmentReason::Accel, None),
            SegmentError::Empty => (SegmentReason::Empty, None),
        }
    }
}

/// Renders one code table as Markdown.
pub fn write_table(
    out: &mut impl core::fmt::Write,
    table: &[(u8, &str, &str)],
) -> core::fmt::Result {
    out.write_str("| Code | Name | Meaning |\n|---:|---|---|\n")?;
    for (code, name, desc) in table {
        writeln!(out, "| {code} | {name} | {desc} |")?;
    }
    Ok(())
}

/// Renders every protocol code table (NAK error codes, segment reasons, fault codes) as Markdown,
/// for the README and `motionctl --help`.
pub fn markdown_table(out: &mut impl core::fmt::Write) -> core::fmt::Result {
    out.write_str("### NAK error codes\n\n")?;
    write_table(out, ErrorCode::TABLE)?;
    out.write_str("\n### InvalidSegment reasons\n\n")?;
    write_table(out, SegmentReason::TABLE)?;
    out.write_str("\n### Fault codes\n\n")?;
    write_table(out, FaultCode::TABLE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check<T: Copy + PartialEq + core::fmt::Debug>(
        table: &[(u8, &str, &str)],
        all: &[T],
        code: fn(T) -> u8,
        from: fn(u8) -> Option<T>,
        name: fn(T) -> &'static str,
    ) {
        assert_eq!(table.len(), all.len());
        for (row, &v) in table.iter().zip(all) {
            assert_eq!(row.0, code(v));
            assert_eq!(row.1, name(v));
            assert_eq!(from(row.0), Some(v));
        }
        let known = (0..=255u8).filter(|&c| from(c).is_some()).count();
        assert_eq!(known, all.len(), "codes are unique");
        assert_eq!(from(0), None, "0 is never a code");
    }

    #[test]
    fn tables_match_enums() {
        check(
            ErrorCode::TABLE,
            ErrorCode::ALL,
            ErrorCode::code,
            ErrorCode::from_code,
            ErrorCode::name,
        );
        check(
            SegmentReason::TABLE,
            SegmentReason::ALL,
            SegmentReason::code,
            SegmentReason::from_code,
            SegmentReason::name,
        );
        check(
            FaultCode::TABLE,
            FaultCode::ALL,
            FaultCode::code,
            FaultCode::from_code,
            FaultCode::name,
        );
        assert!(FaultCode::ALL.iter().all(|f| f.code() < 32));
    }

    #[test]
    fn markdown_lists_every_code() {
        let mut s = String::new();
        markdown_table(&mut s).unwrap();
        for e in ErrorCode::ALL {
            assert!(s.contains(&format!("| {} | {} | {} |", e.code(), e.name(), e.description())));
        }
        assert!(s.contains("| 8 | SensorFault |"));
    }

    #[test]
    fn protocol_doc_has_the_current_tables() {
        let mut s = String::new();
        markdown_table(&mut s).unwrap();
        let doc = include_str!("PROTOCOL.md");
        assert!(
            doc.contains(&s),
            "src/protocol/PROTOCOL.md is out of date; replace its code tables with:\n{s}"
        );
    }
}
