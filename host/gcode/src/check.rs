//! The checks rs274ngc makes on a block before running it (`enhance_block` in
//! interp_internal.cc, `check_items` in interp_check.cc): which words go with which codes, and
//! the motion the block will make.

use crate::block::Block;
use crate::canon::Plane;
use crate::diag::{check, At, Res};
use crate::messages as msg;
use crate::modal::{g, group, is_cycle, mgroup};
use crate::state::Settings;

/// The first axis word of the block (for pointing at it).
fn first_axis(b: &Block) -> At {
    let axes = [b'x', b'y', b'z', b'a', b'b', b'c', b'@', b'^'];
    b.spans
        .iter()
        .filter(|s| s.0 < 256 && axes.contains(&(s.0 as u8)))
        .min_by_key(|s| s.1)
        .map_or(At::Line, |s| At::Letter(s.0 as u8))
}

/// `enhance_block`: decides `motion_to_be` and checks axis words against the codes using them.
pub(crate) fn enhance_block(b: &mut Block, s: &Settings) -> Res<()> {
    if b.polar_flag() {
        let at = At::Letter(if b.radius.is_some() { b'@' } else { b'^' });
        check(s.plane != Plane::XY, "Cannot use polar coordinate except in G17 plane", at)?;
        check(b.x.is_some(), "Cannot specify both polar coordinate and X word", at)?;
        check(b.y.is_some(), "Cannot specify both polar coordinate and Y word", at)?;
    }
    let axis = b.axis_flag();
    let polar = b.polar_flag();
    let ijk = b.i.is_some() || b.j.is_some() || b.k.is_some();
    let mode0 = b.g_modes[group::MODAL_0];
    let mode1 = b.g_modes[group::MOTION];
    let covets = matches!(mode0, g::G10 | g::G28 | g::G30 | g::G52 | g::G92);
    let g0 = At::GGroup(group::MODAL_0);
    let g1 = At::GGroup(group::MOTION);
    if mode1 != -1 {
        if mode1 == g::G80 {
            check((polar || axis) && !covets, msg::CANNOT_USE_AXIS_VALUES_WITH_G80, first_axis(b))?;
            check(polar && mode0 == g::G92, "Polar coordinates can only be used for motion", g0)?;
            check(
                !axis && (mode0 == g::G52 || mode0 == g::G92),
                msg::ALL_AXES_MISSING_WITH_G52_OR_G92,
                g0,
            )?;
        } else {
            check(covets, msg::CANNOT_USE_TWO_AXIS_G_CODES, g0)?;
            let may_have_none = matches!(
                mode1,
                g::G0
                    | g::G1
                    | g::G2
                    | g::G3
                    | g::G5_2
                    | g::G70
                    | g::G71
                    | g::G71_1
                    | g::G71_2
                    | g::G72
                    | g::G72_1
                    | g::G72_2
            );
            check(!axis && !polar && !may_have_none, msg::ALL_AXES_MISSING_WITH_MOTION_CODE, g1)?;
        }
        b.motion_to_be = mode1;
    } else if covets {
        check(polar && mode0 == g::G92, "Polar coordinates can only be used for motion", g0)?;
        check(
            !axis && (mode0 == g::G52 || mode0 == g::G92),
            msg::ALL_AXES_MISSING_WITH_G52_OR_G92,
            g0,
        )?;
    } else if axis || polar {
        let tlo = b.g_modes[group::TOOL_LENGTH];
        check(
            (s.motion_mode == -1 || s.motion_mode == g::G80) && tlo != g::G43_1 && tlo != 432,
            msg::CANNOT_USE_AXIS_VALUES_WITHOUT_G,
            first_axis(b),
        )?;
        if tlo != g::G43_1 {
            b.motion_to_be = s.motion_mode;
        }
    } else if ijk && (s.motion_mode == g::G2 || s.motion_mode == g::G3) {
        b.motion_to_be = s.motion_mode;
    }
    check(
        polar && b.motion_to_be == -1,
        "Polar coordinates can only be used for motion",
        first_axis(b),
    )?;
    Ok(())
}

/// `check_items`: G-codes, M-codes and the other words.
pub(crate) fn check_items(b: &Block, s: &Settings) -> Res<()> {
    check_g_codes(b, s)?;
    check(b.m_count > 4, msg::TOO_MANY_M_CODES, At::Line)?;
    check_other_codes(b)
}

