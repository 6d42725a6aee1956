"""Evolver command-language text: relaxation by criteria, mesh upkeep, machine-readable report.

Every command file starts with :func:`prelude` (procedures) and ends with ``quit``.

Relaxation (``cb_relax(ngrad, maxhess)``): ``ngrad`` gradient steps, then up to
``maxhess`` Newton steps (``hessian_seek``, which never raises the energy, each followed
by one gradient step that re-imposes the one-sided constraints Hessian steps ignore).
If a Newton step raised the energy anyway, the vertex positions are restored and more
gradient steps are taken.  The loop stops when a Newton step changes the energy by less
than ``cb_etol``, or at the first indefinite Hessian (``eigenneg > 0``) when
``cb_abort_indef`` is set (displaced runs, ``Settings.vw_abort_indefinite``).  The
pressure (Lagrange multiplier) is read only after an iteration, never right after a
refinement (it is stale there).

Report lines (one item per line, parsed by :mod:`.parse`)::

    @BEGIN tag
    @E total_energy        @A liquid-gas area     @N nv ne nf
    @R newton_steps newton_rejected last_newton_dE  scale
    @I newton_steps_with_an_indefinite_hessian
    @B body volume target pressure
    @V id x y z            @F id v1 v2 v3 body     @C constraint edge v1 v2
    @H constraint n_vertices_hitting               (one-sided constraints)
    @END tag
"""
from __future__ import annotations

_FMT = "%.17g"


def violation_function(grain_contacts, radii_names=None):
    """Evolver function ``cb_viol()``: number of vertices inside any grain (beyond 1e-9 R^2),
    not counting a grain's own contact-line vertices.

    ``grain_contacts``: dict grain (0-based) -> list of its contact constraint numbers.
    """
    terms = []
    for g, cons in sorted(grain_contacts.items()):
        k = g + 1
        excl = "".join(f"not on_constraint {cn} and " for cn in cons)
        terms.append(f"sum(vertex where {excl}(x-gx{k})^2+(y-gy{k})^2+(z-gz{k})^2 < "
                     f"gr{k}^2*(1-1e-9), 1)")
    body = " + ".join(terms) if terms else "0"
    return f"function real cb_viol() {{ return {body}; }}\n"


def prelude(grain_contacts, etol=1e-11):
    """Procedures shared by all runs.  ``etol``: Newton-loop energy tolerance (absolute).

    ``grain_contacts``: grain (0-based) -> contact constraint numbers (for ``cb_viol``).
    """
    return f"""quiet on;
cb_etol := {etol!r}; cb_vtol := 1e-9;
cb_nh := 0; cb_hrej := 0; cb_lastde := 0; cb_tfrac := 0.25; cb_lfrac := 1.8; cb_ng := 0;
cb_abort_indef := 0; cb_indef := 0;
{violation_function(grain_contacts)}
procedure cb_save() {{
  foreach vertex vv do {{ vv.cbo[1] := vv.x; vv.cbo[2] := vv.y; vv.cbo[3] := vv.z; }};
}}
procedure cb_restore() {{
  foreach vertex vv do {{ vv.x := vv.cbo[1]; vv.y := vv.cbo[2]; vv.z := vv.cbo[3]; }};
  recalc;
}}
procedure cb_relax(integer ngrad, integer maxhess) {{
  local ee0, kk, vv0;
  cb_nh := 0; cb_hrej := 0; cb_lastde := 1e30; cb_ng := 0; cb_indef := 0;
  if ngrad > 0 then g ngrad;
  for (kk := 1; kk <= maxhess; kk += 1) {{
    ee0 := total_energy;
    vv0 := max(body, abs(volume - target)/target);
    cb_save();
    hessian_seek;
    cb_nh += 1;
    if eigenneg > 0 then {{ cb_indef += 1; if cb_abort_indef then break; }};
    if cb_viol() > 0 then {{ g 1; cb_ng += 1; }};
    cb_lastde := ee0 - total_energy;
    if total_energy > ee0 + cb_etol and vv0 < cb_vtol then {{
      cb_restore(); cb_hrej += 1;
      g ngrad + 5;
    }} else if abs(cb_lastde) < cb_etol then break;
  }};
}}
procedure cb_gradient(integer nmax) {{
  local ee0, kk;
  cb_nh := 0; cb_hrej := 0; cb_lastde := 1e30;
  for (kk := 1; kk <= nmax; kk += 1) {{
    ee0 := total_energy;
    g 1;
    cb_lastde := abs(ee0 - total_energy);
    if cb_lastde < cb_etol then break;
  }};
}}
procedure cb_groom() {{
  local el;
  u;
  el := avg(edge, length);
  t cb_tfrac*el;
  l cb_lfrac*el;
  u;
  V;
}}
"""


