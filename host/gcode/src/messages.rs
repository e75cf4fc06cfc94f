//! rs274ngc's own error wording (`rs274ngc_return.hh` and the `_("...")` strings of the
//! interpreter sources), so a message here reads exactly as LinuxCNC prints it.
//!
//! Messages with arguments are built by the functions at the end.

pub const ALL_AXES_MISSING_WITH_G52_OR_G92: &str = "All axes missing with g52 or g92";
pub const ALL_AXES_MISSING_WITH_MOTION_CODE: &str = "All axes missing with motion code";
pub const ARC_RADIUS_TOO_SMALL: &str = "Arc radius too small to reach end point";
pub const ACOS_RANGE: &str = "Argument to acos out of range";
pub const ASIN_RANGE: &str = "Argument to asin out of range";
pub const DIVIDE_BY_ZERO: &str = "Attempt to divide by zero";
pub const NEGATIVE_POWER: &str = "Attempt to raise negative to non integer power";
pub const BAD_FORMAT_UNSIGNED_INTEGER: &str = "Bad format unsigned integer";
pub const CANNOT_CHANGE_AXIS_OFFSETS_WITH_COMP: &str =
    "Cannot change axis offsets with cutter radius comp";
pub const CANNOT_DO_G1_WITH_ZERO_FEED: &str = "Cannot do g1 with zero feed rate";
pub const CANNOT_DO_ZERO_REPEATS: &str = "Cannot do zero repeats of cycle";
pub const CANNOT_MAKE_ARC_WITH_ZERO_FEED: &str = "Cannot make arc with zero feed rate";
pub const CANNOT_PROBE_WITH_COMP: &str = "Cannot probe with cutter radius comp on";
pub const CANNOT_PROBE_WITH_ZERO_FEED: &str = "Cannot probe with zero feed rate";
pub const CANNOT_PUT_A_B_IN_CYCLE: &str = "Cannot put a b in canned cycle";
pub const CANNOT_PUT_A_C_IN_CYCLE: &str = "Cannot put a c in canned cycle";
pub const CANNOT_PUT_AN_A_IN_CYCLE: &str = "Cannot put an a in canned cycle";
pub const CANNOT_TURN_COMP_ON_WHEN_ON: &str = "Cannot turn cutter radius comp on when on";
pub const CANNOT_USE_AXIS_VALUES_WITH_G80: &str = "Cannot use axis values with g80";
pub const CANNOT_USE_AXIS_VALUES_WITHOUT_G: &str =
    "Cannot use axis values without a g code that uses them";
