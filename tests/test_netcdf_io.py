"""Tests of capbridge.tables.netcdf_io (CF netCDF tables)."""
from __future__ import annotations

import datetime as dt
import json

import netCDF4
import numpy as np
import pytest
import xarray as xr

import capbridge
from capbridge.tables.netcdf_io import (read_table, table_solver_settings,
                                           write_table)
from capbridge.status import Status, cf_flag_attributes

SETTINGS = {"method": "shooting", "rtol": 1e-10, "n_nodes": np.int64(400),
            "angles_deg": np.array([0.0, 30.0])}


def _table():
    gap = np.linspace(0.0, 0.5, 6)
    volume = np.array([0.008, 0.05, 0.156])
    rng = np.random.default_rng(0)
    force = rng.random((6, 3))
    force[5, 0] = np.nan
    status = np.zeros((6, 3), np.int64)
    status[5, 0] = Status.RUPTURED
    status[4, 2] = Status.NOT_CONVERGED
    return xr.Dataset(
        {"force": (("gap", "volume"), force,
                   {"units": "1", "long_name": "dimensionless force F/(2 pi gamma r)"}),
         "status": (("gap", "volume"), status, {"units": "1", "long_name": "status"}),
         "n_iter": (("gap", "volume"), np.ones((6, 3), np.int32),
                    {"units": "1", "long_name": "solver iterations"})},
        coords={"gap": ("gap", gap, {"units": "1", "long_name": "gap d/r"}),
                "volume": ("volume", volume, {"units": "1", "long_name": "volume V/r^3"}),
                "contact_angle": ((), 30.0, {"units": "degree",
                                             "long_name": "contact angle"})},
        attrs={"title": "toy doublet table", "comment": "test"})


def test_round_trip_keeps_values_and_attributes(tmp_path):
    ds = _table()
    path = tmp_path / "sub" / "doublet.nc"
    before = (dt.datetime.now(dt.timezone.utc) - dt.timedelta(seconds=2)).isoformat()
    out = write_table(ds, path, command="capbridge sweep doublet --theta 30",
                      solver_settings=SETTINGS,
                      extra_attrs={"grid": {"n_gap": 6}, "normalising_radius": "smaller"})
    assert out == path and path.exists()
    assert [p.name for p in path.parent.iterdir()] == ["doublet.nc"]  # no temp left
    back = read_table(path)

    np.testing.assert_array_equal(back["force"].values, ds["force"].values)
    np.testing.assert_array_equal(back["gap"].values, ds["gap"].values)
    np.testing.assert_array_equal(back["status"].values, ds["status"].values)
    assert back["status"].dtype == np.int8
    assert back["n_iter"].dtype == np.int32
    assert float(back["contact_angle"]) == 30.0
    for name in ["force", "status", "n_iter", "gap", "volume", "contact_angle"]:
        for key in ("units", "long_name"):
            assert back[name].attrs[key] == ds[name].attrs[key], (name, key)
    flags = cf_flag_attributes()
    assert list(back["status"].attrs["flag_values"]) == flags["flag_values"]
    assert back["status"].attrs["flag_meanings"] == flags["flag_meanings"]

    a = back.attrs
    assert a["Conventions"] == "CF-1.8"
    assert a["title"] == "toy doublet table" and a["comment"] == "test"
    assert a["source"] == f"capbridge {capbridge.__version__}"
    assert a["institution"] == f"capbridge {capbridge.__version__}"
    assert a["capbridge_command"] == "capbridge sweep doublet --theta 30"
    assert a["history"].endswith(": capbridge sweep doublet --theta 30")
    stamp = a["history"].split(": ")[0]
    assert stamp == a["date_created"] and stamp.endswith("Z")
    assert dt.datetime.fromisoformat(stamp.replace("Z", "+00:00")).isoformat() >= before[:19]
    assert json.loads(a["solver_settings"]) == {"method": "shooting", "rtol": 1e-10,
                                               "n_nodes": 400, "angles_deg": [0.0, 30.0]}
    assert table_solver_settings(back)["n_nodes"] == 400
    assert json.loads(a["grid"]) == {"n_gap": 6}
    assert a["normalising_radius"] == "smaller"
    # the caller's dataset is untouched
    assert "Conventions" not in ds.attrs and ds["status"].dtype == np.int64
    assert "flag_values" not in ds["status"].attrs


