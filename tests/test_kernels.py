"""Every kernel against the NumPy reference (ppm_engine/oracle/reference.py), on every OpenCL
device: the struct layouts, the progressive update, the counters, the inline builtins; the BVH's
kernels are test_kernels_bvh.py's, the photon hash's and the gather's test_kernels_hash.py's."""
import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.oracle import reference as ref
from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import get_device
from ppm_engine.render.photon_map import GRID_DTYPE
from ppm_engine.scene.arrays import CAMERA_DTYPE, LIGHT_DTYPE
from ppm_engine.scene.emitters import EMITTER_INFO_DTYPE
from ppm_engine.scene.materials import KMATERIAL_DTYPE
from tests.helpers.device_buffers import DEVICES, read, upload

pytestmark = pytest.mark.gpu      # every kernel on every OpenCL device found, GPUs included


@pytest.fixture(params=DEVICES, scope="module")
def device(request):
    return get_device(request.param)


def test_struct_layouts_match_dtypes(device):
    out = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 4 * 8)
    device.programs.get("test/debug.cl").struct_sizes(device.queue, (1,), None, out)
    sizes = read(device, out, 8, np.uint32)[:5]
    assert list(sizes) == [LIGHT_DTYPE.itemsize, CAMERA_DTYPE.itemsize, KMATERIAL_DTYPE.itemsize,
                           EMITTER_INFO_DTYPE.itemsize, GRID_DTYPE.itemsize]

# --- progressive update ---------------------------------------------------------------------------
def test_progressive_update_equals_closed_form(device):
    rng = np.random.default_rng(9)
    n = 1000
    valid = (rng.random(n) < 0.9).astype(np.float32)
    M = np.where(rng.random(n) < 0.2, 0, rng.integers(1, 500, n)).astype(np.float32)
    phi = rng.uniform(0, 10, (n, 3)).astype(np.float32)
    beta = rng.uniform(0, 1, (n, 3)).astype(np.float32)
    N = rng.uniform(0, 1000, n).astype(np.float32)
    R = rng.uniform(1e-3, 1, n).astype(np.float32)
    tau = rng.uniform(0, 100, (n, 3)).astype(np.float32)
    alpha = 0.7
    f4 = lambda a, w=0: np.c_[a, np.full(n, w)].astype(np.float32)
    vp_pos = upload(device, np.c_[np.zeros((n, 3)), valid].astype(np.float32))
    bufs = dict(beta=upload(device, f4(beta)), g=upload(device, np.c_[phi, M].astype(np.float32)),
                R=upload(device, R), N=upload(device, N), tau=upload(device, f4(tau)))
    device.programs.get("integrator/progressive.cl").progressive_update(
        device.queue, (n,), None, vp_pos, bufs["beta"], bufs["g"], bufs["R"], bufs["N"],
        bufs["tau"], np.float32(alpha), np.uint32(n))
    M_eff = np.where(valid > 0, M, 0)
    N_ref, R_ref, tau_ref = ref.ppm_update(alpha, M_eff, beta * phi, N, R, tau)
    np.testing.assert_allclose(read(device, bufs["N"], n, np.float32), N_ref, rtol=1e-5)
    np.testing.assert_allclose(read(device, bufs["R"], n, np.float32), R_ref, rtol=1e-5)
    np.testing.assert_allclose(read(device, bufs["tau"], (n, 4), np.float32)[:, :3], tau_ref,
                               rtol=1e-5)
    assert (R_ref <= R + 1e-7).all() and (R_ref[M_eff > 0] < R[M_eff > 0]).all()


def test_counter_table_matches_the_kernel_header():
    """kernels/shared.h (generated) and ppm_engine/render/counters.py state the same indices."""
    import re

    from ppm_engine.render.device import kernel_dir
    text = (kernel_dir() / "shared.h").read_text()
    header = {m[1]: int(m[2]) for m in re.finditer(r"#define CNT_(\w+) (\d+)", text)}
    assert header == {c.name: int(c) for c in Counter}
    assert int(re.search(r"#define N_COUNTERS (\d+)", text)[1]) == N_COUNTERS


def _debug_run(device, kernel, n, inputs, out_shape, out_dtype=np.float32):
    bufs = [upload(device, a) for a in inputs]
    out = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, int(np.prod(out_shape)) * 4)
    getattr(device.programs.get("test/debug.cl"), kernel)(device.queue, (n,), None, *bufs,
                                                        np.uint32(n), out)
    return read(device, out, out_shape, out_dtype)


