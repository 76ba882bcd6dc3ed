"""Both coupling instruments of two non-adjacent pairs on the base model (no terms) of default battery 2027 clean
case 11 (core9, 5 min, seed 35): ``benchmarks/replace_s19.md`` section 1.

Run: ``python3 benchmarks/replace_s19_pair.py`` (about 15 s CPU once the case is in ``$HVACFMU_CACHE``).
"""

import json
import time

from hvacfmu.data import prepare
from hvacfmu.diagnosis import pipeline as P
from hvacfmu.diagnosis import selection as S
from hvacfmu.diagnosis.design import Within, make_signals
from hvacfmu.emulator import cached_dataset
from hvacfmu.models.extended import ZoneCoupling


def _short(d: dict) -> dict:
    return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in d.items() if k.startswith(("iv_", "held"))}


def main() -> None:
    t0 = time.process_time()
    paths = cached_dataset(weeks=16, seed=35, effects=[], layout="core9")
    ds = prepare(paths.measurements, paths.building, step=300.0)
    model, _ = P._base_model(ds, None, lambda *a, **k: None, [])
    sig = make_signals(ds, model)
    W = Within(sig.group, sig.rows("train"))
    lags = round(6 * 3600 / sig.step)
    for za, zb in (("NW", "SE"), ("N", "E")):
        t = ZoneCoupling(zone_a=za, zone_b=zb, coef_ab=0.0, coef_ba=0.0)
        print(za, zb, "plain", json.dumps(_short(S.coupling_instrument(sig, W, [], t, lags))))
        print(za, zb, "held ", json.dumps(_short(S.coupling_instrument_beyond_neighbours(sig, W, [], t, lags))))
    print(f"CPU {time.process_time() - t0:.1f} s")


if __name__ == "__main__":
    main()
