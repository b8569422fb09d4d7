//! `haptex voltage --force-model circuit` end to end: the design for a
//! carrier, the comment that names the carrier, `haptex play` refusing
//! another carrier, and the flags that do not go together.

use haptex_core::electrovibration::{Device, LayerStack};
use haptex_core::frequency::FingerCircuit;
use haptex_core::io::Table;
use haptex_core::signal::{Carrier, CarrierShape};

mod common;
use common::{haptex, stderr, write};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");

fn column(path: &std::path::Path, name: &str) -> Vec<f64> {
    let t = Table::read(std::fs::read(path).unwrap().as_slice(), "v").unwrap();
    t.column(name).unwrap().to_vec()
}

/// The circuit design for a 100 Hz sine and a 300 Hz square carrier is
/// eq. (8)'s voltage over sqrt(G) (G from the library, 1e-12), clipped at
/// U_max, the file
/// says which carrier, and play accepts that carrier only.
#[test]
fn circuit_design_names_its_carrier_and_play_holds_to_it() {
    let dir = tempfile::tempdir().unwrap();
    let eq3 = dir.path().join("eq3.csv");
    let out = haptex(&["voltage", "--profile", EXAMPLE, "-q", "-o", eq3.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (u3, mu) = (column(&eq3, "voltage_v"), column(&eq3, "mu"));
    let circuit = FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: 0.5 };
    for (shape, word, f) in [(CarrierShape::Sine, "sine", 100.0), (CarrierShape::Square, "square", 300.0)] {
        let path = dir.path().join(format!("{word}.csv"));
        let out = haptex(&[
            "voltage",
            "--profile",
            EXAMPLE,
            "--force-model",
            "circuit",
            "--rho-sc-ohm-m",
            "1e5",
            "--gap-um",
            "0.5",
            "--carrier",
            word,
            "--carrier-hz",
            &f.to_string(),
            "-o",
            path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let gain = circuit.carrier_gain(&LayerStack::PAPER, &Carrier { shape, frequency_hz: f });
        let u = column(&path, "voltage_v");
        // Eq. (8) with eq. (3)'s force times G, clipped at U_max = 100 V
        // and 0 V below mu_HD, from the library's Device.
        let device = Device { force_gain: gain, ..Device::PAPER };
        let mut clipped = 0;
        for (a, m) in u.iter().zip(&mu) {
            let want = device.voltage_v(*m, 1.0).unwrap_or(0.0).min(100.0);
            clipped += usize::from(want == 100.0);
            assert!((a - want).abs() <= 1e-12 * want.max(1.0), "{word}: {a} vs {want} at mu {m}");
        }
        // The gap lowers the force (G < 1 here): more of the bump clips
        // than with eq. (3).
        let clipped_eq3 = u3.iter().filter(|&&b| b == 100.0).count();
        assert!(gain < 1.0 && clipped > clipped_eq3 && clipped < u.len(), "{word}: G = {gain}, {clipped} clipped");
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("# force model: circuit"), "{text}");
        assert!(text.contains(&format!("designed for the carrier: {word} {f} Hz")), "{text}");
        assert!(stderr(&out).contains("force model: circuit"), "{}", stderr(&out));

        let wav = dir.path().join(format!("{word}.wav"));
        let play = |carrier: &str, hz: &str| {
            haptex(&[
                "play",
                "--profile",
                path.to_str().unwrap(),
                "--velocity",
                "50",
                "--carrier",
                carrier,
                "--carrier-hz",
                hz,
                "-o",
                wav.to_str().unwrap(),
            ])
        };
        let ok = play(word, &f.to_string());
        assert!(ok.status.success(), "{}", stderr(&ok));
        for (carrier, hz) in [(word, "1000"), (if word == "sine" { "square" } else { "sine" }, &f.to_string()[..])] {
            let refused = play(carrier, hz);
            assert!(!refused.status.success());
            let e = stderr(&refused);
            assert!(e.contains(&format!("--carrier {word} --carrier-hz {f}")), "{e}");
        }
    }
}

/// A design comment whose carrier cannot be read is an error naming the
/// file, not a silent play on the default carrier.
#[test]
fn unreadable_design_carrier_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "u.csv",
        "# force model: circuit; designed for the carrier: sine fast Hz\nx_mm,mu,voltage_v\n0,1.1,50\n1,1.1,50\n",
    );
    let out = haptex(&["play", "--profile", &p, "--velocity", "50", "-o", dir.path().join("u.wav").to_str().unwrap()]);
    assert!(!out.status.success());
    let e = stderr(&out);
    assert!(e.contains("u.csv") && e.contains("cannot read the design carrier"), "{e}");
    assert!(!dir.path().join("u.wav").exists());
}

