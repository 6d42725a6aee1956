"""Three equal spheres: separate bridges (exact doublets), coalescence, pair forces.

Uncoalesced triplet
-------------------
Without gravity each separate bridge between grains i and j is an axisymmetric doublet,
solved exactly by :func:`capbridge.solvers.young_laplace.solve_doublet` (its contact
angles are those of grains i and j).  A bridge of force F* pulls grain i towards j and j
towards i; the vector forces on the grains are the sums over the bridges (Miot et al.
2021, section 3.2: "simple addition of the vertical components of the axial capillary
force of the two inclined bridges").

Coalescence (when separate bridges stop being separate)
-------------------------------------------------------
Three geometric criteria, all evaluated on the exact shapes; the coalescence volume is
the smallest total volume at which any of them is met:

``caps``      two bridges on a shared grain i (to j and k) whose wetted caps meet:
              beta_ij + beta_ik >= angle jik, the angle between the centre lines at i
              (the paper's criterion beta = alpha for its symmetric top grain).
``grain``     the free surface of bridge i-j reaches the third grain k (the distance
              from the meridian to k's centre, in the meridian half-plane, falls to 1).
``menisci``   the free surfaces of two bridges meet away from the grains (a point of
              one bridge's free surface enters the other bridge's liquid).  Near the
              shared grain this happens together with ``caps`` (the surfaces leave the
              grain from the contact lines); it comes first only for bulging bridges.

Each criterion is a *margin* m(V), negative while the bridges are apart, zero when they
meet; the root is bracketed on a geometric scan of the total volume and refined by
Brent's method.  The volume is shared between the bridges by ``fractions`` (equal by
default).

Pair forces
-----------
Without gravity the forces on the three grains lie in their plane, sum to zero and have
zero torque, so they are exactly three effective pair forces f_ij along the centre lines
(``DESIGN.md``).  :func:`pair_forces` solves the 9 x 3 linear system in the least-squares
sense and reports the residual, which measures how far the input is from such a set.

Conventions: lengths / r, V* = V / r^3, F* = F / (2 pi gamma r), attraction > 0, angles
in degrees at the interface, grains numbered 1, 2, 3 in user-facing text and 0, 1, 2 in
arrays.
"""
from __future__ import annotations

import dataclasses
import itertools

import numpy as np
from scipy.optimize import brentq

from capbridge.dimensionless import opening_angle, triplet_centres
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError, check_range

# the exact meridian of a doublet, used by the coalescence criteria (and kept importable
# from here, where it was first)
from capbridge.solvers.young_laplace import bridge_meridian

__all__ = [
    "TripletGeometry",
    "triplet_geometry",
    "table_frame",
    "parse_bridges",
    "uncoalesced_state",
    "bridge_meridian",
    "coalescence_margins",
    "find_coalescence",
    "CoalescenceResult",
    "pair_forces",
    "pair_direction_matrix",
    "CRITERIA",
]

#: criterion name -> description (JSON output, reports)
CRITERIA = {
    "caps": "wetted caps of two bridges meet on a shared grain i: "
            "beta_ij + beta_ik = angle jik (Miot et al. 2021: beta = alpha)",
    "grain": "free surface of a bridge reaches the third grain",
    "menisci": "free surfaces of two bridges meet away from the grains",
}