def test_encoding_compression_and_int8_flags(tmp_path):
    path = tmp_path / "t.nc"
    write_table(_table(), path, command="cmd", solver_settings={})
    with netCDF4.Dataset(path) as nc:
        force = nc.variables["force"]
        assert force.filters()["zlib"] and force.filters()["complevel"] == 4
        assert nc.variables["gap"].filters()["zlib"]
        st = nc.variables["status"]
        assert st.dtype == np.int8
        assert st.flag_values.dtype == np.int8  # CF: same type as the variable
        assert "_FillValue" not in st.ncattrs()
        assert nc.file_format == "NETCDF4"


def test_rewrite_appends_history_and_overwrites_atomically(tmp_path):
    path = tmp_path / "t.nc"
    write_table(_table(), path, command="first", solver_settings={"a": 1})
    back = read_table(path)
    write_table(back, path, command="second", solver_settings={"a": 2})
    again = read_table(path)
    lines = again.attrs["history"].splitlines()
    assert len(lines) == 2 and lines[0].endswith(": second")
    assert lines[1].endswith(": first")
    assert table_solver_settings(again) == {"a": 2}
    assert again["status"].dtype == np.int8
    np.testing.assert_array_equal(again["force"].values, _table()["force"].values)


def test_missing_units_and_long_name_are_listed(tmp_path):
    ds = _table()
    del ds["force"].attrs["units"]
    del ds["gap"].attrs["long_name"]
    ds["n_iter"].attrs = {}
    path = tmp_path / "t.nc"
    with pytest.raises(ValueError) as err:
        write_table(ds, path, command="cmd", solver_settings={})
    msg = str(err.value)
    assert "'force': units" in msg and "'gap': long_name" in msg
    assert "'n_iter': units, long_name" in msg and "'volume'" not in msg
    assert not path.exists() and list(tmp_path.iterdir()) == []


def test_status_defaults_and_invalid_codes(tmp_path):
    ds = _table()
    ds["status"].attrs = {}  # status variables get CF flag attributes and units "1"
    path = tmp_path / "t.nc"
    write_table(ds, path, command="cmd", solver_settings={})
    back = read_table(path)
    assert back["status"].attrs["units"] == "1"
    assert back["status"].attrs["long_name"] == "status of the point"

    bad = _table()
    bad["status"][0, 0] = 42
    with pytest.raises(ValueError, match="outside"):
        write_table(bad, path, command="cmd", solver_settings={})
    nan = _table()
    nan["status"] = nan["status"].astype(float)
    nan["status"][0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        write_table(nan, path, command="cmd", solver_settings={})
    # a failed write leaves the previous file intact
    np.testing.assert_array_equal(read_table(path)["status"], back["status"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.nc"]


def test_flags_of_their_own_are_kept(tmp_path):
    """A variable with CF flags that are not the statuses' (a triplet table's failure
    kinds) keeps its flag meanings: they were once replaced by the status names."""
    ds = _table()
    ds["failure"] = (("gap", "volume"), np.zeros((6, 3), np.int8),
                     {"units": "1", "long_name": "kind of failure of the point",
                      "flag_values": np.arange(3, dtype=np.int8),
                      "flag_meanings": "none mesh timeout"})
    path = tmp_path / "t.nc"
    write_table(ds, path, command="cmd", solver_settings={})
    back = read_table(path)
    assert back["failure"].attrs["flag_meanings"] == "none mesh timeout"
    np.testing.assert_array_equal(back["failure"].attrs["flag_values"], [0, 1, 2])
    assert back["status"].attrs["flag_meanings"] == cf_flag_attributes()["flag_meanings"]


def test_read_table_rejects_foreign_files(tmp_path):
    plain = tmp_path / "plain.nc"
    _table().to_netcdf(plain)
    with pytest.raises(ValueError, match="plain.nc.*Conventions"):
        read_table(plain)
    cf_only = tmp_path / "cf_only.nc"
    _table().assign_attrs(Conventions="CF-1.8").to_netcdf(cf_only)
    with pytest.raises(ValueError, match="cf_only.nc.*capbridge_command"):
        read_table(cf_only)
    junk = tmp_path / "junk.nc"
    junk.write_bytes(b"not netcdf")
    with pytest.raises(ValueError, match="junk.nc"):
        read_table(junk)
    with pytest.raises(FileNotFoundError, match="missing.nc"):
        read_table(tmp_path / "missing.nc")


def test_write_requires_command(tmp_path):
    with pytest.raises(ValueError, match="command"):
        write_table(_table(), tmp_path / "t.nc", command="", solver_settings={})


def test_read_table_is_in_memory_and_closed(tmp_path):
    path = tmp_path / "t.nc"
    write_table(_table(), path, command="cmd", solver_settings={})
    back = read_table(path)
    path.unlink()  # file closed and data loaded: still usable
    assert float(back["force"].sum()) == pytest.approx(float(np.nansum(_table()["force"])))
