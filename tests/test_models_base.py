import json

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import ModelError
from hvacfmu.models import load_model
from hvacfmu.models.linear import LinearZoneModel


def make_model(nx=2):
    rng = np.random.default_rng(0)
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B")[:nx],
        measured_zones=("A", "B")[:nx],
        output_weights=np.eye(nx),
        vavs=("V1", "V2", "V3"),
        input_map=np.array([[1, 1, 0], [0, 0, 1]])[:nx],
        disturbances=("T_out", "T_supply"),
        A=np.array([[0.9, 0.02], [0.03, 0.85]])[:nx, :nx],
        B=-np.diag([0.3, 0.5])[:nx, :nx],
        C=np.array([[0.02, 0.05], [0.03, 0.06]])[:nx],
        gains={"fall": rng.uniform(0, 0.5, (672, nx))},
    )


def test_simulate_matches_recursion():
    m = make_model()
    rng = np.random.default_rng(1)
    n = 50
    u, v, q = rng.uniform(0, 1, (n, 2)), rng.uniform(10, 20, (n, 2)), rng.uniform(0, 0.3, (n, 2))
    X, Y = m.simulate([21.0, 22.0], u, v, q)
    x = np.array([21.0, 22.0])
    for k in range(n):
        x = m.A @ x + m.B @ u[k] + m.C @ v[k] + q[k]
    assert_allclose(X[-1], x, rtol=0, atol=1e-12)
    # batched simulation equals one-by-one
    Xb, _ = m.simulate(np.stack([[21.0, 22.0]] * 3), np.stack([u] * 3), np.stack([v] * 3), np.stack([q] * 3))
    assert_allclose(Xb[1], X, rtol=0, atol=1e-12)


def test_json_roundtrip(tmp_path):
    m = make_model()
    p = m.save(tmp_path / "m.json")
    m2 = load_model(p)
    assert_allclose(m2.A, m.A, rtol=0, atol=0)
    assert_allclose(m2.gains["fall"], m.gains["fall"], rtol=0, atol=0)
    idx = pd.date_range("2025-09-01", periods=5, freq="15min", tz="America/Los_Angeles")
    assert_allclose(m2.gains_at(idx, "fall"), m.gains["fall"][:5], rtol=0, atol=0)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d.update(format_version=99), "newer than this hvacfmu"),
        (lambda d: d.update(kind="bogus"), "unknown model kind"),
        (lambda d: d.update(A=[[1.0]]), "A has shape"),
        (lambda d: d.pop("B"), "missing keys"),
        (lambda d: d["gains"].update(fall=[[0.0, 0.0]]), r"gains\['fall'\]"),
    ],
)
def test_bad_model_file(tmp_path, edit, message):
    d = make_model().to_dict()
    edit(d)
    p = tmp_path / "m.json"
    p.write_text(json.dumps(d))
    with pytest.raises(ModelError, match=message):
        load_model(p)


def test_corrupt_file(tmp_path):
    p = tmp_path / "m.json"
    p.write_text("{not json")
    with pytest.raises(ModelError, match="not valid JSON"):
        load_model(p)
