"""Progress of the FE functions (haptex.simulate, check, compensate).

The extension module calls ``reporter(progress, what)`` once per call and,
between FE steps, ``reporter(done, total)`` (done and total in FE steps;
total is the most the work may take) with the GIL taken back, then
``close()``. A reporter returning False stops the work
(haptex.CancelledError); an exception it raises propagates.
"""

from __future__ import annotations

from typing import Any, Callable, Optional

from ._errors import InvalidInputError

__all__ = ["reporter"]


class _Bar:
    """A tqdm bar, made at the first report (when the total is known)."""

    def __init__(self, tqdm: Any, what: str):
        self._tqdm = tqdm
        self._what = what
        self._bar = None

    def __call__(self, done: int, total: int) -> bool:
        if self._bar is None:
            self._bar = self._tqdm(total=total, desc=self._what, unit="step", leave=False)
        if self._bar.total != total:
            self._bar.total = total
        self._bar.update(done - self._bar.n)
        return True

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


class _Callback:
    """The caller's progress(done, total): False from it cancels."""

    def __init__(self, function: Callable[[int, int], Any]):
        self._function = function

    def __call__(self, done: int, total: int) -> bool:
        return self._function(done, total) is not False

    def close(self) -> None:
        pass


def reporter(progress: Any, what: str) -> Optional[Any]:
    """The reporter of a ``progress=`` argument: a tqdm bar for True (None
    when tqdm is not installed), None for False or None, the callable
    wrapped; anything else is refused."""
    if progress is True or progress is None:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return None
        return _Bar(tqdm, what)
    if progress is False:
        return None
    if callable(progress):
        return _Callback(progress)
    raise InvalidInputError(
        f"progress must be True, False or a callable progress(done, total), got {type(progress).__name__}"
    )
