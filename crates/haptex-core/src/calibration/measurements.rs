//! The calibration measurements format (docs/calibration.md): friction of
//! a finger sliding steadily on the display under a constant drive, one row
//! per steady sliding segment (or per sample of one).
//!
//! ```text
//! voltage_v,carrier,carrier_hz,amplitude_um,ft_n,fn_n,velocity_mm_s,finger,repetition
//! 0,none,0,0,0.251,0.502,40.1,1,1
//! 80,sine,1000,0,0.316,0.498,39.8,1,1
//! ```
//!
//! - `voltage_v`: the drive's RMS voltage (0: off);
//! - `carrier` (`sine`, `square` or `none`) and `carrier_hz`: the carrier
//!   the voltage was played on (required when any voltage is non-zero;
//!   `carrier_hz` is ignored for `none`, a direct drive);
//! - `amplitude_um`: the ultrasonic plate's peak vibration amplitude (0 or
//!   absent: no vibration);
//! - `ft_n` and `fn_n` (tangential and normal force, N; the friction is
//!   |ft_n| / fn_n, so strokes in either direction may be mixed) or `mu`;
//! - `velocity_mm_s` (optional): the sliding velocity, kept for the report;
//! - `finger` and `repetition` (optional): integer ids. Rows that share a
//!   finger, or failing that a repetition, may share an error (a finger's
//!   own friction, a stroke's moisture); the intervals treat them as one
//!   cluster (`calibration::least_squares`).
//!
//! Every error names the source, the line and the column.

use std::path::Path;

use crate::io::{Category, Table, TableError};
use crate::num::Num;
use crate::ranges;
use crate::signal::{Carrier, CarrierShape};

/// The most rows a measurements file may have (a 10 kHz recording of 100
/// s, as samples): bounds the fit's memory and time, both linear in it.
pub const MAX_ROWS: usize = 1_000_000;

/// The most distinct carriers (shape and frequency) under voltage: eq.
/// (3) fits one force coefficient per carrier, so the fit's parameters, and
/// its cost (the covariance is their square, its inverse their cube), grow
/// with them. A protocol measures a handful (the shipped one seven).
pub const MAX_CARRIERS: usize = 64;

/// The largest measurements file read, in bytes (a million rows of nine
/// fields).
pub const MAX_FILE_BYTES: u64 = 128 << 20;

/// The carrier words of the `carrier` column, in the order the table
/// codes them.
const CARRIERS: [&str; 3] = ["sine", "square", "none"];

/// Measurements that cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasurementsError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error("{path}: {message}")]
    File { path: String, message: String },
}

/// One steady sliding segment (or one sample of it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// The drive's RMS voltage, V.
    pub voltage_v: f64,
    /// The carrier it was played on (`None` when the voltage is 0 and the
    /// file says nothing).
    pub carrier: Option<Carrier>,
    /// The plate's peak vibration amplitude, um.
    pub amplitude_um: f64,
    /// The friction |Ft| / Fn.
    pub mu: f64,
    /// The sliding velocity, mm/s, if given.
    pub velocity_mm_s: Option<f64>,
    /// Finger and repetition ids (0 when the column is absent).
    pub finger: u64,
    pub repetition: u64,
}

/// A measurements file, read and checked.
#[derive(Debug, Clone)]
pub struct Measurements {
    rows: Vec<Measurement>,
    lines: Vec<u64>,
    source_name: String,
    sha256: String,
    has_finger: bool,
    has_repetition: bool,
}

impl Measurements {
    /// Reads measurements from CSV bytes; `source_name` labels errors.
    pub fn from_bytes(bytes: &[u8], source_name: &str) -> Result<Self, MeasurementsError> {
        let carrier = Category { column: "carrier", words: &CARRIERS };
        let table = Table::read_with_categories(bytes, source_name, &[carrier])?;
        let mut m = Self::from_table(&table)?;
        m.sha256 = crate::io::sha256_hex(bytes);
        Ok(m)
    }

    /// Reads a measurements file (at most [`MAX_FILE_BYTES`]).
    pub fn read_file(path: &Path) -> Result<Self, MeasurementsError> {
        let bytes = crate::io::read_file_bounded(path, MAX_FILE_BYTES)
            .map_err(|e| MeasurementsError::File { path: path.display().to_string(), message: e.to_string() })?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }

