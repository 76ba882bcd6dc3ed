"""Command-line options of ``hvacfmu generate --engine energyplus`` (parsing only; no EnergyPlus import)."""

from __future__ import annotations

from ..errors import DataError


def add_energyplus_arguments(parser) -> None:
    """Add the EnergyPlus options to the ``generate`` sub-command's parser."""
    g = parser.add_argument_group("--engine energyplus")
    g.add_argument(
        "--prototype",
        help="IDF file, example file name (ASHRAE901_OfficeMedium_STD2019_Denver) or "
        "pyenergyplus.dataset key (office_medium, ref:small_office)",
    )
    g.add_argument("--weather", help="EPW file or pyenergyplus.dataset weather key (default: the example's city)")
    g.add_argument("--days", type=int, help="run length [days] instead of --weeks")
    g.add_argument("--floor", help="keep conditioned zones whose IDF name contains this text (e.g. mid)")
    g.add_argument("--zone", action="append", dest="zones", help="keep this IDF zone (repeatable)")
    g.add_argument("--site-timezone", dest="site_timezone", help="IANA time zone of the site (default from the EPW)")


def generate_from_args(args):
    """Run :func:`hvacfmu.energyplus.generate` with parsed ``generate`` arguments."""
    if not args.prototype:
        raise DataError("--engine energyplus needs --prototype (an IDF file or an example building name)")
    from .generate import generate

    wind = getattr(args, "wind", None)
    if wind not in (None, "m/s"):
        raise DataError(f"--wind {wind}: the EnergyPlus export writes the site wind speed in m/s (--wind m/s)")
    start = args.start or "2017-01-01"
    try:
        year, month, day = (int(x) for x in start.split("-"))
    except ValueError:
        raise DataError(f"--start {start!r} is not a date like 2017-01-01") from None
    return generate(
        args.outdir,
        args.prototype,
        weather=args.weather,
        weeks=args.weeks,
        days=args.days,
        start=f"{month:02d}-{day:02d}",
        year=year,
        floor=args.floor,
        zones=args.zones,
        timezone=args.site_timezone,
        fmt=args.format,
        wind=wind is not None,
    )
