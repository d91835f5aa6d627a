"""A pass run beside the render, in a thread: its POV-Ray runs mostly wait (a run idles about 0.4 s
starting and 0.25 s at a frame change, ``povray.watch``), so on the render's cores it costs little
wall time, where after the render it would add its whole length.  The depth maps' pass starts as
soon as the render knows where its rays start (``registry.run_method``'s ``on_clearance``) and is
joined where its result is read (``outputs.steps.Still``).  Its progress is held, not shown, while
the render shows its own, and passed on from the main thread while the result is waited for.

The thread runs ``povray.process.run_jobs`` as the render's own does: its children are stopped
when the pass is cancelled (``should_stop``), which the render does on any error of its own, so
no POV-Ray outlives the command; an error of the pass is raised where its result is read.
"""

from __future__ import annotations

import contextvars
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

from .record import mark_beside

#: How often the main thread passes on the pass's progress while it waits for its result, s.
_PROGRESS_SECONDS = 0.1

_T = TypeVar("_T")


#: ``work(should_stop, progress)``: ``should_stop()`` polled while its POV-Ray runs, ``progress(done, total)``.
Work = Callable[[Callable[[], bool], Callable[[float, int], None]], _T]


def stop_either(first: Callable[[], bool], second: Callable[[], bool] | None) -> Callable[[], bool]:
    """A ``should_stop`` that is True when either is (``second`` None: ``first``)."""
    return first if second is None else (lambda: first() or second())


class BesidePass(Generic[_T]):
    """``work`` started in a thread now; ``result()`` waits for it, ``cancel()`` stops it."""

    def __init__(self, work: Work[_T]) -> None:
        self._stop = threading.Event()
        self._progress: tuple[float, int] | None = None   # the pass's latest, for the main thread
        self._value: _T | None = None
        self._error: BaseException | None = None
        self._done = False
        # The pass records its cost in the request's notes (``passes.record``, a context variable).
        context = contextvars.copy_context()
        self._thread = threading.Thread(target=context.run, args=(self._main, work), name="povh3d-beside",
                                        daemon=True)
        self._thread.start()

    def _main(self, work: Work[_T]) -> None:
        mark_beside()   # in this thread's copy of the context: the pass's notes say where it ran
        try:
            self._value = work(self._stop.is_set, self._hold)
        except BaseException as error:   # raised where the result is read
            self._error = error

    def _hold(self, done: float, total: int) -> None:
        self._progress = (done, total)   # one assignment: read whole by the main thread

    def result(self, progress: Callable[[float, int], None] | None = None) -> _T:
        """The pass's result, once it has finished (its error, raised here); ``progress(done, total)``
        gets the pass's progress meanwhile, from this thread."""
        shown = None
        try:
            while True:
                self._thread.join(_PROGRESS_SECONDS)
                if progress is not None and self._progress is not None and self._progress != shown:
                    shown = self._progress
                    progress(*shown)
                if not self._thread.is_alive():
                    break
        except BaseException:   # Ctrl-C while waiting, or a progress display's error: stop the pass's POV-Ray too
            self.cancel()
            raise
        self._done = True
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]   # set when no error was raised

    def cancel(self) -> None:
        """Stop the pass (its POV-Ray runs within ``povray.watch.STOP_CHECK_SECONDS``) and wait for it."""
        if not self._done:
            self._stop.set()
            self._thread.join()
            self._done = True
