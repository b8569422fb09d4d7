//! The names messages give the arguments they ask a user to change: the
//! command line's flags, or the Python package's keywords. A library
//! message that tells what to give names it through these, so that each
//! front end's user reads their own words.

/// The names a message gives the arguments it asks to change: the
/// command line's flags, or the Python keywords.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArgNames {
    /// The argument that lowers U_max.
    pub u_max: &'static str,
    /// The argument that lowers the plate's a_max.
    pub a_max: &'static str,
    /// Keyword arguments (`name=value`), not flags (`--name value`).
    pub keywords: bool,
    /// How to ask for the electrovibration display.
    pub electrovibration: &'static str,
    /// How to design with the device file (for what the FE check cannot do).
    pub design_with_file: &'static str,
}

impl ArgNames {
    /// The command line's flags.
    pub const CLI: ArgNames = ArgNames {
        u_max: "--u-max",
        a_max: "--a-max-um",
        keywords: false,
        electrovibration: "--display electrovibration",
        design_with_file: "`haptex voltage --device`",
    };
    /// The Python package's keyword arguments.
    pub const PYTHON: ArgNames = ArgNames {
        u_max: "u_max",
        a_max: "a_max_um",
        keywords: true,
        electrovibration: "display='electrovibration'",
        design_with_file: "haptex.voltage(..., device=...)",
    };

    /// The arguments that choose a carrier of `shape` ("sine", "square",
    /// "none") at `frequency_hz`, as the user gives them.
    pub fn carrier(&self, shape: &str, frequency_hz: f64) -> String {
        let f = crate::num::Num(frequency_hz);
        if self.keywords {
            format!("carrier=\"{shape}\", carrier_hz={f}")
        } else {
            format!("--carrier {shape} --carrier-hz {f}")
        }
    }
}
