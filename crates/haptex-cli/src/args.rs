//! Flag value parsers and output helpers shared by the subcommands.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use haptex_core::calibration::force_fit::carrier_name;
use haptex_core::electrovibration::LayerStack;
use haptex_core::ranges;

/// Parses a positive, finite number (for physical constants and limits).
pub fn positive(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(format!("must be a positive finite number, got {text}"))
    }
}

/// Parses a finite number >= 0 (a length that may be zero).
pub fn non_negative(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
    if value.is_finite() && value >= 0.0 { Ok(value) } else { Err(format!("must be a finite number >= 0, got {text}")) }
}

/// A flag parser for a parameter with an accepted range (the table of
/// [`haptex_core::ranges`], shared with the web API): a finite number in
/// (0, max].
pub fn in_range(range: haptex_core::ranges::Range) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |text: &str| {
        let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
        range.check(value).map_err(|e| e.to_string())
    }
}

/// Where a command writes its main output: a file (written atomically) or stdout.
#[derive(Debug, Clone)]
pub enum Output {
    Stdout,
    File(PathBuf),
}

impl Output {
    pub fn new(path: Option<PathBuf>) -> Self {
        match path {
            Some(p) if p.as_os_str() != "-" => Output::File(p),
            _ => Output::Stdout,
        }
    }

    pub fn path(&self) -> Option<&Path> {
        match self {
            Output::File(p) => Some(p),
            Output::Stdout => None,
        }
    }

    /// Writes the content produced by `fill`.
    pub fn write<F>(&self, fill: F) -> anyhow::Result<()>
    where
        F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
    {
        match self {
            Output::File(path) => Ok(haptex_core::io::write_atomic(path, fill)?),
            Output::Stdout => {
                let stdout = std::io::stdout();
                let mut lock = std::io::BufWriter::with_capacity(1 << 16, stdout.lock());
                fill(&mut lock).and_then(|()| lock.flush()).context("cannot write to stdout")
            }
        }
    }
}

/// Reads a profile from a path, or from stdin when the path is `-`.
pub fn read_profile(path: &Path) -> anyhow::Result<haptex_core::FrictionProfile> {
    use haptex_core::FrictionProfile;
    Ok(if path.as_os_str() == "-" {
        FrictionProfile::read_csv(std::io::stdin().lock(), "<stdin>")?
    } else {
        FrictionProfile::read_csv_file(path)?
    })
}

pub use haptex_core::io::shipped_data;

/// The dielectric layers of eq. (3), as flags (defaults: the paper's Fig. 2).
#[derive(Debug, Clone, clap::Args)]
pub struct LayerStackArgs {
    /// Relative permittivity of the stratum corneum, eps_sc.
    #[arg(long, default_value_t = LayerStack::PAPER.eps_sc, value_parser = in_range(ranges::EPS_SC))]
    pub eps_sc: f64,
    /// Relative permittivity of the display insulator, eps_i.
    #[arg(long, default_value_t = LayerStack::PAPER.eps_i, value_parser = in_range(ranges::EPS_I))]
    pub eps_i: f64,
    /// Stratum corneum thickness d_sc in mm.
    #[arg(long, default_value_t = LayerStack::PAPER.d_sc_mm, value_parser = in_range(ranges::D_SC_MM))]
    pub d_sc_mm: f64,
    /// Insulator thickness d_i in mm.
    #[arg(long, default_value_t = LayerStack::PAPER.d_i_mm, value_parser = in_range(ranges::D_I_MM))]
    pub d_i_mm: f64,
}

impl LayerStackArgs {
    pub fn stack(&self) -> LayerStack {
        LayerStack { d_sc_mm: self.d_sc_mm, eps_sc: self.eps_sc, d_i_mm: self.d_i_mm, eps_i: self.eps_i }
    }
}

/// The FE finger flag (`--model`): the 2D plane-strain cross-section or
/// the 3D fingertip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelArg {
    #[value(name = "2d")]
    TwoD,
    #[value(name = "3d")]
    ThreeD,
}