pub const CANNOT_USE_G28_G30_WITH_COMP: &str = "Cannot use g28 or g30 with cutter radius comp";
pub const CANNOT_USE_G53_INCREMENTAL: &str = "Cannot use g53 incremental";
pub const CANNOT_USE_TWO_AXIS_G_CODES: &str = "Cannot use two g codes that both use axis values";
pub const COMMAND_TOO_LONG: &str = "Command too long";
pub const CURRENT_POINT_SAME_AS_END: &str = "Current point same as end point of arc";
pub const DWELL_TIME_MISSING_G4: &str = "Dwell time missing with g4";
pub const DWELL_P_MISSING_G82: &str = "Dwell time p word missing with g82";
pub const DWELL_P_MISSING_G86: &str = "Dwell time p word missing with g86";
pub const DWELL_P_MISSING_G88: &str = "Dwell time p word missing with g88";
pub const DWELL_P_MISSING_G89: &str = "Dwell time p word missing with g89";
pub const EQUAL_SIGN_MISSING: &str = "Equal sign missing in parameter setting";
pub const F_MISSING_INVERSE_ARC: &str = "F word missing with inverse time arc move";
pub const F_MISSING_INVERSE_G1: &str = "F word missing with inverse time g1 move";
pub const FILE_ENDED_NO_PERCENT: &str = "File ended with no percent sign";
pub const FILE_ENDED_NO_PERCENT_OR_END: &str = "File ended with no percent sign or program end";
pub const G_CODE_OUT_OF_RANGE: &str = "G-code out of range";
pub const I_WORD_IN_YZ: &str = "I word given for arc in yz plane";
pub const I_MISSING_G87: &str = "I word missing with g87";
pub const J_WORD_IN_XZ: &str = "J word given for arc in xz plane";
pub const J_MISSING_G87: &str = "J word missing with g87";
pub const K_WORD_IN_XY: &str = "K word given for arc in xy plane";
pub const K_MISSING_G87: &str = "K word missing with g87";
pub const SLASH_MISSING_ATAN: &str = "Slash missing after first atan argument";
pub const LEFT_BRACKET_MISSING_ATAN: &str = "Left bracket missing after slash with atan";
pub const LEFT_BRACKET_MISSING_UNARY: &str = "Left bracket missing after unary operation name";
pub const MUST_USE_G0_OR_G1_WITH_G53: &str = "Must use g0 or g1 with g53";
pub const MIXED_RADIUS_IJK: &str = "Mixed radius ijk format for arc";
pub const NEGATIVE_SQRT: &str = "Negative argument to sqrt";
pub const NEGATIVE_D_WORD: &str = "Negative d word tool radius index used";
pub const NEGATIVE_F_WORD: &str = "Negative f word used";
pub const NEGATIVE_G_CODE: &str = "Negative g code used";
pub const NEGATIVE_H_WORD: &str = "Negative h word used";
pub const NEGATIVE_L_WORD: &str = "Negative l word used";
pub const NEGATIVE_M_CODE: &str = "Negative m code used";
pub const NEGATIVE_OR_ZERO_Q: &str = "Negative or zero q value used";
pub const NEGATIVE_SPINDLE_SPEED: &str = "Negative spindle speed used";
pub const NEGATIVE_TOOL_ID: &str = "Negative tool id (tool not found)";
pub const NESTED_COMMENT: &str = "Nested comment found";
pub const NO_CHARACTERS_REAL_VALUE: &str = "No characters found in reading real value";
pub const NON_INTEGER_VALUE: &str = "Non integer value for integer";
pub const PARAMETER_OUT_OF_RANGE: &str = "Parameter number out of range";
pub const PARAMETER_READONLY: &str = "Parameter is readonly";
pub const Q_MISSING_G83: &str = "Q word missing with g83";
pub const Q_MISSING_G73: &str = "Q word missing with g73";
pub const R_UNSPECIFIED_IN_CYCLE: &str = "R clearance plane unspecified in cycle";
pub const RIJK_ALL_MISSING: &str = "R i j k words all missing for arc";
pub const R_LESS_THAN_X_YZ: &str = "R less than x in cycle in yz plane";
pub const R_LESS_THAN_Y_XZ: &str = "R less than y in cycle in xz plane";
pub const R_LESS_THAN_Z_XY: &str = "R less than z in cycle in xy plane";
pub const R_WORD_UNUSED: &str = "R word with no g code that uses it";
pub const SPINDLE_NOT_TURNING_G86: &str = "Spindle not turning in g86";
pub const SPINDLE_NOT_TURNING_G87: &str = "Spindle not turning in g87";
pub const SPINDLE_NOT_TURNING_G88: &str = "Spindle not turning in g88";
pub const START_TOO_CLOSE_TO_PROBE: &str = "Start point too close to probe point";
pub const TOO_MANY_M_CODES: &str = "Too many m codes on line";
pub const TWO_G_SAME_GROUP: &str = "Two g codes used from same modal group";
pub const TWO_M_SAME_GROUP: &str = "Two m codes used from same modal group";
pub const UNCLOSED_COMMENT: &str = "Unclosed comment found";
pub const UNCLOSED_EXPRESSION: &str = "Unclosed expression";
pub const UNKNOWN_G_CODE: &str = "Unknown g code used";
pub const UNKNOWN_OPERATION: &str = "Unknown operation";
pub const UNKNOWN_WORD_UNARY: &str = "Unknown word where unary operation could be";
pub const X_Y_MISSING_ARC_XY: &str = "X and y words missing for arc in xy plane";
pub const X_Z_MISSING_ARC_XZ: &str = "X and z words missing for arc in xz plane";
pub const Y_Z_MISSING_ARC_YZ: &str = "Y and z words missing for arc in yz plane";
pub const X_UNSPECIFIED_YZ_CYCLE: &str = "X value unspecified in yz plane canned cycle";
pub const Y_UNSPECIFIED_XZ_CYCLE: &str = "Y value unspecified in xz plane canned cycle";
pub const Z_UNSPECIFIED_XY_CYCLE: &str = "Z value unspecified in xy plane canned cycle";
pub const ZERO_OR_NEGATIVE_LN: &str = "Zero or negative argument to ln";
pub const K_MISSING_G33: &str = "K word missing with g33/g33.1";
pub const F_USED_WITH_G33: &str = "F word used with a g33/g33.1";
pub const TOO_MANY_SUB_PARAMETERS: &str = "Too many subroutine parameters";
pub const TOO_MANY_SUB_LEVELS: &str = "Too many subroutine levels";
pub const UNKNOWN_COMMAND_IN_O_LINE: &str = "Unknown control command in o word";
pub const NESTED_SUB_DEFINITION: &str = "Nested subroutine definition";
pub const NOT_IN_SUB_DEFINITION: &str = "Not in subroutine definition";
pub const TXX_MISSING_FOR_M6: &str = "Need tool prepared -Txx- for toolchange";
pub const CANNOT_CHANGE_PLANES_WITH_COMP: &str =
    "Cannot change planes with cutter radius compensation on";
