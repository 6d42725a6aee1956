"""Tables trusted blindly (issue 16, item 3): the table checksum covers the attributes
that give the numbers their meaning, an unverified table is refused unless asked for,
and every table is checked on load for what it can prove about itself.

Each test failed before the change: the old checksum (``data_sha256``) covered the
values only, deleting it switched the check off, and edited tables (units, error model,
grid, a negative coalescence volume, a gravity response x10, a sign-flipped pair force)
were used with success statuses.  The tables are copies of the shipped ones rewritten by
the project's own ``write_table`` in a temporary directory (the doublet one cut to two
ratios), edited with netCDF4 as a user or another tool would.
"""
from __future__ import annotations

import json
import logging
import shutil

import netCDF4
import pytest

from capbridge.cli import (DEFAULT_COALESCENCE_TABLE, DEFAULT_TABLE, DEFAULT_TRIPLET_TABLE,
                           main)
from capbridge.tables.netcdf_io import (TableError, allow_unverified_tables,
                                           checksum_state, read_table, write_table)
from capbridge.surrogate.doublet import DoubletSurrogate
from capbridge.surrogate.triplet import TripletSurrogate

SHIPPED = {"doublet": DEFAULT_TABLE, "triplet": DEFAULT_TRIPLET_TABLE,
           "coalescence": DEFAULT_COALESCENCE_TABLE}
CHECKSUMS = ("table_sha256", "data_sha256")


