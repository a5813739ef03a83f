"""Light tracing (kernels/integrator/light_trace.cl): an unbiased estimator independent of the
photon map, for references (the benchmark's, where no Cycles estimator samples the light: a point
light's caustic in a mirror).  Photons leave the emitters as in the photon pass and every
non-singular vertex is connected to the pinhole camera, splatted through the scene's pixel filter.
It renders what the camera sees of surfaces it can evaluate directly (``coverage()``); not emitters
seen directly, nor anything seen through mirrors or glass."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.device import SHADING_GROUP, get_device
from ppm_engine.render.device_scene import DeviceScene
from ppm_engine.render.film import FILTER_SAMPLES
from ppm_engine.scene.arrays import SceneArrays


class LightTracer:
    """``trace(n)`` adds n passes of ``photons`` photons; ``image()`` is the mean so far
    (h, w, 3) float32, row 0 = bottom, of the render region."""

    def __init__(self, scene: SceneArrays, photons: int = 1 << 16, seed: int = 0,
                 max_bounces: int = 12, device: str = "", specialize: bool = True):
        import pyopencl as cl
        if float(scene.camera["aperture_radius"][0]) > 0:
            raise ValueError("light tracing renders through a pinhole: turn depth of field off")
        self.device = dev = get_device(device)
        self.scene = DeviceScene(dev, scene, specialize)
        # the scene's own features (fastest), or every feature (one build that scenes share:
        # tests, the quick benchmark)
        _, defines = self.scene.kernel_defines(specialize)
        self.program = dev.programs.get("integrator/light_trace.cl", defines)
        self.kernel = self.program.launch("light_trace", "light trace")
        self.coverage_kernel = self.program.launch("lt_coverage", "coverage")
        cam = self.scene.scene.camera[0]
        self.w, self.h = int(cam["region"][2]), int(cam["region"][3])
        # the pixel filter's density the splats use: the DeviceScene's (film.filter_density)
        self.reach = self.scene.filter_reach
        self.image_buf = dev.buffer(12 * self.w * self.h, "light tracing image")
        cl.enqueue_fill_buffer(dev.queue, self.image_buf, np.uint32(0), 0, 12 * self.w * self.h)
        self.counters = dev.buffer(64, "light tracing counters")
        self.photons, self.seed, self.max_bounces = int(photons), int(seed), int(max_bounces)
        self.passes = 0

    def trace(self, passes: int = 1) -> None:
        q = self.device.queue
        for _ in range(passes):
            self.kernel(q, self.photons, SHADING_GROUP, **self.scene.args,
                        pass_index=np.uint32(self.passes), seed=np.uint32(self.seed),
                        max_bounces=np.int32(self.max_bounces), n_photons=np.uint32(self.photons),
                        filter_density=self.scene.filter_density,
                        n_table=np.int32(FILTER_SAMPLES),
                        reach=np.float32(self.reach), image=self.image_buf,
                        counters=self.counters)
            self.passes += 1
        q.finish()

    def image(self) -> np.ndarray:
        import pyopencl as cl
        out = np.empty((self.h, self.w, 3), np.float32)
        cl.enqueue_copy(self.device.queue, out, self.image_buf)
        n = max(self.passes * self.photons, 1)
        return out / np.float32(n) * np.float32(self.scene.scene.camera["exposure"][0])

    def coverage(self) -> np.ndarray:
        """(h, w) bool: the pixels whose camera ray (through the centre) first meets a
        non-emitting surface with only evaluable closures, and whose neighbours within the
        pixel filter's reach do too: what light tracing renders."""
        import pyopencl as cl
        buf = self.device.buffer(4 * self.w * self.h, "light tracing coverage")
        self.coverage_kernel(self.device.queue, self.w * self.h, SHADING_GROUP,
                             **self.scene.args, covered=buf)
        out = np.empty((self.h, self.w), np.float32)
        cl.enqueue_copy(self.device.queue, out, buf)
        buf.release()
        # a pixel the filter reaches from an uncovered one may hold some of what that one sees
        covered, k = out > 0.5, int(np.ceil(self.reach))
        padded = np.pad(covered, k, constant_values=True)
        eroded = covered.copy()
        for dy in range(-k, k + 1):
            for dx in range(-k, k + 1):
                eroded &= padded[k + dy:k + dy + self.h, k + dx:k + dx + self.w]
        return eroded

    def close(self) -> None:
        for b in (self.image_buf, self.counters):
            b.release()
