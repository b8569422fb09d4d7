#!/usr/bin/env python3
"""Seeds of the drive_wav fuzz target (fuzz/seeds/drive_wav), made by a
haptex binary: small drive WAVs in every sample format, on one channel
and two (the amplitude envelope and the plate's displacement), and
forgeries of them with every hash of the scale chunk recomputed (a
version-1 chunk, an edited format tag, a NaN sample, a rate of 0 Hz), so
that the fuzzer starts from files that pass the hash checks and explores
the fmt/hptx consistency and the sample checks behind them.

    python3 scripts/drive_wav_seeds.py target/release/haptex fuzz/seeds/drive_wav
"""
import hashlib
import json
import os
import struct
import subprocess
import sys
import tempfile


def chunks(data):
    """The (id, content) chunks of a RIFF/WAVE file."""
    out, at = [], 12
    while at + 8 <= len(data):
        size = struct.unpack_from("<I", data, at + 4)[0]
        out.append((data[at:at + 4], data[at + 8:at + 8 + size]))
        at += 8 + size + (size & 1)
    return out


def assemble(fmt, samples, scale):
    """A WAV of these chunks, every hash of the scale chunk recomputed."""
    scale = dict(scale)
    scale["samples_sha256"] = hashlib.sha256(samples).hexdigest()
    if "fmt_sha256" in scale:
        scale["fmt_sha256"] = hashlib.sha256(fmt).hexdigest()
    body = b"WAVE"
    for cid, content in ((b"fmt ", fmt), (b"data", samples), (b"hptx", json.dumps(scale, separators=(",", ":")).encode())):
        body += cid + struct.pack("<I", len(content)) + content + (b"\0" if len(content) % 2 else b"")
    return b"RIFF" + struct.pack("<I", len(body)) + body


def main(haptex, out_dir):
    os.makedirs(out_dir, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        one = os.path.join(tmp, "u.csv")
        with open(one, "w") as f:
            f.write("x_mm,voltage_v\n0,10\n5,80\n10,40\n")
        two = os.path.join(tmp, "ua.csv")
        with open(two, "w") as f:
            f.write("# amplitude_um is the plate's amplitude, peak, at most a_max = 2 um\n"
                    "x_mm,voltage_v,amplitude_um\n0,10,0\n5,80,1.5\n10,40,0.5\n")
        made = []
        for fmt in ("pcm16", "pcm24", "float32"):
            for name, profile, extra in (
                ("mono", one, ["--sample-rate", "1000", "--carrier-hz", "100"]),
                ("stereo", two, ["--sample-rate", "1000", "--carrier-hz", "100"]),
                ("plate", two, ["--sample-rate", "192000", "--plate-resonance-hz", "40000", "--velocity", "50000"]),
            ):
                path = os.path.join(tmp, f"{name}_{fmt}.wav")
                args = [haptex, "play", "--profile", profile, "--wav-format", fmt, "-o", path, "-q"]
                args += extra if "--velocity" in extra else extra + ["--velocity", "1000"]
                subprocess.run(args, check=True)
                with open(path, "rb") as f:
                    made.append((f"{name}_{fmt}", f.read()))
        for name, data in made:
            parts = dict(chunks(data))
            fmt, samples, scale = parts[b"fmt "], parts[b"data"], json.loads(parts[b"hptx"])
            variants = {name: data}
            v1 = {k: v for k, v in scale.items() if k not in ("version", "fmt", "fmt_sha256")}
            variants[f"{name}_v1"] = assemble(fmt, samples, v1)
            tag = struct.pack("<H", 3 if fmt[:2] == b"\x01\x00" else 1)
            variants[f"{name}_tag"] = assemble(tag + fmt[2:], samples, scale)
            width = scale["fmt"]["block_align"] // scale["fmt"]["channels"]
            nan = (b"\x00\x00\xc0\x7f" if width == 4 else b"\x00\x80" if width == 2 else b"\x00\x00\x80")
            variants[f"{name}_extreme"] = assemble(fmt, nan + samples[width:], scale)
            zero_rate = dict(scale, sample_rate_hz=0, fmt=dict(scale["fmt"], sample_rate_hz=0, byte_rate=0))
            variants[f"{name}_0hz"] = assemble(fmt[:4] + b"\0" * 8 + fmt[12:], samples, zero_rate)
            for vname, vdata in variants.items():
                with open(os.path.join(out_dir, f"{vname}.wav"), "wb") as f:
                    f.write(vdata)
    print(f"wrote {len(made) * 5} seeds to {out_dir}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