# ------------------------------------------------------------------------------ helpers
def run(args, capsys):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_clean_error(code, err, *words):
    """One line ``capbridge: error: ...`` naming ``words``, exit status 2."""
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("capbridge: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    """Small tables written by write_table: kind -> path (the doublet table with two
    ratios, 1 and 2, and its gravity response; the others whole)."""
    d = tmp_path_factory.mktemp("tables")
    out = {}
    for kind, src in SHIPPED.items():
        ds = read_table(src)
        if kind == "doublet":
            ds = ds.sel(ratio=[1.0, 2.0])
        out[kind] = write_table(ds, d / f"{kind}.nc", command=f"test {kind}",
                                solver_settings={"test": True})
    return out


def edited(tables, kind, tmp_path, edit=None, drop_checksums=False, name="edited.nc"):
    """A copy of ``tables[kind]`` edited in place by ``edit(nc)`` (netCDF4)."""
    path = tmp_path / f"{kind}-{name}"
    shutil.copyfile(tables[kind], path)
    with netCDF4.Dataset(path, "r+") as nc:
        if edit is not None:
            edit(nc)
        if drop_checksums:
            for a in CHECKSUMS:
                if a in nc.ncattrs():
                    nc.delncattr(a)
    return path


def load(kind, path, **kw):
    """Load a table the way its users do: the surrogates' fit, read_table otherwise."""
    if kind == "doublet":
        return DoubletSurrogate().fit(path, **kw)
    if kind == "triplet":
        return TripletSurrogate().fit(path, coalescence_table=DEFAULT_COALESCENCE_TABLE, **kw)
    return TripletSurrogate().fit(DEFAULT_TRIPLET_TABLE, coalescence_table=path, **kw)


def refused(kind, path, *words, allow=False):
    """Refused by the loader and by `capbridge info` (one line, exit 2), naming the
    file and ``words``."""
    with pytest.raises(TableError) as exc:
        load(kind, path, allow_unverified=allow)
    text = str(exc.value)
    assert str(path) in text and "\n" not in text, text
    assert "regenerate" in text, text                      # what to do
    for w in words:
        assert w in text, (w, text)
    return text


def info_refuses(path, capsys, *words, allow=False):
    args = ["info", "--table", str(path)] + (["--allow-unverified-table"] if allow else [])
    code, _, err = run(args, capsys)
    assert_clean_error(code, err, str(path), *words)


def set_units(var, units):
    return lambda nc: nc[var].setncattr("units", units)


# ---------------------------------------------------------------- the shipped tables
@pytest.mark.parametrize("kind", sorted(SHIPPED))
def test_shipped_tables_are_verified(kind):
    ds = read_table(SHIPPED[kind])
    assert len(ds.attrs["table_sha256"]) == 64
    assert checksum_state(ds).startswith("verified")
    assert "+dirty" not in ds.attrs["git_commit"]


def test_info_says_verified(capsys):
    code, out, err = run(["info"], capsys)
    assert code == 0, err
    assert out.count("table checksum: verified") == 3, out
    assert "warning" not in err


# ------------------------------------------------------------------- units edited
UNIT_EDITS = [("doublet", "gravity_theta", "radian"),      # an axis the lookups read
              ("doublet", "weight_share_axial", "N"),
              ("triplet", "f12", "N"),
              ("triplet", "theta", "radian"),
              ("triplet", "force_gravity_gradient", "N"),
              ("coalescence", "theta", "radian"),
              ("coalescence", "V_coal_pair", "mm3")]


@pytest.mark.parametrize("kind, var, units", UNIT_EDITS)
def test_units_edited_are_refused(tables, tmp_path, capsys, kind, var, units):
    path = edited(tables, kind, tmp_path, set_units(var, units))
    refused(kind, path, "table_sha256", "mismatch")
    info_refuses(path, capsys, "table_sha256")
    # without the checksum, and allowed explicitly: the units check still refuses
    path = edited(tables, kind, tmp_path, set_units(var, units), drop_checksums=True,
                  name="nochecksum.nc")
    refused(kind, path, repr(var), repr(units), allow=True)
    info_refuses(path, capsys, repr(var), allow=True)


# ------------------------------------------------------------ error model replaced
ERROR_MODEL = {"doublet": "holdout_max_rel_error_force_ratio1_band0.2",
               "triplet": "holdout_max_rel_error_pair_force_by_v"}


@pytest.mark.parametrize("kind", sorted(ERROR_MODEL))
def test_error_model_replaced_is_refused(tables, tmp_path, capsys, kind):
    path = edited(tables, kind, tmp_path, lambda nc: nc.setncattr(ERROR_MODEL[kind], 1e-9))
    refused(kind, path, "table_sha256", "error model")
    info_refuses(path, capsys, "table_sha256")


def test_coalescence_error_model_replaced_is_refused_even_allowed(tables, tmp_path, capsys):
    def better(nc):
        model = json.loads(nc.getncattr("interpolation_error_pair"))
        model["cubic"]["max"] = 1e-9
        nc.setncattr("interpolation_error_pair", json.dumps(model))

    refused("coalescence", edited(tables, "coalescence", tmp_path, better), "table_sha256")
    path = edited(tables, "coalescence", tmp_path, better, drop_checksums=True, name="n.nc")
    refused("coalescence", path, "interpolation_error_pair", "held-out", allow=True)
    info_refuses(path, capsys, "interpolation_error_pair", allow=True)


# ---------------------------------------------------------------- grid edited
def test_grid_attribute_edited_is_refused(tables, tmp_path, capsys):
    def shift(nc):
        grid = json.loads(nc.getncattr("grid"))
        grid["theta"][1] += 1.0
        nc.setncattr("grid", json.dumps(grid))

    refused("doublet", edited(tables, "doublet", tmp_path, shift), "table_sha256")
    path = edited(tables, "doublet", tmp_path, shift, drop_checksums=True, name="n.nc")
    refused("doublet", path, "'grid'", "coordinates", allow=True)
    info_refuses(path, capsys, "'grid'", allow=True)


# --------------------------------------------------------------- checksum deleted
@pytest.mark.parametrize("kind", sorted(SHIPPED))
@pytest.mark.parametrize("drop", [("table_sha256",), CHECKSUMS])
def test_unverified_table_is_refused_unless_allowed(tables, tmp_path, capsys, caplog,
                                                     kind, drop):
    def delete(nc):
        for a in drop:
            nc.delncattr(a)

    path = edited(tables, kind, tmp_path, delete)
    text = refused(kind, path, "unverified", "--allow-unverified-table",
                   "allow_unverified=True")
    assert ("data_sha256" in text) == (len(drop) == 1)
    info_refuses(path, capsys, "unverified", "--allow-unverified-table")
    with pytest.raises(TableError, match="unverified"):
        read_table(path)
    # allowed: used, with one warning line, and info says it is not verified
    with caplog.at_level(logging.WARNING, logger="capbridge"):
        load(kind, path, allow_unverified=True)
        ds = read_table(path, allow_unverified=True)
    lines = [r.getMessage() for r in caplog.records if str(path) in r.getMessage()]
    assert len(lines) == 1 and "\n" not in lines[0] and "unverified" in lines[0], lines
    assert checksum_state(ds).startswith("NOT verified")
    with allow_unverified_tables():
        read_table(path)
    code, out, err = run(["info", "--table", str(path), "--allow-unverified-table"], capsys)
    assert code == 0, err
    assert "table checksum: NOT verified" in out


# ------------------------------------------------------- physically impossible edits
def _negative_vcoal(nc):
    v = nc["V_coal_pair"]
    v[1, 2, 3, 2] = -v[1, 2, 3, 2]          # one node: V_coal -23 %, P -24 % before


def _gravity_x10(nc):
    nc["force_gravity_gradient"][:] = nc["force_gravity_gradient"][:] * 10


def _flip_f12(nc):
    nc["f12"][:] = -nc["f12"][:]


def _doublet_share_x10(nc):
    nc["weight_share_axial"][:] = nc["weight_share_axial"][:] * 10


IMPOSSIBLE = [("coalescence", _negative_vcoal, ["V_coal_pair", "not positive"]),
              ("triplet", _gravity_x10, ["force_gravity_gradient", "sum rule",
                                         "10 times the liquid's weight"]),
              ("triplet", _flip_f12, ["f12", "pair force of the stored force vectors"]),
              ("doublet", _doublet_share_x10, ["weight_share_axial", "equal grains"])]


@pytest.mark.parametrize("kind, edit, words", IMPOSSIBLE,
                         ids=["negative V_coal node", "triplet gravity x10",
                              "f12 sign-flipped", "doublet weight share x10"])
def test_physically_impossible_edits_are_refused(tables, tmp_path, capsys, kind, edit,
                                                 words):
    refused(kind, edited(tables, kind, tmp_path, edit), "table_sha256", "mismatch")
    path = edited(tables, kind, tmp_path, edit, drop_checksums=True, name="n.nc")
    refused(kind, path, words[0])                     # no checksum, not allowed
    refused(kind, path, *words, allow=True)           # allowed: the physics refuses
    info_refuses(path, capsys, words[0], allow=True)


def test_lookup_with_an_edited_table_is_one_line(tables, tmp_path, capsys):
    """The CLI's lookups refuse the edited table before answering anything."""
    path = edited(tables, "triplet", tmp_path, _flip_f12, drop_checksums=True)
    pts = tmp_path / "p.csv"
    pts.write_text("d12,d13,d23,V,theta\n0.1,0.1,0.1,0.3,40\n")
    code, _, err = run(["lookup", "triplet", "--input", str(pts), "--output",
                        str(tmp_path / "o.csv"), "--table", str(path),
                        "--allow-unverified-table"], capsys)
    assert_clean_error(code, err, str(path), "f12")
    assert not (tmp_path / "o.csv").exists()


# ---------------------------------------------------- what write_table writes
def test_checksum_covers_every_attribute(tables, tmp_path):
    """Any variable or global attribute edited (here a long name and the history,
    which mean nothing to the numbers) changes table_sha256; the values-only
    data_sha256 does not see it."""
    for edit in (lambda nc: nc["volume"].setncattr("long_name", "edited"),
                 lambda nc: nc.setncattr("history", "edited")):
        path = edited(tables, "doublet", tmp_path, edit)
        with pytest.raises(TableError, match="table_sha256"):
            read_table(path)
    ds = read_table(tables["doublet"])
    assert ds.attrs["data_sha256"] and ds.attrs["table_sha256"]
