"""A season boundary inside one run of an FMU or a co-simulation (issue 13).

Before: both FMUs ran the ``season`` parameter's gains profile and coefficient set for the whole run, and
``hvacfmu cosim`` over a free span from one season into the next ran the first season's all along, without a word.
Now the Python FMU exported with the building file takes ``season = 0``, "follow the calendar" (the season table by
date is in its resources; needs ``start_time``), the native FMU refuses 0 naming the Python FMU, and ``cosim``
switches season at the boundary (season 0) or refuses the span naming the dates, the seasons and the remedy.
On main every test here fails (no season 0, no refusal; ``harness.cosim.season_pieces`` does not exist).
"""

from __future__ import annotations

import copy
import json
import warnings
import zipfile

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.building import building_from_dict
from hvacfmu.errors import DataError, HvacfmuWarning
from tests.conftest import SMALL_BUILDING
from tests.test_seasons_s21 import _signals, two_season

EXACT = 1e-9  # [K] FMU against the Python model: the same double-precision recursion, piece by piece
TZ = "America/Los_Angeles"
NAMES_IN = ["m_V1", "m_V2", "m_V3", "T_out", "T_supply"]
Y0 = {"T_A_start": 21.0, "T_B_start": 22.0}


def _building():
    d = copy.deepcopy(SMALL_BUILDING)
    d["seasons"] = [
        {"name": "winter", "start": "10-15", "end": "04-14"},
        {"name": "summer", "start": "04-15", "end": "10-14"},
    ]
    return building_from_dict(d)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """The two-season Model A's Python FMU exported with the building file (season table) and without it."""
    from hvacfmu.fmu import export_fmu

    d = tmp_path_factory.mktemp("fmuseason")
    path = two_season().save(d / "s.json")
    return {
        "table": export_fmu(path, d / "Table.fmu", building=_building()),
        "plain": export_fmu(path, d / "Plain.fmu"),
    }


def _inputs(start="2025-04-12 00:00", days=5):
    idx = pd.date_range(start, periods=96 * days, freq="15min", tz=TZ)
    m, v = _signals(len(idx))
    return idx, m, v, np.hstack([m, v])


def _python_pieces(idx, m, v):
    """The Python simulation of each season's piece (the building's season of each step's local day), the state
    carried over from one piece to the next."""
    from hvacfmu.models.state import state_from_outputs

    sm, b = two_season(), _building()
    seasons = [b.season_of(t) for t in idx]
    x, ys = None, []
    for k in range(len(idx)):
        mod = sm.for_season(seasons[k])
        u = m[k] @ mod.input_map.T
        q = np.asarray(mod.gains_at(idx[k : k + 1], seasons[k]))[0]
        if x is None:
            x = state_from_outputs(mod, np.array([21.0, 22.0]), u, v[k], q)
            ys.append(mod.output(x))
        x = mod.step_state(x, u, v[k], q)
        ys.append(mod.output(x))
    return np.array(ys), seasons


def _run(path, name, sv, U, k0=0):
    from tests.test_fmu import Slave, run_fmu

    s = Slave(path, name)
    try:
        s.init({**Y0, **sv}, inputs=(NAMES_IN, U[0]))
        return run_fmu(s, NAMES_IN, U, ["T_A", "T_B"])
    finally:
        s.close()


def test_layout_holds_the_season_table_and_season_zero(fmus):
    from fmpy import read_model_description

    lay = json.loads(zipfile.ZipFile(fmus["table"]).read("resources/interface.json"))
    assert lay["season_dates"] == [["winter", "10-15", "04-14"], ["summer", "04-15", "10-14"]]
    assert lay["timezone"] == TZ
    md = read_model_description(str(fmus["table"]))
    assert "season = 0 follows them" in md.description
    var = {v.name: v for v in md.modelVariables}
    assert var["season"].min == "0" and "0 = follow the calendar" in var["season"].description
    assert "winter 10-15 .. 04-14" in var["season"].description
    assert "needed by season = 0" in var["start_time"].description
    assert lay["calendar"] is False  # no holidays: start_time unset is no cause for a warning
    plain = {v.name: v for v in read_model_description(str(fmus["plain"])).modelVariables}
    assert plain["season"].min == "1" and "start_time" not in plain  # without the building: as before


