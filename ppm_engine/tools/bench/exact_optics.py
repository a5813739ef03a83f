"""The scattering and the direction sampling of the exact-geometry references (exact_caustic.py,
exact_pool.py), in NumPy: the exact unpolarised dielectric Fresnel factor, the ball's smooth
glass and its rough (GGX) glass (exact_caustic.py's docstring has the model), both ways out of
a glass vertex with their weights (``glass_split``, the camera's chains of
exact_caustic_camera.py) and the rough glass's kernel evaluated (``rough_glass_eval``, their
next-event estimation), cosine-distributed directions about a normal and uniform ones in a
cone."""
from __future__ import annotations

import numpy as np

IOR = 1.5                        # the ball's glass (scenes.cornell_box.glass's default)


def fresnel(cos_i, eta):
    """Exact unpolarised dielectric Fresnel reflectance for the incidence cosine (> 0) and
    eta = n_incident / n_transmitted; 1 under total internal reflection.  Also cos_t."""
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return np.where(sin2_t >= 1.0, 1.0, 0.5 * (rs * rs + rp * rp)), cos_t


def glass_scatter(d, n, inside, u):
    """Reflect or refract unit directions d at the ball (outward normals n) with the Fresnel
    probability; u uniform in [0, 1).  (new directions, reflected?, inside afterwards)."""
    cos_o = -np.einsum("ij,ij->i", d, n)              # > 0 from outside
    nf = np.where((cos_o > 0)[:, None], n, -n)         # the normal on the incident side
    cos_i = np.abs(cos_o)
    eta = np.where(inside, IOR, 1.0 / IOR)
    f, cos_t = fresnel(cos_i, eta)
    refl = u < f
    r = d + 2.0 * cos_i[:, None] * nf
    t = eta[:, None] * d + (eta * cos_i - cos_t)[:, None] * nf
    out = np.where(refl[:, None], r, t)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    return out, refl, np.where(refl, inside, ~inside)


