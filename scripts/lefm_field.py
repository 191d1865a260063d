"""The failure criteria of peristat evaluated on the continuum (LEFM) field of a closed,
frictional, straight crack in a uniaxially compressed infinite plate (issue 14,
docs/verification.md "Frictional crack initiation"). Used by scripts/lefm-start-load.

The field: the remote uniaxial compression sigma along y, plus the perturbation of a
traction-free crack loaded by the effective shear tau_eff = tau - f_c sigma_n (Westergaard,
mode II, plane stress). The faces stay closed and slide with the friction stress f_c sigma_n;
when tau_eff <= 0 they stick and the field is uniform.

The criterion is a replica of src/materials/failure.cpp (critical stretch, critical skew with
the reference bond the intact family bond closest to the crack direction, the offset across it
floored at |xi| sin(min_angle)) on the lattice of the case ((i + 1/2) dx, partial-area stencil,
bonds crossing the crack removed). `replica_peak` evaluates it on a displacement field given
per particle, so that the script can check the replica against the program's own
criterion_peak on every probe.
"""

import math

import numpy as np

E, NU = 10.0e9, 0.3
MU = E / (2 * (1 + NU))
KOLOSOV = (3 - NU) / (1 + NU)
BULK_2D = E / (2 * (1 - NU))


def set_poisson(nu):
    """Poisson's ratio of the field and of the criteria (plane stress), for runs that change it."""
    global NU, MU, KOLOSOV, BULK_2D
    NU, MU, KOLOSOV, BULK_2D = nu, E / (2 * (1 + nu)), (3 - nu) / (1 + nu), E / (2 * (1 - nu))


SKEW_SCALE = 1.0  # failure.skew_scale of the runs (docs/theory/failure.md, "A boundary-layer calibration")


def set_skew_scale(scale):
    """The critical skew's calibration factor, for runs that set failure.skew_scale."""
    global SKEW_SCALE
    SKEW_SCALE = scale


def critical(criterion, g_c, delta):
    if criterion == "skew":
        return SKEW_SCALE * math.sqrt(75 * math.pi * g_c / (64 * MU * delta))
    return math.sqrt(g_c / ((6 * MU / math.pi + 16 * (BULK_2D - 2 * MU) / (9 * math.pi ** 2)) * delta))