# --------------------------------------------------------------------------------------
# geometry
# --------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class TripletGeometry:
    """Three unit spheres; ``gaps[(i, j)]`` (i < j, 0-based) between surfaces.

    ``centres`` (3, 3): grains 2 and 3 (indices 1, 2) on the x axis, symmetric about
    x = 0, grain 1 (index 0) above them (z > 0) in the plane y = 0, so that gravity
    along -z is "down" as in the experiment of Miot et al. (2021), Fig. 4.
    """

    d12: float
    d13: float
    d23: float
    centres: np.ndarray

    @property
    def gaps(self):
        return {(0, 1): self.d12, (0, 2): self.d13, (1, 2): self.d23}

    def gap(self, i, j):
        return self.gaps[tuple(sorted((i, j)))]

    def axis(self, i, j):
        """Unit vector from the centre of grain i to that of grain j."""
        v = self.centres[j] - self.centres[i]
        return v / np.linalg.norm(v)

    def angle_at(self, i, j, k):
        """Angle jik [deg] at grain i between the centre lines to j and to k."""
        return float(np.degrees(opening_angle(self.gap(i, j), self.gap(i, k),
                                              self.gap(j, k))))

    def as_dict(self):
        return {"d12": self.d12, "d13": self.d13, "d23": self.d23,
                "centres": np.round(self.centres, 12).tolist()}


def triplet_geometry(d12, d13, d23):
    """:class:`TripletGeometry` from the three gaps d* (>= 0, forming a triangle).

    >>> g = triplet_geometry(0.175, 0.175, 0.075)
    >>> round(g.angle_at(0, 1, 2) / 2, 2)      # the paper's opening angle alpha
    28.49
    """
    d = [float(check_range(name, v, 0.0, 10.0, hint="gap between sphere surfaces / r; "
                           "overlapping grains are not supported"))
         for name, v in (("d12", d12), ("d13", d13), ("d23", d23))]
    try:    # grain 2 at the origin, grain 3 on +x, grain 1 at y > 0 ...
        p = triplet_centres(d[2], d[0], d[1])
    except ValueError:
        raise CapbridgeInputError(f"gaps {d} do not form a triangle of centres") from None
    # ... moved to this frame: grains 2 and 3 symmetric about x = 0, grain 1 at z > 0
    half = 0.5 * p[1, 0]
    centres = np.array([[p[2, 0] - half, 0.0, p[2, 1]], [-half, 0.0, 0.0],
                        [half, 0.0, 0.0]])
    return TripletGeometry(d[0], d[1], d[2], centres)


def table_frame(centres):
    """Rotation Q (..., 3, 3) from the table frame of a triplet to the caller's frame.

    The table frame is that of :func:`triplet_geometry`, in which the triplet tables are
    computed: grains 2 and 3 on the x axis (grain 3 at +x), grain 1 at z > 0 and the
    centres in the plane y = 0.  The columns of Q are its axes in the caller's frame:

        e_x = (c3 - c2) / |c3 - c2|,   e_z = the part of c1 - c2 normal to e_x, normalised,
        e_y = e_z x e_x,

    so a vector u_t of the table frame is Q u_t in the caller's, and det Q = +1.

    Parameters
    ----------
    centres : array_like (..., 3, 3)
        Centres of grains 1, 2, 3 (rows) in the caller's frame (any unit).

    >>> np.allclose(table_frame(triplet_geometry(0.1, 0.05, 0.2).centres), np.eye(3))
    True
    """
    c = np.asarray(centres, float)
    ex = c[..., 2, :] - c[..., 1, :]
    ex = ex / np.linalg.norm(ex, axis=-1, keepdims=True)
    a = c[..., 0, :] - c[..., 1, :]
    ez = a - np.sum(a * ex, -1, keepdims=True) * ex
    ez = ez / np.linalg.norm(ez, axis=-1, keepdims=True)
    ey = np.cross(ez, ex)
    return np.stack([ex, ey, ez], -1)