pub const COMP_ONLY_XY_XZ: &str = "Cutter radius compensation allowed only in XY, XZ planes";
pub const P_MISSING_G76: &str = "P word missing with G76";
pub const IJK_MISSING_G76: &str = "I J or K words missing with G76";
pub const NAMED_PARAMETER_NOT_TERMINATED: &str = "Named parameter not terminated";
pub const S_MISSING_G96: &str = "S word missing with G96";
pub const BOTH_DIGITAL_AND_ANALOG: &str =
    "Invalid to select both a digital and an analog input with M66";
pub const ZERO_TIMEOUT_NOT_IMMEDIATE: &str = "Zero timeout with wait type != immediate return";
pub const ANALOG_WAIT_NOT_IMMEDIATE: &str =
    "Can't select analog input with wait type != immediate return";
pub const P_E_MISSING_M66: &str = "Need to have either a valid P or a valid E word with M66";
pub const NAN_RESULT: &str = "Calculation resulted in 'not a number'";
pub const INF_RESULT: &str = "Calculation resulted in 'infinity'";
pub const EXPECTED_HASH: &str = "Expected # reading parameter";
pub const EXPECTED_BRACKET: &str = "Expected ] reading bracketed parameter";
pub const CURRENT_POSITION_WITH_COMP: &str =
    "Cannot read current position with cutter radius compensation on";
pub const UNEXPECTED_AFTER_OWORD: &str = "Unexpected character after O-word";

/// "Multiple x words on one line" and friends (lowercase letter, as rs274 prints it).
pub fn multiple_words(letter: u8) -> String {
    match letter {
        b'$' => "Multiple spindle choice ($) words on one line".into(),
        b'u' | b'v' | b'w' => {
            format!("Multiple {} words on one line", letter.to_ascii_uppercase() as char)
        }
        _ => format!("Multiple {} words on one line", letter as char),
    }
}

/// rs274's "Bad character" message: printable characters up to 'z' quoted, others in octal.
pub fn bad_character(c: u8) -> String {
    if c.is_ascii_graphic() && c <= b'z' {
        format!("Bad character '{}' used", c as char)
    } else {
        format!("Bad character '\\{c:03o}' used")
    }
}

pub fn unknown_m_code(m: i32) -> String {
    format!("Unknown m code used: M{m}")
}

pub fn m_code_greater_than_199(m: i32) -> String {
    format!("M-code greater than 199: M{m}")
}

pub fn named_parameter_not_defined(name: &str) -> String {
    format!("Named parameter #<{name}> not defined")
}

pub fn tool_not_found(tool: i32) -> String {
    format!("Requested tool {tool} not found in the tool table")
}