def stencil(m):
    """Offsets whose cell overlaps the disc of radius m (the partial-area stencil)."""
    reach = math.ceil(m + 0.5)
    out = []
    for i in range(-reach, reach + 1):
        for j in range(-reach, reach + 1):
            if (i, j) == (0, 0):
                continue
            nx, ny = max(abs(i) - 0.5, 0.0), max(abs(j) - 0.5, 0.0)
            if nx * nx + ny * ny < m * m:
                out.append((i, j))
    return np.array(out, float)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def cut_mask(x, q, p0, p1):
    """Bonds x -> q (q: array of ends) crossing the segment p0-p1 (model.cpp's rule)."""
    d = p1 - p0
    sp = _cross(d, x - p0)
    sq = _cross(d, q - p0)
    opposite = (sp >= 0) != (sq >= 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        cross_pt = x + (q - x) * (sp / (sp - sq))[:, None]
        u = ((cross_pt - p0) @ d) / (d @ d)
    return opposite & (u >= 0) & (u <= 1)


def family_values(xi, eta, criterion, direction, min_sin):
    """Criterion value of every bond of one family (intact bonds only)."""
    lens = np.linalg.norm(xi, axis=1)
    if criterion == "stretch":
        return np.linalg.norm(xi + eta, axis=1) / lens - 1.0
    d = direction / np.linalg.norm(direction)
    cosv = np.abs(xi @ d) / lens
    # the closest direction, the shortest of equally close ones (tolerance as in failure.cpp)
    best, r = -1.0, -1
    for b in range(len(xi)):
        if cosv[b] > best + 1e-12 or (abs(cosv[b] - best) <= 1e-12 and lens[b] < lens[r]):
            best, r = cosv[b], b
    x0, y0 = xi[r], xi[r] + eta[r]
    beta = math.atan2(y0[1], y0[0]) - math.atan2(x0[1], x0[0])
    c, s = math.cos(beta), math.sin(beta)
    e1 = x0 / lens[r]
    e2 = np.array([-e1[1], e1[0]])
    y = xi + eta
    back = np.stack([c * y[:, 0] + s * y[:, 1], -s * y[:, 0] + c * y[:, 1]], axis=1)
    along = np.abs((back - xi) @ e1)
    across = np.abs(xi @ e2)
    if min_sin > 0:
        return along / np.maximum(across, min_sin * lens)
    return np.where(across < 1e-9 * lens, 0.0, along / np.where(across < 1e-9 * lens, 1.0, across))


def replica_peak(positions, displacement, dx, m, p0, p1, criterion, g_c, direction, min_sin, radius):
    """Largest criterion / critical over the intact bonds of the particles within `radius` of
    either crack tip. `displacement(points)` returns the displacement at lattice points
    (an array of points -> array of vectors)."""
    offs = stencil(m) * dx
    crit = critical(criterion, g_c, m * dx)
    peak = 0.0
    for tip in (p0, p1):
        near = positions[np.linalg.norm(positions - tip, axis=1) < radius]
        for x in near:
            q = x + offs
            keep = ~cut_mask(x, q, p0, p1)
            q = q[keep]
            u = displacement(np.vstack([x[None, :], q]))
            vals = family_values(q - x, u[1:] - u[0], criterion, direction, min_sin)
            peak = max(peak, float(vals.max()) / crit)
    return peak


def continuum_displacement(points, centre, theta, f_c, a, sigma, load="uniaxial"):
    """LEFM displacement at `points` (global), crack of half-length a at `centre` along
    t = (cos theta, -sin theta), remote uniaxial compression sigma (> 0) along y; with
    load = "shear", a remote pure shear sigma on the crack's plane and no normal stresses."""
    t = np.array([math.cos(theta), -math.sin(theta)])
    n = np.array([math.sin(theta), math.cos(theta)])
    xl = (points - centre) @ t
    yl = (points - centre) @ n
    s_nn = -sigma * math.cos(theta) ** 2
    s_tt = -sigma * math.sin(theta) ** 2
    tau = sigma * math.sin(theta) * math.cos(theta)
    if load == "shear":
        s_nn, s_tt, tau = 0.0, 0.0, sigma
    tau_eff = max(0.0, tau + f_c * s_nn)
    # uniform part: the normal and parallel stresses, and the shear the faces carry
    e_tt = (s_tt - NU * s_nn) / E
    e_nn = (s_nn - NU * s_tt) / E
    ut = e_tt * xl + (tau - tau_eff) / MU * yl
    un = e_nn * yl
    if tau_eff > 0:
        z = xl + 1j * yl
        root = np.sqrt(z - a) * np.sqrt(z + a)  # branch cut on the crack, ~ z far away
        Z = tau_eff * z / root
        Zhat = tau_eff * root
        ut = ut + ((KOLOSOV + 1) / 2 * Zhat.imag + yl * Z.real) / (2 * MU)
        un = un + (-(KOLOSOV - 1) / 2 * Zhat.real - yl * Z.imag) / (2 * MU)
    return np.outer(ut, t) + np.outer(un, n)


def lattice_near_tips(dx, p0, p1, radius):
    """Lattice points (i + 1/2) dx within radius + 4 dx of either tip."""
    pts = []
    for tip in (p0, p1):
        lo = np.floor((tip - radius - 4 * dx) / dx - 0.5).astype(int)
        hi = np.ceil((tip + radius + 4 * dx) / dx - 0.5).astype(int)
        ii, jj = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij")
        pts.append(np.stack([(ii.ravel() + 0.5) * dx, (jj.ravel() + 0.5) * dx], axis=1))
    return np.unique(np.vstack(pts), axis=0)


def continuum_start(dx, m, centre, theta, f_c, a, criterion, g_c, min_sin, load="uniaxial"):
    """Remote stress at which the criterion, evaluated on the LEFM field, first reaches 1."""
    t = np.array([math.cos(theta), -math.sin(theta)])
    p0, p1 = centre - a * t, centre + a * t
    radius = 2 * m * dx
    pts = lattice_near_tips(dx, p0, p1, radius)
    sigma = 1.0e6
    peak = replica_peak(pts, lambda q: continuum_displacement(q, centre, theta, f_c, a, sigma, load), dx, m, p0, p1,
                        criterion, g_c, t, min_sin, radius)
    return sigma / peak