def test_python_fmu_follows_the_calendar_across_a_boundary(fmus):
    """season = 0 through FMPy: equal (1e-9 K) to the Python simulation of the winter piece then the summer piece
    with the state carried over; equal to season 1 up to the boundary (2025-04-15 00:00 local), kelvins apart after."""
    idx, m, v, U = _inputs()
    t0 = idx[0].timestamp()
    Y = _run(fmus["table"], "follow", {"season": 0, "start_time": t0}, U)
    ref, seasons = _python_pieces(idx, m, v)
    assert_allclose(Y, ref, rtol=0, atol=EXACT)
    cut = seasons.index("summer")
    assert idx[cut] == pd.Timestamp("2025-04-15 00:00", tz=TZ)
    Yw = _run(fmus["table"], "winter", {"season": 1, "start_time": t0}, U)
    assert_allclose(Y[: cut + 1], Yw[: cut + 1], rtol=0, atol=EXACT)
    # season 1 without start_time: the time-of-week profile as before the table existed (2025-04-12 is a Saturday)
    assert_allclose(_run(fmus["table"], "tow", {"season": 1, "start_time_of_week": 5 * 86400.0}, U), Yw, atol=EXACT)
    assert np.abs(Y[cut + 1 :] - Yw[cut + 1 :]).max() > 1.0
    # a run that starts in summer and stays there is season 2's run
    idx2, _, _, U2 = _inputs("2025-05-01 00:00", days=2)
    Y2 = _run(fmus["table"], "follow2", {"season": 0, "start_time": idx2[0].timestamp()}, U2)
    assert_allclose(Y2, _run(fmus["table"], "summer2", {"season": 2, "start_time": idx2[0].timestamp()}, U2), atol=0)


def test_fmu_state_restored_across_the_boundary(fmus):
    """fmi2GetFMUstate before the boundary, run past it, restore, run again: the same outputs (season included)."""
    from tests.test_fmu import Slave, run_fmu

    idx, m, v, U = _inputs(days=4)
    s = Slave(fmus["table"], "state")
    try:
        s.init({**Y0, "season": 0, "start_time": idx[0].timestamp()}, inputs=(NAMES_IN, U[0]))
        k = 200  # 2025-04-14 02:00, before the boundary at step 288
        run_fmu(s, NAMES_IN, U[:k], ["T_A", "T_B"])
        state = s.fmu.getFMUstate()
        a = run_fmu(s, NAMES_IN, U[k:], ["T_A", "T_B"], k0=k)
        s.fmu.setFMUstate(state)
        b = run_fmu(s, NAMES_IN, U[k:], ["T_A", "T_B"], k0=k)
        s.fmu.freeFMUstate(state)
    finally:
        s.close()
    assert_allclose(a, b, rtol=0, atol=0)
    ref, _ = _python_pieces(idx, m, v)
    assert_allclose(a, ref[k:], rtol=0, atol=EXACT)


@pytest.mark.parametrize(
    "which, sv, expected",
    [
        ("table", {"season": 0}, "season=0 (follow the calendar's seasons) needs start_time"),
        ("plain", {"season": 0}, "export the FMU with the building file"),
    ],
)
def test_season_zero_refused_without_start_time_or_table(fmus, which, sv, expected):
    from tests.test_fmu import Slave

    _, _, _, U = _inputs(days=1)
    s = Slave(fmus[which], f"refuse_{which}")
    try:
        s.init({**Y0, **sv}, inputs=(NAMES_IN, U[0]))
        with pytest.raises(Exception, match="fmi2DoStep"):
            s.fmu.doStep(0.0, 900.0)
        assert any(expected in msg for _, _, msg in s.log), s.log
    finally:
        s.close()


@pytest.mark.slow
def test_native_fmu_refuses_season_zero_naming_the_python_fmu(tmp_path):
    from fmpy import read_model_description

    from hvacfmu.fmu import export_native_fmu
    from tests.test_fmu import Slave

    path = export_native_fmu(two_season(), tmp_path / "N.fmu", model_name="seasonal")
    var = {v.name: v for v in read_model_description(str(path)).modelVariables}
    assert "season = 0 (follow the calendar) is refused" in var["season"].description
    _, _, _, U = _inputs(days=1)
    s = Slave(path, "native0")
    try:
        with pytest.raises(Exception, match="fmi2ExitInitializationMode"):  # refused at initialisation
            s.init({**Y0, "season": 0, "start_time_of_week": 0.0}, inputs=(NAMES_IN, U[0]))
        assert any("not supported by the native FMU" in msg and "Python FMU" in msg for _, _, msg in s.log), s.log
    finally:
        s.close()


def test_energyplus_host_stepper_runs_season_zero(fmus):
    """The EnergyPlus host's FMU stepper with ``follow`` (what ``run_host`` sets for a span across a boundary)
    starts the FMU with season 0 and start_time from the first step's local time: equal to the pieces."""
    from harness.energyplus_host import _FMUStepper

    idx, m, v, U = _inputs(days=4)
    st = _FMUStepper(fmus["table"], ("A", "B"), "winter")
    st.follow = True
    ys = []
    try:
        for k, t in enumerate(idx):
            out = st.step(k * 900.0, 900.0, dict(zip(NAMES_IN, U[k])), None, t, {"T_A": 21.0, "T_B": 22.0})
            ys.append([out["T_A"], out["T_B"]])
    finally:
        st.close()
    ref, _ = _python_pieces(idx, m, v)
    assert_allclose(np.array(ys), ref[1:], rtol=0, atol=EXACT)