fn check_g_codes(b: &Block, s: &Settings) -> Res<()> {
    let mode0 = b.g_modes[group::MODAL_0];
    let mode1 = b.g_modes[group::MOTION];
    let g0 = At::GGroup(group::MODAL_0);
    match mode0 {
        g::G4 => {
            check(b.p_number == -1.0, msg::DWELL_TIME_MISSING_G4, g0)?;
            check(
                mode1 == g::G2 || mode1 == g::G3,
                "G4 not allowed with G2 or G3 because they both use P",
                g0,
            )?;
        }
        g::G10 => {
            let p = b.p_number;
            let p_int = if p >= 0.0 { (p + 0.5) as i32 } else { (p - 0.5) as i32 };
            let l = b.l_number;
            check(
                !matches!(l, 0 | 1 | 2 | 10 | 11 | 20),
                "Line with G10 does not have L0, L1, L10, L11, L2, or L20",
                g0,
            )?;
            check(
                (p + 0.0001) - p_int as f64 > 0.0002,
                "P value not an integer with G10",
                At::Letter(b'p'),
            )?;
            if (l == 2 || l == 20) && !(0..=9).contains(&p_int) {
                return Err(crate::diag::Fault::new(
                    format!("P value out of range (0-9) with G10 L{l}"),
                    At::Letter(b'p'),
                ));
            }
            if (l == 1 || l == 10 || l == 11) && p_int < 1 {
                return Err(crate::diag::Fault::new(
                    format!("P value out of range with G10 L{l}"),
                    At::Letter(b'p'),
                ));
            }
        }
        g::G5_3 => {
            check(
                mode1 != g::G5_2 && mode1 != -1,
                "Between G5.2 and G5.3 codes, only additional G5.2 codes are allowed.",
                g0,
            )?;
        }
        g::G53 => {
            check(
                b.motion_to_be != g::G0 && b.motion_to_be != g::G1,
                msg::MUST_USE_G0_OR_G1_WITH_G53,
                g0,
            )?;
            let dist = b.g_modes[group::DISTANCE];
            check(
                dist == g::G91 || (dist != g::G90 && !s.absolute),
                msg::CANNOT_USE_G53_INCREMENTAL,
                g0,
            )?;
        }
        _ => {}
    }
    Ok(())
}

