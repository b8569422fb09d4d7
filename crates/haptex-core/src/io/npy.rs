//! Two-dimensional float NPY arrays, read with their header checked
//! first and every size bounded by the bytes present.

/// Reads a 2-D float32 or float64 NPY array (C or Fortran order) into
/// row-major f64: (rows, columns, values). `accept` checks the shape the
/// header claims, of any rank (its message is the error), before anything
/// is sized by it; the claim is then checked against the bytes present.
pub fn read_2d(
    bytes: &[u8],
    accept: impl FnOnce(&[u64]) -> Result<(), String>,
) -> Result<(usize, usize, Vec<f64>), String> {
    check_header(bytes).map_err(|m| format!("not a valid NPY file: {m}"))?;
    let npy = npyz::NpyFile::new(bytes).map_err(|e| format!("not a valid NPY file: {e}"))?;
    let shape = npy.shape().to_vec();
    accept(&shape)?;
    if shape.len() != 2 {
        return Err(format!("array shape {shape:?}: expected a 2-D array"));
    }
    let fits = shape[0].checked_mul(shape[1]).is_some_and(|n| n.saturating_mul(4) <= bytes.len() as u64);
    if !fits {
        return Err(format!("array shape {shape:?} claims more values than the file's {} bytes hold", bytes.len()));
    }
    let (rows, cols) = (shape[0] as usize, shape[1] as usize);
    let fortran = npy.order() == npyz::Order::Fortran;
    let dtype = npy.dtype().descr();
    let flat: Vec<f64> = match npy.try_data::<f64>() {
        Ok(reader) => reader.collect::<std::io::Result<_>>(),
        Err(npy) => match npy.try_data::<f32>() {
            Ok(reader) => reader.map(|v| v.map(f64::from)).collect::<std::io::Result<_>>(),
            Err(_) => return Err(format!("dtype {dtype}: expected float32 or float64")),
        },
    }
    .map_err(|e| format!("cannot read the array data: {e}"))?;
    if flat.len() != rows * cols {
        return Err(format!("{} values for shape {shape:?}", flat.len()));
    }
    Ok((
        rows,
        cols,
        if fortran { (0..rows * cols).map(|k| flat[(k % cols) * rows + k / cols]).collect() } else { flat },
    ))
}

/// Checks that an NPY header is the plain dictionary numpy writes
/// (`{'descr': '<f4', 'fortran_order': False, 'shape': (N, K), }`) before
/// the NPY library parses it: its Python-literal parser takes exponential
/// time on nested brackets (`'shape': [[[[...`, found by the fuzz
/// campaign), which no numpy header has.
fn check_header(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("no NPY magic".into());
    }
    let (length, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
        version => return Err(format!("NPY version {version} is not supported")),
    };
    const MAX_HEADER_BYTES: usize = 4096;
    if length > MAX_HEADER_BYTES {
        return Err(format!("a header of {length} bytes (numpy writes under {MAX_HEADER_BYTES})"));
    }
    let header = bytes.get(start..start + length).ok_or("the header is cut short")?;
    let count = |c: u8| header.iter().filter(|&&b| b == c).count();
    if count(b'{') != 1 || count(b'}') != 1 || count(b'(') > 1 || count(b')') > 1 || count(b'[') > 0 {
        return Err("the header is not the plain dictionary numpy writes ({'descr': ..., 'fortran_order': ..., \
                    'shape': (..)})"
            .into());
    }
    Ok(())
}