def parse_bridges(spec):
    """Bridge layout "12,13" (1-based grain pairs) -> [(0, 1), (0, 2)].

    >>> parse_bridges("12,13,23")
    [(0, 1), (0, 2), (1, 2)]
    """
    if isinstance(spec, str):
        items = [s.strip() for s in spec.replace(";", ",").split(",") if s.strip()]
        pairs = []
        for s in items:
            s = s.replace("-", "")
            if len(s) != 2 or not s.isdigit():
                raise CapbridgeInputError(
                    f"bridge {s!r}: give grain pairs as two digits 1-3, e.g. 12,13,23")
            pairs.append((int(s[0]) - 1, int(s[1]) - 1))
    else:
        pairs = [tuple(int(k) for k in p) for p in spec]
    out = []
    for p in pairs:
        if len(p) != 2 or p[0] == p[1] or min(p) < 0 or max(p) > 2:
            raise CapbridgeInputError(f"bridge {''.join(str(k + 1) for k in p)} is not a pair of "
                                      "distinct grains among 1-3")
        q = tuple(sorted(p))
        if q in out:
            raise CapbridgeInputError(f"bridge {q[0] + 1}{q[1] + 1} listed twice")
        out.append(q)
    if not out:
        raise CapbridgeInputError("no bridge given")
    return out


def contact_angles(theta):
    return np.broadcast_to(check_range("contact angle theta", theta, 0.0, 90.0, high_open=True,
                                       units=" deg", hint="the exact doublet solver covers "
                                       "0 <= theta < 90 deg"), (3,)).astype(float)


def volume_fractions(fractions, n):
    if fractions is None:
        return np.full(n, 1.0 / n)
    f = np.atleast_1d(check_range("volume fraction", fractions, 0.0, np.inf, low_open=True))
    if f.size != n:
        raise CapbridgeInputError(f"{f.size} volume fractions given for {n} bridges")
    return f / f.sum()


# --------------------------------------------------------------------------------------
# separate bridges (exact doublets)
# --------------------------------------------------------------------------------------


def uncoalesced_state(volume, geom, theta, bridges=((0, 1), (0, 2)), fractions=None):
    """Separate bridges holding ``fractions`` of the total volume ``volume`` (array ok).

    Returns a dict with, per bridge (key ``(i, j)``), the exact doublet result
    (``bridge[(i, j)]``: force, pressure, beta on grain i and j [deg], energy, status,
    volume), the vector forces on the grains ``forces`` (..., 3, 3), the summed energy
    ``energy`` (E* = sum of A - cos(theta) A_wet) and ``status`` (CONVERGED only where
    every bridge converged; RUPTURED where a bridge does not exist).
    """
    from capbridge.solvers.young_laplace import solve_doublet

    bridges = parse_bridges(bridges)
    t = contact_angles(theta)
    w = volume_fractions(fractions, len(bridges))
    V = np.asarray(check_range("total volume V*", volume, 0.0, np.inf, low_open=True))
    shape = V.shape
    forces = np.zeros(shape + (3, 3))
    energy = np.zeros(shape)
    status = np.full(shape, int(Status.CONVERGED), np.int8)
    per = {}
    cache = {}
    for (i, j), wb in zip(bridges, w):
        key = (geom.gap(i, j), t[i], t[j], wb)     # mirror-image bridges: solved once
        if key not in cache:
            cache[key] = {k: np.asarray(v) for k, v in
                          solve_doublet(geom.gap(i, j), V * wb, t[i], 1.0, t[j]).items()}
        r = cache[key]
        per[(i, j)] = {"force": r["force"], "pressure": r["pressure"], "beta_i": r["beta1"],
                       "beta_j": r["beta2"], "energy": r["energy"], "status": r["status"],
                       "volume": V * wb, "neck_radius": r["neck_radius"]}
        u = geom.axis(i, j)
        ok = r["status"] == Status.CONVERGED
        F = np.where(ok, r["force"], 0.0)
        forces[..., i, :] += F[..., None] * u
        forces[..., j, :] -= F[..., None] * u
        energy = energy + np.where(ok, r["energy"], 0.0)
        status = np.where(~ok & (status == Status.CONVERGED), r["status"], status)
    return {"bridge": per, "forces": forces, "energy": np.where(status == 0, energy, np.nan),
            "status": status, "volume": V, "bridges": bridges, "fractions": w}


