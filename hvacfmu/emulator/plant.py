"""The emulated building as a steppable plant (for FMUs, the co-simulation harness and MPC).

:class:`Plant` is the same thermal model that produced the dataset: the RC
network of :mod:`hvacfmu.emulator.thermal` with the true parameters and the
injected effects, discretised exactly at 60 s, internal gains and the
temperature of the floors above and below from the emulator's own occupancy
model (same seed). The airflows are commanded directly (no local controller).

Per 60 s sub-step ``k`` the zone air receives from the VAV boxes::

    Q_hvac,z = sum_{i in z} m_i c_p (T_supply - T_z,k) + P_reheat,i

evaluated with the zone temperature at the start of the sub-step (the bilinear
term), and the linear part is advanced exactly:
``x_{k+1} = Ad x_k + Bd [T_out, T_fl, I_N..I_W, Q_ig, Q_hvac]_k``.

With ``local_reheat=True`` the boxes keep their own reheat loops (the heating
sequence of :class:`hvacfmu.emulator.controllers.VavControllers` with the
dataset's settings, run every control interval from the dataset start): the
commanded airflows replace only the boxes' airflow loops. That is the building
the measured airflows came from; reheat power is not measured, so replaying
the airflows without it runs the heated zones too cold. During the
forced-response experiments (``excitation``) the building's loops are off
and reset, as in the dataset.
"""

from __future__ import annotations

import dataclasses
import zlib

import numpy as np
import pandas as pd

from .effects import EmulatorError
from .occupancy import internal_gains
from .thermal import CP_AIR, ORIENTATIONS, build_network

DT = 60.0  # [s] internal step of the thermal model


