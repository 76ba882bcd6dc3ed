"""Construction templates (issue 13 p.7): Model B from zone areas, adjacency, facades and one template name."""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from hvacfmu.building import building_from_dict, load_building
from hvacfmu.errors import BuildingError, ModelError
from hvacfmu.models import load_model
from hvacfmu.models.physics import PhysicsModel, parse_physics
from hvacfmu.models.physics.templates import TEMPLATES, expand_template
from tests.test_datadriven import six_zone_building_dict


def template_building(name="concrete_slab_office_1990s", **extra):
    d = six_zone_building_dict()  # zones: area, volume, adjacency, facades; boxes; nothing else
    d["construction_template"] = name
    d.update(extra)
    return building_from_dict(d)


def gains(model, value=500.0):
    n = int(7 * 86400 / model.step)
    return {s: np.full((n, len(model.q_names)), value) for s in ("fall", "winter", "spring", "summer")}


def _model(name):
    b = template_building(name)
    probe = PhysicsModel(b, parse_physics(b).nominal, {"winter": np.zeros((672, 6))})
    return PhysicsModel(b, probe.params, gains(probe))


@pytest.mark.parametrize("name", list(TEMPLATES))
def test_every_template_builds_a_runnable_model(name):
    m = _model(name)
    spec = m._spec
    b = m.building
    # one floor and one ceiling per zone, one wall per facade, one partition per adjacent pair
    n_fac = sum(len(z.facades) for z in b.zones)
    assert len(spec.elements) == 2 * len(b.zones) + n_fac + len(b.adjacency_pairs())
    assert len(spec.windows) == n_fac
    assert spec.nominal["U_win"] == TEMPLATES[name]["window_u"]
    x0 = m.network.wall_steady_state(np.full(6, 21.0), 10.0)
    n = 96
    u = np.full((n, len(b.vavs)), 0.2)
    v = np.column_stack([np.full(n, 5.0), np.full(n, 14.0)])
    q = m.gains_for_rows(pd.date_range("2025-01-06", periods=n, freq="15min", tz=b.timezone))
    _, Y = m.simulate(x0, u, v, q)
    assert np.all(np.isfinite(Y)) and np.all((Y > 0) & (Y < 40))


def test_heavier_templates_respond_slower():
    """4 h of 2 kW in every zone from equilibrium: less accessible mass, larger rise.

    Ordering light steel > 1990s office (its slabs behind carpet and plenum) > heavy masonry,
    each by more than 30 % (measured: 1.56, 1.06, 0.57 K).
    """
    rise = {}
    for name in TEMPLATES:
        m = _model(name)
        x0 = m.network.wall_steady_state(np.full(6, 20.0), 20.0)
        n = 16
        u = np.zeros((n, len(m.inputs)))
        v = np.full((n, len(m.disturbances)), 20.0)
        q = np.zeros((n, len(m.q_names)))
        q[:, :6] = 2000.0
        _, Y = m.simulate(x0, u, v, q)
        rise[name] = float(np.mean(Y[-1] - 20.0))
    assert rise["light_steel_frame"] > 1.3 * rise["concrete_slab_office_1990s"], rise
    assert rise["concrete_slab_office_1990s"] > 1.3 * rise["heavy_masonry"], rise


def test_overrides_and_round_trip(tmp_path):
    b = template_building("heavy_masonry", physics={"ground_temperature": 12.0, "nominal": {"U_win": 2.0}})
    spec = parse_physics(b)
    assert spec.nominal["U_win"] == 2.0 and spec.nominal["gamma_floor"] == 5.9 and spec.ground_temperature == 12.0
    path = b.save(tmp_path / "b.toml")
    assert load_building(path).physics["construction_template"] == "heavy_masonry"
    m = PhysicsModel(b, spec.nominal, gains(PhysicsModel(b, spec.nominal, {"winter": np.zeros((672, 6))})))
    back = load_model(m.save(tmp_path / "m.json"))
    assert back.n_states == m.n_states and back.params == m.params


@pytest.mark.parametrize(
    "change, message",
    [
        ({"construction_template": "igloo"}, "'igloo' is not a known template; known: concrete_slab_office_1990s"),
        ({"elements": [{"name": "x"}]}, r"construction_template .* and the tables \['elements'\] are both given"),
    ],
)
def test_bad_templates(change, message):
    d = six_zone_building_dict()
    d["construction_template"] = "light_steel_frame"
    d.update(change)
    with pytest.raises(BuildingError, match=message):
        parse_physics(building_from_dict(d))
    with pytest.raises(ModelError, match=message):
        PhysicsModel(building_from_dict(d), {"U_win": 1.0}, {"winter": np.zeros((672, 6))})


def test_expand_is_pure():
    b = template_building()
    raw = copy.deepcopy(b.physics)
    expand_template(b, b.physics)
    assert b.physics == raw
