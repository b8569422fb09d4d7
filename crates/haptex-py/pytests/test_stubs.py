"""The type stubs (python/haptex/_haptex.pyi) describe the extension module
as it is: mypy's stubtest compares every name, signature and default of the
installed module with the stubs, so an argument added to a function but not
to its stub (or the reverse) fails here."""

from __future__ import annotations

import subprocess
import sys


def test_stubs_match_the_module():
    result = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "haptex._haptex"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_public_name_has_a_docstring():
    import haptex

    missing = [name for name in haptex.__all__ if not name.startswith("_") and not (getattr(haptex, name).__doc__ or "").strip()]
    assert not missing, f"no docstring: {missing}"