# --------------------------------------------------------------------------------------
# coalescence criteria
# --------------------------------------------------------------------------------------


def _frame(geom, i, j):
    u = geom.axis(i, j)
    helper = np.array([0.0, 1.0, 0.0]) if abs(u[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    return geom.centres[i], u, e1, e2


def _to_meridian_plane(points, origin, u):
    p = points - origin
    x = p @ u
    rho = np.sqrt(np.maximum(np.einsum("...i,...i->...", p, p) - x * x, 0.0))
    return x, rho


def _grain_margin(geom, bridge, x, y, k):
    """1 - (distance from the free surface of ``bridge`` to the centre of grain k)."""
    c, u, _, _ = _frame(geom, *bridge)
    xk, rk = _to_meridian_plane(geom.centres[k][None], c, u)
    return float(1.0 - np.min(np.hypot(x - xk[0], y - rk[0])))


def _menisci_margin(geom, bA, prof_A, bB, prof_B, n_phi=48, stride=4):
    """Largest depth (in r) of a free-surface point of bridge A inside bridge B's liquid,
    measured radially from B's axis (negative: the largest clearance).  A's surface is
    sampled on every ``stride``-th meridian point (and both ends) x ``n_phi`` azimuths
    plus the two in the plane of the centres."""
    xa, ya = prof_A
    keep = np.unique(np.r_[np.arange(0, len(xa), stride), len(xa) - 1])
    xa, ya = xa[keep], ya[keep]
    xb, yb = prof_B
    if np.any(np.diff(xb) <= 0):
        raise ValueError("meridian not single-valued in x (cannot test the liquid region)")
    cA, uA, e1, e2 = _frame(geom, *bA)
    cB, uB, _, _ = _frame(geom, *bB)
    # azimuths: a grid plus the two in the plane of the centres (mirror plane)
    normal = np.cross(geom.centres[1] - geom.centres[0], geom.centres[2] - geom.centres[0])
    normal /= np.linalg.norm(normal)
    inplane = np.cross(normal, uA)
    phi0 = np.arctan2(inplane @ e2, inplane @ e1)
    phi = np.concatenate([np.linspace(0, 2 * np.pi, n_phi, endpoint=False), [phi0, phi0 + np.pi]])
    dirs = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2          # (nphi, 3)
    P = cA + xa[None, :, None] * uA + ya[None, :, None] * dirs[:, None, :]  # (nphi, n, 3)
    x, rho = _to_meridian_plane(P.reshape(-1, 3), cB, uB)
    inside = (x > xb[0]) & (x < xb[-1])
    if not np.any(inside):
        return -np.inf
    yB = np.interp(x[inside], xb, yb)
    return float(np.max(yB - rho[inside]))


def coalescence_margins(volume, geom, theta, bridges=((0, 1), (0, 2)), fractions=None,
                        shapes=True):
    """Margins of every coalescence criterion at total volume ``volume`` (scalar).

    Returns (state, margins) with ``margins`` a list of dicts ``{"criterion", "where",
    "margin", "units"}``; margins are < 0 while the bridges are apart.  ``caps`` margins
    are in degrees (beta_ij + beta_ik - angle jik), the others in units of r.  Where a
    bridge does not exist (ruptured or not converged) its margins are NaN.
    """
    bridges = parse_bridges(bridges)
    t = contact_angles(theta)
    st = uncoalesced_state(float(volume), geom, t, bridges, fractions)
    return st, _margins(st, geom, t, bridges, shapes)


def _at(st, n):
    """The state of one volume out of a vectorised :func:`uncoalesced_state`."""
    return {"bridge": {b: {k: (v[n] if np.ndim(v) else v) for k, v in r.items()}
                       for b, r in st["bridge"].items()}}


def _shared_grains(bridges):
    """(bA, bB, g, j, k) for every two bridges g-j and g-k sharing a grain g."""
    for bA, bB in itertools.combinations(bridges, 2):
        shared = set(bA) & set(bB)
        if shared:
            g = shared.pop()
            yield bA, bB, g, (bA[1] if bA[0] == g else bA[0]), (bB[1] if bB[0] == g else bB[0])


def _margins(st, geom, t, bridges, shapes=True):
    out = []
    # caps meeting on shared grains
    for bA, bB, g, j, k in _shared_grains(bridges):
        rA, rB = st["bridge"][bA], st["bridge"][bB]
        betaA = float(rA["beta_i"] if bA[0] == g else rA["beta_j"])
        betaB = float(rB["beta_i"] if bB[0] == g else rB["beta_j"])
        ok = rA["status"] == Status.CONVERGED and rB["status"] == Status.CONVERGED
        m = betaA + betaB - geom.angle_at(g, j, k) if ok else np.nan
        out.append({"criterion": "caps", "where": f"grain {g + 1} (bridges "
                    f"{bA[0] + 1}{bA[1] + 1}, {bB[0] + 1}{bB[1] + 1})", "margin": m,
                    "units": "deg", "grains": (g, j, k), "bridges": (bA, bB)})
    if not shapes:
        return out
    profiles = {}
    for b in bridges:
        r = st["bridge"][b]
        if r["status"] != Status.CONVERGED:
            continue
        try:
            profiles[b] = bridge_meridian(geom.gap(*b), r["pressure"], r["beta_i"],
                                          r["beta_j"], t[b[0]], t[b[1]])
        except ValueError:
            continue
    for b in bridges:
        for k in sorted(set(range(3)) - set(b)):
            m = _grain_margin(geom, b, *profiles[b], k) if b in profiles else np.nan
            out.append({"criterion": "grain", "where": f"bridge {b[0] + 1}{b[1] + 1} "
                        f"reaching grain {k + 1}", "margin": m, "units": "r",
                        "bridges": (b,), "grains": (k,)})
    for bA, bB in itertools.combinations(bridges, 2):
        if bA in profiles and bB in profiles:
            try:
                m = max(_menisci_margin(geom, bA, profiles[bA], bB, profiles[bB]),
                        _menisci_margin(geom, bB, profiles[bB], bA, profiles[bA]))
            except ValueError:
                m = np.nan
        else:
            m = np.nan
        out.append({"criterion": "menisci", "where": f"bridges {bA[0] + 1}{bA[1] + 1} and "
                    f"{bB[0] + 1}{bB[1] + 1}", "margin": m, "units": "r",
                    "bridges": (bA, bB)})
    return out


@dataclasses.dataclass
class CoalescenceResult:
    """Outcome of :func:`find_coalescence` (volumes are totals, V* = V / r^3)."""

    status: str                    # "coalescence" | "none_found"
    V_coal: float                  # smallest volume over the criteria (NaN if none)
    criterion: str                 # name of the criterion met first ("" if none)
    where: str
    criteria: list                 # every criterion: volume at which it is met (or NaN)
    beta: dict                     # "ij" -> {"grain i": deg, "grain j": deg} at V_coal
    forces: dict                   # "ij" -> F* of each bridge at V_coal
    grain_forces: list             # (3, 3) vector forces on the grains at V_coal
    opening_angles: dict           # "grain g": angle jik [deg] at shared grains
    theta: list
    bridges: list
    fractions: list
    pressure: dict
    energy: float                  # sum of the doublet energies at V_coal
    scan: dict                     # volumes and margins of the bracketing scan

    def as_dict(self):
        d = dataclasses.asdict(self)
        d.pop("scan")
        return d


def _margin_fn(geom, t, bridges, fractions, crit, where):
    def f(V):
        _, ms = coalescence_margins(V, geom, t, bridges, fractions,
                                    shapes=(crit != "caps"))
        for m in ms:
            if m["criterion"] == crit and m["where"] == where:
                return m["margin"]
        return np.nan
    return f


def find_coalescence(geom, theta, bridges=((0, 1), (0, 2)), fractions=None, v_min=None,
                     v_max=2.5, n_scan=48, xtol=1e-9):
    """Smallest total volume V* at which separate bridges meet (any criterion).

    The margins are scanned on ``n_scan`` volumes geometric in [v_min, v_max] (v_min
    by default half the volume at which the widest-gap bridge can first exist, from
    Lian's rupture distance (1 + theta/2) V^(1/3)); each
    criterion's first change of sign (from < 0 to >= 0, skipping volumes where a bridge
    does not exist) is refined by Brent's method to ``xtol``.  Criteria never met in the
    scan have volume NaN.

    >>> g = triplet_geometry(0.175, 0.175, 0.075)
    >>> r = find_coalescence(g, 0.0)
    >>> r.criterion, round(r.V_coal * 64, 2)    # total volume in ul for r = 4 mm
    ('caps', 13.14)
    """
    bridges = parse_bridges(bridges)
    t = contact_angles(theta)
    w = volume_fractions(fractions, len(bridges))
    if v_min is None:
        v_min = 0.5 * max((geom.gap(i, j) / (1.0 + 0.5 * np.radians(min(t[i], t[j])))) ** 3
                          / wb for (i, j), wb in zip(bridges, w))
        v_min = max(v_min, 1e-6)
    v_min = float(check_range("v_min", v_min, 0.0, np.inf, low_open=True))
    v_max = float(check_range("v_max", v_max, v_min, np.inf, low_open=True))
    Vs = np.geomspace(v_min, v_max, int(n_scan))
    margins = None
    keys = None
    st_all = uncoalesced_state(Vs, geom, t, bridges, w)
    for n in range(len(Vs)):
        ms = _margins(_at(st_all, n), geom, t, bridges)
        if margins is None:
            keys = [(m["criterion"], m["where"]) for m in ms]
            margins = {k: [] for k in keys}
        for m in ms:
            margins[(m["criterion"], m["where"])].append(m["margin"])
    results = []
    for key in keys:
        m = np.asarray(margins[key], float)
        root = np.nan
        for a in range(len(Vs) - 1):
            if np.isfinite(m[a]) and np.isfinite(m[a + 1]) and m[a] < 0 <= m[a + 1]:
                f = _margin_fn(geom, t, bridges, w, *key)
                try:
                    root = brentq(f, Vs[a], Vs[a + 1], xtol=xtol, rtol=1e-12)
                except ValueError:
                    root = Vs[a + 1]
                break
            if np.isfinite(m[a]) and m[a] >= 0 and a == 0:
                root = Vs[0]       # already met at the smallest volume
                break
        results.append({"criterion": key[0], "where": key[1], "V": root})
    found = [r for r in results if np.isfinite(r["V"])]
    scan = {"volume": Vs, "margins": {f"{c}: {w_}": np.asarray(v) for (c, w_), v in
                                      margins.items()}}
    if not found:
        return CoalescenceResult("none_found", np.nan, "", "", results, {}, {},
                                 [], _opening(geom, bridges), t.tolist(), bridges,
                                 w.tolist(), {}, np.nan, scan)
    # first met; ties (within 1e-7 relative) go to the caps criterion (the paper's)
    vmin = min(r["V"] for r in found)
    first = [r for r in found if r["V"] <= vmin * (1 + 1e-7)]
    first.sort(key=lambda r: list(CRITERIA).index(r["criterion"]))
    best = first[0]
    st = uncoalesced_state(best["V"], geom, t, bridges, w)
    beta, force, pres = {}, {}, {}
    for (i, j) in bridges:
        r = st["bridge"][(i, j)]
        name = f"{i + 1}{j + 1}"
        beta[name] = {f"grain {i + 1}": float(r["beta_i"]), f"grain {j + 1}": float(r["beta_j"])}
        force[name] = float(r["force"])
        pres[name] = float(r["pressure"])
    return CoalescenceResult("coalescence", float(best["V"]), best["criterion"], best["where"],
                             results, beta, force, st["forces"].tolist(),
                             _opening(geom, bridges), t.tolist(), bridges, w.tolist(), pres,
                             float(st["energy"]), scan)


def _opening(geom, bridges):
    return {f"grain {g + 1}": geom.angle_at(g, j, k) for _, _, g, j, k in _shared_grains(bridges)}


# --------------------------------------------------------------------------------------
# pair forces
# --------------------------------------------------------------------------------------


def pair_direction_matrix(centres, pairs=None):
    """The linear map from pair forces to grain forces, F = A f.

    Column m of ``A`` (3N rows: x, y, z of grain 0, then grain 1, ...) holds +u_ij in
    the rows of grain i and -u_ij in those of grain j, u_ij the unit vector from i to
    j of the m-th pair (i, j), so that F_i = sum_j f_ij u_ij with attraction f_ij > 0.
    The pair forces are determined by the grain forces exactly when ``A`` has full
    column rank.

    Parameters
    ----------
    centres : array_like, shape (N, 3)
    pairs : sequence of (i, j), optional
        0-based grain pairs (default: every pair, in ``itertools.combinations`` order).

    Returns
    -------
    A : numpy.ndarray, shape (3N, M)
    pairs : list of (i, j) with i < j

    >>> A, p = pair_direction_matrix([[0., 0, 0], [3, 0, 0]])
    >>> A[:, 0].tolist(), p
    ([1.0, 0.0, 0.0, -1.0, -0.0, -0.0], [(0, 1)])
    """
    C = np.asarray(centres, float)
    n = len(C)
    pairs = list(itertools.combinations(range(n), 2)) if pairs is None else \
        [tuple(sorted(p)) for p in pairs]
    A = np.zeros((3 * n, len(pairs)))
    for m, (i, j) in enumerate(pairs):
        u = C[j] - C[i]
        u /= np.linalg.norm(u)
        A[3 * i:3 * i + 3, m] = u
        A[3 * j:3 * j + 3, m] = -u
    return A, pairs


def pair_forces(centres, forces, pairs=None):
    """Effective pair forces f_ij along the centre lines (attraction > 0).

    Solves sum_j f_ij u_ij = F_i (u_ij: unit vector from i to j) for all grains i in
    the least-squares sense.  Returns (f, residual): ``f`` a dict (i, j) -> f_ij and
    ``residual`` = |A f - F| / max_i |F_i|, zero for an in-plane, balanced, torque-free
    force set on three grains.

    >>> c = np.array([[0., 0, 0], [2, 0, 0], [1, 1.5, 0]])
    >>> u = lambda i, j: (c[j] - c[i]) / np.linalg.norm(c[j] - c[i])
    >>> F = np.array([0.3 * u(0, 1) + 0.2 * u(0, 2), 0.3 * u(1, 0) - 0.1 * u(1, 2),
    ...               0.2 * u(2, 0) - 0.1 * u(2, 1)])
    >>> f, res = pair_forces(c, F)
    >>> [round(f[p], 6) for p in sorted(f)], res < 1e-12
    ([0.3, 0.2, -0.1], True)
    """
    F = np.asarray(forces, float)
    n = len(np.asarray(centres))
    if F.shape != (n, 3):
        raise CapbridgeInputError(f"forces must have shape ({n}, 3), got {F.shape}")
    A, pairs = pair_direction_matrix(centres, pairs)
    f, *_ = np.linalg.lstsq(A, F.ravel(), rcond=None)
    scale = max(float(np.max(np.linalg.norm(F, axis=1))), 1e-300)
    res = float(np.linalg.norm(A @ f - F.ravel()) / scale)
    return {p: float(v) for p, v in zip(pairs, f)}, res
