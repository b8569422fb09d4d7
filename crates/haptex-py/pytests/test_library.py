"""haptex.Library against `haptex library`: the same materials, strokes and
sampled profiles (bit for bit), imports that agree, the same refusals."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

import haptex
from conftest import DATA, EXAMPLES, assert_identical, read_csv

SHIPPED = DATA / "library" / "library.sqlite"
DEMO = DATA / "library" / "demo"


def test_the_default_library_is_the_shipped_one_or_haptex_library(monkeypatch, tmp_path):
    monkeypatch.delenv("HAPTEX_LIBRARY", raising=False)
    assert os.path.samefile(haptex.Library().path, SHIPPED)
    monkeypatch.setenv("HAPTEX_LIBRARY", str(tmp_path / "elsewhere.sqlite"))
    assert str(haptex.Library().path) == str(tmp_path / "elsewhere.sqlite")


def test_materials_and_strokes_are_the_command_lines(cli):
    listed = json.loads(cli.run("library", "--db", SHIPPED, "list", "--format", "json").stdout)
    library = haptex.Library(SHIPPED)
    materials = library.materials()
    assert materials == listed["materials"]
    assert len(materials) == 12 and all(m["synthetic"] for m in materials)
    strokes = json.loads(cli.run("library", "--db", SHIPPED, "list", "--material", "velvet", "--format", "json").stdout)
    assert library.strokes("VELVET") == strokes["strokes"]


@pytest.mark.parametrize("material,seed", [("velvet", 7), ("sandpaper-p24", 1), ("tile", 2016)])
def test_sample_is_the_command_lines_bit_for_bit(cli, tmp_path, material, seed):
    out = tmp_path / "s.csv"
    cli.run("library", "--db", SHIPPED, "sample", "--material", material, "--seed", str(seed), "-o", out)
    expected = read_csv(out)
    sample = haptex.Library(SHIPPED).sample(material, seed=seed)
    assert sample.seed == seed
    assert_identical(sample.profile.x_mm, expected["x_mm"], "x_mm")
    assert_identical(sample.profile.mu, expected["mu"], "mu")
    assert_identical(sample.profile.fn_n, expected["fn_n"], "fn_n")
    # The CLI's comments: its own first line, then the stroke's provenance.
    assert expected["#"][1:] == sample.comments
    assert f"stroke id {sample.stroke['id']}" in expected["#"][0]
    # The stored profile by id is the same stroke.
    by_id = haptex.Library(SHIPPED).stroke(sample.stroke["id"])
    assert by_id.seed is None and by_id.stroke == sample.stroke
    assert_identical(by_id.profile.mu, sample.profile.mu, "mu")


def test_a_fresh_seed_is_returned_and_repeats_the_choice():
    library = haptex.Library(SHIPPED)
    first = library.sample("linen")
    again = library.sample("linen", seed=first.seed)
    assert again.stroke == first.stroke


def test_export_profiles_are_the_stored_ones(cli, tmp_path):
    cli.run("library", "--db", SHIPPED, "export", "--out", tmp_path / "export", "--material", "latex")
    manifest = json.loads((tmp_path / "export" / "manifest.json").read_text())
    library = haptex.Library(SHIPPED)
    for entry in manifest["strokes"]:
        exported = read_csv(tmp_path / "export" / entry["file"])
        stored = library.stroke(entry["stroke"]["id"])
        assert stored.stroke == entry["stroke"]
        assert_identical(stored.profile.mu, exported["mu"], "mu")
        assert_identical(stored.profile.x_mm, exported["x_mm"], "x_mm")


def test_import_recordings_agrees_with_the_command_line(cli, tmp_path):
    recordings = [DEMO / "velvet", DEMO / "tile" / "tile-s1.recording.json"]
    cli_db, py_db = tmp_path / "cli.sqlite", tmp_path / "py.sqlite"
    cli.run("library", "--db", cli_db, "import", "-q", "--dx-mm", "0.2", *recordings)
    library = haptex.Library(py_db)
    added = library.import_recordings(recordings, dx_mm=0.2)
    assert len(added["new"]) == 4 and added["duplicate"] == []
    assert library.check() == []
    ours, theirs = library.materials(), haptex.Library(cli_db).materials()
    assert ours == theirs
    for material in ("velvet", "tile"):
        for mine, cli_stroke in zip(library.strokes(material), haptex.Library(cli_db).strokes(material)):
            for key in ("content_sha256", "n_points", "span_mm", "mean_mu", "mean_fn_n", "config_json"):
                assert mine[key] == cli_stroke[key], key
            assert_identical(library.stroke(mine["id"]).profile.mu,
                             haptex.Library(cli_db).stroke(cli_stroke["id"]).profile.mu, "mu")
    # Importing again adds nothing.
    again = library.import_recordings(DEMO / "velvet", dx_mm=0.2)
    assert again["new"] == [] and len(again["duplicate"]) == 3


def test_import_profile_and_its_refusals(cli, tmp_path):
    db = tmp_path / "mine.sqlite"
    library = haptex.Library(db)
    added = library.import_profile(EXAMPLES / "bump_friction.csv", material="my bump", synthetic=True,
                                   licence="CC0-1.0")
    assert list(added) == ["new"]
    assert library.import_profile(EXAMPLES / "bump_friction.csv", material="my bump", synthetic=True) == {
        "duplicate": added["new"]}
    stored = library.stroke(added["new"])
    bump = haptex.Profile.read_csv(EXAMPLES / "bump_friction.csv")
    assert_identical(stored.profile.mu, bump.mu, "mu")
    assert stored.stroke["licence"] == "CC0-1.0" and stored.stroke["synthetic"]
    # A material never mixes synthetic and measured strokes: the CLI's message.
    x = np.linspace(0.0, 10.0, 21)
    with pytest.raises(haptex.InvalidInputError) as caught:
        library.import_profile((x, np.full(21, 1.2)), material="my bump", synthetic=False)
    flat = tmp_path / "flat.csv"
    haptex.Profile(x, np.full(21, 1.2)).write_csv(flat)
    message = cli.error("library", "--db", db, "import", "--profile", flat, "--measured", "--material", "my bump")
    assert str(caught.value) == message
    for name in ("", ".hidden", "a/b", "x" * 101):
        with pytest.raises(haptex.InvalidInputError):
            library.import_profile((x, np.full(21, 1.2)), material=name, synthetic=True)
    with pytest.raises(haptex.InvalidInputError):
        library.import_profile((x, np.full(21, np.nan)), material="nan", synthetic=True)


def test_unknown_material_is_the_command_lines_refusal(cli):
    message = cli.error("library", "--db", SHIPPED, "sample", "--material", "marble")
    with pytest.raises(haptex.InvalidInputError) as caught:
        haptex.Library(SHIPPED).sample("marble")
    assert str(caught.value) == message


def test_a_missing_library_or_recording_is_an_os_error(tmp_path):
    missing = haptex.Library(tmp_path / "nope.sqlite")
    for call in (missing.materials, lambda: missing.sample("velvet"), lambda: missing.strokes("velvet")):
        with pytest.raises(haptex.HaptexOSError) as caught:
            call()
        assert isinstance(caught.value, OSError) and "nope.sqlite" in str(caught.value)
    with pytest.raises(haptex.HaptexOSError):
        haptex.Library(tmp_path / "new.sqlite").import_recordings(tmp_path / "no-such-recording.recording.json")
    # A recording whose data file is gone is named, and the others are kept.
    copy = tmp_path / "velvet"
    shutil.copytree(DEMO / "velvet", copy)
    (copy / "velvet-s2.force.npy").unlink()
    library = haptex.Library(tmp_path / "partial.sqlite")
    with pytest.raises(haptex.InvalidInputError) as caught:
        library.import_recordings(copy)
    assert "1 of 3" in str(caught.value) and "velvet-s2" in str(caught.value)
    assert library.materials()[0]["strokes"] == 2


def test_processing_arguments_are_checked():
    with pytest.raises(haptex.InvalidInputError):
        haptex.Library("unused.sqlite").import_recordings(DEMO / "velvet", dx_mm=-1.0)
    with pytest.raises(haptex.InvalidInputError):
        haptex.Library("unused.sqlite").import_recordings(DEMO / "velvet", direction="sideways")
    with pytest.raises(haptex.InvalidInputError):
        haptex.Library("unused.sqlite").import_recordings(DEMO / "velvet", min_fn_n=float("nan"))
    assert not os.path.exists("unused.sqlite")
