"""Two more clean EnergyPlus exports that were refused (session 16, benchmarks/refusals_s16.md): synthetic, no EnergyPlus."""

from __future__ import annotations

import datetime as dt

from hvacfmu.building import building_from_dict
from hvacfmu.energyplus.idf import parse_idf
from hvacfmu.energyplus.inputs import MAX_REHEAT_AIR, Site, prepare_idf

# two boxes as the DOE Ref (2004) medium office writes them (no maximum reheat air temperature) and as the 90.1
# prototypes do (40 °C, kept); fields after the class name, the limit is the 19th
_BOX = "AirTerminal:SingleDuct:VAV:Reheat,{n},ALWAYS_ON,{n} D,{n} I,AUTOSIZE,Constant,0.3,,,Coil:Heating:Electric,{n} C,AUTOSIZE,0.0,{n} O,0.001,NORMAL,AUTOCALCULATE,AUTOCALCULATE{tail};"
_IDF = _BOX.format(n="Ref", tail="") + "\n" + _BOX.format(n="Std", tail=",35")
_SITE = Site(41.98, -87.92, -6.0, 201.0, "America/Chicago", "Chicago")


def test_a_reheat_box_without_a_discharge_limit_gets_one():
    # the Ref medium office's electric coils blew 84 °C air at 0.3 x m_max in the morning warm-up: check refused it
    idf = parse_idf(_IDF)
    notes = prepare_idf(idf, dt.date(2017, 1, 11), dt.date(2017, 2, 8), _SITE)
    boxes = {o.name: o for o in idf.all("AirTerminal:SingleDuct:VAV:Reheat")}
    assert boxes["Ref"].number(18) == MAX_REHEAT_AIR == 40.0
    assert boxes["Std"].number(18) == 35.0  # a limit the file sets is kept
    assert any("Maximum Reheat Air Temperature" in n and "Ref" in n and "Std" not in n for n in notes)
    assert "AUTOCALCULATE,40;" in parse_idf(idf.text()).text()


def test_a_data_centres_unit_is_not_taken_for_a_unit_error(small_building_dict):
    # 90.1 large office: the basement data centre (484 W/m2 of IT) gets 25.5 kg/s into 1911 m3, 40 air changes an
    # hour; the building file refused it as "more than any VAV box delivers"
    d = small_building_dict
    d["zones"][0].update(area=640.0, volume=1911.39)
    d["vavs"][0].update(m_min=0.0, m_max=25.4962)
    assert building_from_dict(d).vavs[0].m_max == 25.4962
