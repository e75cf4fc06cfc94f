//! Length units of the commands that work in inches (turning and polar contouring, the theses'
//! unit and, for turning, the board's: X in inches Q24, Z in inches Q32): `--units in|mm`, so a
//! user may give and read everything in mm.

/// The unit of every length a command takes and prints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Units {
    #[default]
    In,
    Mm,
}

/// Millimetres per inch (exact by definition).
pub const MM_PER_IN: f64 = 25.4;

impl Units {
    /// A length in this unit, in inches.
    pub fn to_in(self, v: f64) -> f64 {
        match self {
            Units::In => v,
            Units::Mm => v / MM_PER_IN,
        }
    }

    /// A length in inches, in this unit.
    pub fn from_in(self, v_in: f64) -> f64 {
        match self {
            Units::In => v_in,
            Units::Mm => v_in * MM_PER_IN,
        }
    }

    /// The unit's name as printed and used in column and JSON key names: `in` or `mm`.
    pub fn name(self) -> &'static str {
        match self {
            Units::In => "in",
            Units::Mm => "mm",
        }
    }

    /// The millionth of the unit for small figures (part errors): `uin` or `um` (a thousandth
    /// of a mm), and how many of them make one inch.
    pub fn micro(self) -> (&'static str, f64) {
        match self {
            Units::In => ("uin", 1e6),
            Units::Mm => ("um", MM_PER_IN * 1e3),
        }
    }

    /// The nanounit (`nin`, `nm`) and how many make one inch: for part errors far below a
    /// microunit.
    pub fn nano(self) -> (&'static str, f64) {
        match self {
            Units::In => ("nin", 1e9),
            Units::Mm => ("nm", MM_PER_IN * 1e6),
        }
    }

    /// A small length (inches) in the micro- or, below 0.01 of it, the nanounit: `0.241 uin`,
    /// `3.2 nm`.
    pub fn small(self, v_in: f64) -> String {
        let (mu, per_mu) = self.micro();
        let (nu, per_nu) = self.nano();
        if (v_in * per_mu).abs() >= 0.01 || v_in == 0.0 {
            format!("{:.4} {mu}", v_in * per_mu)
        } else {
            format!("{:.4} {nu}", v_in * per_nu)
        }
    }

    /// Decimals that print a coefficient to well below the board's resolution (2^-32 in).
    pub fn coefficient_decimals(self) -> usize {
        match self {
            Units::In => 12,
            Units::Mm => 11,
        }
    }

    /// Decimals for X and the table step.
    pub fn x_decimals(self) -> usize {
        match self {
            Units::In => 6,
            Units::Mm => 5,
        }
    }
}
