//! `haptex force-curve`: the frequency-dependent force model's gain on
//! eq. (3) against the carrier frequency, for a sine, a square wave and a
//! direct drive (docs/physics.md, "Frequency-dependent force").

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use haptex_core::frequency::FingerCircuit;
use haptex_core::io::write_csv_row;
use haptex_core::num::Num;
use haptex_core::plot::{Figure, Panel};
use haptex_core::ranges;

use crate::args::{LayerStackArgs, Output, in_range};

/// Tabulate (and plot) the electrovibration force per V^2 of the finger
/// circuit against the carrier frequency, as a gain on eq. (3).
///
/// Writes `f_hz,gain_sine,gain_square,gain_direct,fe_per_v2_sine_n_per_mm2`
/// on a logarithmic frequency grid: G = 1 is eq. (3); the last column is
/// the mean force per contact area per V^2 (RMS) of a sine carrier. The
/// stratum corneum's corner frequency 1/(2 pi eps0 eps_sc rho_sc) goes to
/// stderr.
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  haptex force-curve --rho-sc-ohm-m 1e5 --gap-um 0 -o gain.csv --png gain.png\n  \
                  haptex voltage --profile P.csv --force-model circuit --rho-sc-ohm-m 1e5 --gap-um 0 \
                  --carrier sine --carrier-hz 100 -o U.csv")]
pub struct ForceCurveArgs {
    /// DC resistivity of the stratum corneum, rho_sc in ohm m.
    #[arg(long, value_parser = in_range(ranges::RHO_SC_OHM_M))]
    rho_sc_ohm_m: f64,
    /// Air gap between skin and display, g in um (0: none).
    #[arg(long, value_parser = in_range(ranges::GAP_UM))]
    gap_um: f64,
    #[command(flatten)]
    stack: LayerStackArgs,
    /// Lowest carrier frequency in Hz.
    #[arg(long, default_value_t = 1.0, value_parser = in_range(ranges::CARRIER_HZ))]
    from_hz: f64,
    /// Highest carrier frequency in Hz.
    #[arg(long, default_value_t = 1e5, value_parser = in_range(ranges::CARRIER_HZ))]
    to_hz: f64,
    /// Frequencies on the logarithmic grid.
    #[arg(long, default_value_t = 121, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    points: u32,
    /// Output CSV (default: stdout). Written atomically.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// Also plot the three gains against log10 f to this PNG.
    #[arg(long, value_name = "FILE.png")]
    png: Option<PathBuf>,
}

pub fn run(args: ForceCurveArgs) -> anyhow::Result<()> {
    if args.to_hz <= args.from_hz {
        bail!("--to-hz {} must be above --from-hz {}", Num(args.to_hz), Num(args.from_hz));
    }
    let stack = args.stack.stack();
    stack.validate()?;
    let circuit = FingerCircuit { rho_sc_ohm_m: args.rho_sc_ohm_m, gap_um: args.gap_um };
    circuit.validate()?;
    let n = args.points as usize;
    let (l0, l1) = (args.from_hz.log10(), args.to_hz.log10());
    let f: Vec<f64> = (0..n).map(|i| 10f64.powf(l0 + (l1 - l0) * i as f64 / (n - 1) as f64)).collect();
    let sine: Vec<f64> = f.iter().map(|&f| circuit.gain(&stack, f)).collect();
    let square: Vec<f64> = f.iter().map(|&f| circuit.square_gain(&stack, f)).collect();
    let direct = circuit.gain(&stack, 0.0);
    // Eq. (3) per mm^2 and V^2: eps0 / (2 (a + b)(d_sc + d_i)) in N/mm^2.
    let eq3 = haptex_core::electrovibration::electrostatic_force_n(&stack, 1.0, 1.0);
    let output = Output::new(args.output);
    output.write(|w| {
        writeln!(w, "# haptex force-curve: {}; G = 1 is eq. (3)", circuit.describe(&stack))?;
        writeln!(w, "f_hz,gain_sine,gain_square,gain_direct,fe_per_v2_sine_n_per_mm2")?;
        for i in 0..n {
            write_csv_row(w, &[f[i], sine[i], square[i], direct, sine[i] * eq3])?;
        }
        Ok(())
    })?;
    if let Some(path) = &args.png {
        let x: Vec<f64> = f.iter().map(|f| f.log10()).collect();
        let title = format!(
            "force gain on eq. (3): rho_sc = {} ohm m, g = {} um, corner {:.3e} Hz",
            Num(circuit.rho_sc_ohm_m),
            Num(circuit.gap_um),
            circuit.corner_hz(&stack)
        );
        Figure::new(title)
            .panel(
                Panel::new("log10 carrier frequency (Hz)", "G = Fe / Fe_eq3")
                    .line("sine carrier", &x, &sine)
                    .line("square carrier", &x, &square)
                    .line("direct drive (DC)", &x, &vec![direct; n])
                    .line("eq. (3)", &x, &vec![1.0; n]),
            )
            .write_png(path)?;
    }
    eprintln!("{}", circuit.describe(&stack));
    eprintln!(
        "G: direct drive {:.4}, sine at {} Hz {:.4}, at {} Hz {:.4}",
        direct,
        Num(f[0]),
        sine[0],
        Num(f[n - 1]),
        sine[n - 1]
    );
    if let Some(path) = output.path() {
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.png {
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
