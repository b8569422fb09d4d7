//! The shared PNG plot module writes a valid PNG of the stated size.

use haptex_core::plot::{Figure, Panel, Series};

/// Reads the PNG signature and the IHDR chunk (PNG spec, ISO/IEC 15948:
/// 8-byte signature, then IHDR with big-endian width and height).
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR", "first chunk is IHDR");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn writes_a_png_of_the_figure_size_atomically() {
    let t: Vec<f64> = (0..20_000).map(|i| i as f64 * 1e-4).collect();
    let x: Vec<f64> = t.iter().map(|t| 10.0 * t).collect();
    let s: Vec<f64> = t.iter().map(|t| (2.0 * std::f64::consts::PI * 1000.0 * t).sin()).collect();
    let figure = Figure::new("plot test")
        .size(640, 200)
        .panel(Panel::new("t (s)", "x (mm)").title("trajectory").line("finger", &t, &x))
        .panel(
            Panel::new("t (s)", "s (V)")
                .series(Series::line("carrier", &t, &s).color((200, 0, 0)))
                .points("marks", &[0.5, 1.0], &[0.0, f64::NAN])
                .line("no label, NaN gap", &[0.0, 1.0, 2.0], &[0.0, f64::NAN, 0.5]),
        );
    assert_eq!(figure.dimensions(), (640, 40 + 2 * 200));

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fig.png");
    figure.write_png(&path).unwrap();
    if let Ok(keep) = std::env::var("HAPTEX_KEEP_PLOT") {
        std::fs::copy(&path, keep).unwrap();
    }
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(png_size(&bytes), (640, 440));
    // Decodes as a whole, and is not a blank image.
    let mut reader = png::Decoder::new(std::io::Cursor::new(&bytes)).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (640, 440));
    let pixels = &buf[..info.buffer_size()];
    let non_white = pixels.chunks(3).filter(|p| p != &[255, 255, 255]).count();
    assert!(non_white > 10_000, "{non_white} drawn pixels");
    // Only the PNG remains in the directory (temporary file renamed).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}
