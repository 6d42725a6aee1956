# Scene scripts run inside YADE (as subprocesses), never imported by pytest.
collect_ignore_glob = ["yade_scenes/*"]
