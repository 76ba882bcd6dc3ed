"""examples/energyplus_cosim.py takes --weather and passes it to the export and to both host runs.

Fourth EnergyPlus round: a building exported with `hvacfmu generate --weather usa_ca_fresno` could not be hosted in the
same weather by the example (it always used the IDF's city), so model and host ran on another climate than the data.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "energyplus_cosim.py"


class Stop(Exception):
    pass


def test_weather_reaches_the_export_and_the_host(monkeypatch):
    spec = importlib.util.spec_from_file_location("energyplus_cosim_example", EXAMPLE)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    seen = {}

    def identify(prototype, out, kind="zones", weather=None):
        seen["identify"] = weather
        return type("D", (), {"weeks": [1]})(), type("M", (), {"kind": "zones"})(), out / "zones.fmu"

    def run_week(*args, weather=None, **kwargs):
        seen["host"] = weather
        raise Stop

    monkeypatch.setattr(example, "identify", identify)
    monkeypatch.setattr(example, "run_week", run_week)
    with pytest.raises(Stop):
        example.main(["--prototype", "x", "--weather", "usa_ca_fresno", "--out", "/tmp/hvacfmu-example-test"])
    assert seen == {"identify": "usa_ca_fresno", "host": "usa_ca_fresno"}

    import hvacfmu.energyplus as ep

    calls = []
    monkeypatch.setattr(
        ep, "cached_export", lambda prototype, **options: calls.append(options) or (_ for _ in ()).throw(Stop())
    )
    spec.loader.exec_module(example)
    with pytest.raises(Stop):
        example.identify("x", Path("/tmp/hvacfmu-example-test"), weather="usa_ca_fresno")
    assert calls == [{"weather": "usa_ca_fresno"}]