fn check_other_codes(b: &Block) -> Res<()> {
    let motion = b.motion_to_be;
    let cc = b.g_modes[group::CUTTER_COMP];
    let m5 = b.m_modes[mgroup::IO];
    let m7 = b.m_modes[mgroup::SPINDLE];
    let m9 = b.m_modes[mgroup::OVERRIDE];
    let mode0 = b.g_modes[group::MODAL_0];
    let g7x =
        matches!(motion, g::G70 | g::G71 | g::G71_1 | g::G71_2 | g::G72 | g::G72_1 | g::G72_2);
    if b.a.is_some() {
        check(is_cycle(motion), msg::CANNOT_PUT_AN_A_IN_CYCLE, At::Letter(b'a'))?;
    }
    if b.b.is_some() {
        check(is_cycle(motion), msg::CANNOT_PUT_A_B_IN_CYCLE, At::Letter(b'b'))?;
    }
    if b.c.is_some() {
        check(is_cycle(motion), msg::CANNOT_PUT_A_C_IN_CYCLE, At::Letter(b'c'))?;
    }
    if b.d.is_some() {
        check(
            !matches!(cc, g::G41 | g::G42 | g::G41_1 | g::G42_1)
                && !g7x
                && b.g_modes[group::SPINDLE_MODE] != g::G96,
            "D word with no G41, G41.1, G42, G42.1, G71, G71.1, G71.2 or G96 to use it",
            At::Letter(b'd'),
        )?;
    }
    if b.dollar.is_some() {
        check(
            !matches!(motion, g::G76 | g::G33 | g::G33_1 | g::G95 | g::G96 | g::G97)
                && !matches!(m7, 3 | 4 | 5 | 19)
                && m9 != 51
                && b.s.is_none(),
            "$ (spindle selection) word with no M3, M4, M5, M19, M51, G33, G33.1, G76, G95, G96 or G97 to use it",
            At::Letter(b'$'),
        )?;
    }
    if b.e.is_some() {
        check(
            !matches!(motion, g::G76 | g::G33 | g::G33_1 | g::G70) && !matches!(m5, 66..=68),
            "E word with no G70, G76, M66, M67 or M68 to use it",
            At::Letter(b'e'),
        )?;
    }
    if b.h_flag {
        let tlo = b.g_modes[group::TOOL_LENGTH];
        check(
            tlo != g::G43 && motion != g::G76 && tlo != g::G43_2,
            "H word with no G43 or G76 to use it",
            At::Letter(b'h'),
        )?;
    }
    if b.i.is_some() {
        check(
            !matches!(
                motion,
                g::G2
                    | g::G3
                    | g::G5
                    | g::G5_1
                    | g::G71
                    | g::G71_1
                    | g::G71_2
                    | g::G72
                    | g::G72_1
                    | g::G72_2
                    | g::G76
                    | g::G87
                    | g::G33_1
            ) && mode0 != g::G10,
            "I word with no G2, G3, G5, G5.1, G10, G33.1, G76, or G87 to use it",
            At::Letter(b'i'),
        )?;
    }
    if b.j.is_some() {
        check(
            !matches!(motion, g::G2 | g::G3 | g::G5 | g::G5_1 | g::G76 | g::G87) && mode0 != g::G10,
            "J word with no G2, G3, G5, G5.1, G10, G76 or G87 to use it",
            At::Letter(b'j'),
        )?;
    }
    if b.k.is_some() {
        check(
            !matches!(motion, g::G2 | g::G3 | g::G33 | g::G33_1 | g::G76 | g::G87),
            "K word with no G2, G3, G33, G33.1, G76, or G87 to use it",
            At::Letter(b'k'),
        )?;
    }
    if b.l_number != -1 {
        let is_m98 = b.o.as_ref().is_some_and(|o| o.kind == crate::state::OKind::M98);
        check(
            !(g::G81..=g::G89).contains(&motion)
                && motion != g::G76
                && motion != g::G5_2
                && motion != g::G73
                && mode0 != g::G10
                && !matches!(cc, g::G41 | g::G41_1 | g::G42 | g::G42_1)
                && m5 != 66
                && !is_m98,
            "L word with no G10, cutter compensation, canned cycle, digital/analog input, M98 or NURBS code",
            At::Letter(b'l'),
        )?;
    }
    if b.p_flag {
        let is_m98 = b.o.as_ref().is_some_and(|o| o.kind == crate::state::OKind::M98);
        check(
            mode0 != g::G10
                && mode0 != g::G4
                && b.g_modes[group::CONTROL] != g::G64
                && !matches!(motion, g::G76 | g::G82 | g::G86 | g::G88 | g::G89 | g::G5 | g::G5_2 | g::G70 | g::G2
                    | g::G3 | g::G74 | g::G84)
                && !matches!(m9, 50..=53)
                && !matches!(m5, 62..=66)
                && m7 != 19
                && !b.user_m
                && !is_m98,
            "P word with no G2 G3 G4 G10 G64 G5 G5.2 G76 G82 G86 G88 G89 or M50 M51 M52 M53 M62 M63 M64 M65 M66 M98 or user M code to use it",
            At::Letter(b'p'),
        )?;
        let p_value = b.p_number.round_ties_even();
        check(
            (motion == g::G2 || motion == g::G3 || m7 == 19)
                && (p_value - b.p_number).abs() > 0.001,
            "P value not an integer with M19 G2 or G3",
            At::Letter(b'p'),
        )?;
        check(
            m7 == 19 && !(0.0..=2.0).contains(&p_value),
            "P value must be 0,1,or 2 with M19",
            At::Letter(b'p'),
        )?;
        check(
            (motion == g::G2 || motion == g::G3) && p_value < 1.0,
            "P value should be 1 or greater with G2 or G3",
            At::Letter(b'p'),
        )?;
    }
    if b.q_number != -1.0 {
        check(
            !matches!(motion, g::G83 | g::G73 | g::G5 | g::G76 | g::G70 | g::G71 | g::G71_1 | g::G71_2 | g::G72
                | g::G72_1 | g::G72_2)
                && !b.user_m
                && !matches!(m5, 66..=68)
                && mode0 != g::G10
                && b.m_modes[mgroup::TOOL] != 61
                && b.g_modes[group::CONTROL] != g::G64
                && m7 != 19,
            "Q word with no G5, G10, G64, G73, G76, G83, M19, M66, M67, M68 or user M code that uses it",
            At::Letter(b'q'),
        )?;
    }
    if let Some(r) = b.r {
        check(
            !matches!(
                motion,
                g::G2
                    | g::G3
                    | g::G76
                    | g::G71
                    | g::G71_1
                    | g::G71_2
                    | g::G72
                    | g::G72_1
                    | g::G72_2
                    | g::G73
                    | g::G74
            ) && !(g::G81..=g::G89).contains(&motion)
                && cc != g::G41_1
                && cc != g::G42_1
                && mode0 != g::G10
                && m7 != 19,
            msg::R_WORD_UNUSED,
            At::Letter(b'r'),
        )?;
        check(
            m7 == 19 && !(0.0..=360.0).contains(&r),
            "R value must be within 0..360 with M19",
            At::Letter(b'r'),
        )?;
    }
    if b.s.is_none() {
        check(
            b.g_modes[group::SPINDLE_MODE] == g::G96,
            msg::S_MISSING_G96,
            At::GGroup(group::SPINDLE_MODE),
        )?;
    }
    if motion == g::G33 || motion == g::G33_1 {
        check(b.k.is_none(), msg::K_MISSING_G33, At::GGroup(group::MOTION))?;
        check(b.f.is_some(), msg::F_USED_WITH_G33, At::Letter(b'f'))?;
    }
    if motion == g::G76 {
        check(b.p_number == -1.0, msg::P_MISSING_G76, At::GGroup(group::MOTION))?;
        check(
            b.i.is_none() || b.j.is_none() || b.k.is_none(),
            msg::IJK_MISSING_G76,
            At::GGroup(group::MOTION),
        )?;
    }
    Ok(())
}