/// `--direction-deg` of the 3D finger: a finite angle from -360 to 360
/// degrees, or the flag's error.
pub fn direction_deg(given: Option<f64>) -> anyhow::Result<f64> {
    let direction = given.unwrap_or(0.0);
    if !haptex_fem::solid3d::slide::is_direction(direction) {
        anyhow::bail!("--direction-deg {direction} must be a finite angle from -360 to 360 degrees");
    }
    Ok(direction)
}

/// The FE mesh resolution flag (`--mesh`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum MeshArg {
    Coarse,
    Default,
    Fine,
    ExtraFine,
}

impl MeshArg {
    pub fn resolution(self) -> haptex_fem::finger::Resolution {
        use haptex_fem::finger::Resolution;
        match self {
            MeshArg::Coarse => Resolution::Coarse,
            MeshArg::Default => Resolution::Default,
            MeshArg::Fine => Resolution::Fine,
            MeshArg::ExtraFine => Resolution::ExtraFine,
        }
    }
}

/// The FE tissue model flag (`--material`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum MaterialArg {
    Elastic,
    Viscoelastic,
}

impl MaterialArg {
    pub fn viscoelastic(self) -> bool {
        matches!(self, MaterialArg::Viscoelastic)
    }
}

/// The carrier waveform flag (`--carrier`), shared by `haptex play` and
/// the frequency-dependent force model of `haptex voltage`.
#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum CarrierArg {
    Sine,
    Square,
    None,
}

impl CarrierArg {
    pub fn shape(self) -> haptex_core::signal::CarrierShape {
        use haptex_core::signal::CarrierShape;
        match self {
            CarrierArg::Sine => CarrierShape::Sine,
            CarrierArg::Square => CarrierShape::Square,
            CarrierArg::None => CarrierShape::None,
        }
    }
}

/// Which law turns voltage into electrostatic force (`haptex voltage`).
#[derive(Debug, Clone, clap::Args)]
pub struct ForceModelArgs {
    /// eq3: the paper's eq. (3), independent of the carrier (default).
    /// circuit: eq. (3) times the gain of a finger-display circuit (a leaky
    /// stratum corneum and an air gap, docs/physics.md) for the carrier
    /// that will be played; needs --rho-sc-ohm-m and --gap-um, and the
    /// file says which carrier it was designed for (`haptex play` refuses
    /// another).
    #[arg(long, value_enum, default_value_t = ForceModelArg::Eq3)]
    pub force_model: ForceModelArg,
    /// Circuit model: DC resistivity of the stratum corneum, rho_sc in ohm m.
    #[arg(long, value_parser = in_range(ranges::RHO_SC_OHM_M))]
    pub rho_sc_ohm_m: Option<f64>,
    /// Circuit model: air gap between skin and display, g in um (0: none).
    #[arg(long, value_parser = in_range(ranges::GAP_UM))]
    pub gap_um: Option<f64>,
    /// Circuit model or --device: the carrier the design will be played
    /// with (as `haptex play --carrier`). Default sine.
    #[arg(long, value_enum)]
    pub carrier: Option<CarrierArg>,
    /// Circuit model or --device: the carrier frequency in Hz (as
    /// `haptex play --carrier-hz`). Default 1000.
    #[arg(long, value_name = "F", value_parser = in_range(ranges::CARRIER_HZ))]
    pub carrier_hz: Option<f64>,
}

impl ForceModelArgs {
    /// The carrier the design will be played on: --carrier and
    /// --carrier-hz, default a 1 kHz sine.
    pub fn carrier(&self) -> haptex_core::signal::Carrier {
        carrier_of(self.carrier, self.carrier_hz)
    }
}

