"""README "Your own BMS export", run as a new user runs it: the CLI commands as subprocesses.

A short real-world-like export of the emulator (dual-maximum VAV with reheat, two air handlers, cold
climate, °F / CFM / %, naive local timestamps, logger outages, 15-minute trend log) goes through
``check``, ``fit`` (lumped, zones, physics), ``evaluate``, ``export`` and ``cosim``; the same export with
naive UTC timestamps declared as local must make ``check`` warn with the offset; without the ``Td_``
columns the verdict must say the models lose and name the missing input.

Measured (10 weeks from 2025-11-03, seed 0, the README's export; 10 of 14 test windows scored, fall 5
and winter 5, inputs filled across gaps up to 2 h): with ``Td`` the 24-h open-loop RMS is 0.10-0.19 K
(six-zone) and 0.11-0.17 K (physics) against persistence 0.53-0.90 K in every zone (lumped 0.117 against
0.642 K); against the time-of-week mean the lumped model wins by 26 %, the six-zone model in every zone
(by 1 % in C to 45 % in S), physics in 4 of 6 (it loses in NE by 5.5 % and in C by 5.0 %: the winter test
Monday, see README "Where physics lost"). The export declares the floor and ceiling slabs against the
storeys below and above (a constant-temperature boundary; adiabatic, as up to emulator 1.3, physics lost
by 25 % in NE and 11 % in C); with step 2's gain profile pooled over the workdays
(``gain_days="workdays"``, not the default) or shrunk toward it (``"shrunk"``) physics wins in every
zone, and that is asserted too. Without
``Td`` the lumped and six-zone models are worse than persistence everywhere (1.9-2.6 K) and physics is
worse than the time-of-week mean in 1 of 6 zones (3 of 6, W, E, NE, with the paper's ``gain_days="week"``,
the default before session 8); every kind is flagged first with the missing
``Td_`` columns. Bounds: every kind and zone beats persistence with ``Td``; lumped and six-zone beat the
time-of-week mean everywhere, physics in at least 4 of 6 zones and in none loses by 10 % or more; without
``Td`` the six-zone model loses to persistence in at least 4 of 6 zones and physics to the time-of-week
mean in at least 1. With 8 weeks (one winter training week) the Model A kinds lose to the time-of-week
mean in winter: the 10-week export is the one that is asserted.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import pandas as pd
import pytest

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]
EXPORT = [
    "--hvac",
    "reheat-dual",
    "--climate",
    "cold",
    "--units",
    "us",
    "--fault",
    "outages",
    "--start",
    "2025-11-03",
    "--weeks",
    "10",
    "--export-step",
    "900",
    "--seed",
    "0",
]


def hvacfmu(*args, ok=True, timeout=900):
    """Run ``python3 -m hvacfmu.cli ARGS`` with this tree first on the path; returns the process."""
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run(
        [sys.executable, "-m", "hvacfmu.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        cwd=REPO,
    )
    if ok:
        assert proc.returncode == 0, (
            f"hvacfmu {' '.join(map(str, args))}:\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
        )
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    return proc


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    out = tmp_path_factory.mktemp("bms") / "bms"
    hvacfmu("generate", out, "--clock", "naive-local", *EXPORT)
    return out


def test_check_reads_the_us_naive_export_and_its_clock(export):
    proc = hvacfmu("check", export / "measurements.parquet", "-b", export / "building.toml")
    out = proc.stdout
    assert "times naive, read in America/Chicago" in out
    assert "Clock: measured solar noon" in out and "look" not in out.split("Clock:")[1].splitlines()[0]
    last = out.rstrip().splitlines()[-1]
    assert last.startswith("OK") and "NEED" not in last and proc.returncode == 0, last
    # no library-version noise or bar debris on stderr (a pipe): plain log lines only
    assert "Pandas4Warning" not in proc.stderr and "\r" not in proc.stderr


def test_naive_utc_declared_local_is_flagged_with_the_offset(tmp_path):
    out = tmp_path / "utc"
    hvacfmu("generate", out, "--clock", "naive-utc", *EXPORT)
    toml = out / "building.toml"
    toml.write_text("".join(l for l in toml.read_text().splitlines(True) if not l.startswith("data_timezone")))
    proc = hvacfmu("check", out / "measurements.parquet", "-b", toml, ok=False)
    assert "clock: the data look 6 h late" in proc.stdout, proc.stdout
    assert "use --timezone UTC" in proc.stdout
    # not a clean bill: the final line names the warning that needs action, exit code 3
    assert proc.returncode == 3 and proc.stdout.rstrip().splitlines()[-1].startswith(
        "OK WITH 1 WARNING THAT NEEDS ACTION (see above: clock offset)"
    ), proc.stdout[-1000:]
    fixed = hvacfmu("check", out / "measurements.parquet", "-b", toml, "--timezone", "UTC")
    assert "look" not in fixed.stdout.split("Clock:")[1].splitlines()[0], fixed.stdout


def _verdict(path):
    return json.loads(Path(path).read_text())["verdict"]


def test_every_model_beats_persistence_with_td_then_export_and_cosim(export):
    data, bld = export / "measurements.parquet", export / "building.toml"
    models = []
    for kind in ("lumped", "zones", "physics"):
        fit = hvacfmu("fit", data, "-b", bld, "--model", kind, "-o", export / f"{kind}.json")
        assert "\r" not in fit.stderr  # Model B's progress is log lines when stderr is a pipe
        models += ["--model", export / f"{kind}.json"]
        if kind != "physics":  # the delivered-heat form is refined for 24-h prediction, and says so
            assert "refined for 24-h open-loop prediction (delivered heat" in fit.stdout, fit.stdout[-1500:]
    ev = hvacfmu("evaluate", data, "-b", bld, *models, "--json", export / "eval.json")
    verdict = _verdict(export / "eval.json")
    rows = verdict["zones"]
    assert {r["model"] for r in rows} == {"lumped", "zones", "physics"} and len(rows) == 13
    losing = [(r["model"], r["output"], r["rms"], r["persistence"]) for r in rows if r["rms"] >= r["persistence"]]
    assert not losing, losing
    # the time-of-week mean too: the Model A kinds in every zone; physics in at least 4 of 6 (see the docstring)
    tow = [(r["model"], r["output"], r["rms"], r["time_of_week"]) for r in rows if not r["beats_time_of_week"]]
    assert all(m == "physics" for m, *_ in tow) and len(tow) <= 2, tow
    assert all(r["rms"] < 1.1 * r["time_of_week"] for r in rows), rows
    assert "WORSE THAN PERSISTENCE" not in ev.stdout
    assert ev.stdout.splitlines()[0].startswith("lumped: beats persistence in 1/1 zones")
    _slabs_face_the_storeys(export)
    _physics_with_workday_gains_beats_time_of_week_everywhere(export)
    _cli_physics_with_auto_gain_days(export)
    # logger outages no longer skip most windows (inputs filled up to 2 h, errors on measured steps):
    # both seasons are scored, and the verdict says how many windows it stands on and why the others went
    cov = verdict["coverage"]["zones"]
    assert sum(cov["windows"].values()) >= 10 and set(cov["windows"]) == {"fall", "winter"}, cov
    assert sum(cov["windows"].values()) < cov["total"] and cov["rules"]["fill_inputs_h"] == 2.0, cov
    assert "per season: fall" in ev.stdout
    assert f"on {sum(cov['windows'].values())} of {cov['total']} test windows" in ev.stdout.splitlines()[1]

    diag = hvacfmu("diagnose", data, "-b", bld, "--json", export / "diag.json")
    head = diag.stdout.split("Verdict:")[0]  # the verdict against the baselines comes before the causes
    assert "Held-out verdict against persistence" in head and "extended: beats persistence in" in head, head
    assert "verdict" in json.loads((export / "diag.json").read_text())["heldout"]

    fmu = export / "zones.fmu"
    hvacfmu("export", export / "zones.json", "-o", fmu)
    with zipfile.ZipFile(fmu) as z:  # the discharge temperature inputs carry their unit
        md = ElementTree.fromstring(z.read("modelDescription.xml"))
    td = [sv for sv in md.iter("ScalarVariable") if sv.get("name", "").startswith("Td_")]
    assert len(td) == 21 and all(sv[0].get("unit") == "degC" and sv.get("causality") == "input" for sv in td)
    run = hvacfmu(
        "cosim",
        "--fmu",
        fmu,
        "-d",
        data,
        "-b",
        bld,
        "--model",
        export / "zones.json",
        "-c",
        "rule",
        "-o",
        export / "cosim.csv",
    )
    assert "completed       672 / 672 steps" in run.stdout, run.stdout
    assert "\r" not in run.stderr


def _slabs_face_the_storeys(export):
    """The export's building file says what the emulated building is: slabs against the storeys.

    The emulated floor's slabs face the storeys below and above (about 22 °C); the file declares them
    against a boundary at a constant temperature (``side2 = "ground"``, ``[physics].ground_temperature``),
    not adiabatic as up to emulator 1.3 (README "Where physics loses": the margins of both).
    """
    text = (export / "building.toml").read_text()
    assert text.count('side2 = "ground"') == 12, "the walkthrough floor has 6 floor and 6 ceiling slabs"
    assert 'side2 = "adiabatic"' not in text and "ground_temperature = 22.0" in text


def _physics_with_workday_gains_beats_time_of_week_everywhere(export):
    """``fit_physics(gain_days="workdays")``: one daily gain profile for Monday to Friday; ``"shrunk"``: each
    workday's profile shrunk toward it by the training weeks' scatter.

    The default per-time-of-week profile averages each winter Monday over three training weeks, one of
    them at the fall occupancy level (the emulator's season changes on a Tuesday, the data's on a Monday):
    physics over-predicts the winter test Monday and loses to the time-of-week mean in NE and C by 5 %.
    Pooled over the 15 training workdays it beats the time-of-week mean in every zone (by 2.6 % in C to
    54 % in S); shrunk by 4.5 % in C to 55 % in S. Neither is the default: both lose a zone-season cell of
    the 16-week reheat data (README). ``refit_gains`` redoes only step 2 and gives what a refit gives.
    """
    from hvacfmu.data import prepare
    from hvacfmu.evaluation import evaluate
    from hvacfmu.models.physics import fit_physics, refit_gains

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(export / "measurements.parquet", export / "building.toml")
        model = fit_physics(ds, progress=False, gain_days="workdays")
        again = refit_gains(model, ds, "workdays")
        shrunk = refit_gains(model, ds, "shrunk")
        res = evaluate([model, shrunk], ds, names=["workdays", "shrunk"])
    assert model.meta["gains"]["day_types"] == "workdays" and shrunk.meta["gains"]["day_types"] == "shrunk"
    assert all((again.gains[s] == model.gains[s]).all() for s in model.gains)
    assert any((shrunk.gains[s] != model.gains[s]).any() for s in model.gains)
    for name in ("workdays", "shrunk"):
        rms = res.table(name).loc["all"]
        tow = res.table(name, which="time-of-week mean").loc["all", rms.index]
        assert len(rms) >= 6 and (rms < tow).all(), (name, rms, tow)


def _cli_physics_with_auto_gain_days(export):
    """``hvacfmu fit --model physics --gain-days auto``: step 2's profile chosen by blocked CV on the training
    weeks (README "Chosen by cross-validation"); on this export it picks a pooled profile (measured: workdays),
    and the refit beats the time-of-week mean in every zone, as the pooled profiles above do."""
    from hvacfmu.models import load_model

    data, bld = export / "measurements.parquet", export / "building.toml"
    out = export / "physics_auto.json"
    fit = hvacfmu("fit", data, "-b", bld, "--model", "physics", "--gain-days", "auto", "-o", out)
    m = load_model(out)
    auto = m.meta["gains"]["auto"]
    assert m.meta["fit_options"]["gain_days"] == "auto" and auto["chosen"] in ("workdays", "shrunk"), auto
    assert f"auto -> {auto['chosen']}" in fit.stdout, fit.stdout[-1500:]
    hvacfmu("evaluate", data, "-b", bld, "--model", out, "--json", export / "eval_auto.json")
    rows = _verdict(export / "eval_auto.json")["zones"]
    assert len(rows) == 6 and all(r["beats_time_of_week"] and r["rms"] < r["persistence"] for r in rows), rows


def test_without_td_the_verdict_says_the_models_lose_and_names_the_missing_input(export, tmp_path):
    frame = pd.read_parquet(export / "measurements.parquet")
    frame.drop(columns=[c for c in frame.columns if c.startswith("Td_")]).to_parquet(tmp_path / "m.parquet")
    data, bld = tmp_path / "m.parquet", export / "building.toml"
    models = []
    for kind in ("lumped", "zones", "physics"):
        hvacfmu("fit", data, "-b", bld, "--model", kind, "-o", tmp_path / f"{kind}.json")
        models += ["--model", tmp_path / f"{kind}.json"]
    ev = hvacfmu("evaluate", data, "-b", bld, *models, "--json", tmp_path / "eval.json")
    first = ev.stdout.splitlines()[:3]
    assert first[0].startswith("!! lumped: beats persistence in 0/1") and first[1].startswith("!! zones:"), first
    # every kind is flagged on its first line, with the missing input named there
    assert first[2].startswith("!! physics:"), first
    assert all("missing input: Td_VAV_NW_1, Td_VAV_NW_2, Td_VAV_NW_3, Td_VAV_W_1 and 17 more" in f for f in first)
    # physics still beats persistence without Td (its RC structure keeps the sign of the heat right) but loses
    # to the time-of-week mean (with the default gain_days="auto" in 1 of 6 zones; with the paper's "week"
    # profile, the default before session 8, in W, E and NE), and the verdict says so
    verdict = _verdict(tmp_path / "eval.json")
    phys = [r for r in verdict["zones"] if r["model"] == "physics"]
    assert sum(not r["beats_time_of_week"] for r in phys) >= 1, phys
    assert "!! physics: WORSE THAN THE TIME-OF-WEEK MEAN in " in ev.stdout
    assert set(verdict["missing_inputs"]) == {"lumped", "zones", "physics"}
    assert verdict["likely_causes"]["physics"][0].startswith("missing input: the boxes reheat"), verdict
    zones = [r for r in _verdict(tmp_path / "eval.json")["zones"] if r["model"] == "zones"]
    assert sum(r["rms"] > r["persistence"] for r in zones) >= 4, zones
    causes = _verdict(tmp_path / "eval.json")["likely_causes"]["zones"]
    assert any(c.startswith("missing input") and "Td_VAV_NW_1" in c for c in causes), causes
    assert "missing input: the boxes reheat" in ev.stdout
    # one line per unused column, not one per (column, zone)
    unused = [c for c in causes if c.startswith("unused measured column")]
    assert len(unused) == len({c.split("'")[1] for c in unused}), unused
    # the note about the air handlers' weighted supply temperature is not a clock/unit cause
    assert not any(c.startswith("loading warned: T_supply is the airflow-weighted") for c in causes), causes