def test_inline_builtins_equal_numpy(device):
    """kernels/builtins.h (PoCL's builtins as inline code) against NumPy: fmin and fmax keep the
    non-NaN argument, clamp is fmin(fmax), length and normalize hold for vectors whose squared
    length overflows or underflows a float (the library's fallback), the rest to rounding."""
    rng = np.random.default_rng(5)
    n = 4096
    x = rng.normal(size=(n, 4)).astype(np.float32) * 3
    y = rng.normal(size=(n, 4)).astype(np.float32) * 3
    x[:64] *= np.float32(1e25)                    # squared length over FLT_MAX
    x[64:128] *= np.float32(1e-25)                # under FLT_MIN
    x[128:136] = 0.0                              # normalize(0) and length(0)
    x[136:160, 3] = np.nan                        # fmin/fmax: the other argument
    y[160:184, :3] = np.nan
    out = _debug_run(device, "builtins_at", n, [x, y], (n, 8, 4)).astype(np.float64)
    x64, y64, x3 = x.astype(np.float64), y.astype(np.float64), x[:, :3]
    close = dict(rtol=2e-6, atol=1e-6)
    np.testing.assert_array_equal(out[:, 0], np.fmin(x, y))
    np.testing.assert_array_equal(out[:, 1], np.fmax(x, y))
    np.testing.assert_array_equal(out[:, 2, :3], np.fmin(np.fmax(x3, -1), 1))
    ok = np.isfinite(x64[:, 3])
    lo, hi = np.fmin(y[:, 3], 0), np.fmax(y[:, 3], 0)
    np.testing.assert_array_equal(out[ok, 2, 3], np.fmin(np.fmax(x[ok, 3], lo[ok]), hi[ok]))
    fin = np.isfinite(x64).all(1) & np.isfinite(y64).all(1) & (np.abs(x64) < 1e20).all(1)
    mix = x64[:, :3] + (y64[:, :3] - x64[:, :3]) * 0.25
    np.testing.assert_allclose(out[fin, 3, :3], mix[fin], **close)
    np.testing.assert_allclose(out[fin, 3, 3], (x64[:, :3] * y64[:, :3]).sum(1)[fin],
                               rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out[fin, 4, :3], np.cross(x64[:, :3], y64[:, :3])[fin],
                               rtol=1e-5, atol=1e-5)
    norm = np.linalg.norm(x64[:, :3], axis=1)
    np.testing.assert_allclose(out[:, 4, 3], norm, rtol=2e-6)      # tiny and huge ones too
    nz = norm > 0
    np.testing.assert_allclose(out[nz, 5, :3], x64[nz, :3] / norm[nz, None], rtol=2e-6,
                               atol=1e-7)
    np.testing.assert_array_equal(out[128:136, 5, :3], 0.0)
    np.testing.assert_allclose(out[ok, 5, 3], np.sqrt(np.abs(x64[ok, 3])), rtol=1e-6)
    np.testing.assert_array_equal(out[:, 6, :3], np.abs(x3))
    fin4 = fin & np.isfinite(x64[:, 3])
    np.testing.assert_allclose(out[fin4, 6, 3], (x64 * y64).sum(1)[fin4], rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out[:, 7], np.fmin(x, y[:, :1]) + np.fmax(x, y) * np.float32(0.5),
                               rtol=1e-6)


def test_inline_isfinite_equals_numpy(device):
    """isfinite (kernels/builtins.h on PoCL): false for infinities and NaN, true for every finite
    float up to FLT_MAX and the subnormals; 1 for a scalar, -1 for a vector's component."""
    f = np.finfo(np.float32)
    vals = np.array([0.0, -0.0, 1.0, -3.5, f.max, -f.max, f.tiny, f.tiny / 8, np.inf, -np.inf,
                     np.nan, -np.nan, 1e38, 3e38, -1e-45, 7.0], np.float32)
    x = np.stack([np.roll(vals, k) for k in range(4)], axis=1)
    out = _debug_run(device, "isfinite_at", len(x), [x], (len(x), 2, 4))
    fin = np.isfinite(x)
    np.testing.assert_array_equal(out[:, 0, :3], np.where(fin[:, :3], -1.0, 0.0))
    np.testing.assert_array_equal(out[:, 0, 3], np.where(fin[:, 3], 1.0, 0.0))
    np.testing.assert_array_equal(out[:, 1], np.where(fin, -1.0, 0.0))


def test_sincos_in_turns_equals_numpy(device):
    """geometry.h's sincos_turns (the samplers' sin and cos of 2 pi u, reduced in turns) within
    2e-7 of float64's over [-1/8, 1] (the concentric disk map's turns start at -1/8), exactly
    0 and +-1 at the quarter turns."""
    rng = np.random.default_rng(3)
    u = np.concatenate([np.linspace(-0.125, 1.0, 9001), rng.random(8192),
                        [0.0, 0.25, 0.5, 0.75, 1.0, 1e-8, 0.999999]]).astype(np.float32)
    out = _debug_run(device, "sincos_turns_at", len(u), [u], (len(u), 2)).astype(np.float64)
    a = 2 * np.pi * u.astype(np.float64)
    assert np.abs(out[:, 0] - np.sin(a)).max() < 2e-7
    assert np.abs(out[:, 1] - np.cos(a)).max() < 2e-7
    quarter = out[-7:-2]
    np.testing.assert_array_equal(np.abs(quarter), [[0, 1], [1, 0], [0, 1], [1, 0], [0, 1]])
