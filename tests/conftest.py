import os
import re

import pytest

# Scene scripts run inside YADE (as subprocesses), never imported by pytest.
collect_ignore_glob = ["yade_scenes/*"]

#: skip reasons that say an installable dependency is missing (Debian's yade, Surface
#: Evolver, python3-vtk9, dask's distributed, ...): `make test` installs every one of
#: them, so there such a skip is a broken set-up and fails instead of checking nothing.
_MISSING_DEPENDENCY = re.compile(r"not installed|could not import|no module named", re.I)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    if not (rep.skipped and os.environ.get("CAPBRIDGE_NO_DEPENDENCY_SKIPS") == "1"):
        return
    if hasattr(rep, "wasxfail"):
        return
    reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
    if _MISSING_DEPENDENCY.search(reason):
        rep.outcome = "failed"
        rep.longrepr = (f"skipped for a missing dependency, which `make test` installs "
                        f"(CAPBRIDGE_NO_DEPENDENCY_SKIPS=1): {reason}")
