"""Parts of one render: the film's sums over a set of passes, which add up exactly.

With the global radius schedule (RenderOptions.radius_schedule "global", Knaus & Zwicker 2011)
a pass's contribution to the film depends on its index alone (Renderer.independent): its seeds
are the pass index's, its radius the sequence's term for that index times its own visible
point's footprint, and nothing is learned from the passes before it.  The film is then a sum
over passes: the direct samples and their count, S = sum of Phi / R^2, the light tracing's
splats, the moments (y, y^2, photons emitted, passes), the denoising passes, the transparency,
N.  A Part holds those sums for a set of pass indices and what must agree for two parts to
belong to one render (``meta``: the scene's digest, the options that change a pass, the film's
size and exposure); merge() adds parts whose passes do not overlap and resolve() makes the image
as film_resolve (kernels/integrator/progressive.cl) does.

    passes 0-999 here + passes 1000-1999 there, merged = passes 0-1999 in one run

to float rounding on the same device (the sums are added in another order), within noise across
devices.  A Part is saved as .npz (``save``/``load``): sums in float64, the metadata as JSON.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np

from ppm_engine.errors import PPMError
from ppm_engine.render.film import aux_passes

# the film's sums a part carries (film.py FILM_BUFFERS names): float4 sums read with read_sum,
# plain float32 sums (the kernels add to them each pass) read as they are
SUMS4 = ("direct", "photon_sum", "lt_sum", "moments")
PLAIN = (("aux_albedo", 4), ("aux_normal", 4), ("transparency", 1), ("nstat", 1))
# RenderOptions fields that do not change what a pass renders: they may differ between parts
FREE_OPTIONS = ("passes", "time_limit", "device", "devices")
FORMAT = 1       # the .npz layout's version


class PartError(PPMError):
    """Parts that cannot be merged, or a file that is not a part."""


def scene_digest(scene) -> str:
    """SHA-256 of every array and name of a SceneArrays: parts of different scenes (another
    frame, another camera, another material) never merge."""
    h = hashlib.sha256()
    for f in dataclasses.fields(scene):
        v = getattr(scene, f.name)
        h.update(f.name.encode())
        if isinstance(v, np.ndarray):
            h.update(str(v.dtype).encode() + str(v.shape).encode())
            h.update(np.ascontiguousarray(v).tobytes())
        elif f.name != "warnings":
            h.update(repr(v).encode())
    return h.hexdigest()


def render_meta(scene, options, device, film, lt_kappa: float, **extra) -> dict:
    """What must agree for parts to merge: the scene's digest, the options that change a pass
    (all but FREE_OPTIONS), the film's size and exposure and whether it holds photon splats
    (the photons traced to the camera, or the volume photons' gather: passes/volume.py);
    ``device`` is recorded (parts of other devices merge: within their noise)."""
    opts = {k: v for k, v in dataclasses.asdict(options).items() if k not in FREE_OPTIONS}
    return {"scene": scene_digest(scene), "options": opts,
            "resolution": [film.width, film.height], "exposure": float(film.exposure),
            "light_tracing": bool(lt_kappa > 0 or getattr(film, "light_tracing", False)),
            **extra,
            "devices": [device.info.name]}


def _ranges(indices) -> list[tuple[int, int]]:
    """Sorted pass indices as inclusive ranges [(first, last), ...]."""
    out: list[list[int]] = []
    for i in sorted(indices):
        if out and i == out[-1][1] + 1:
            out[-1][1] = i
        else:
            out.append([i, i])
    return [(a, b) for a, b in out]


def format_ranges(ranges, base: int = 1) -> str:
    """'1001-2000, 3001' (passes counted from ``base``, as the CLI counts them)."""
    return ", ".join(f"{a + base}" if a == b else f"{a + base}-{b + base}" for a, b in ranges)


@dataclasses.dataclass
class Part:
    """The sums of a film over the passes ``passes`` (indices from 0, sorted, unique), the
    photons emitted over them, the radius of the last of them (the "PPM Radius" pass) and
    ``meta`` (render_meta)."""
    sums: dict[str, np.ndarray]        # name -> (h, w, c) float64, row 0 = bottom
    passes: np.ndarray                 # (n,) int64
    photons_emitted: int
    radius: np.ndarray                 # (h, w) float32
    meta: dict

    @classmethod
    def of(cls, renderer, **meta) -> Part:
        """The film of a Renderer as a Part (its passes: renderer.pass_indices); ``meta``
        adds what must agree besides what render_meta lists."""
        with renderer.device.lock:
            return cls.from_film(renderer.film, renderer.pass_indices, render_meta(
                renderer.scene.scene, renderer.options, renderer.device, renderer.film,
                renderer.lt_kappa, **meta))

    @classmethod
    def from_film(cls, film, pass_indices, meta: dict) -> Part:
        passes = np.asarray(pass_indices, np.int64)
        if len(np.unique(passes)) != len(passes):
            raise PartError("the film holds a pass twice")
        sums = {name: film.read_sum(name) for name in SUMS4}
        for name, c in PLAIN:
            a = film.read(name, np.float32, c).astype(np.float64)
            sums[name] = a if c > 1 else a[..., None]
        return cls(sums, np.sort(passes), int(film.photons_emitted), film.read("radius"), meta)

    @property
    def ranges(self) -> list[tuple[int, int]]:
        return _ranges(self.passes.tolist())

    # -- files ----------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        meta = {**self.meta, "format": FORMAT, "photons_emitted": str(self.photons_emitted)}
        with open(path, "wb") as f:     # a name without .npz stays as given
            # the plain sums were float32 on the device: saved as such (a fifth of the file)
            plain = {name for name, _ in PLAIN}
            np.savez_compressed(f, passes=self.passes, radius=self.radius,
                                meta=np.array(json.dumps(meta, sort_keys=True)),
                                **{f"sum_{k}": v.astype(np.float32) if k in plain else v
                                   for k, v in self.sums.items()})

    @classmethod
    def load(cls, path: str | Path) -> Part:
        path = Path(path)
        if not path.is_file():
            raise PartError(f"part not found: {path}")
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                sums = {k[4:]: z[k].astype(np.float64) for k in z.files
                        if k.startswith("sum_")}
                passes, radius = z["passes"], z["radius"]
        except (OSError, ValueError, KeyError) as e:
            raise PartError(f"{path} is not a part of a render (python -m ppm_engine render "
                            f"--pass-range ... -o PART.npz writes them): {e}") from None
        if meta.pop("format", None) != FORMAT:
            raise PartError(f"{path} is a part of another version of the engine")
        photons = int(meta.pop("photons_emitted"))
        return cls(sums, passes.astype(np.int64), photons, radius, meta)

    # -- the image ------------------------------------------------------------------------------
    def image(self) -> np.ndarray:
        """Linear RGBA (h, w, 4) float32, row 0 = bottom: film_resolve's image of these sums."""
        s = self.sums
        d, m = s["direct"], s["moments"]
        with np.errstate(invalid="ignore", divide="ignore"):
            c = np.where(d[..., 3:] > 0, d[..., :3] / d[..., 3:], 0.0)
            photon = s["photon_sum"][..., :3] / np.pi
            if self.meta.get("light_tracing"):
                photon = photon + s["lt_sum"][..., :3]
            c = c + np.where(m[..., 2:3] > 0, photon / m[..., 2:3], 0.0)
            alpha = np.where(m[..., 3:] > 0, 1.0 - np.clip(
                s["transparency"] / m[..., 3:], 0.0, 1.0), 1.0)
        rgb = c * float(self.meta.get("exposure", 1.0))
        return np.concatenate([rgb, alpha], axis=-1).astype(np.float32)


    def aux_passes(self) -> dict:
        """The extra render passes as Film.aux_passes makes them: "Denoising Albedo" (mean),
        "Denoising Normal" (unit mean), "PPM Radius" (the last pass's R), "PPM Photons" (N)."""
        return aux_passes(self.sums["aux_albedo"], self.sums["aux_normal"], self.radius,
                          self.sums["nstat"])


def _agree(a: dict, b: dict) -> list[str]:
    """The keys of two parts' metadata that differ (their devices may)."""
    keys = (set(a) | set(b)) - {"devices"}
    out = []
    for k in sorted(keys):
        if k == "options":
            oa, ob = a.get(k, {}), b.get(k, {})
            out += [f"option {n} ({oa.get(n)!r} / {ob.get(n)!r})"
                    for n in sorted(set(oa) | set(ob)) if oa.get(n) != ob.get(n)]
        elif a.get(k) != b.get(k):
            out.append("the scene" if k == "scene" else k)
    return out


def merge(parts, names=None) -> Part:
    """One Part of ``parts`` (their sums added): refused where they are of different scenes or
    settings or where two of them hold the same pass (named in the message, with ``names``,
    the parts' file names, where given)."""
    parts = list(parts)
    if not parts:
        raise PartError("nothing to merge")
    names = list(names) if names is not None else [f"part {i + 1}" for i in range(len(parts))]
    first = parts[0]
    for p, name in zip(parts[1:], names[1:]):
        differ = _agree(first.meta, p.meta)
        if differ:
            raise PartError(f"{name} is not of the same render as {names[0]}: "
                            f"{', '.join(differ)} differ")
    for k, p in enumerate(parts):
        for j in range(k):
            both = np.intersect1d(parts[j].passes, p.passes)
            if len(both):
                raise PartError(f"{names[j]} and {names[k]} both hold passes "
                                f"{format_ranges(_ranges(both.tolist()))}: each pass may be "
                                "counted once")
    sums = {name: np.sum([p.sums[name] for p in parts], axis=0) for name in first.sums}
    last = max(range(len(parts)), key=lambda i: int(parts[i].passes.max(initial=-1)))
    devices = sorted({d for p in parts for d in p.meta.get("devices", [])})
    return Part(sums, np.sort(np.concatenate([p.passes for p in parts])),
                sum(p.photons_emitted for p in parts), parts[last].radius,
                {**first.meta, "devices": devices})


def check_splittable(options) -> None:
    """Refuse settings whose passes are not independent: adaptive sampling stops pixels by
    what the passes before found, and the per-pixel radius statistics (radius_schedule
    "pixel") depend on every pass before."""
    from ppm_engine.render.options import SettingsError
    if options.noise_threshold > 0:
        raise SettingsError("adaptive sampling (noise threshold > 0) decides which pixels go on "
                            "from the passes before: passes split across renders need it off")
    if options.radius_schedule != "global":
        raise SettingsError("passes split across renders need radius_schedule 'global'")


def render_range(scene, options, passes, progress=None, renderer=None) -> Part:
    """The Part of ``passes`` (pass indices from 0) of ``scene`` with ``options`` (the global
    schedule; check_splittable), rendered by one Renderer on ``options.device`` (or
    ``renderer``, kept open); ``progress(done, total, stats)`` after each pass."""
    from ppm_engine.render.renderer import Renderer
    check_splittable(options)
    passes = list(passes)
    r = renderer if renderer is not None else Renderer(scene, options)
    try:
        for k, i in enumerate(passes):
            stats = r.iterate(pass_index=i)
            if progress is not None:
                progress(k + 1, len(passes), stats)
        return Part.of(r)
    finally:
        if renderer is None:
            r.close()
