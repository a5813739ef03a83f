"""Several OpenCL devices on one image: each device's Renderer renders the passes it takes from
one list, interleaved, and their films merge exactly (ppm_engine/render/parts.py), as Cycles
renders one image on several devices.  The passes must be independent: the global radius
schedule, no adaptive sampling (parts.check_splittable).

Load balancing by measured pass time: device k's first pass is the list's k-th (each device's
time is measured), then every device takes the next pass as soon as it finished its last one
(a GPU takes more of them than a CPU), and near the end a device no longer takes one when its
own pass time is longer than the fastest device needs for all the passes left, so a slow
device does not hold the image back by its last pass.

Each device renders on its own Python thread: pyopencl lets the others run while one waits for
its queue (the host work between launches is small).  Two contexts on one device ("KEY#1":
device/context.py get_device) stand for two devices in the tests.
"""
from __future__ import annotations

import queue
import threading
import time

from ppm_engine.render.parts import Part, check_splittable, merge


class MultiRenderer:
    """``devices`` (device names or keys, as RenderOptions.device) rendering ``options.passes``
    passes of ``scene`` with the global schedule; the Renderer's interface as the Session uses
    it: iterate() (returns when one more pass is done, with its stats), passes_done, image(),
    passes(), part(), close()."""

    # a pass time is a moving average over the device's passes: new = (1 - w) old + w last
    TIME_WEIGHT = 0.3

    def __init__(self, scene, options, devices, passes=None):
        from ppm_engine.render.renderer import Renderer
        self.options = options.replace(radius_schedule="global").validate()
        check_splittable(self.options)
        if len(devices) < 1:
            raise ValueError("no device to render on")
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self.renderers: list[Renderer] = []
        try:
            for d in devices:
                self.renderers.append(Renderer(scene, self.options.replace(device=d)))
        except BaseException:
            self.close()
            raise
        self.device = self.renderers[0].device
        self.pass_list = list(range(self.options.passes) if passes is None else passes)
        self.pass_seconds: list[float | None] = [None] * len(self.renderers)
        self.passes_by_device = [0] * len(self.renderers)
        self.passes_done = 0
        self._first_taken = [False] * len(self.renderers)
        self._taking = set(range(len(self.renderers)))   # devices still taking passes
        self._next = min(len(self.renderers), len(self.pass_list))
        self._lock = threading.Lock()
        self._results: queue.Queue = queue.Queue()
        self._running = 0

    @property
    def warnings(self) -> list[str]:
        return self.renderers[0].warnings

    def can_reuse(self, options, scene=None) -> bool:
        """Never: persistent data keeps one device's Renderer only (Session)."""
        return False

    def refit(self, scene) -> bool:
        return False

    # -- scheduling -------------------------------------------------------------------------
    def _take(self, k: int) -> int | None:
        """The next pass for device ``k``, or None: none left, stopped, or device k's pass time
        is longer than the fastest device still taking passes needs for all the passes left
        (then k takes no more; the fastest one never stops, so every pass is taken)."""
        with self._lock:
            if self._stop.is_set():
                return None
            if not self._first_taken[k]:        # each device's first pass is its own (its
                self._first_taken[k] = True     # time is measured), however late it starts
                return self.pass_list[k] if k < len(self.pass_list) else None
            left = len(self.pass_list) - self._next
            if left <= 0:
                return None
            mine = self.pass_seconds[k]
            known = [t for j, t in enumerate(self.pass_seconds)
                     if t is not None and j in self._taking]
            if mine is not None and len(known) > 1 and mine > min(known) * left:
                self._taking.discard(k)
                return None
            i = self.pass_list[self._next]
            self._next += 1
            return i

    def _work(self, k: int) -> None:
        r = self.renderers[k]
        try:
            while (i := self._take(k)) is not None:
                t0 = time.perf_counter()
                stats = r.iterate(pass_index=i)
                dt = time.perf_counter() - t0
                with self._lock:
                    old = self.pass_seconds[k]
                    self.pass_seconds[k] = dt if old is None else (
                        (1 - self.TIME_WEIGHT) * old + self.TIME_WEIGHT * dt)
                    self.passes_by_device[k] += 1
                self._results.put(stats)
        except BaseException as e:       # handed to iterate() in the caller's thread
            self._stop.set()
            self._results.put(e)
        finally:
            self._results.put(None)

    def _start(self) -> None:
        self._running = len(self.renderers)
        self._threads = [threading.Thread(target=self._work, args=(k,), daemon=True,
                                          name=f"ppm-device-{k}")
                         for k in range(len(self.renderers))]
        for t in self._threads:
            t.start()

    def iterate(self, interrupt=None):
        """Wait for the next finished pass and return its stats (None when every device has
        stopped: all passes taken and done)."""
        if not self._threads:
            self._start()
        while self._running:
            got = self._results.get()
            if got is None:
                self._running -= 1
                continue
            if isinstance(got, BaseException):
                raise got
            self.passes_done += 1
            got.pass_index = self.passes_done       # the stats line counts all devices' passes
            return got
        return None

    def run(self, progress=None) -> Part:
        """Every pass of ``pass_list``, then their merged Part; ``progress(done, total,
        stats)`` after each."""
        while (stats := self.iterate()) is not None:
            if progress is not None:
                progress(self.passes_done, len(self.pass_list), stats)
        return self.part()

    # -- the image ----------------------------------------------------------------------------
    def part(self) -> Part:
        """The devices' films merged (each read between its passes)."""
        return merge([Part.of(r) for r in self.renderers if r.pass_indices],
                     names=[r.device.info.name for r in self.renderers if r.pass_indices])

    def image(self):
        return self.part().image()

    def passes(self) -> dict:
        return self.part().aux_passes()

    def close(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join()
        for r in self.renderers:
            r.close()
        self.renderers = []


def render_devices(scene, options, passes, devices, progress=None) -> Part:
    """The Part of ``passes`` (pass indices) rendered by ``devices`` together (MultiRenderer)."""
    m = MultiRenderer(scene, options, devices, passes)
    try:
        return m.run(progress)
    finally:
        m.close()