def report(tag, contact_constraints, outside_constraints):
    """Commands printing the full state between ``@BEGIN tag`` and ``@END tag``."""
    f = _FMT
    lines = [f'printf "@BEGIN {tag}\\n";',
             f'printf "@E {f}\\n", total_energy;',
             f'printf "@A {f}\\n", total_area;',
             'printf "@N %d %d %d\\n", vertex_count, edge_count, facet_count;',
             f'printf "@R %d %d {f} {f}\\n", cb_nh, cb_hrej, cb_lastde, scale;',
             'printf "@I %d\\n", cb_indef;',
             f'foreach body bb do printf "@B %d {f} {f} {f}\\n", bb.id, bb.volume, '
             'bb.target, bb.pressure;',
             f'foreach vertex vv do printf "@V %d {f} {f} {f}\\n", vv.id, vv.x, vv.y, vv.z;',
             'foreach facet ff do printf "@F %d %d %d %d %d\\n", ff.id, ff.vertex[1].id, '
             'ff.vertex[2].id, ff.vertex[3].id, ff.frontbody;']
    for cn in sorted(contact_constraints):
        lines.append(f'foreach edge ee where on_constraint {cn} do printf "@C {cn} %d %d %d\\n",'
                     ' ee.id, ee.vertex[1].id, ee.vertex[2].id;')
    for cn in sorted(outside_constraints):
        lines.append(f'printf "@H {cn} %d\\n", sum(vertex where hit_constraint {cn}, 1);')
    lines.append(f'printf "@END {tag}\\n";')
    return "\n".join(lines) + "\n"


def band_refine(contact):
    """Refine the facets touching a contact line (one extra level there)."""
    cond = " or ".join(f"on_constraint {cn}" for cn in sorted(contact))
    return f"refine facet ff where max(ff.vertex, {cond}) > 0; u;"


def converge_level(level, contact, outside, ngrad=20, maxhess=8, refine=True, groom=True,
                   newton=True, dumpfile=None, ngrad_first=40, band=0, bond=None):
    """Commands for one refinement level: refine, groom, relax, report, dump.

    Level 0 relaxes the starting mesh (no refinement; more gradient steps, since the
    volume is being brought to its target).  ``bond`` sets the Bond number parameter
    ``bo`` first (gravity is switched on only from level 1: the coarse starting mesh
    folds under strong gravity).
    """
    c = [] if bond is None else [f"bo := {float(bond)!r}; recalc;"]
    if level == 0:
        c.append(f"g {ngrad_first};")
        if groom:
            c.append("u; V; u;")
    elif refine:
        c.append("r;")
        if groom:
            c.append("cb_groom();")
        for _ in range(band):
            c.append(band_refine(contact))
    if newton:
        c.append(f"cb_relax({ngrad}, {maxhess});")
    else:
        c.append(f"cb_gradient({max(ngrad, 1) * 50});")
    c.append(report(f"level{level}", contact, outside))
    if dumpfile:
        c.append(f'dump "{dumpfile}";')
    c.append("quit")
    return "\n".join(c) + "\n"


def transport_weight(grain, n_grains, v="vv"):
    """Evolver expressions (d_k, d_o) for the transport weight w = d_o / (d_k + d_o)
    used when moving grain ``grain``: d is the distance from vertex ``v`` to a grain's
    surface, d_o the smallest over the other grains.  w is 1 on the moved grain, 0 on
    every other grain, and smooth in between."""
    def dist(k):
        return (f"maximum(0,sqrt(({v}.x-gx{k})^2+({v}.y-gy{k})^2+({v}.z-gz{k})^2)-gr{k})")
    dk = dist(grain + 1)
    others = [dist(j + 1) for j in range(n_grains) if j != grain]
    do = others[0]
    for o in others[1:]:
        do = f"minimum({do},{o})"
    return dk, do


def displaced(grain, shift, n_grains, contact, outside, ngrad=0, maxhess=12,
              newton=True, tag="moved", abort_indefinite=False):
    """Commands moving grain ``grain`` (0-based) by ``shift``, carrying the free surface
    along with the smooth weight of :func:`transport_weight` (the grain's own contact
    line moves rigidly, other grains' contact lines stay), then re-minimising at fixed
    mesh topology (no refinement; Newton steps) and reporting."""
    k = grain + 1
    dx, dy, dz = (float(v) for v in shift)
    dk, do = transport_weight(grain, n_grains)
    c = ["foreach vertex vv do { local dk, dd, ww;",
         f"  dk := {dk};",
         f"  dd := {do};",
         "  ww := (dk + dd > 0) ? dd/(dk + dd) : 0.5;",
         f"  vv.x := vv.x + ({dx!r})*ww; vv.y := vv.y + ({dy!r})*ww; "
         f"vv.z := vv.z + ({dz!r})*ww; }};",
         f"gx{k} := gx{k} + ({dx!r}); gy{k} := gy{k} + ({dy!r}); gz{k} := gz{k} + ({dz!r});",
         "recalc;",
         # a zero-length gradient step projects onto the constraints and sets the
         # pressures, which Hessian steps need (they may be invalid after loading a dump)
         "m 1e-12; g 1; optimize 1;",
         # with abort_indefinite, an indefinite Hessian means the displacement left the
         # basin of the minimum (theta = 0 on fine meshes): stop, the driver halves delta
         f"cb_abort_indef := {1 if abort_indefinite else 0};"]
    if newton:
        c.append(f"cb_relax({ngrad}, {maxhess});")
    else:
        c.append("cb_gradient(2000);")
    c.append(report(tag, contact, outside))
    c.append("quit")
    return "\n".join(c) + "\n"