# ----------------------------------------------------------------------------- cosim over a free span
@pytest.fixture(scope="module")
def late_data(short_paths, tmp_path_factory):
    """The 8-week emulator dataset with its fall cut in two seasons at 09-29 (fall until 09-28, "late" after)."""
    from pathlib import Path

    from hvacfmu.data import prepare

    text = Path(short_paths.building).read_text()
    old = '{ name = "fall", start = "09-01", end = "12-15" }'
    assert old in text
    text = text.replace(
        old, '{ name = "fall", start = "09-01", end = "09-28" }, { name = "late", start = "09-29", end = "12-15" }'
    )
    d = tmp_path_factory.mktemp("late")
    (d / "building.toml").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        data = prepare(short_paths.measurements, d / "building.toml")
    from hvacfmu.fmu import export_fmu
    from tests.test_fmu import zones_model

    model = zones_model(data.building)
    path = model.save(d / "zones.json")
    return data, export_fmu(path, d / "Table.fmu", building=d / "building.toml"), export_fmu(path, d / "Plain.fmu")


SPAN = dict(start="2025-09-27 00:00", stop="2025-10-01 00:00", warmup=0.0)


def test_season_pieces_of_a_span(late_data):
    from harness.cosim import season_pieces

    data, _, _ = late_data
    idx = data.frame.loc["2025-09-27":"2025-09-30"].index
    pieces = season_pieces(idx, data.building)
    assert [p[0] for p in pieces] == ["fall", "late"]
    assert pieces[1][1] == pd.Timestamp("2025-09-29 00:00", tz=idx.tz)
    assert pieces[0][2] == pieces[1][1] - pd.Timedelta(minutes=15)


def test_cosim_refuses_a_span_across_a_boundary_it_cannot_follow(late_data):
    from harness.controllers import ReplayController
    from harness.cosim import run_cosim

    data, _, plain = late_data
    with pytest.raises(DataError) as err:
        run_cosim(plain, data, ReplayController(), **SPAN)
    msg = str(err.value)
    for part in (
        "crosses 1 season boundary",
        "fall 2025-09-27 00:00 .. 2025-09-28 23:45",
        "late 2025-09-29 00:00",
        "Split the run at the boundaries",
        "--season",
        "export -b",
    ):
        assert part in msg, msg
    with pytest.warns(HvacfmuWarning, match="season 'fall' was chosen and runs for the whole span"):
        r = run_cosim(plain, data, ReplayController(), season="fall", **SPAN)
    assert r.covered


def test_cosim_refuses_an_fmu_whose_season_table_is_another_buildings(late_data, short_paths, tmp_path):
    """An FMU exported with the default seasons (fall until 12-15) on data whose building cuts fall at 09-29."""
    from harness.controllers import ReplayController
    from harness.cosim import run_cosim
    from hvacfmu.fmu import export_fmu
    from tests.test_fmu import zones_model

    data, _, _ = late_data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        from hvacfmu.building import load_building

        other = load_building(short_paths.building)
        path = zones_model(data.building).save(tmp_path / "z.json")
        fmu = export_fmu(path, tmp_path / "Other.fmu", building=other)
    with pytest.raises(DataError, match="would follow its own season table .* not the building file's"):
        run_cosim(fmu, data, ReplayController(), **SPAN)


def test_cosim_switches_season_at_the_boundary(late_data):
    """The FMU with the season table runs season 0: the same as season 'fall' until the boundary, not after."""
    from harness.controllers import ReplayController
    from harness.cosim import run_cosim

    data, table, _ = late_data
    r = run_cosim(table, data, ReplayController(), **SPAN)
    assert r.covered and r.summary["season"] == "fall"
    assert [p["season"] for p in r.summary["seasons_followed"]] == ["fall", "late"]
    assert "the FMU followed the calendar (season 0): fall 2025-09-27" in r.format_summary()
    with pytest.warns(HvacfmuWarning):
        f = run_cosim(table, data, ReplayController(), season="fall", **SPAN)
    zones = [f"T_{z}" for z in data.building.zone_names]
    cut = r.table.index.searchsorted(pd.Timestamp("2025-09-29 00:00", tz=r.table.index.tz))
    a, b = r.table[zones].to_numpy(), f.table[zones].to_numpy()
    assert_allclose(a[: cut + 1], b[: cut + 1], rtol=0, atol=EXACT)
    assert np.abs(a[cut + 1 :] - b[cut + 1 :]).max() > 0.01


def test_cosim_command_names_the_boundary(late_data, short_paths, cli):
    """``hvacfmu cosim --start/--stop`` across the boundary with an FMU exported without the building: refused,
    exit status not 0, the message on stderr; with ``--season``: runs (the warning names the boundary)."""
    from pathlib import Path

    data, _, plain = late_data
    bfile = Path(plain).parent / "building.toml"
    args = ["cosim", "--fmu", plain, "--data", short_paths.measurements, "-b", bfile, "-c", "replay"]
    span = ["--start", SPAN["start"], "--stop", SPAN["stop"]]
    r = cli(*args, *span)
    assert r.returncode != 0
    assert "crosses 1 season boundary" in r.stderr and "Split the run at the boundaries" in r.stderr, r.stderr
    r = cli(*args, *span, "--season", "fall")
    assert r.returncode == 0, r.stderr
    assert "season 'fall' was chosen" in r.stderr
