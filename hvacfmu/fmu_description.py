"""The FMI 2.0 model description and documentation of the hvacfmu FMUs, from a variable layout.

A layout (:func:`hvacfmu.fmu_slave.zone_model_layout`) lists the variables in
value-reference order with role, name, causality, start, unit, description and
bounds. This module turns it into ``<UnitDefinitions>``, ``<TypeDefinitions>``
(one type per physical quantity, every variable refers to it through
``declaredType``), ``<ModelVariables>`` and a complete ``<ModelStructure>``, and
writes ``documentation/index.html`` saying what the FMU needs at run time.
"""

from __future__ import annotations

import html
import time
from xml.etree.ElementTree import Element, SubElement, indent, tostring

#: unit name -> SI base-unit exponents and offset for ``<UnitDefinitions>``
UNITS = {
    "degC": ({"K": "1"}, "273.15"),
    "K": ({"K": "1"}, None),
    "kg/s": ({"kg": "1", "s": "-1"}, None),
    "W/m2": ({"kg": "1", "s": "-3"}, None),
    "s": ({"s": "1"}, None),
    "kW": ({"kg": "1", "m": "2", "s": "-3", "factor": "1000"}, None),
    "m/s": ({"m": "1", "s": "-1"}, None),
}

#: unit -> (type name, quantity) of ``<TypeDefinitions>``
TYPES = {
    "degC": ("Temperature", "ThermodynamicTemperature"),
    "K": ("TemperatureDifference", "ThermodynamicTemperature"),
    "kg/s": ("MassFlowRate", "MassFlowRate"),
    "W/m2": ("Irradiance", "Irradiance"),
    "s": ("Time", "Time"),
    "kW": ("HeatFlowRate", "Power"),
    "m/s": ("Speed", "Velocity"),
}
#: type of Real variables without a unit, and of Integer variables
DIMENSIONLESS = ("Dimensionless", "Dimensionless")
INTEGER_TYPE = ("Index", "Index")

LOG_CATEGORIES = {
    "logStatusWarning": "Log messages with fmi2Warning status.",
    "logStatusDiscard": "Log messages with fmi2Discard status.",
    "logStatusError": "Log messages with fmi2Error status.",
    "logStatusFatal": "Log messages with fmi2Fatal status.",
    "logAll": "Log all messages.",
}


def variable_type(entry: dict) -> tuple[str, str]:
    """(type name, quantity) of a layout entry."""
    if entry["type"] != "Real":
        return INTEGER_TYPE
    return TYPES.get(entry.get("unit") or "", DIMENSIONLESS)


def _fmt(value, vtype: str) -> str:
    return repr(float(value)) if vtype == "Real" else str(int(value))


def type_definitions(variables) -> Element:
    """``<TypeDefinitions>`` with one SimpleType per quantity used by ``variables``."""
    types = Element("TypeDefinitions")
    seen = set()
    for e in variables:
        name, quantity = variable_type(e)
        if name in seen:
            continue
        seen.add(name)
        st = SubElement(types, "SimpleType", name=name)
        if e["type"] == "Real":
            attrs = {"quantity": quantity}
            if e.get("unit"):
                attrs["unit"] = e["unit"]
            SubElement(st, "Real", **attrs)
        else:
            SubElement(st, "Integer", quantity=quantity)
    return types


def unit_definitions(variables) -> Element | None:
    used = [u for u in UNITS if any(e.get("unit") == u for e in variables)]
    if not used:
        return None
    units = Element("UnitDefinitions")
    for u in used:
        exps, offset = UNITS[u]
        base = SubElement(SubElement(units, "Unit", name=u), "BaseUnit", **exps)
        if offset is not None:
            base.set("offset", offset)
    return units


def scalar_variable(parent: Element, vr: int, e: dict) -> Element:
    """One ``<ScalarVariable>`` of layout entry ``e`` (value reference ``vr``)."""
    causality = e["causality"]
    sv = SubElement(
        parent,
        "ScalarVariable",
        name=e["name"],
        valueReference=str(vr),
        description=e.get("description") or e["name"],
        causality=causality,
    )
    if causality == "input":
        sv.set("variability", "continuous" if e["type"] == "Real" else "discrete")
    elif causality == "output":
        sv.set("variability", "discrete")
        sv.set("initial", "calculated")
    else:
        sv.set("variability", "fixed")
        sv.set("initial", "exact")
    typ = SubElement(sv, e["type"], declaredType=variable_type(e)[0])
    if e.get("unit") and e["type"] == "Real":
        typ.set("unit", e["unit"])
    if causality != "output":
        typ.set("start", _fmt(e["start"], e["type"]))
    for key in ("min", "max", "nominal"):
        if e.get(key) is not None:
            typ.set(key, _fmt(e[key], e["type"]))
    return sv


