"""Surface Evolver datafile for liquid bodies on spheres, generated from a :class:`Problem`.

Layout of the generated file (dimensionless, gamma = 1):

* ``PARAMETER gx<k> gy<k> gz<k> gr<k> gc<k>``: centre, radius and cos(theta) of grain k
  (1-based); ``bo`` the Bond number.  Grains are moved at run time by changing these.
* constraint ``c`` for each (body, wetted grain) pair: the sphere as an equality level
  set, on the contact-line vertices and edges only, carrying the wetting energy
  ``-cos(theta) * wetted area`` and, when Bo > 0, the gravitational energy of the liquid
  in the cap region (ENERGY), and the missing cap volume (CONTENT).  The line-integral
  fields are those of :mod:`.geometry` (pole axis pointing into the cap).
* constraint ``NC + k`` for each grain k near a body: NONNEGATIVE one-sided sphere
  constraint on the free (non-contact) elements, so that the free surface can never cut
  into a grain (without it a theta = 0 trimer sinks into the bottom grains and the energy
  falls without bound).
* ``quantity gpe``: gravitational potential energy Bo * \\int h dV of the meshed part, as
  \\int F.n dA with F = Bo (k.x)^2 / 2 k over every facet (k = up).
* ``SYMMETRIC_CONTENT``: body volume = \\int (x/3).n dA, matched by the cap CONTENT.

Every facet's right-hand normal points out of its liquid body, and every contact edge is
positively oriented in its facet, so the edge integrals run counter-clockwise about the
grain's outward normal on the wet cap (the orientation :mod:`.geometry` assumes).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import starting_body
from .problem import Problem

_FMT = "%.17g"


def _num(v):
    s = _FMT % float(v)
    return f"({s})" if s.startswith("-") else s


def _cross(a, b):
    """Symbolic cross product of two 3-tuples of expression strings."""
    return (f"({a[1]})*({b[2]})-({a[2]})*({b[1]})",
            f"({a[2]})*({b[0]})-({a[0]})*({b[2]})",
            f"({a[0]})*({b[1]})-({a[1]})*({b[0]})")


def _dot(a, b):
    return "+".join(f"({x})*({y})" for x, y in zip(a, b))


def _grain_params(k):
    """Expression names for grain k (1-based)."""
    return (f"gx{k}", f"gy{k}", f"gz{k}"), f"gr{k}", f"gc{k}"


def contact_integrands(k, axis, up=None):
    """Evolver ENERGY and CONTENT vector fields for a contact line on grain k (1-based).

    Returns (energy, content), each a 3-tuple of expression strings.  ``up`` (unit
    vector) adds the gravitational energy of the cap region, scaled by parameter ``bo``.
    """
    c, R, cth = _grain_params(k)
    p = tuple(f"({v}-{ci})" for v, ci in zip("xyz", c))
    a = tuple(_num(v) for v in axis)
    s = _dot(a, p)
    axp = _cross(a, p)
    cxp = _cross(c, p)
    fw = f"{R}/({R}+{s})"
    energy = [f"-{cth}*{fw}*({axp[i]})" for i in range(3)]
    content = [f"-({cxp[i]})/6-{R}*{R}/3/({R}+{s})*({axp[i]})" for i in range(3)]
    if up is not None:
        k_ = tuple(_num(v) for v in up)
        kc = _dot(k_, c)
        z = _dot(k_, p)
        kxp = _cross(k_, p)
        coef = f"(({kc})^2/4+({kc})*({z})/3+({R}^2+({z})^2)/8)"
        for i in range(3):
            energy[i] += (f"-bo*({coef}*({kxp[i]})+({kc})*{R}^2/3/({R}+{s})*({axp[i]}))")
    return tuple(energy), tuple(content)


@dataclass
class MeshedProblem:
    """A problem with its starting meshes and the constraint numbering used in the file."""

    problem: Problem
    meshes: list                 # one geometry.BodyMesh per body
    contact_constraints: dict    # (body index, grain index) -> constraint number
    outside_constraints: dict    # grain index -> one-sided constraint number
    body_near_grains: list       # per body, grains whose one-sided constraint applies

    def grain_contacts(self):
        """grain (0-based) -> its contact constraint numbers (one per body wetting it)."""
        out = {}
        for (bi, g), cn in self.contact_constraints.items():
            out.setdefault(g, []).append(cn)
        return out


def mesh_problem(problem, n_ring=8, near_margin=1.0, one_sided=True):
    """Starting meshes and constraint numbers for every body of ``problem``.

    ``one_sided=False`` leaves the free vertices unconstrained (only for demonstrating
    what the failure checks catch: the free surface may then cut into grains).
    """
    meshes = [starting_body(b.grains, problem.centres, problem.radii, b.volume, n=n_ring)
              for b in problem.bodies]
    contact = {}
    nc = 0
    for bi, b in enumerate(problem.bodies):
        for g in b.grains:
            nc += 1
            contact[(bi, g)] = nc
    near = []
    for m in meshes:
        lo = m.vertices.min(axis=0)
        hi = m.vertices.max(axis=0)
        ext = near_margin * max(float(np.max(hi - lo)), 0.5)
        sel = []
        for g in range(problem.n_grains):
            c = problem.centres[g]
            d = np.linalg.norm(np.maximum(0.0, np.maximum(lo - ext - c, c - hi - ext)))
            if d <= problem.radii[g]:
                sel.append(g)
        near.append(sel if one_sided else [])
    used = sorted({g for s in near for g in s})
    outside = {g: nc + 1 + i for i, g in enumerate(used)}
    return MeshedProblem(problem, meshes, contact, outside, near)


def write_datafile(mp, path=None, integral_order_1d=4, integral_order_2d=4):
    """Datafile text for a :class:`MeshedProblem`; written to ``path`` if given."""
    pb = mp.problem
    gravity = pb.bond > 0
    up = pb.up
    L = ["// capbridge: liquid bodies on spheres (dimensionless, gamma = 1)",
         "SYMMETRIC_CONTENT",
         f"INTEGRAL_ORDER_1D {integral_order_1d}",
         f"INTEGRAL_ORDER_2D {integral_order_2d}",
         "define vertex attribute cbo real[3]   // saved positions (undo of a Newton step)",
         ""]
    for g in range(pb.n_grains):
        k = g + 1
        c = pb.centres[g]
        L += [f"PARAMETER gx{k} = {_FMT % c[0]}", f"PARAMETER gy{k} = {_FMT % c[1]}",
              f"PARAMETER gz{k} = {_FMT % c[2]}", f"PARAMETER gr{k} = {_FMT % pb.radii[g]}",
              f"PARAMETER gc{k} = {_FMT % np.cos(np.radians(pb.contact_angles_deg[g]))}"]
    L += [f"PARAMETER bo = {_FMT % pb.bond}", ""]
    # contact-line constraints
    for (bi, g), cn in mp.contact_constraints.items():
        mesh = mp.meshes[bi]
        ring = next(r for r in mesh.rings if r.grain == g)
        (cx, cy, cz), R, _ = _grain_params(g + 1)
        en, co = contact_integrands(g + 1, ring.axis, up if gravity else None)
        L += [f"constraint {cn}   // contact line of body {bi + 1} on grain {g + 1}",
              f"formula: (x-{cx})^2+(y-{cy})^2+(z-{cz})^2 = {R}^2",
              "energy:", f"e1: {en[0]}", f"e2: {en[1]}", f"e3: {en[2]}",
              "content:", f"c1: {co[0]}", f"c2: {co[1]}", f"c3: {co[2]}", ""]
    for g, cn in mp.outside_constraints.items():
        (cx, cy, cz), R, _ = _grain_params(g + 1)
        L += [f"constraint {cn} nonnegative   // free surface stays outside grain {g + 1}",
              f"formula: (x-{cx})^2+(y-{cy})^2+(z-{cz})^2 = {R}^2", ""]
    if gravity:
        k = tuple(_num(v) for v in up)
        h = f"({k[0]}*x+{k[1]}*y+{k[2]}*z)"
        L += ["quantity gpe energy method facet_vector_integral global",
              "vector_integrand:"]
        L += [f"q{i + 1}: bo*{k[i]}*{h}^2/2" for i in range(3)]
        L += [""]
    # elements
    verts, edges, faces, bodies = [], [], [], []
    for bi, mesh in enumerate(mp.meshes):
        v0 = len(verts)
        free_con = " ".join(str(mp.outside_constraints[g]) for g in mp.body_near_grains[bi])
        for vi, x in enumerate(mesh.vertices):
            g = mesh.rings[mesh.vertex_ring[vi]].grain
            verts.append(f"{v0 + vi + 1} {_FMT % x[0]} {_FMT % x[1]} {_FMT % x[2]} "
                         f"constraint {mp.contact_constraints[(bi, g)]}")
        ring_edge = {}
        start = 0
        for r in mesh.rings:
            n = len(r.points)
            for m in range(n):
                ring_edge[(start + m, start + (m + 1) % n)] = mp.contact_constraints[(bi, r.grain)]
            start += n
        emap = {}
        body_faces = []
        for t in mesh.triangles:
            signed = []
            for m in range(3):
                a, b = int(t[m]), int(t[(m + 1) % 3])
                if (a, b) in emap:
                    signed.append(emap[(a, b)])
                elif (b, a) in emap:
                    signed.append(-emap[(b, a)])
                else:
                    eid = len(edges) + 1
                    emap[(a, b)] = eid
                    if (a, b) in ring_edge:
                        attr = f"constraint {ring_edge[(a, b)]}"
                    elif (b, a) in ring_edge:
                        raise ValueError("contact edge oriented against its facet")
                    else:
                        attr = f"constraint {free_con}" if free_con else ""
                    edges.append(f"{eid} {v0 + a + 1} {v0 + b + 1} {attr}".rstrip())
                    signed.append(eid)
            fid = len(faces) + 1
            attr = f" constraint {free_con}" if free_con else ""
            faces.append(f"{fid} {signed[0]} {signed[1]} {signed[2]}{attr}")
            body_faces.append(fid)
        bodies.append(f"{bi + 1} " + " ".join(map(str, body_faces))
                      + f" volume {_FMT % pb.bodies[bi].volume}")
    L += ["vertices"] + verts + ["", "edges"] + edges + ["", "faces"] + faces
    L += ["", "bodies"] + bodies + [""]
    text = "\n".join(L)
    if path is not None:
        with open(path, "w") as fh:
            fh.write(text)
    return text
