"""Every model kind with linear/bilinear dynamics describes itself as ModelEquations that match step_state."""

from __future__ import annotations

import numpy as np
import pytest

from hvacfmu.errors import ModelError
from hvacfmu.models.equations import ModelEquations, Switch, check_equations
from hvacfmu.models.linear import LinearZoneModel


def _linear(nx=2):
    from tests.test_models_base import make_model

    return make_model(nx)


def test_linear_equations_match_step_state():
    model = _linear()
    eq = model.equations()
    assert not eq.bilinear
    assert check_equations(model, eq, atol=1e-12) <= 1e-12


def test_equations_detect_a_wrong_matrix():
    model = _linear()
    eq = model.equations()
    A = eq.A.copy()
    A[0, 0] += 1e-3
    wrong = ModelEquations(
        step=eq.step,
        A=A,
        Bu=eq.Bu,
        Bv=eq.Bv,
        Bq=eq.Bq,
        C=eq.C,
        inputs=eq.inputs,
        disturbances=eq.disturbances,
        outputs=eq.outputs,
        gains=eq.gains,
    )
    with pytest.raises(ModelError, match="differ from its step_state"):
        check_equations(model, wrong)


def test_shapes_are_checked():
    model = _linear()
    eq = model.equations()
    with pytest.raises(ModelError, match="Bu has shape"):
        ModelEquations(
            step=eq.step,
            A=eq.A,
            Bu=eq.Bu[:, :0],
            Bv=eq.Bv,
            Bq=eq.Bq,
            C=eq.C,
            inputs=eq.inputs,
            disturbances=eq.disturbances,
            outputs=eq.outputs,
            gains=eq.gains,
        )


def test_switch_adds_gain_only_when_active():
    model = _linear(1)
    eq = model.equations()
    sw = Switch(gain=np.array([0.5]), input_index=0, input_below=0.1, disturbance_index=0, disturbance_below=10.0)
    eq2 = ModelEquations(
        step=eq.step,
        A=eq.A,
        Bu=eq.Bu,
        Bv=eq.Bv,
        Bq=eq.Bq,
        C=eq.C,
        inputs=eq.inputs,
        disturbances=eq.disturbances,
        outputs=eq.outputs,
        gains=eq.gains,
        switches=(sw,),
    )
    x, q = np.array([20.0]), np.zeros(eq.Bq.shape[1])
    v = np.full(len(eq.disturbances), 5.0)
    on = eq2.step_state(x, np.zeros(len(eq.inputs)), v, q) - eq.step_state(x, np.zeros(len(eq.inputs)), v, q)
    off = eq2.step_state(x, np.ones(len(eq.inputs)), v, q) - eq.step_state(x, np.ones(len(eq.inputs)), v, q)
    np.testing.assert_allclose(on, [0.5], rtol=0, atol=1e-12)
    np.testing.assert_allclose(off, [0.0], rtol=0, atol=1e-12)


def test_physics_equations_match_step_state():
    from hvacfmu.emulator import sdh_building
    from hvacfmu.models.physics import PhysicsModel

    b = sdh_building()
    nominal = b.physics["physics"]["nominal"]
    gains = np.zeros((672, 7))  # internal gains of the six zones [W], then the slabs' boundary [°C]
    gains[:, 6] = b.physics["physics"]["ground_temperature"]
    model = PhysicsModel(b, nominal, {"fall": gains})
    assert model.q_names[-1] == "T_ground"  # the floor and ceiling slabs face the storeys below and above
    eq = model.equations()
    assert eq.bilinear
    assert check_equations(model, eq, atol=1e-9) <= 1e-9


def test_linear_model_class_has_equations():
    assert hasattr(LinearZoneModel, "equations")