def stream(seed: int, name: str) -> np.random.Generator:
    """Independent random stream ``name`` of dataset seed ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(name.encode())]))


def site_wind(truth: dict, index: pd.DatetimeIndex) -> np.ndarray:
    """The dataset's wind speed [m/s] per minute: :func:`~hvacfmu.emulator.weather.synthetic_wind` on its own
    stream ``stream(seed, "wind")`` (the other weather series do not depend on it)."""
    from .weather import CLIMATE_WIND_MEAN, synthetic_wind

    return synthetic_wind(index, stream(truth["seed"], "wind"), CLIMATE_WIND_MEAN.get(truth.get("climate"), 3.5))


def dataset_index(start: str, weeks: int, timezone: str) -> pd.DatetimeIndex:
    """One-minute tz-aware index of a dataset of ``weeks`` weeks from local time ``start``."""
    t0 = pd.Timestamp(start)
    t0 = t0.tz_localize(timezone) if t0.tzinfo is None else t0.tz_convert(timezone)
    return pd.date_range(t0, periods=int(weeks) * 7 * 1440, freq="min")


@dataclasses.dataclass
class PlantCore:
    """Matrices and schedules shared by the dataset simulation and :class:`Plant`."""

    zones: tuple
    vavs: tuple
    m_min: np.ndarray
    m_max: np.ndarray
    box_zone: np.ndarray  # zone index of each box
    Mzb: np.ndarray  # (nz, nb) 0/1
    Ad: np.ndarray
    Bw: np.ndarray  # (nx, 6 + nz) columns T_out, T_fl, I_N..I_W, Q_ig
    BQ: np.ndarray  # (nx, nz) Q_hvac columns
    node_names: tuple
    node_zones: list  # zone indices each node belongs to (for initial states)
    Q_ig: np.ndarray  # (n, nz) [W]
    T_fl: np.ndarray  # (n,) [°C]
    delay_zone: int | None
    delay_minutes: int
    delay_boxes: np.ndarray
    reheat_effect: dict | None
    #: ``wind_infiltration`` effect: ``{"zone": index, "g": (n_blocks,) [W/K] ua · wind per control interval, "per"}``
    wind_effect: dict | None = None
    #: ``off_hours_heater`` effect: ``{"zone": index, "power" [W], "below" [°C], "boxes": the zone's boxes}``
    heater_effect: dict | None = None
    ahus: tuple = ()  # air handler names ("reheat" mode); () = one implicit unit
    box_ahu: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))  # unit index per box

    @classmethod
    def from_truth(cls, truth: dict) -> "PlantCore":
        base = truth["baseline"]
        bld = base["building"]
        zones = tuple(z["name"] for z in bld["zones"])
        vavs = tuple(v["name"] for v in bld["vavs"])
        zidx = {z: i for i, z in enumerate(zones)}
        box_zone = np.array([zidx[v["zone"]] for v in bld["vavs"]])
        Mzb = np.zeros((len(zones), len(vavs)))
        Mzb[box_zone, np.arange(len(vavs))] = 1.0
        effects = truth.get("effects", [])
        net = build_network(bld, base["parameters"], base["extras"], effects)
        Ad, Bd = net.discretize(DT)
        nz = len(zones)
        k_hvac = [net.input_index(f"Q_hvac_{z}") for z in zones]
        k_w = [
            net.input_index(n)
            for n in ["T_out", "T_fl"] + [f"I_{o}" for o in ORIENTATIONS] + [f"Q_ig_{z}" for z in zones]
        ]
        index = dataset_index(truth["start"], truth["weeks"], truth["timezone"])
        areas = [z["area"] for z in bld["zones"]]
        gains = internal_gains(index, zones, areas, stream(truth["seed"], "occupancy"), base["occupancy"], effects)
        # zone membership of every node (initial states)
        elements = {e["name"]: e for e in bld["elements"]}
        node_zones = []
        for name in net.node_names:
            if ":" in name:
                el = elements[name.split(":")[0]]
                node_zones.append([zidx[s] for s in (el["side1"], el["side2"]) if s in zidx])
            else:
                node_zones.append([zidx[name.rsplit("_", 1)[1]]])
        delay = [e for e in effects if e["name"] == "actuation_delay"]
        dz = zidx[delay[0]["zone"]] if delay else None
        ahus = tuple(a["name"] for a in bld.get("ahus", []))
        reheat = [e for e in effects if e["name"] == "reheat"]
        rh = None
        if reheat:
            rh = {
                "zone": zidx[reheat[0]["zone"]],
                "power": float(reheat[0]["power"]),
                "below": float(reheat[0]["below"]),
            }
            rh["boxes"] = np.flatnonzero(box_zone == rh["zone"])
        heater = [e for e in effects if e["name"] == "off_hours_heater"]
        he = None
        if heater:
            hz = zidx[heater[0]["zone"]]
            he = {
                "zone": hz,
                "power": float(heater[0]["power"]),
                "below": float(heater[0]["below"]),
                "boxes": np.flatnonzero(box_zone == hz),
            }
        wind = [e for e in effects if e["name"] == "wind_infiltration"]
        wind_effect = None
        if wind:
            per = int(round(float(base["controllers"]["control_interval"]) / DT))
            w = site_wind(truth, index)
            n_blocks = len(w) // per
            block = w[: n_blocks * per].reshape(n_blocks, per).mean(axis=1)
            wind_effect = {"zone": zidx[wind[0]["zone"]], "g": float(wind[0]["ua"]) * block, "per": per}
        return cls(
            zones=zones,
            vavs=vavs,
            m_min=np.array([v["m_min"] for v in bld["vavs"]], dtype=float),
            m_max=np.array([v["m_max"] for v in bld["vavs"]], dtype=float),
            box_zone=box_zone,
            Mzb=Mzb,
            Ad=Ad,
            Bw=Bd[:, k_w].copy(),
            BQ=Bd[:, k_hvac].copy(),
            node_names=net.node_names,
            node_zones=node_zones,
            Q_ig=gains["Q_ig"],
            T_fl=gains["T_fl"],
            delay_zone=dz,
            delay_minutes=int(round(delay[0]["minutes"])) if delay else 0,
            delay_boxes=np.flatnonzero(box_zone == dz) if delay else np.zeros(0, dtype=int),
            reheat_effect=rh,
            wind_effect=wind_effect,
            heater_effect=he,
            ahus=ahus,
            box_ahu=np.array([ahus.index(v["ahu"]) if ahus else 0 for v in bld["vavs"]], dtype=int),
        )

    @property
    def n_thermal(self) -> int:
        return self.Ad.shape[0]

    @property
    def n_buffer(self) -> int:
        return 2 * self.delay_minutes * len(self.delay_boxes)

    def w_rows(self, k0, k1, T_out, irradiance):
        """Disturbance rows [T_out, T_fl, I_N..I_W, Q_ig] for minutes k0..k1-1."""
        n = k1 - k0
        w = np.empty((n, self.Bw.shape[1]))
        w[:, 0] = T_out
        w[:, 1] = self.T_fl[k0:k1]
        w[:, 2:6] = irradiance
        w[:, 6:] = self.Q_ig[k0:k1]
        return w


class Plant:
    """The emulated building, steppable from outside (airflows commanded directly).

    Create it with :meth:`from_truth` from a ``truth.json`` mapping. The state
    ``x`` is a flat float array: the thermal nodes followed by the airflow
    history of a delayed zone (``actuation_delay`` effect), so it can be
    saved and restored exactly.

    Examples
    --------
    >>> plant = Plant.from_truth(json.load(open("truth.json")))      # doctest: +SKIP
    >>> x = plant.initial_state([22.0] * 6)                           # doctest: +SKIP
    >>> x, T = plant.advance(x, 0.0, 900.0, m, 15.0, 14.0, [0, 0, 0, 0])  # doctest: +SKIP
    """

    def __init__(self, core: PlantCore, truth: dict, local_reheat: bool = False):
        self.core = core
        self.truth = truth
        self.local_reheat = bool(local_reheat)
        self._loops = None

    @classmethod
    def from_truth(cls, truth: dict, local_reheat: bool = False) -> "Plant":
        """Build the plant from a ``truth.json`` mapping (everything needed is in it).

        Parameters
        ----------
        truth : dict
        local_reheat : bool
            Keep the boxes' local reheat loops (see the module docstring).
        """
        return cls(PlantCore.from_truth(truth), truth, local_reheat)

    def with_local_reheat(self, on: bool = True) -> "Plant":
        """The same plant (shared matrices and gains) with or without the boxes' local reheat loops."""
        return Plant(self.core, self.truth, on)

    def facades_from_ghi(self, t, dt, ghi) -> np.ndarray:
        """Facade irradiance ``I_N, I_E, I_S, I_W`` [W/m2] per minute from a global horizontal irradiance.

        The emulator's own model (:mod:`hvacfmu.emulator.weather`): Erbs
        decomposition and Perez transposition on the vertical facades, with
        ``ghi`` held over ``[t, t + dt)``. Measured datasets only carry ``ghi``;
        another transposition (e.g. isotropic sky) misses part of the sun on
        the facades.

        Parameters
        ----------
        t, dt : float [s]
            Start (since the dataset start) and length, multiples of 60 s.
        ghi : float [W/m2]

        Returns
        -------
        ndarray (dt / 60, 4)
        """
        import warnings

        import pvlib

        from .weather import FACADE_AZIMUTH

        k0, n = int(round(t / DT)), int(round(dt / DT))
        sun = self._sun(k0, k0 + n)
        g = np.full(n, max(float(ghi), 0.0))
        with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
            warnings.simplefilter("ignore")
            erbs = pvlib.irradiance.erbs(g, sun["zenith"], sun["doy"])  # day of year: as the index, without pandas
            dni = np.nan_to_num(np.asarray(erbs["dni"], dtype=float), nan=0.0)
            dhi = np.nan_to_num(np.asarray(erbs["dhi"], dtype=float), nan=0.0)
            # the four facades in one call (pvlib is elementwise): facade-major blocks of n minutes
            az = np.repeat([FACADE_AZIMUTH[o] for o in ORIENTATIONS], n)
            tile = [
                np.tile(a, 4)
                for a in (sun["apparent_zenith"], sun["azimuth"], dni, g, dhi, sun["dni_extra"], sun["airmass"])
            ]
            poa = pvlib.irradiance.get_total_irradiance(
                90.0,
                az,
                tile[0],
                tile[1],
                tile[2],
                tile[3],
                tile[4],
                dni_extra=tile[5],
                airmass=tile[6],
                model="perez",
                albedo=0.2,
            )
            out = np.asarray(poa["poa_global"], dtype=float).reshape(4, n).T
        return np.clip(np.nan_to_num(out, nan=0.0), 0.0, None)

    def _sun(self, k0, k1) -> dict:
        """Sun position of minutes ``k0..k1-1`` (computed a week at a time and kept)."""
        import warnings

        import pvlib

        cache = self.__dict__.setdefault("_sun_cache", {})
        week = 7 * 1440
        parts = []
        for w in range(k0 // week, (k1 - 1) // week + 1):
            if w not in cache:
                if len(cache) > 8:
                    cache.clear()
                index = dataset_index(self.truth["start"], self.truth["weeks"], self.truth["timezone"])[
                    w * week : (w + 1) * week
                ]
                bld = self.truth["baseline"]["building"]
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sp = pvlib.solarposition.ephemeris(index, bld["latitude"], bld["longitude"])
                    app_zen = sp["apparent_zenith"].to_numpy()
                    cache[w] = {
                        "doy": np.asarray(index.day_of_year, dtype=float),
                        "zenith": sp["zenith"].to_numpy(),
                        "apparent_zenith": app_zen,
                        "azimuth": sp["azimuth"].to_numpy(),
                        "dni_extra": pvlib.irradiance.get_extra_radiation(index).to_numpy(),
                        "airmass": pvlib.atmosphere.get_relative_airmass(app_zen),
                    }
            a, b = max(k0 - w * week, 0), min(k1 - w * week, week)
            parts.append({key: val[a:b] for key, val in cache[w].items()})
        if len(parts) == 1:
            return parts[0]
        return {key: np.concatenate([q[key] for q in parts]) for key in parts[0]}

    def _reheat_loops(self) -> dict:
        """Settings of the boxes' heating loops (built once)."""
        if self._loops is None:
            from .controllers import occupied_mode

            cp = self.truth["baseline"]["controllers"]
            index = dataset_index(self.truth["start"], self.truth["weeks"], self.truth["timezone"])
            kp = float(cp["kp"])
            self._loops = {
                "per": int(round(float(cp["control_interval"]) / DT)),
                "occupied": occupied_mode(index, cp),
                "sp": {
                    True: float(cp["heating_setpoint"]["occupied"]),
                    False: float(cp["heating_setpoint"]["unoccupied"]),
                },
                "kp": kp,
                "ki_dt": kp * float(cp["control_interval"]) / float(cp["integral_time"]),
                "offsets": np.asarray(cp["box_offsets"], dtype=float),
                "rh_max": self.core.m_min * CP_AIR * float(cp["reheat_rise"]),
                "T_discharge_max": cp.get("T_discharge_max"),
                "dual": cp.get("heating_sequence", "single") == "dual",
            }
        return self._loops

    @property
    def zones(self) -> tuple:
        return self.core.zones

    @property
    def vavs(self) -> tuple:
        return self.core.vavs

    @property
    def n_loop_states(self) -> int:
        """Local reheat loop states (integrator and held power of every box), 0 without local reheat."""
        return 2 * len(self.vavs) if self.local_reheat else 0

    @property
    def n_states(self) -> int:
        return self.core.n_thermal + self.core.n_buffer + self.n_loop_states

    @property
    def horizon(self) -> float:
        """Seconds from the dataset start for which internal gains are defined."""
        return len(self.core.T_fl) * DT

    def initial_state(self, T_zones, T_out=None) -> np.ndarray:
        """A state with every node at the temperature of its zone(s).

        Parameters
        ----------
        T_zones : array (n_zones,) [°C]
        T_out : float [°C], optional
            Not needed; exterior wall nodes start at their zone's temperature.

        Returns
        -------
        ndarray (n_states,)
            Thermal nodes, then the delay buffer filled with minimum airflows,
            then (local reheat) the loop integrators and held powers at 0.
        """
        T = np.asarray(T_zones, dtype=float)
        if T.shape != (len(self.zones),):
            raise EmulatorError(
                f"T_zones must have {len(self.zones)} values ({', '.join(self.zones)}), got shape {T.shape}"
            )
        x = np.array([T[z].mean() for z in self.core.node_zones])
        c = self.core
        if c.delay_minutes:
            buf = np.zeros((c.delay_minutes, len(c.delay_boxes), 2))
            buf[:, :, 0] = c.m_min[c.delay_boxes]
            x = np.concatenate([x, buf.ravel()])
        if self.local_reheat:
            x = np.concatenate([x, np.zeros(self.n_loop_states)])
        return x

    def zone_temperatures(self, x) -> np.ndarray:
        """Zone air temperatures [°C] of state ``x``."""
        return np.asarray(x)[: len(self.zones)].copy()

    @property
    def ahus(self) -> tuple:
        """Air handler names (``reheat`` mode); empty for the single implicit unit."""
        return self.core.ahus

    def supply_of_boxes(self, T_supply) -> np.ndarray:
        """Supply air temperature [°C] of every box from one value or one per air handler (:attr:`ahus`)."""
        c = self.core
        Ts = np.asarray(T_supply, dtype=float)
        n_units = max(len(c.ahus), 1)
        if Ts.shape not in ((), (n_units,)):
            raise EmulatorError(f"T_supply must be one value or {n_units} values, got shape {Ts.shape}")
        return np.broadcast_to(Ts, (n_units,))[c.box_ahu] if Ts.ndim else np.full(len(c.m_min), float(Ts))

    def discharge_reheat(self, m_vav, T_supply, T_discharge) -> np.ndarray:
        """Reheat power [W] of every box that discharges at ``T_discharge`` [°C] (a command, not a measurement).

        ``m c_p max(T_discharge - T_supply, 0)`` per box with its unit's supply
        air: a box can only heat its supply air, so a command at or below the
        supply temperature (e.g. an unset input) means no reheat, exactly the
        box without a discharge command. Passed to :meth:`advance` as ``reheat=``,
        it adds to the local loops' power when those run.

        Parameters
        ----------
        m_vav : array (n_vav,) [kg/s]
        T_supply : float or array (n_ahu,) [°C]
        T_discharge : array (n_vav,) [°C]
        """
        m = np.asarray(m_vav, dtype=float)
        Td = np.asarray(T_discharge, dtype=float)
        if Td.shape != m.shape or not np.all(np.isfinite(Td)):
            raise EmulatorError(f"T_discharge must have {m.size} finite values [°C], got shape {Td.shape}")
        return m * CP_AIR * np.maximum(Td - self.supply_of_boxes(T_supply), 0.0)

    def _inputs(self, x, t, dt, m_vav, T_out, T_supply, irradiance, reheat, T_discharge):
        """Validate :meth:`advance` inputs; return (k0, nsub, x, m, irr, p, Ts_box) or raise listing every problem."""
        c = self.core
        problems = []
        k0, nsub = t / DT, dt / DT
        if abs(k0 - round(k0)) > 1e-6 or k0 < 0:
            problems.append(f"t = {t} s must be a non-negative multiple of {DT:g} s")
        if abs(nsub - round(nsub)) > 1e-6 or nsub < 1:
            problems.append(f"dt = {dt} s must be a positive multiple of {DT:g} s")
        m = np.asarray(m_vav, dtype=float)
        if m.shape != c.m_min.shape:
            problems.append(f"m_vav must have {len(c.m_min)} values, got shape {m.shape}")
        elif not np.all(np.isfinite(m)) or np.any(m < 0):
            problems.append("m_vav must be finite and >= 0 kg/s")
        irr = np.asarray(irradiance, dtype=float)
        per_minute = irr.ndim == 2 and irr.shape == (round(nsub), 4)
        if irr.shape != (4,) and not per_minute:
            problems.append(
                f"irradiance must be [I_N, I_E, I_S, I_W] or one such row per minute, got shape {irr.shape}"
            )
        Ts = np.asarray(T_supply, dtype=float)
        n_units = max(len(c.ahus), 1)
        if Ts.shape not in ((), (n_units,)):
            names = f" ({', '.join(c.ahus)})" if c.ahus else ""
            problems.append(f"T_supply must be one value or {n_units} values{names}, got shape {Ts.shape}")
            Ts = np.zeros(())
        if not (np.isfinite(T_out) and np.all(np.isfinite(Ts))) or not np.all(np.isfinite(irr)):
            problems.append("T_out, T_supply and irradiance must be finite")
        x = np.asarray(x, dtype=float)
        if x.shape != (self.n_states,):
            problems.append(f"state must have {self.n_states} values, got shape {x.shape}")
        p = np.zeros_like(c.m_min) if reheat is None else np.asarray(reheat, dtype=float)
        if p.shape != c.m_min.shape:
            problems.append(f"reheat must have {len(c.m_min)} values, got shape {p.shape}")
        Ts_box = np.broadcast_to(Ts, (n_units,))[c.box_ahu] if Ts.ndim else np.full(len(c.m_min), float(Ts))
        if T_discharge is not None:
            Td = np.asarray(T_discharge, dtype=float)
            if reheat is not None or self.local_reheat:
                problems.append("give either T_discharge or reheat/local reheat loops, not both")
            elif Td.shape != c.m_min.shape or not np.all(np.isfinite(Td)):
                problems.append(f"T_discharge must have {len(c.m_min)} finite values [°C], got shape {Td.shape}")
            elif m.shape == Td.shape:
                p = m * CP_AIR * (Td - Ts_box)  # the heat the discharge air carries above the supply air
        if not problems and round(k0) + round(nsub) > len(c.T_fl):
            problems.append(
                f"t + dt = {t + dt} s is beyond the emulated span ({self.horizon:g} s); internal gains are only defined there"
            )
        if problems:
            from ..errors import problems_message

            raise EmulatorError(problems_message("Plant.advance", problems))
        return round(k0), round(nsub), x, m, irr, p, Ts_box

    def advance(self, x, t, dt, m_vav, T_out, T_supply, irradiance, reheat=None, excitation=False, T_discharge=None):
        """Advance the plant by ``dt`` seconds with inputs held constant.

        Parameters
        ----------
        x : array (n_states,)
        t : float [s]
            Time since the dataset start (multiple of 60 s).
        dt : float [s]
            Multiple of 60 s.
        m_vav : array (n_vav,) [kg/s]
            Airflow of every box, in the order of :attr:`vavs`.
        T_out : float [°C]
        T_supply : float or array (n_ahu,) [°C]
            Supply air temperature: one value, or one per air handler in the
            order of :attr:`ahus` (``reheat`` mode; each box gets its unit's).
        irradiance : array (4,) or (dt / 60, 4) [W/m2]
            Facade irradiance ``I_N, I_E, I_S, I_W`` (held, or per minute).
        reheat : array (n_vav,) [W], optional
            Reheat power added to each box's supply air (default none); with
            local reheat it adds to the loops' power.
        excitation : bool
            A forced-response experiment runs: the local reheat loops are off
            and reset (no effect without local reheat).
        T_discharge : array (n_vav,) [°C], optional
            Measured discharge air temperature of every box: the box delivers
            ``m c_p (T_discharge - T_zone)``. Excludes ``reheat`` and local loops.

        Returns
        -------
        x : ndarray (n_states,)
        T_zones : ndarray (n_zones,) [°C]
            Zone air temperatures at ``t + dt``.
        """
        c = self.core
        k0, nsub, x, m, irr, p, Ts_box = self._inputs(x, t, dt, m_vav, T_out, T_supply, irradiance, reheat, T_discharge)
        nth = c.n_thermal
        xt = x[:nth].copy()
        buf = (
            x[nth : nth + c.n_buffer].reshape(c.delay_minutes, len(c.delay_boxes), 2).copy()
            if c.delay_minutes
            else None
        )
        W = self.core.w_rows(k0, k0 + nsub, T_out, irr) @ c.Bw.T
        nz = len(self.zones)
        p_cmd = p
        if self.local_reheat:
            loops = self._reheat_loops()
            nb = len(self.vavs)
            integ = x[nth + c.n_buffer : nth + c.n_buffer + nb].copy()
            p_loc = x[nth + c.n_buffer + nb :].copy()
            rh_max = (
                loops["rh_max"]
                if loops["T_discharge_max"] is None
                else (c.m_min * CP_AIR * np.maximum(loops["T_discharge_max"] - Ts_box, 0.0))
            )
            if loops["dual"]:  # the discharge stage of a dual-maximum box heats the commanded airflow
                rh_max = np.maximum(m, c.m_min) * CP_AIR * np.maximum(loops["T_discharge_max"] - Ts_box, 0.0)
        for j in range(nsub):
            if self.local_reheat:
                k = k0 + j
                if excitation:  # the experiment overrides the boxes: loops reset, no reheat
                    integ = np.zeros_like(integ)
                    p_loc = np.zeros_like(p_loc)
                elif k % loops["per"] == 0:  # control interval boundary: the loops act on the room temperatures
                    eh = loops["sp"][bool(loops["occupied"][k])] - (xt[c.box_zone] + loops["offsets"])
                    integ = np.clip(integ + loops["ki_dt"] * eh, 0.0, 1.0)
                    y = np.clip(loops["kp"] * eh + integ, 0.0, 1.0)
                    p_loc = (np.minimum(2.0 * y, 1.0) if loops["dual"] else y) * rh_max
                p = p_cmd + p_loc
            m_app, p_app = m, p
            if buf is not None:
                m_app, p_app = m.copy(), p.copy()
                m_app[c.delay_boxes] = buf[0, :, 0]
                p_app[c.delay_boxes] = buf[0, :, 1]
                buf = np.roll(buf, -1, axis=0)
                buf[-1, :, 0] = m[c.delay_boxes]
                buf[-1, :, 1] = p[c.delay_boxes]
            mcp = CP_AIR * m_app
            h_z = c.Mzb @ (p_app + mcp * Ts_box)
            rh = c.reheat_effect
            if rh is not None and T_out < rh["below"] and np.all(m_app[rh["boxes"]] <= c.m_min[rh["boxes"]] + 1e-9):
                h_z[rh["zone"]] += rh["power"]
            he = c.heater_effect
            if he is not None and T_out < he["below"] and np.all(m_app[he["boxes"]] <= 0.0):
                h_z[he["zone"]] += he["power"]
            Q = h_z - (c.Mzb @ mcp) * xt[:nz]
            we = c.wind_effect
            if we is not None:  # outdoor air leaking in with the wind of this control interval
                z = we["zone"]
                Q[z] += we["g"][min((k0 + j) // we["per"], len(we["g"]) - 1)] * (T_out - xt[z])
            xt = c.Ad @ xt + W[j] + c.BQ @ Q
        out = xt if buf is None else np.concatenate([xt, buf.ravel()])
        if self.local_reheat:
            out = np.concatenate([out, integ, p_loc])
        return out, xt[:nz].copy()
