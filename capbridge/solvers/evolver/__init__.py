"""Surface Evolver driver: liquid bodies on spheres by surface-energy minimisation.

Public API
----------
:func:`minimise_bridge` / :func:`minimise`  any grains, bodies, contact angles, gravity
:func:`doublet_force`                       axial force of a two-sphere bridge
:class:`BridgeResult`, :class:`Settings`    result and numerical settings
:func:`make_problem`, :func:`doublet_problem`
:func:`available`                           is the ``evolver`` binary installed?

Modules: ``problem`` (inputs), ``geometry`` (cap integrals, starting meshes), ``datafile``
(Evolver file), ``script`` (Evolver commands), ``runner`` (processes), ``parse`` (reports),
``checks`` (failure detection), ``forces`` (direct and virtual-work forces), ``minimise``
(convergence driver).
"""
from .minimise import (BridgeResult, LevelRecord, Settings, doublet_force, doublet_problem,
                       minimise, minimise_bridge, minimise_many, vw_directions)
from .problem import Body, Problem, make_problem
from .runner import available

__all__ = ["BridgeResult", "LevelRecord", "Settings", "doublet_force", "doublet_problem",
           "minimise", "minimise_bridge", "minimise_many", "vw_directions", "Body", "Problem",
           "make_problem", "available"]