    fn from_table(table: &Table) -> Result<Self, MeasurementsError> {
        let n = table.n_rows();
        if n == 0 {
            return Err(table.error_at(None, None, "no measurements: the file has a header but no rows").into());
        }
        if n > MAX_ROWS {
            return Err(table
                .error_at(Some(MAX_ROWS), None, format!("more than {MAX_ROWS} rows: average samples into segments"))
                .into());
        }
        let voltage = table.require("voltage_v")?;
        let mu: Vec<f64> = match (table.column("mu"), table.column("ft_n"), table.column("fn_n")) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                return Err(table
                    .error_at(None, Some("mu"), "give the friction as mu or as ft_n and fn_n, not both")
                    .into());
            }
            (Some(mu), None, None) => {
                if let Some(i) = ranges::MU.first_outside(mu) {
                    return Err(table.error_at(Some(i), Some("mu"), ranges::MU.refusal(mu[i]).to_string()).into());
                }
                mu.iter().map(|m| m.abs()).collect()
            }
            (None, Some(ft), Some(fnn)) => {
                for (column, values, range) in [("ft_n", ft, ranges::FT_N), ("fn_n", fnn, ranges::FN_N)] {
                    if let Some(i) = range.first_outside(values) {
                        return Err(table.error_at(Some(i), Some(column), range.refusal(values[i]).to_string()).into());
                    }
                }
                ft.iter().zip(fnn).map(|(t, n)| t.abs() / n).collect()
            }
            (None, _, _) => return Err(table.missing("mu (or ft_n and fn_n)").into()),
        };
        if let Some(i) = ranges::VOLTAGE_V.first_outside(voltage) {
            return Err(table
                .error_at(Some(i), Some("voltage_v"), ranges::VOLTAGE_V.refusal(voltage[i]).to_string())
                .into());
        }
        let zeros = vec![0.0; n];
        let amplitude = table.column("amplitude_um").unwrap_or(&zeros);
        if let Some(i) = ranges::AMPLITUDE_UM.first_outside(amplitude) {
            return Err(table
                .error_at(Some(i), Some("amplitude_um"), ranges::AMPLITUDE_UM.refusal(amplitude[i]).to_string())
                .into());
        }
        let velocity = table.column("velocity_mm_s");
        if let Some(v) = velocity
            && let Some(i) = ranges::VELOCITY_MM_S.first_outside(v)
        {
            return Err(table
                .error_at(Some(i), Some("velocity_mm_s"), ranges::VELOCITY_MM_S.refusal(v[i]).to_string())
                .into());
        }
        let ids = |name: &str| -> Result<Option<Vec<u64>>, MeasurementsError> {
            let Some(values) = table.column(name) else { return Ok(None) };
            let mut out = Vec::with_capacity(values.len());
            for (i, &v) in values.iter().enumerate() {
                if !((0.0..=1e15).contains(&v) && v.fract() == 0.0) {
                    return Err(table
                        .error_at(Some(i), Some(name), format!("an id is a whole number from 0, got {}", Num(v)))
                        .into());
                }
                out.push(v as u64);
            }
            Ok(Some(out))
        };
        let finger = ids("finger")?;
        let repetition = ids("repetition")?;
        let shape = table.column("carrier");
        let hz = table.column("carrier_hz");
        let mut rows = Vec::with_capacity(n);
        let mut carriers = std::collections::HashSet::new();
        for i in 0..n {
            let carrier = match shape {
                None if voltage[i] > 0.0 => {
                    return Err(table
                        .error_at(
                            Some(i),
                            Some("carrier"),
                            format!(
                                "the voltage is {} V but the file has no 'carrier' column: say what the voltage was \
                                 played on (sine, square or none)",
                                Num(voltage[i])
                            ),
                        )
                        .into());
                }
                None => None,
                Some(codes) => {
                    let shape = match codes[i] as usize {
                        0 => CarrierShape::Sine,
                        1 => CarrierShape::Square,
                        _ => CarrierShape::None,
                    };
                    let frequency_hz = match (shape, hz) {
                        (CarrierShape::None, _) => 0.0,
                        (_, None) => {
                            return Err(table.missing("carrier_hz (the frequency of a sine or square carrier)").into());
                        }
                        (_, Some(hz)) => ranges::CARRIER_HZ
                            .check(hz[i])
                            .map_err(|e| table.error_at(Some(i), Some("carrier_hz"), e.to_string()))?,
                    };
                    Some(Carrier { shape, frequency_hz })
                }
            };
            if let Some(c) = carrier.filter(|_| voltage[i] > 0.0)
                && carriers.insert((c.shape as u8, c.frequency_hz.to_bits()))
                && carriers.len() > MAX_CARRIERS
            {
                return Err(table
                    .error_at(
                        Some(i),
                        Some("carrier_hz"),
                        format!(
                            "more than {MAX_CARRIERS} distinct carriers: eq. (3) fits one force coefficient per \
                             carrier; measure a few carrier frequencies (three or more for the circuit model)"
                        ),
                    )
                    .into());
            }
            if voltage[i] > 0.0 && amplitude[i] > 0.0 {
                return Err(table
                    .error_at(
                        Some(i),
                        Some("amplitude_um"),
                        "both the voltage and the vibration are on: haptex calibrates each channel alone (measure \
                         the electrovibration at amplitude 0 and the vibration at 0 V)",
                    )
                    .into());
            }
            rows.push(Measurement {
                voltage_v: voltage[i],
                carrier,
                amplitude_um: amplitude[i],
                mu: mu[i],
                velocity_mm_s: velocity.map(|v| v[i]),
                finger: finger.as_ref().map_or(0, |f| f[i]),
                repetition: repetition.as_ref().map_or(0, |r| r[i]),
            });
        }
        Ok(Self {
            rows,
            lines: (0..n).map(|i| table.line_of_row(i)).collect(),
            source_name: table.source_name().to_string(),
            sha256: String::new(),
            has_finger: finger.is_some(),
            has_repetition: repetition.is_some(),
        })
    }

    /// Measurements made in memory (the virtual device), with line numbers
    /// as a file of one header line would have them.
    pub fn from_rows(rows: Vec<Measurement>, source_name: &str) -> Self {
        let lines = (0..rows.len() as u64).map(|i| i + 2).collect();
        Self {
            rows,
            lines,
            source_name: source_name.to_string(),
            sha256: String::new(),
            has_finger: true,
            has_repetition: true,
        }
    }

    pub fn rows(&self) -> &[Measurement] {
        &self.rows
    }

    /// The source line of row `i`.
    pub fn line(&self, i: usize) -> u64 {
        self.lines[i]
    }

    pub fn source_name(&self) -> &str {
        &self.source_name
    }

    /// SHA-256 of the file's bytes (empty for in-memory measurements).
    pub fn sha256(&self) -> &str {
        &self.sha256
    }

    /// The cluster of each row (module docs): by finger when the file
    /// names two or more, else by repetition when it names two or more,
    /// else each row alone. Returns the clusters (0-based, dense) and
    /// what they are.
    pub fn clusters(&self, rows: &[usize]) -> (Vec<usize>, ClusterLevel) {
        let distinct = |key: &dyn Fn(&Measurement) -> u64| {
            let mut v: Vec<u64> = rows.iter().map(|&i| key(&self.rows[i])).collect();
            v.sort_unstable();
            v.dedup();
            v
        };
        type Key = Box<dyn Fn(&Measurement) -> u64>;
        let (level, key): (ClusterLevel, Key) = if self.has_finger && distinct(&|m| m.finger).len() >= 2 {
            (ClusterLevel::Finger, Box::new(|m: &Measurement| m.finger))
        } else if self.has_repetition && distinct(&|m| m.repetition).len() >= 2 {
            (ClusterLevel::Repetition, Box::new(|m: &Measurement| m.repetition))
        } else {
            return ((0..rows.len()).collect(), ClusterLevel::Row);
        };
        let keys = distinct(&*key);
        let index = rows.iter().map(|&i| keys.binary_search(&key(&self.rows[i])).unwrap_or(0)).collect();
        (index, level)
    }
}

/// What the rows of one cluster share.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClusterLevel {
    /// A finger: the intervals hold for the population of fingers the
    /// measured ones stand for.
    Finger,
    /// A repetition (one finger, or fingers not named): the intervals hold
    /// for the finger(s) measured.
    Repetition,
    /// Nothing named: every row is independent.
    Row,
}

impl ClusterLevel {
    pub fn describe(self, count: usize) -> String {
        match self {
            ClusterLevel::Finger => format!(
                "{count} fingers (intervals for the population of fingers they stand for; a finger's own \
                 friction is one error shared by its rows)"
            ),
            ClusterLevel::Repetition => format!(
                "{count} repetitions of the finger(s) measured (the constants are theirs: friction varies from \
                 finger to finger by more than these intervals; name the fingers in a 'finger' column to include it)"
            ),
            ClusterLevel::Row => format!(
                "{count} independent rows (no 'finger' or 'repetition' column: if rows are samples of a few \
                 strokes, name the strokes, or the intervals will be too narrow)"
            ),
        }
    }
}
