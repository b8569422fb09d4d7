//! Forging drive WAVs the way an attacker or a careless tool would
//! (included with `#[path] mod` by the WAV tests of the core and the
//! CLI): take a WAV haptex wrote apart into its `fmt `, `data` and `hptx`
//! chunks, edit any of them, then recompute every hash the scale chunk
//! holds (`samples_sha256`, and `fmt_sha256` when the chunk has one) and
//! every size (chunks and RIFF), so that the forged file is refused, if at
//! all, by what its contents say and not by a stale hash.
#![allow(dead_code)]

use haptex_core::io::sha256_hex;

/// The three chunks of a haptex drive WAV, editable.
pub struct Parts {
    pub fmt: Vec<u8>,
    pub data: Vec<u8>,
    /// The scale chunk's JSON.
    pub scale: serde_json::Value,
}

/// The chunks of `bytes` (a WAV haptex wrote).
pub fn parts(bytes: &[u8]) -> Parts {
    let (mut fmt, mut data, mut scale) = (None, None, None);
    let mut at = 12;
    while at + 8 <= bytes.len() {
        let size = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap()) as usize;
        let content = bytes[at + 8..at + 8 + size].to_vec();
        match &bytes[at..at + 4] {
            b"fmt " => fmt = Some(content),
            b"data" => data = Some(content),
            b"hptx" => scale = Some(serde_json::from_slice(&content).unwrap()),
            _ => {}
        }
        at += 8 + size + (size & 1);
    }
    Parts { fmt: fmt.unwrap(), data: data.unwrap(), scale: scale.unwrap() }
}

/// A WAV of `parts` with every hash of its scale chunk recomputed (the
/// ones it has) and every size right.
pub fn assemble(parts: &Parts) -> Vec<u8> {
    let mut scale = parts.scale.clone();
    scale["samples_sha256"] = sha256_hex(&parts.data).into();
    if scale.get("fmt_sha256").is_some() {
        scale["fmt_sha256"] = sha256_hex(&parts.fmt).into();
    }
    let mut bytes = b"RIFF\0\0\0\0WAVE".to_vec();
    for (id, content) in
        [(b"fmt ", parts.fmt.clone()), (b"data", parts.data.clone()), (b"hptx", serde_json::to_vec(&scale).unwrap())]
    {
        bytes.extend_from_slice(id);
        bytes.extend_from_slice(&(content.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&content);
        if content.len() % 2 == 1 {
            bytes.push(0);
        }
    }
    let riff = (bytes.len() - 8) as u32;
    bytes[4..8].copy_from_slice(&riff.to_le_bytes());
    bytes
}

/// `bytes` with `edit` applied to its chunks and the hashes recomputed.
pub fn forge(bytes: &[u8], edit: impl FnOnce(&mut Parts)) -> Vec<u8> {
    let mut p = parts(bytes);
    edit(&mut p);
    assemble(&p)
}

/// Writes a little-endian u16 / u32 into a chunk at byte `at`.
pub fn put_u16(chunk: &mut [u8], at: usize, v: u16) {
    chunk[at..at + 2].copy_from_slice(&v.to_le_bytes());
}

pub fn put_u32(chunk: &mut [u8], at: usize, v: u32) {
    chunk[at..at + 4].copy_from_slice(&v.to_le_bytes());
}