/// Circuit flags without the circuit, the circuit without its parameters,
/// out-of-range parameters, and a compensation of a circuit design.
#[test]
fn flags_that_do_not_go_together_are_refused() {
    let cases: &[(&[&str], &str)] = &[
        (&["--carrier-hz", "100"], "--carrier-hz is for the frequency-dependent force model"),
        (&["--gap-um", "1"], "--gap-um is for the frequency-dependent force model"),
        (&["--force-model", "circuit"], "needs --rho-sc-ohm-m"),
        (&["--force-model", "circuit", "--rho-sc-ohm-m", "1e5"], "--gap-um"),
        (&["--force-model", "circuit", "--rho-sc-ohm-m", "-1", "--gap-um", "0"], "rho_sc_ohm_m must be"),
        (&["--force-model", "circuit", "--rho-sc-ohm-m", "1e5", "--gap-um", "2000"], "gap_um must be"),
        (
            &["--force-model", "circuit", "--rho-sc-ohm-m", "1e5", "--gap-um", "0", "--compensate"],
            "cannot compensate a --force-model circuit",
        ),
    ];
    for (extra, want) in cases {
        let mut args = vec!["voltage", "--profile", EXAMPLE, "-q"];
        args.extend_from_slice(extra);
        let out = haptex(&args);
        assert!(!out.status.success(), "{extra:?}");
        assert!(stderr(&out).contains(want), "{extra:?}: {}", stderr(&out));
    }
}

/// `haptex force-curve` tabulates the library's gains on a logarithmic
/// grid (to the bit: the same functions), writes its PNG, and refuses an
/// empty frequency range.
#[test]
fn force_curve_tabulates_the_gains() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, png) = (dir.path().join("g.csv"), dir.path().join("g.png"));
    let out = haptex(&[
        "force-curve",
        "--rho-sc-ohm-m",
        "2e5",
        "--gap-um",
        "0.2",
        "--from-hz",
        "10",
        "--to-hz",
        "1e4",
        "--points",
        "7",
        "-o",
        csv.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let c = FingerCircuit { rho_sc_ohm_m: 2e5, gap_um: 0.2 };
    let f = column(&csv, "f_hz");
    assert_eq!(f.len(), 7);
    assert!((f[0] - 10.0).abs() < 1e-12 && (f[6] - 1e4).abs() < 1e-8 && (f[1] / f[0] - 10f64.sqrt()).abs() < 1e-12);
    let (sine, square, direct) = (column(&csv, "gain_sine"), column(&csv, "gain_square"), column(&csv, "gain_direct"));
    for i in 0..7 {
        assert_eq!(sine[i], c.gain(&LayerStack::PAPER, f[i]));
        assert_eq!(square[i], c.square_gain(&LayerStack::PAPER, f[i]));
        assert_eq!(direct[i], c.gain(&LayerStack::PAPER, 0.0));
    }
    let out = haptex(&["force-curve", "--rho-sc-ohm-m", "1e5", "--gap-um", "0", "--from-hz", "100", "--to-hz", "10"]);
    assert!(!out.status.success() && stderr(&out).contains("must be above --from-hz"), "{}", stderr(&out));
}
