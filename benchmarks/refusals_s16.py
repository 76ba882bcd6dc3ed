"""False refusals of clean EnergyPlus exports (session 16): ``prepare`` on each export, before/after.

Usage: ``python3 benchmarks/refusals_s16.py OUT EXPORT_DIR ...`` (directories of ``cached_export``: measurements,
building.toml, energyplus.json). An export written before version 1.9 gets a copy in OUT whose building.toml has
each scheduled-minimum VAV box's ``m_min`` rewritten by the 1.9 rule (the schedule's smallest positive fraction
times ``m_max``; the measurements do not change with that rule), then each is prepared and its outcome printed:
``prepared`` with its warnings, or ``refused`` with the problems. See ``benchmarks/refusals_s16.md``.
"""

from __future__ import annotations

import json
import re
import sys
import warnings
from pathlib import Path

from hvacfmu.data import prepare
from hvacfmu.energyplus.hvac import _schedule_min_positive
from hvacfmu.energyplus.idf import read_idf
from hvacfmu.errors import DataError


def _max_fraction(idf, name: str) -> float:
    """The rule of exports up to 1.8: the schedule's largest value."""
    sch = idf.by_name("Schedule:Compact").get(name.lower())
    vals = []
    for f in sch.fields[2:] if sch is not None else []:
        try:
            vals.append(float(f))
        except ValueError:
            pass
    return max(vals, default=0.0)


def rewrite_m_min(src: Path, out: Path) -> tuple[Path, list[str]]:
    """A copy of ``src`` (measurements linked) with the 1.9 ``m_min`` of every scheduled-minimum box."""
    info = json.loads((src / "energyplus.json").read_text())
    if tuple(int(x) for x in info.get("export_version", "0").split(".")) >= (1, 9):
        return src, []
    idf = read_idf(info["idf"])
    text = (src / "building.toml").read_text()
    changed = []
    for b in info["boxes"]:
        term = idf.by_name(b["terminal_type"]).get(b["terminal"].lower())
        if not b["terminal_type"].lower().startswith("airterminal:singleduct:vav") or term is None:
            continue
        if term.get(5).lower() != "scheduled":
            continue
        old, new = _max_fraction(idf, term.get(8)), _schedule_min_positive(idf, term.get(8))
        if old == new:
            continue
        pat = re.compile(
            '(name = "' + re.escape(b["name"]) + r'"\nzone = "[^"]*"\nm_min = )([0-9.eE+-]+)(\nm_max = )([0-9.eE+-]+)'
        )
        m = pat.search(text)
        if m is None:
            continue
        m_new = round(new * float(m.group(4)), 5)
        text = text[: m.start(2)] + repr(m_new) + text[m.end(2) :]
        changed.append(f"{b['name']}: m_min {m.group(2)} -> {m_new} kg/s (fraction {old:g} -> {new:g})")
    if not changed:
        return src, []
    dst = out / src.name
    dst.mkdir(parents=True, exist_ok=True)
    for f in src.iterdir():
        if f.name != "building.toml" and not (dst / f.name).exists():
            (dst / f.name).symlink_to(f)
    (dst / "building.toml").write_text(text)
    return dst, changed


def main(argv=None) -> None:
    args = list(sys.argv[1:] if argv is None else argv)
    out = Path(args[0])
    for src in map(Path, args[1:]):
        d, changed = rewrite_m_min(src, out)
        for c in changed:
            print(f"  {src.name}: {c}")
        data = next(iter(sorted(d.glob("measurements.*"))))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = prepare(data, d / "building.toml")
            print(f"{src.name}: prepared, {len(ds.warnings)} warning(s)")
            for w in ds.warnings:
                print(f"    W: {w[:300]}")
        except DataError as exc:
            print(f"{src.name}: refused\n    {str(exc)[:3000]}")


if __name__ == "__main__":
    main()
