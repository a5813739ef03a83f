"""The media's sampling functions (kernels/geom/medium.h) against their closed forms: the
Henyey-Greenstein phase function and its sampling, equiangular sampling (kernels/test/volume_test.cl
runs them as the passes call them)."""
import numpy as np
import pytest


@pytest.fixture(scope="module")
def volume_kernels(pocl_key):
    from ppm_engine.render.device import get_device
    device = get_device(pocl_key)
    return device, device.programs.get("test/volume_test.cl")


def _hg(g, x):
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * x) ** 1.5)


@pytest.mark.parametrize("g", [0.0, 0.6, -0.85])
def test_hg_phase_sampling_matches_its_closed_form(volume_kernels, g):
    """hg_phase is the Henyey-Greenstein closed form and integrates to 1 over the sphere;
    hg_sample's directions have the density it reports, and their histogram in the cosine
    follows it (chi-square), their azimuth uniform."""
    import pyopencl as cl
    device, prog = volume_kernels
    q, n = device.queue, 1 << 18
    out = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 16 * n)
    prog.launch("hg_samples", "test")(q, n, 64, g=np.float32(g), seed=np.uint32(3), out=out,
                                      n=np.uint32(n))
    a = np.empty((n, 4), np.float32)
    cl.enqueue_copy(q, a, out)
    c = a[:, 2].astype(np.float64)
    assert np.allclose(np.linalg.norm(a[:, :3], axis=1), 1.0, atol=1e-5)
    assert np.allclose(a[:, 3], _hg(g, c), rtol=1e-3)
    xs = np.linspace(-1, 1, 200001)
    vals = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 4 * xs.size)
    prog.launch("hg_eval", "test")(q, xs.size, 64, g=np.float32(g),
                                   cosines=device.upload(xs.astype(np.float32), "cos"), out=vals,
                                   n=np.uint32(xs.size))
    v = np.empty(xs.size, np.float32)
    cl.enqueue_copy(q, v, vals)
    assert np.allclose(v, _hg(g, xs), rtol=1e-4)
    assert 2 * np.pi * np.trapz(v.astype(np.float64), xs) == pytest.approx(1.0, rel=1e-4)
    edges = np.linspace(-1, 1, 41)
    hist = np.histogram(c, edges)[0]
    f = _hg(g, xs)
    cdf = np.r_[0, np.cumsum(2 * np.pi * np.diff(xs) * 0.5 * (f[1:] + f[:-1]))]
    expect = n * np.diff(np.interp(edges, xs, cdf))
    keep = expect > 20
    chi2 = ((hist[keep] - expect[keep]) ** 2 / expect[keep]).sum()
    assert chi2 < 2.0 * keep.sum(), chi2
    phi = np.arctan2(a[:, 1], a[:, 0])
    assert np.abs(np.histogram(phi, 8)[0] / (n / 8) - 1).max() < 0.02


def test_equiangular_density_matches_its_samples(volume_kernels):
    """equiangular_sample's distances fall on [t0, t] with the density it and equiangular_pdf
    report, which integrates to 1 there (chi-square of their histogram)."""
    import pyopencl as cl
    device, prog = volume_kernels
    q, n, t0, t = device.queue, 1 << 18, 0.5, 5.0
    out = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 16 * n)
    prog.launch("equiangular_samples", "test")(q, n, 64, c=np.float32([0.7, 0.2, 1.5, 0]),
                                               t0=np.float32(t0), t=np.float32(t),
                                               seed=np.uint32(5), out=out, n=np.uint32(n))
    a = np.empty((n, 4), np.float32)
    cl.enqueue_copy(q, a, out)
    s = a[:, 0]
    assert (s >= t0).all() and (s <= t).all()
    assert np.allclose(a[:, 1], a[:, 2], rtol=1e-4)
    D, delta = np.hypot(0.7, 0.2), 1.5
    xs = np.linspace(t0, t, 100001)
    pdf = D / ((np.arctan((t - delta) / D) - np.arctan((t0 - delta) / D))
               * (D * D + (xs - delta) ** 2))
    assert np.trapz(pdf, xs) == pytest.approx(1.0, rel=1e-5)
    assert np.allclose(a[:, 1], np.interp(s, xs, pdf), rtol=1e-3)
    edges = np.linspace(t0, t, 26)
    hist = np.histogram(s, edges)[0]
    cdf = np.r_[0, np.cumsum(np.diff(xs) * 0.5 * (pdf[1:] + pdf[:-1]))]
    expect = n * np.diff(np.interp(edges, xs, cdf))
    chi2 = ((hist - expect) ** 2 / expect).sum()
    assert chi2 < 2.0 * len(expect), chi2
