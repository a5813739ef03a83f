"""ViewportSession's hold: Blender's thread is about to export an edit, so no pass runs until
it is posted.  On a small machine PoCL's threads take every core, and an export on Blender's
thread beside a pass ran 10-30 times slower (docs/BENCHMARKS.md, "Viewport")."""
from __future__ import annotations

import time

# the longest an export holds the worker
HOLD_LIMIT = 2.0


class ExportHold:
    """Mixed into ViewportSession (its ``_cond``, ``_frame``, ``_dropped``, ``_renderer``,
    ``_options``, ``_new_options``)."""

    _hold_until = 0.0                   # no pass runs until then (or a post)

    def hold(self, hold: bool = True) -> None:
        """An export is coming (Blender's thread is about to read the scene): the pass in
        progress is dropped and none runs until update_scene, ``hold(False)`` or HOLD_LIMIT
        seconds, so that the export has the processor.  A dropped pass and no change after
        it: the accumulation restarts."""
        with self._cond:
            self._hold_until = time.perf_counter() + HOLD_LIMIT if hold else 0.0
            self._cond.notify_all()

    def _export_held(self) -> bool:
        return time.perf_counter() < self._hold_until

    def _hold_wait(self) -> bool:
        """In the worker's wait for work, under the lock, nothing posted: whether to look
        again (it waited out a hold, or posted a restart after a pass dropped for nothing)."""
        held = self._hold_until - time.perf_counter()
        if held > 0 and self._frame is not None:
            self._cond.wait(held)               # an export on Blender's thread
            return True
        if self._dropped and self._renderer is not None:
            self._new_options = self._options   # a pass dropped for nothing: restart
            return True
        return False