/// The carrier of `--carrier` and `--carrier-hz` given as options:
/// default a 1 kHz sine.
pub fn carrier_of(shape: Option<CarrierArg>, frequency_hz: Option<f64>) -> haptex_core::signal::Carrier {
    use haptex_core::signal::Carrier;
    Carrier {
        shape: shape.unwrap_or(CarrierArg::Sine).shape(),
        frequency_hz: frequency_hz.unwrap_or(Carrier::DEFAULT.frequency_hz),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum ForceModelArg {
    Eq3,
    Circuit,
}

impl ForceModelArgs {
    /// The force model the flags give, refusing circuit flags with eq. (3).
    pub fn model(&self) -> anyhow::Result<haptex_core::frequency::ForceModel> {
        use haptex_core::frequency::{FingerCircuit, ForceModel};
        if self.force_model == ForceModelArg::Eq3 {
            for (given, flag) in [
                (self.rho_sc_ohm_m.is_some(), "--rho-sc-ohm-m"),
                (self.gap_um.is_some(), "--gap-um"),
                (self.carrier.is_some(), "--carrier"),
                (self.carrier_hz.is_some(), "--carrier-hz"),
            ] {
                if given {
                    anyhow::bail!(
                        "{flag} is for the frequency-dependent force model: give --force-model circuit, or a \
                         device file (--device FILE) measured on that carrier (eq. 3, the default, does not depend on \
                         the carrier)"
                    );
                }
            }
            return Ok(ForceModel::Eq3);
        }
        let (Some(rho_sc_ohm_m), Some(gap_um)) = (self.rho_sc_ohm_m, self.gap_um) else {
            anyhow::bail!(
                "--force-model circuit needs --rho-sc-ohm-m (the stratum corneum's DC resistivity) and --gap-um (the \
                 air gap, 0 for none): haptex has no default for either, measure or choose them (docs/physics.md)"
            );
        };
        let circuit = FingerCircuit { rho_sc_ohm_m, gap_um };
        circuit.validate()?;
        Ok(ForceModel::Circuit { circuit, carrier: self.carrier() })
    }
}

/// The friction display and its ultrasonic plate, shared by `haptex
/// voltage` and `haptex check`.
#[derive(Debug, Clone, clap::Args)]
pub struct DisplayArgs {
    /// The friction display: electrovibration (eq. 8, raises friction
    /// above mu_HD), ultrasonic (vibration amplitude, lowers it below
    /// mu_HD) or combined (both, shared by --strategy).
    #[arg(long, value_enum, default_value_t = DisplayArg::Electrovibration)]
    pub display: DisplayArg,
    /// Combined display: how the target is shared. split: the plate below
    /// mu_HD, the voltage above (least drive); bias: a constant amplitude
    /// lowering the baseline to the profile's minimum, the voltage renders
    /// the rest; weighted: per point, the least (U/U_max)^2 + weight
    /// ((rho(a) - rho_bias)/(1 - rho_bias))^2 (docs/physics.md). Default split.
    #[arg(long, value_enum)]
    pub strategy: Option<StrategyArg>,
    /// With --strategy weighted: the weight of the ultrasonic term (0 is
    /// split, large approaches bias; 1 weighs full voltage against the
    /// vibration fully off). Default 1.
    #[arg(long, value_parser = in_range(ranges::STRATEGY_WEIGHT))]
    pub weight: Option<f64>,
    /// Ultrasonic display: the plate's calibration, CSV
    /// `amplitude_um,relative_friction` (docs/file-formats.md). Without
    /// it, a literature default stands in (a placeholder, said in every
    /// output).
    #[arg(long, value_name = "FILE")]
    pub ultrasonic_calibration: Option<PathBuf>,
    /// Ultrasonic display: the highest vibration amplitude a_max in um
    /// (peak). Default: the calibration's last amplitude, or 2.3 um for
    /// the literature default; never beyond either.
    #[arg(long, value_parser = in_range(ranges::A_MAX_UM))]
    pub a_max_um: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum DisplayArg {
    Electrovibration,
    Ultrasonic,
    Combined,
}

#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum StrategyArg {
    Split,
    Bias,
    Weighted,
}

impl DisplayArgs {
    /// Refuses the ultrasonic flags on the electrovibration display.
    pub fn refuse_display_flags(&self) -> anyhow::Result<()> {
        for (given, flag) in [
            (self.strategy.is_some(), "--strategy"),
            (self.weight.is_some(), "--weight"),
            (self.ultrasonic_calibration.is_some(), "--ultrasonic-calibration"),
            (self.a_max_um.is_some(), "--a-max-um"),
        ] {
            if given {
                anyhow::bail!("{flag} is for an ultrasonic or combined display: give --display ultrasonic or combined");
            }
        }
        Ok(())
    }

    /// The ultrasonic plate: the device file's (a_max at most its own),
    /// the calibration given, or the literature default (a placeholder).
    pub fn ultrasonic(
        &self,
        device_file: Option<&DesignDevice>,
    ) -> anyhow::Result<haptex_core::ultrasonic::UltrasonicDevice> {
        use haptex_core::ultrasonic::{Calibration, UltrasonicDevice};
        if let Some(file) = device_file {
            return Ok(file.ultrasonic(self.a_max_um)?);
        }
        Ok(match &self.ultrasonic_calibration {
            Some(path) => UltrasonicDevice::calibrated(Calibration::read_csv_file(path)?, self.a_max_um)?,
            None => UltrasonicDevice::literature_default(self.a_max_um)?,
        })
    }

    /// The combined display's strategy (None for the other displays),
    /// refusing --strategy and --weight where they do not apply.
    pub fn strategy(&self) -> anyhow::Result<Option<haptex_core::combined::Strategy>> {
        use haptex_core::combined::Strategy;
        if self.display != DisplayArg::Combined && (self.strategy.is_some() || self.weight.is_some()) {
            anyhow::bail!("--strategy and --weight share a target between two channels: give --display combined");
        }
        if self.weight.is_some() && self.strategy != Some(StrategyArg::Weighted) {
            anyhow::bail!("--weight is the weighted strategy's: give --strategy weighted");
        }
        if self.display != DisplayArg::Combined {
            return Ok(None);
        }
        Ok(Some(match self.strategy.unwrap_or(StrategyArg::Split) {
            StrategyArg::Split => Strategy::Split,
            StrategyArg::Bias => Strategy::Bias,
            StrategyArg::Weighted => Strategy::Weighted { weight: self.weight.unwrap_or(1.0) },
        }))
    }
}

/// The finger model of `--finger FILE`, or the shipped one.
pub fn finger_model(path: Option<&Path>) -> anyhow::Result<haptex_fem::finger::FingerModel> {
    Ok(match path {
        Some(path) => haptex_fem::finger::FingerModel::read(path)?,
        None => haptex_fem::finger::FingerModel::default_model(),
    })
}

/// A calibrated display's device file (`--device FILE`, written by
/// `haptex calibrate`; docs/file-formats.md, "Device file"), on `haptex
/// voltage`, `check`, `play` and `map voltage`. `--device-file` is the
/// same flag under the name `haptex live` and `haptex serve` give it
/// (their `--device` is the audio output).
#[derive(Debug, Clone, clap::Args)]
pub struct DeviceFileArgs {
    /// The display's device file (TOML, `haptex calibrate`): mu_HD, the
    /// layer stack, the force coefficient (eq. 3 on each measured carrier,
    /// or the circuit model on any carrier) and U_max come from it, so the
    /// flags that set them are refused with it. --u-max may lower U_max
    /// (a lower limit is safe), never raise it. Every output says which
    /// device file (and its SHA-256) designed it.
    #[arg(long = "device", visible_alias = "device-file", id = "device_file", value_name = "FILE")]
    pub device_file: Option<PathBuf>,
}

impl DeviceFileArgs {
    /// The device file, read and checked, if one was given.
    pub fn read(&self) -> anyhow::Result<Option<DesignDevice>> {
        self.device_file.as_deref().map(read_device_file).transpose()
    }
}

/// For a command's `mut_args`: the arguments named `names` (what a device
/// file sets) conflict with `--device`, each refused by its own name.
pub fn set_by_device_file(names: &'static [&'static str]) -> impl FnMut(clap::Arg) -> clap::Arg {
    move |arg| {
        if names.contains(&arg.get_id().as_str()) { arg.conflicts_with("device_file") } else { arg }
    }
}

/// The access token of a served page (`haptex serve`, `haptex live --ws`):
/// given, read from a file, or from $HAPTEX_TOKEN.
#[derive(Debug, Clone, Default, PartialEq, clap::Args)]
pub struct TokenArgs {
    /// The access token requests must carry (16 to 256 letters, digits,
    /// '-', '.', '_', '~'). Default: $HAPTEX_TOKEN, else a random one
    /// where one is needed, printed in the address to open. On a shared
    /// machine prefer --token-file or $HAPTEX_TOKEN: a command line is
    /// visible to other users.
    #[arg(long, value_name = "TOKEN", conflicts_with = "token_file")]
    pub token: Option<String>,
    /// Read the access token from this file (its first line).
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
}

impl TokenArgs {
    /// The token given by --token, --token-file or $HAPTEX_TOKEN, and where
    /// it came from (to name it without printing it).
    pub fn given(&self) -> anyhow::Result<Option<(haptex_server::access::Token, String)>> {
        use haptex_server::access::Token;
        if let Some(text) = &self.token {
            let token = Token::new(text).map_err(|e| anyhow::anyhow!("--token: {e}"))?;
            return Ok(Some((token, "--token".to_string())));
        }
        if let Some(path) = &self.token_file {
            let text =
                std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("--token-file {}: {e}", path.display()))?;
            let first = text.lines().next().unwrap_or("");
            let token =
                Token::new(first).map_err(|e| anyhow::anyhow!("--token-file {}, line 1: {e}", path.display()))?;
            return Ok(Some((token, format!("--token-file {}", path.display()))));
        }
        match std::env::var("HAPTEX_TOKEN") {
            Ok(text) => {
                let token = Token::new(&text).map_err(|e| anyhow::anyhow!("$HAPTEX_TOKEN: {e}"))?;
                Ok(Some((token, "$HAPTEX_TOKEN".to_string())))
            }
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(_)) => anyhow::bail!("$HAPTEX_TOKEN: not valid UTF-8"),
        }
    }

    /// `?token=...` for the address to open: the token itself when it was
    /// made here (the only way to learn it), else a placeholder naming
    /// where it came from.
    pub fn query(token: &haptex_server::access::Token, given: Option<&str>) -> String {
        match given {
            None => format!("?token={}", token.expose()),
            Some(source) => format!("?token=<the token of {source}>"),
        }
    }
}