def _frame(n):
    """Two unit tangents completing each unit normal (rows) to an orthonormal frame (Duff et
    al.'s branchless construction)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t = np.stack([1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], 1)
    bt = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], 1)
    return t, bt


def smith_lambda(cos, alpha):
    """Smith's Lambda of the isotropic GGX distribution (alpha: roughness squared) for
    directions at |cos| to the macro normal."""
    c2 = np.maximum(cos * cos, 1e-300)
    tan2 = np.maximum(1.0 - c2, 0.0) / c2
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)


def ggx_visible_normals(wl, alpha, u1, u2):
    """Microfacet normals (local frame, z the macro normal) distributed as the GGX
    distribution's normals visible from the local directions wl (z > 0): Heitz 2018, "Sampling
    the GGX distribution of visible normals" (stretch, sample the projected hemisphere,
    unstretch)."""
    vh = np.stack([alpha * wl[:, 0], alpha * wl[:, 1], wl[:, 2]], 1)
    vh /= np.linalg.norm(vh, axis=1, keepdims=True)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = np.where(lensq > 0, 1.0 / np.sqrt(np.maximum(lensq, 1e-300)), 0.0)
    t1 = np.where((lensq > 0)[:, None],
                  np.stack([-vh[:, 1] * inv, vh[:, 0] * inv, np.zeros_like(lensq)], 1),
                  np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(vh, t1)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + s * p2
    nh = (p1[:, None] * t1 + p2[:, None] * t2
          + np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))[:, None] * vh)
    m = np.stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(nh[:, 2], 0.0)], 1)
    return m / np.linalg.norm(m, axis=1, keepdims=True)


def rough_glass_scatter(d, n, inside, u, alpha, rng):
    """A rough dielectric (GGX of ``alpha``, Smith height-correlated shadowing, exact Fresnel,
    no multiple-scattering compensation) for photons along unit d at the ball (outward normals
    n): a microfacet normal visible from where the photon came from (Heitz 2018), then
    reflection or refraction about it with the Fresnel probability.  The photon's flux is
    multiplied by G2(i, o) / G1(i), the estimator's weight for flux (no eta^2: photons carry
    flux, not radiance); directions on the wrong side of the macro surface get weight 0.
    (new directions, reflected?, inside afterwards, weights)."""
    wi = -d
    cos_o = np.einsum("ij,ij->i", wi, n)
    nf = np.where((cos_o > 0)[:, None], n, -n)         # the normal on the incident side
    t, b = _frame(nf)
    wl = np.stack([np.einsum("ij,ij->i", wi, t), np.einsum("ij,ij->i", wi, b),
                   np.abs(cos_o)], 1)
    ml = ggx_visible_normals(wl, alpha, rng.random(d.shape[0]), rng.random(d.shape[0]))
    m = ml[:, :1] * t + ml[:, 1:2] * b + ml[:, 2:3] * nf
    cos_im = np.maximum(np.einsum("ij,ij->i", wi, m), 0.0)
    eta = np.where(inside, IOR, 1.0 / IOR)
    f, cos_t = fresnel(cos_im, eta)
    refl = u < f
    r = 2.0 * cos_im[:, None] * m - wi
    tr = -eta[:, None] * wi + (eta * cos_im - cos_t)[:, None] * m
    out = np.where(refl[:, None], r, tr)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    cos_out = np.einsum("ij,ij->i", out, nf)
    valid = np.where(refl, cos_out > 0, cos_out < 0)
    li, lo = smith_lambda(np.abs(cos_o), alpha), smith_lambda(np.abs(cos_out), alpha)
    weight = np.where(valid, (1.0 + li) / (1.0 + li + lo), 0.0)
    return out, refl, np.where(refl, inside, ~inside), weight


def glass_split(d, n, inside, alpha, rng=None):
    """Both ways a ray along unit d leaves the ball's glass (outward normals n), each with its
    weight: the expectation of glass_scatter's (alpha 0) or rough_glass_scatter's random choice
    between reflection and refraction, taken exactly.  Smooth: F and 1 - F about n.  Rough
    (GGX of ``alpha``): one microfacet normal m visible from where the ray came from (Heitz
    2018, drawn from ``rng``), then F(m) G2 / G1 reflected and (1 - F(m)) G2 / G1 refracted
    about it, 0 on the wrong side of the macro surface.  (reflected directions, their weights,
    refracted directions, their weights); reflected rays stay on their side, refracted cross."""
    wi = -d
    cos_o = np.einsum("ij,ij->i", wi, n)
    nf = np.where((cos_o > 0)[:, None], n, -n)         # the normal on the incident side
    if alpha > 0.0:
        t, b = _frame(nf)
        wl = np.stack([np.einsum("ij,ij->i", wi, t), np.einsum("ij,ij->i", wi, b),
                       np.abs(cos_o)], 1)
        ml = ggx_visible_normals(wl, alpha, rng.random(d.shape[0]), rng.random(d.shape[0]))
        m = ml[:, :1] * t + ml[:, 1:2] * b + ml[:, 2:3] * nf
    else:
        m = nf
    cos_im = np.maximum(np.einsum("ij,ij->i", wi, m), 0.0)
    eta = np.where(inside, IOR, 1.0 / IOR)
    with np.errstate(divide="ignore", invalid="ignore"):     # m seen edge-on: weight 0
        f, cos_t = fresnel(cos_im, eta)
    f = np.nan_to_num(f, nan=1.0)
    r = 2.0 * cos_im[:, None] * m - wi
    tr = -eta[:, None] * wi + (eta * cos_im - cos_t)[:, None] * m
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    tr /= np.maximum(np.linalg.norm(tr, axis=1, keepdims=True), 1e-300)
    if alpha <= 0.0:
        return r, f, tr, 1.0 - f
    li = smith_lambda(np.abs(cos_o), alpha)
    cr, ct = np.einsum("ij,ij->i", r, nf), np.einsum("ij,ij->i", tr, nf)
    wr = np.where(cr > 0, f * (1.0 + li) / (1.0 + li + smith_lambda(cr, alpha)), 0.0)
    wt = np.where((ct < 0) & (f < 1.0),
                  (1.0 - f) * (1.0 + li) / (1.0 + li + smith_lambda(ct, alpha)), 0.0)
    return r, wr, tr, wt


def rough_glass_eval(a, b, n, alpha):
    """The kernel rough_glass_scatter samples, evaluated: f(a -> b) |b.n| for a ray that came
    from unit direction a (towards where it came from) leaving along unit b, at the ball's
    surface of outward normals n (the ray outside where a.n > 0): Walter et al. 2007's rough
    dielectric (GGX of ``alpha``, Smith's height-correlated G2, the exact Fresnel factor) in the
    form whose samples rough_glass_scatter draws (tests/test_exact_caustic.py checks the two
    against the BSDF written out in full)."""
    ca = np.einsum("ij,ij->i", a, n)
    outside = ca > 0
    nf = np.where(outside[:, None], n, -n)
    ca = np.abs(ca)
    cb = np.einsum("ij,ij->i", b, nf)
    refl = cb > 0
    eta_a = np.where(outside, 1.0, IOR)
    eta_o = np.where(outside, IOR, 1.0)                 # the other side's
    eta_p = np.where(refl, 1.0, eta_o / eta_a)          # b's side over a's
    m = np.where(refl[:, None], a + b, a + eta_p[:, None] * b)
    m /= np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)
    m *= np.where(np.einsum("ij,ij->i", m, nf) < 0, -1.0, 1.0)[:, None]
    cm = np.einsum("ij,ij->i", m, nf)
    dist = alpha * alpha / (np.pi * (cm * cm * (alpha * alpha - 1.0) + 1.0) ** 2)
    g2 = 1.0 / (1.0 + smith_lambda(ca, alpha) + smith_lambda(np.abs(cb), alpha))
    am, bm = np.einsum("ij,ij->i", m, a), np.einsum("ij,ij->i", m, b)
    with np.errstate(divide="ignore", invalid="ignore"):     # m edge-on: weight 0 below
        f, _ = fresnel(np.clip(am, 0.0, 1.0), eta_a / eta_o)
    fr = f * dist * g2 / (4.0 * ca)
    with np.errstate(divide="ignore", invalid="ignore"):
        ft = (1.0 - f) * dist * g2 * np.abs(bm * am) / (ca * (bm + am / eta_p) ** 2)
    ok = (am > 0) & np.where(refl, bm > 0, bm < 0) & (ca > 0)
    return np.where(ok, np.where(refl, fr, ft), 0.0)


def cosine_dirs(n, rng):
    """Cosine-distributed unit directions about the unit normals n (rows)."""
    k = n.shape[0]
    u1, u2 = rng.random(k), rng.random(k)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], 1)
    t, bt = _frame(n)
    return local[:, :1] * t + local[:, 1:2] * bt + local[:, 2:3] * n


def cone_dirs(axis, cos_max, k, rng):
    """k unit directions uniform in the cone of half-angle acos(cos_max) about ``axis``."""
    cz = 1.0 - rng.random(k) * (1.0 - cos_max)
    sz = np.sqrt(np.maximum(1.0 - cz * cz, 0.0))
    phi = 2.0 * np.pi * rng.random(k)
    a = np.asarray(axis, float)
    t = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
    t /= np.linalg.norm(t)
    b = np.cross(a, t)
    return (sz * np.cos(phi))[:, None] * t + (sz * np.sin(phi))[:, None] * b + cz[:, None] * a
