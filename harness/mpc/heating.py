"""Reheat as an MPC decision: the discharge air of every box between its supply air and the heating limit.

A VAV box with reheat delivers ``m c_p (Td - T_zone) = m c_p (T_supply - T_zone) + h`` with the reheat
``h = m c_p (Td - T_supply) >= 0``. The MPC decides the airflows as before and, per heat group (a box for
models with one input per box, the boxes of a zone for Model A's zone inputs), a reheat ``h`` [kW]
that enters the model linearly:

    x+ = (model's step) + G_h h,        0 <= h <= h_max

``h_max`` is the reheat the group's boxes deliver at minimum airflow from the supply air to their heating
limit, ``Σ m_min c_p (Td_max - T_supply)``: a single-maximum reheat sequence, so any airflow the plan
chooses (at least ``m_min``) reaches ``h`` with ``Td <= Td_max``. The applied discharge air of a box is
``Td = T_supply + h_b / (m c_p)`` with the group's reheat split over its boxes by their capacity, and
clipped to ``[T_supply, Td_max]`` (:func:`discharge_commands`).

``G_h`` (K per step per kW) comes from the model's own equations: a bilinear model that carries
``m (T_in - T_zone)`` per box (Model B, extended supply-air terms, Model A's delivered-heat form) has it in
``Bvu_i[:, T_in] / c_p`` with ``T_in`` the box's inlet column (:func:`box_inlets`: its measured discharge air
``Td_<vav>`` where the model reads it, else ``T_supply``);
a linear model (Model A) only knows the airflow gain ``B``, whose heat per kg/s is
``c_p (T_supply - T_zone)`` at the data's typical difference, so ``G_h = B / (c_p ΔT_ref)`` with
``ΔT_ref`` the run's median of ``T_supply - T_zone`` (refused when the data give no cooling difference).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
from scipy import sparse

from hvacfmu.errors import HvacfmuWarning, ModelError
from hvacfmu.models.causes.reheat import reheat_column, zone_boxes

from .predict import model_equations

CP_AIR = 1005.0  #: [J/(kg K)]
#: quadratic weight of the reheat [1/kW²] in the cost Σ ||u||² (+ ...): a kW of reheat a step costs like
#: 0.22 kg/s of airflow; the comfort penalty (1e4 per K) dominates both
HEAT_WEIGHT = 0.05


@dataclasses.dataclass(frozen=True)
class HeatPlan:
    """How the MPC's reheat decisions map to boxes.

    Attributes
    ----------
    groups : tuple of tuple of int
        Box indices (in the plant's ``vavs`` order) of each heat input.
    G : array (nx, n_groups) [K/step per kW]
    capacity : array (n_vav,) [kW/K]
        ``m_min c_p`` of each box (its share of the group's reheat).
    td_max : array (n_vav,) [°C]
    """

    groups: tuple
    G: np.ndarray
    capacity: np.ndarray
    td_max: np.ndarray

    def limits(self, T_supply) -> np.ndarray:
        """``h_max`` [kW] of every group at supply air ``T_supply`` [°C]."""
        per_box = self.capacity * np.maximum(self.td_max - float(T_supply), 0.0)
        return np.array([per_box[list(g)].sum() for g in self.groups])


class HeatedModel:
    """A zone model whose equations gain one reheat input [kW] per heat group (``h_<group>``)."""

    def __init__(self, model, eq, plan: HeatPlan, names):
        self.base = model
        self.kind = getattr(model, "kind", "model")
        self.step = eq.step
        self.outputs = tuple(eq.outputs)
        self.disturbances = tuple(eq.disturbances)
        self.inputs = tuple(eq.inputs) + tuple(f"h_{n}" for n in names)
        nx, ng = eq.A.shape[0], plan.G.shape[1]
        Bu = np.hstack([np.asarray(eq.Bu.toarray() if sparse.issparse(eq.Bu) else eq.Bu, dtype=float), plan.G])
        nv = np.shape(eq.Bv)[1]
        pad = ()
        if eq.bilinear:
            pad = tuple(sparse.csr_matrix((nx, nx)) for _ in range(ng))
        self._eq = dataclasses.replace(
            eq,
            Bu=Bu,
            inputs=self.inputs,
            Bxu=tuple(eq.Bxu) + pad,
            Bvu=tuple(eq.Bvu) + (tuple(sparse.csr_matrix((nx, nv)) for _ in range(ng)) if eq.bilinear else ()),
        )

    def equations(self):
        return self._eq


def heat_plan(model, building, vavs, discharge, td_max, frame):
    """The reheat inputs of ``model`` for a plant whose boxes ``discharge`` take discharge commands.

    Parameters
    ----------
    model : ZoneModel
    building : Building
    vavs : sequence of str, the plant's boxes (command order)
    discharge : sequence of str, the boxes with a discharge command
    td_max : array (len(discharge),) [°C] their heating limits
    frame : DataFrame, the run's data (``T_supply``, ``T_<zone>``: the reference difference of Model A)

    Returns
    -------
    (HeatedModel, HeatPlan, names)
    """
    eq = model_equations(model)
    if eq is None:
        raise ModelError(f"reheat as an MPC decision needs the equations of the {getattr(model, 'kind', '?')} model")
    box = {b.name: b for b in building.vavs}
    vavs = list(vavs)
    cap = np.array([box[b].m_min * CP_AIR / 1000.0 for b in vavs])  # [kW/K]
    tdm = np.full(len(vavs), -np.inf)
    tdm[[vavs.index(b) for b in discharge]] = td_max
    cap = np.where(np.isfinite(tdm), cap, 0.0)
    names, groups, cols = [], [], []
    per_box = [n[2:] if n.startswith("m_") else n for n in eq.inputs]
    inlet = box_inlets(model)
    if eq.bilinear and all(n in vavs for n in per_box):  # one input per box: the heat of its airflow term
        for i, n in enumerate(per_box):
            # the box's inlet air (its measured discharge Td_<vav>, its unit's supply, else T_supply): the
            # reheat h = m c_p (Td - T_supply) acts through the inlet's coefficient, whatever the airflow
            col = inlet.get(n, "T_supply")
            if col not in eq.disturbances:
                raise ModelError(
                    f"reheat as an MPC decision needs box {n}'s inlet air input {col!r} in the model; it has "
                    f"{list(eq.disturbances)}"
                )
            j = list(eq.disturbances).index(col)
            g = np.asarray(eq.Bvu[i][:, [j]].toarray() if sparse.issparse(eq.Bvu[i]) else eq.Bvu[i][:, [j]])
            cols.append(g.ravel() * 1000.0 / CP_AIR)  # [K/step per kW]
            groups.append((vavs.index(n),))
            names.append(n)
    else:
        if "T_supply" not in eq.disturbances:
            raise ModelError(
                f"reheat as an MPC decision needs the model's supply air input 'T_supply'; it has "
                f"{list(eq.disturbances)}"
            )
        cols, groups, names = _linear_heat_columns(model, eq, vavs, frame)
        # an extended model whose diagnosis found a zone's reheat through its discharge air (a term
        # ``coef * Qrh_<zone>``, Qrh in kW) has measured that zone's heat gain: it replaces the scaled airflow gain
        src = getattr(model, "base", model)
        outs = list(getattr(src, "outputs", ()))
        dist = list(eq.disturbances)
        if len(outs) == len(cols):
            Bv = np.asarray(eq.Bv.toarray() if sparse.issparse(eq.Bv) else eq.Bv, dtype=float)
            for i, z in enumerate(outs):
                g = Bv[:, dist.index(reheat_column(z))] if reheat_column(z) in dist else None
                if g is not None and g[i] > 0.0:  # a coefficient at its bound 0: keep the airflow's
                    cols[i] = g
    G = np.column_stack(cols)
    if np.any(G.sum(axis=0) <= 0.0):
        raise ModelError("the model's reheat effect is not a warming one for every input; cannot heat with it")
    _warn_weak_heat(G, names)
    plan = HeatPlan(tuple(groups), G, cap, np.where(np.isfinite(tdm), tdm, 0.0))
    return HeatedModel(model, eq, plan, names), plan, names


#: a heat input whose largest effect is below this share of the median input's: the MPC will barely use it
WEAK_HEAT_SHARE = 0.05


def _warn_weak_heat(G, names) -> None:
    """Warn about heat inputs whose gain is a small fraction of the others' (the MPC will barely heat there).

    A zone whose boxes' airflow the fit could not identify gets an airflow gain near 0, and with it a reheat gain
    near 0 when that is scaled into one (Model A's airflow form): the MPC then leaves the zone cold without a word
    (round 2 of fleet sweep s10, building B's control model: E 128 K*h below the band in two days).
    """
    gain = np.max(G, axis=0)
    ref = float(np.median(gain))
    weak = [(n, g) for n, g in zip(names, gain) if ref > 0.0 and g < WEAK_HEAT_SHARE * ref]
    if weak:
        warnings.warn(
            "the model's reheat gain of "
            + ", ".join(f"{n} ({g:.2g} K/step per kW)" for n, g in weak)
            + f" is below {WEAK_HEAT_SHARE:.0%} of the median input's ({ref:.2g}): the MPC will barely heat there "
            "(was the boxes' airflow identifiable in the fit?)",
            HvacfmuWarning,
            stacklevel=3,
        )


def box_inlets(model) -> dict:
    """``{box: disturbance column}`` of the inlet air of every box of a model that reads it per box.

    A model fitted where the discharge air is measured (Model A's delivered-heat form, Model B with
    ``inlets``, or an extended model on such a base) takes each box's air at ``Td_<vav>`` (or its unit's
    ``T_supply_<ahu>``); empty for a model without per-box inlets (they take ``T_supply``).
    """
    src = model
    while not getattr(src, "inlets", None) and getattr(src, "base", None) is not None:
        src = src.base
    inlets = tuple(getattr(src, "inlets", None) or ())
    if not inlets:
        return {}
    boxes = getattr(src, "vavs", None)
    if boxes is None and getattr(src, "building", None) is not None:
        boxes = src.building.vav_names
    boxes = [getattr(b, "name", b) for b in (boxes or ())]
    return dict(zip(boxes, inlets)) if len(boxes) == len(inlets) else {}


def _linear_heat_columns(model, eq, vavs, frame):
    """Model A: heat per kW from the airflow gain at the data's median ``T_supply - T_zone``."""
    src = getattr(model, "base", model)
    if not (hasattr(src, "input_map") and hasattr(src, "vavs")):
        raise ModelError("reheat as an MPC decision: the model's inputs map to no boxes")
    zones = list(getattr(src, "measured_zones", eq.outputs))
    cols = [f"T_{z}" for z in zones if f"T_{z}" in frame]
    if "T_supply" not in frame or not cols:
        raise ModelError("reheat as an MPC decision for Model A needs the data's T_supply and zone temperatures")
    dT = float(np.nanmedian(frame["T_supply"].to_numpy(float)[:, None] - frame[cols].to_numpy(float)))
    if not dT < -1.0:
        raise ModelError(
            f"the data's median supply-zone difference is {dT:+.1f} K: no cooling difference to scale Model A's "
            "airflow gain into a heat gain"
        )
    Bu = np.asarray(eq.Bu, dtype=float)
    imap = np.asarray(src.input_map, dtype=float)
    cols_out, groups, names = [], [], []
    for i, n in enumerate(eq.inputs):
        boxes = tuple(vavs.index(b) for b, w in zip(src.vavs, imap[i]) if w != 0.0 and b in vavs)
        cols_out.append(Bu[:, i] * 1000.0 / (CP_AIR * dT))  # B [K/step per kg/s] / (c_p ΔT) [kJ/kg]
        groups.append(boxes)
        names.append(n[2:] if n.startswith("m_") else n)
    return cols_out, groups, names


def discharge_commands(plan: HeatPlan, h, m, T_supply, td_boxes) -> np.ndarray:
    """Discharge air [°C] of the boxes ``td_boxes`` (indices into the plant's boxes) for reheat ``h`` [kW].

    Each group's reheat is split over its boxes by their capacity; ``Td = T_supply + h_b / (m c_p)``,
    clipped to ``[T_supply, Td_max]``.
    """
    h = np.maximum(np.asarray(h, dtype=float), 0.0)
    hb = np.zeros(plan.capacity.size)
    for g, hg in zip(plan.groups, h):
        g = list(g)
        w = plan.capacity[g] * np.maximum(plan.td_max[g] - T_supply, 0.0)
        if w.sum() > 0.0:
            hb[g] = hg * w / w.sum()
    m = np.maximum(np.asarray(m, dtype=float), 1e-9)
    Td = T_supply + hb * 1000.0 / (m * CP_AIR)
    Td = np.clip(Td, T_supply, np.maximum(plan.td_max, T_supply))
    return Td[np.asarray(td_boxes, dtype=int)]


def reheat_disturbances(model, frame, commanded=()) -> dict:
    """The reheat heat ``Qrh_<zone>`` [kW] an extended model's discharge reheat terms read, from ``frame``.

    A diagnosis that finds a zone's reheat through its measured discharge air (``Td_<vav>``) adds a disturbance
    ``Qrh_<zone> = Σ m c_p (Td - T_supply)`` the data do not carry: the model derives it from the frame
    (:meth:`~hvacfmu.models.causes.base.Term.derive`). On a plant whose boxes take discharge commands
    (``commanded``) the recorded reheat never reaches the plant (its boxes discharge their supply air plus this
    controller's reheat, the ``h`` inputs): a zone whose boxes are all commanded previews 0.
    """
    base = getattr(model, "base", None)
    commanded = set(commanded)
    out = {}
    for t in getattr(model, "terms", ()):
        for col, q in t.derive(frame, base).items():
            zone = getattr(t, "zone", None)
            boxes = zone_boxes(base, zone) if zone is not None and col == reheat_column(zone) else None
            out[col] = np.zeros(len(frame)) if boxes and set(boxes) <= commanded else np.asarray(q, dtype=float)
    return out