/// `--device-file FILE`: [`DeviceFileArgs`] for `haptex live` and `haptex
/// serve`, whose `--device` names the audio output.
#[derive(Debug, Clone, PartialEq, clap::Args)]
pub struct DeviceFileLongArgs {
    /// The display's device file (TOML, `haptex calibrate`; as --device
    /// FILE of `haptex voltage`, `check`, `play` and `map voltage`).
    #[arg(long = "device-file", id = "device_file", value_name = "FILE")]
    pub device_file: Option<PathBuf>,
}

impl DeviceFileLongArgs {
    /// The device file, read and checked, if one was given.
    pub fn read(&self) -> anyhow::Result<Option<DesignDevice>> {
        self.device_file.as_deref().map(read_device_file).transpose()
    }
}

/// A device file read for a design (haptex-core's, shared with the Python
/// package; its messages name this command line's flags).
pub use haptex_core::calibration::design_device::DesignDevice;

/// Reads and checks the device file at `path`.
pub fn read_device_file(path: &Path) -> anyhow::Result<DesignDevice> {
    Ok(DesignDevice::read(path, haptex_core::arg_names::ArgNames::CLI)?)
}

/// The web application's default device (`haptex serve --device-file`,
/// `haptex recipe run`): the file's device on the default carrier (sine
/// 1000 Hz, the page's playback default), the circuit model's gain on it
/// folded into k (the API's device has no gain: Fe is proportional to k G
/// either way).
pub fn server_default(file: &DesignDevice) -> anyhow::Result<haptex_server::params::DefaultDevice> {
    use haptex_core::signal::Carrier;
    use haptex_server::params::{DefaultDevice, DeviceFileSource};
    let carrier = Carrier::DEFAULT;
    let mut device = file.file.device(&carrier)?;
    device.contact.k_mm2_per_n = ranges::K_MM2_PER_N
        .check(device.contact.k_mm2_per_n * device.force_gain)
        .map_err(|e| anyhow::anyhow!("device file {}: k G on {}: {e}", file.file.path, carrier_name(&carrier)))?;
    device.force_gain = 1.0;
    Ok(DefaultDevice {
        device,
        file: Some(DeviceFileSource {
            path: file.file.path.clone(),
            sha256: file.sha256.clone(),
            describe: file.file.describe(),
            carrier: carrier_name(&carrier),
        }),
    })
}
