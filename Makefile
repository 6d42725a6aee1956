# capbridge: every target installs what it needs first (idempotent), then runs.
# Environment: Debian's /usr/bin/python3 (3.11) + a venv that sees Debian's packages
# (YADE's modules), with numpy < 2 from pip (YADE was built against numpy 1.24).
SHELL := /bin/bash
VENV  := .venv
PY    := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# python3-vtk9: VTK's readers check the files of capbridge.dem.vtk_output (tests);
# the same VTK 9.1 as YADE's libvtk9.1, numpy-API only, so it imports in the venv too.
APT_PACKAGES := python3 python3-venv python3-pip yade evolver-nox evolver-doc python3-vtk9

.PHONY: setup system-packages demo test test-fast bench bench-evolver data data-packings reproduce clean

system-packages:
	@missing=""; for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi

$(STAMP): pyproject.toml | system-packages
	test -x $(PY) || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[test,dask]"
	touch $(STAMP)

setup: system-packages $(STAMP)

# Main job on the shipped data: F*(d*) from data/doublet_table.nc beside the exact solver,
# the paper's coalesced triplet from data/triplet_table.nc, a wet packing of 300 grains in
# YADE with CapbridgeEngine; figures and CSV in out/ (about 1 min on 2 cores).
demo: setup
	$(VENV)/bin/capbridge info
	$(VENV)/bin/capbridge demo --output-dir out

# Every dependency is installed above: a test skipped for a missing one fails instead
# (tests/conftest.py), so a broken set-up cannot pass by checking less.
test: setup
	CAPBRIDGE_NO_DEPENDENCY_SKIPS=1 $(PY) -m pytest -n 2 -q

# The quick loop while editing: the suite without YADE, Surface Evolver and the slow
# tests (markers `yade`, `evolver`, `slow`: tests/conftest.py): 934 of the 1,139 tests,
# measured 38 s on 2 cores (-n 2; 2026-11-27).  A test slower than
# ~2.5 s gets @pytest.mark.slow to keep this under 2 minutes.
test-fast: setup
	CAPBRIDGE_NO_DEPENDENCY_SKIPS=1 $(PY) -m pytest -n 2 -q -m "not yade and not evolver and not slow"

bench: setup
	$(PY) benchmarks/bench_doublet.py
	$(PY) benchmarks/bench_yade.py
	$(PY) benchmarks/bench_pressure_base.py
	$(PY) benchmarks/bench_triplet_packings.py --label current
	$(PY) benchmarks/bench_triplet_lookup.py

# Surface Evolver: the paper's protocol against ours, and the 200-triplet stress run
# (hours; resumable).  Results: benchmarks/evolver_out/, summarised in RESULTS.md.
bench-evolver: setup
	$(PY) benchmarks/bench_evolver.py compare --paper-refine 3 4 --paper-full D1
	$(PY) benchmarks/bench_evolver.py stress --n 200 --jobs 2
	$(PY) examples/evolver_convergence/run_convergence.py
	$(PY) benchmarks/bench_evolver.py report
	$(PY) benchmarks/bench_clusters.py
	$(PY) benchmarks/bench_clusters.py --packing

# The triplet study of Miot et al. (2021): examples/miot2021 (resumable after a kill).
reproduce: setup
	$(VENV)/bin/capbridge reproduce miot2021 --checkpoint-dir .sweep-checkpoints/miot2021

# Regenerates the shipped tables (resumable: rerun after a kill to continue).  The
# doublet table takes about 1 h 45 min on 2 cores (most of it its gravity response), the
# coalescence table 8 min; the two triplet tables hours of Surface Evolver each (their
# committed checkpoints in sweeps/triplet and sweeps/triplet_packings are reused point
# by point: minutes).
data: setup data-packings
	$(VENV)/bin/capbridge generate doublet --checkpoint-dir .sweep-checkpoints/doublet
	$(VENV)/bin/capbridge generate coalescence --checkpoint-dir .sweep-checkpoints/triplet_coalescence
	$(VENV)/bin/capbridge generate triplet --jobs 2 --holdout 12 --checkpoint-dir sweeps/triplet

# The second triplet table, data/triplet_table_packings.nc (issue 18: the domain that
# coalesced triplets of packings reach; the DEM engine's table): ~10 CPU hours from
# scratch, minutes from the chunks committed in sweeps/triplet_packings.
data-packings: setup
	$(VENV)/bin/capbridge generate triplet --grid packings --jobs 2 --checkpoint-dir sweeps/triplet_packings

clean:
	rm -rf out .sweep-checkpoints
