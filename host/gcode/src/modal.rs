//! G- and M-code numbers and their modal groups (rs274ngc's `_gees` and `_ems` tables).
//!
//! G-codes are held as ten times their number (G38.2 is 382), as rs274ngc does.

/// Modal group slots of a block (rs274ngc's GM_* indices).
pub mod group {
    pub const MODAL_0: usize = 0;
    pub const MOTION: usize = 1;
    pub const PLANE: usize = 2;
    pub const DISTANCE: usize = 3;
    pub const IJK_DISTANCE: usize = 4;
    pub const FEED_MODE: usize = 5;
    pub const UNITS: usize = 6;
    pub const CUTTER_COMP: usize = 7;
    pub const TOOL_LENGTH: usize = 8;
    pub const RETRACT: usize = 10;
    pub const COORD_SYSTEM: usize = 12;
    pub const CONTROL: usize = 13;
    pub const SPINDLE_MODE: usize = 14;
    pub const LATHE_DIAMETER: usize = 15;
    pub const G92_APPLIED: usize = 16;
    pub const COUNT: usize = 17;
}

/// M-code groups (rs274ngc's `m_modes` indices).
pub mod mgroup {
    pub const STOP: usize = 4;
    pub const IO: usize = 5;
    pub const TOOL: usize = 6;
    pub const SPINDLE: usize = 7;
    pub const COOLANT: usize = 8;
    pub const OVERRIDE: usize = 9;
    pub const USER: usize = 10;
    pub const COUNT: usize = 11;
}

/// Ten times a G number, as rs274 keeps it.
pub mod g {
    pub const G0: i32 = 0;
    pub const G1: i32 = 10;
    pub const G2: i32 = 20;
    pub const G3: i32 = 30;
    pub const G4: i32 = 40;
    pub const G5: i32 = 50;
    pub const G5_1: i32 = 51;
    pub const G5_2: i32 = 52;
    pub const G5_3: i32 = 53;
    pub const G7: i32 = 70;
    pub const G8: i32 = 80;
    pub const G10: i32 = 100;
    pub const G17: i32 = 170;
    pub const G17_1: i32 = 171;
    pub const G18: i32 = 180;
    pub const G18_1: i32 = 181;
    pub const G19: i32 = 190;
    pub const G20: i32 = 200;
    pub const G28: i32 = 280;
    pub const G28_1: i32 = 281;
    pub const G30: i32 = 300;
    pub const G30_1: i32 = 301;
    pub const G33: i32 = 330;
    pub const G33_1: i32 = 331;
    pub const G38_2: i32 = 382;
    pub const G38_3: i32 = 383;
    pub const G38_4: i32 = 384;
    pub const G38_5: i32 = 385;
    pub const G40: i32 = 400;
    pub const G41: i32 = 410;
    pub const G41_1: i32 = 411;
    pub const G42: i32 = 420;
    pub const G42_1: i32 = 421;
    pub const G43: i32 = 430;
    pub const G43_1: i32 = 431;
    pub const G43_2: i32 = 432;
    pub const G49: i32 = 490;
    pub const G52: i32 = 520;
    pub const G53: i32 = 530;
    pub const G61: i32 = 610;
    pub const G61_1: i32 = 611;
    pub const G64: i32 = 640;
    pub const G70: i32 = 700;
    pub const G71: i32 = 710;
    pub const G71_1: i32 = 711;
    pub const G71_2: i32 = 712;
    pub const G72: i32 = 720;
    pub const G72_1: i32 = 721;
    pub const G72_2: i32 = 722;
    pub const G73: i32 = 730;
    pub const G74: i32 = 740;
    pub const G76: i32 = 760;
    pub const G80: i32 = 800;
    pub const G81: i32 = 810;
    pub const G82: i32 = 820;
    pub const G83: i32 = 830;
    pub const G84: i32 = 840;
    pub const G85: i32 = 850;
    pub const G86: i32 = 860;
    pub const G87: i32 = 870;
    pub const G88: i32 = 880;
    pub const G89: i32 = 890;
    pub const G90: i32 = 900;
    pub const G90_1: i32 = 901;
    pub const G91: i32 = 910;
    pub const G92: i32 = 920;
    pub const G92_1: i32 = 921;
    pub const G92_2: i32 = 922;
    pub const G93: i32 = 930;
    pub const G94: i32 = 940;
    pub const G95: i32 = 950;
    pub const G96: i32 = 960;
    pub const G97: i32 = 970;
    pub const G98: i32 = 980;
}

/// Every G-code rs274ngc knows, with its modal group.
pub const G_CODES: &[(i32, usize)] = &[
    (0, 1),
    (10, 1),
    (20, 1),
    (30, 1),
    (40, 0),
    (50, 1),
    (51, 1),
    (52, 1),
    (53, 0),
    (70, 15),
    (80, 15),
    (100, 0),
    (170, 2),
    (171, 2),
    (180, 2),
    (181, 2),
    (190, 2),
    (191, 2),
    (200, 6),
    (210, 6),
    (280, 0),
    (281, 0),
    (300, 0),
    (301, 0),
    (330, 1),
    (331, 1),
    (382, 1),
    (383, 1),
    (384, 1),
    (385, 1),
    (400, 7),
    (410, 7),
    (411, 7),
    (420, 7),
    (421, 7),
    (430, 8),
    (431, 8),
    (432, 8),
    (490, 8),
    (520, 0),
    (530, 0),
    (540, 12),
    (550, 12),
    (560, 12),
    (570, 12),
    (580, 12),
    (590, 12),
    (591, 12),
    (592, 12),
    (593, 12),
    (610, 13),
    (611, 13),
    (640, 13),
    (700, 1),
    (710, 1),
    (711, 1),
    (712, 1),
    (720, 1),
    (721, 1),
    (722, 1),
    (730, 1),
    (740, 1),
    (760, 1),
    (800, 1),
    (810, 1),
    (820, 1),
    (830, 1),
    (840, 1),
    (850, 1),
    (860, 1),
    (870, 1),
    (880, 1),
    (890, 1),
    (900, 3),
    (901, 4),
    (910, 3),
    (911, 4),
    (920, 0),
    (921, 16),
    (922, 16),
    (923, 16),
    (930, 5),
    (940, 5),
    (950, 5),
    (960, 14),
    (970, 14),
    (980, 10),
    (990, 10),
];

/// The modal group of a G-code (ten times its number), `None` for an unknown code.
pub fn g_group(code: i32) -> Option<usize> {
    G_CODES.iter().find(|(c, _)| *c == code).map(|&(_, grp)| grp)
}

/// The group of an M-code 0..=199, `None` for an unknown code.
pub fn m_group(m: i32) -> Option<usize> {
    use mgroup::*;
    Some(match m {
        0 | 1 | 2 | 30 | 60 | 99 => STOP,
        3 | 4 | 5 | 19 | 70..=73 => SPINDLE,
        6 | 61 => TOOL,
        7..=9 => COOLANT,
        48..=53 => OVERRIDE,
        62..=68 => IO,
        100..=199 => USER,
        _ => return None,
    })
}

/// G73, G74 and G81..G89: the canned cycles (rs274ngc's `is_a_cycle`).
pub fn is_cycle(motion: i32) -> bool {
    motion == g::G73 || motion == g::G74 || (g::G81..=g::G89).contains(&motion)
}

/// `G38.2` for 382, `G1` for 10.
pub fn g_name(code: i32) -> String {
    if code % 10 != 0 {
        format!("G{}.{}", code / 10, code % 10)
    } else {
        format!("G{}", code / 10)
    }
}
