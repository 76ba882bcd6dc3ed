"""`check` names what keeps the physics model from being built (session 19).

A building file whose windows had shgc = 4 or whose concrete layer was 150 "m" (mm meant) passed `check` with
exit 0; the first sign was a later `fit --kind physics` refusing it (the shgc) or a network with a 150 m wall (the
thickness, which nothing refused). `check` now adds a note listing the physics tables' problems, and a layer
thicker than 2 m is refused as a unit slip.
"""

from __future__ import annotations

import copy
import re
import shutil

from test_properties import BUILDING

from hvacfmu.building import building_from_dict
from hvacfmu.models.physics import physics_problems


def _building_copy(short_paths, tmp_path, edit):
    text = edit(short_paths.building.read_text())
    path = tmp_path / "building.toml"
    path.write_text(text)
    data = tmp_path / short_paths.measurements.name
    shutil.copy(short_paths.measurements, data)
    return data, path


def test_check_notes_window_shgc_above_1_and_a_layer_in_mm(short_paths, tmp_path, cli):
    def edit(text):
        text = text.replace("shgc = 0.4", "shgc = 4", 1)
        return re.sub(r"thickness = 0\.15\b", "thickness = 150", text, count=1)

    data, building = _building_copy(short_paths, tmp_path, edit)
    r = cli("-q", "check", data, "-b", building)
    assert r.returncode == 0, r.stdout[-3000:]  # the data-driven kinds can still be fitted
    (note,) = [x for x in r.stdout.splitlines() if "the physics model (fit --kind physics) cannot be built" in x]
    assert "(2 problem(s))" in note and "shgc must lie in [0, 1], got 4" in note
    assert "thickness [m] = 150 m is thicker than any building layer (> 2 m): is it in mm (0.15 m)" in note


def test_check_of_a_usable_building_file_adds_no_physics_note(short_paths, cli):
    r = cli("-q", "check", short_paths.measurements, "-b", short_paths.building)
    assert r.returncode == 0 and "physics" not in r.stdout.split("Warnings")[-1], r.stdout[-3000:]


def test_a_building_file_without_physics_tables_gets_no_physics_note():
    """A BMS building file with zones and boxes only is for the data-driven kinds: no note. The CLI keys on the
    first problem physics_problems gives for it (test_data.py::test_check_cli counts the notes of such a file)."""
    assert physics_problems(building_from_dict(copy.deepcopy(BUILDING)))[0].startswith(
        "no [[elements]] or [[constructions]] tables"
    )


def test_a_template_refusal_on_one_line_is_a_physics_problem():
    """physics_problems dropped a one-line BuildingError (a template beside its own tables) and said "usable"."""
    d = copy.deepcopy(BUILDING)
    d["construction_template"] = "concrete_slab_office_1990s"
    assert physics_problems(building_from_dict(copy.deepcopy(d))) == []
    d["windows"] = [{"name": "w", "zone": "A", "orientation": "S", "area": 10.0, "u_value": 2.6, "shgc": 0.4}]
    (problem,) = physics_problems(building_from_dict(d))
    assert "construction_template 'concrete_slab_office_1990s' and the tables ['windows'] are both given" in problem