def model_structure(parent: Element, variables) -> Element:
    """Outputs without direct feedthrough; at initialisation output ``T_z`` depends on ``T_z_start``."""
    structure = SubElement(parent, "ModelStructure")
    outs = [vr for vr, e in enumerate(variables) if e["causality"] == "output"]
    starts = [vr for vr, e in enumerate(variables) if e["role"] == "y0"]
    o = SubElement(structure, "Outputs")
    for vr in outs:
        SubElement(o, "Unknown", index=str(vr + 1), dependencies="")
    init = SubElement(structure, "InitialUnknowns")
    for i, vr in enumerate(outs):
        deps = str(starts[i] + 1) if len(starts) == len(outs) else " ".join(str(s + 1) for s in starts)
        SubElement(init, "Unknown", index=str(vr + 1), dependencies=deps)
    return structure


def model_description_xml(
    layout: dict,
    *,
    identifier: str,
    guid: str,
    native: bool,
    source_files=(),
    model_name: str | None = None,
    version: str | None = None,
) -> bytes:
    """The complete ``modelDescription.xml`` (FMI 2.0 co-simulation) of a layout, as UTF-8 bytes."""
    from . import __version__

    variables = layout["variables"]
    root = Element(
        "fmiModelDescription",
        fmiVersion="2.0",
        modelName=model_name or identifier,
        guid=guid,
        description=layout["description"],
        author="hvacfmu",
        version=version or f"hvacfmu {__version__}",
        generationTool=f"hvacfmu {__version__}",
        generationDateAndTime=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        variableNamingConvention="flat",
        numberOfEventIndicators="0",
    )
    cs = SubElement(
        root,
        "CoSimulation",
        modelIdentifier=identifier,
        needsExecutionTool="false",
        canHandleVariableCommunicationStepSize="false",
        canInterpolateInputs="false",
        maxOutputDerivativeOrder="0",
        canRunAsynchronuously="false",
        canBeInstantiatedOnlyOncePerProcess="false",
        canNotUseMemoryManagementFunctions="true",
        canGetAndSetFMUstate="true",
        canSerializeFMUstate="true",
        providesDirectionalDerivative="false",
    )
    if source_files:
        files = SubElement(cs, "SourceFiles")
        for f in source_files:
            SubElement(files, "File", name=f)
    units = unit_definitions(variables)
    if units is not None:
        root.append(units)
    root.append(type_definitions(variables))
    cats = SubElement(root, "LogCategories")
    for name, desc in LOG_CATEGORIES.items():
        SubElement(cats, "Category", name=name, description=desc)
    SubElement(
        root, "DefaultExperiment", startTime="0.0", stopTime=repr(7 * 86400.0), stepSize=repr(float(layout["step"]))
    )
    mv = SubElement(root, "ModelVariables")
    for vr, e in enumerate(variables):
        scalar_variable(mv, vr, e)
    model_structure(root, variables)
    indent(root)
    return tostring(root, encoding="UTF-8", xml_declaration=True)


def runtime_requirements(native: bool) -> list[str]:
    """What an FMU needs at run time, one line each."""
    if native:
        return [
            "Nothing but the operating system's C library: the model is compiled C code "
            "(binaries/linux64); no Python, no hvacfmu.",
            "Other platforms: compile sources/ (C99 and the FMI 2.0 headers), e.g. `fmpy compile FMU`.",
        ]
    import platform
    from importlib.metadata import PackageNotFoundError, version

    lines = [
        f"A Python {platform.python_version()} host process (the FMU's binary calls into the importer's "
        "Python interpreter; C/C++ importers need libpython preloaded and PYTHONPATH set)."
    ]
    for pkg in ("hvacfmu", "numpy", "scipy", "pandas", "pythonfmu"):
        try:
            lines.append(f"Python package {pkg} {version(pkg)} (or compatible) importable in that interpreter")
        except PackageNotFoundError:
            lines.append(f"Python package {pkg} importable in that interpreter")
    return lines


def documentation_html(layout: dict, *, native: bool) -> str:
    """``documentation/index.html``: description, run-time requirements and the variables."""
    rows = "\n".join(
        f"<tr><td>{html.escape(e['name'])}</td><td>{e['causality']}</td><td>{html.escape(e.get('unit') or '')}</td>"
        f"<td>{html.escape(str(e.get('min', '')) if e.get('min') is not None else '')}</td>"
        f"<td>{html.escape(str(e.get('max', '')) if e.get('max') is not None else '')}</td>"
        f"<td>{html.escape(e.get('description') or '')}</td></tr>"
        for e in layout["variables"]
    )
    needs = "\n".join(f"<li>{html.escape(line)}</li>" for line in runtime_requirements(native))
    return (
        f'<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>hvacfmu FMU</title></head><body>\n'
        f"<h1>hvacfmu {html.escape(str(layout['kind']))} FMU</h1>\n<p>{html.escape(layout['description'])}</p>\n"
        f"<h2>Needed at run time</h2>\n<ul>\n{needs}\n</ul>\n"
        f"<h2>Variables</h2>\n<table>\n<tr><th>name</th><th>causality</th><th>unit</th><th>min</th><th>max</th>"
        f"<th>description</th></tr>\n{rows}\n</table>\n</body></html>\n"
    )
