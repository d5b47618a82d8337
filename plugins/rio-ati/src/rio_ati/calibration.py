"""The counts-per-unit calibration a Net F/T box serves on its configuration page, `netftapi2.xml`
(`<netft>` with `cfgcpf` counts per force unit, `cfgcpt` counts per torque unit, and the units of the
active configuration in `scfgfu` / `scfgtu`), turned into SI: counts per newton and per newton-meter.

A box's configuration may be in lbf and lbf-in, kN and N-mm; dividing counts by `cfgcpf` alone would then
publish the wrong units. Unknown unit names are an error naming them, never a guess.
"""

from __future__ import annotations

import urllib.request
import xml.etree.ElementTree as ET
from dataclasses import dataclass

#: Newtons per force unit, as the box names them.
FORCE_UNITS = {"N": 1.0, "kN": 1000.0, "lbf": 4.4482216152605, "klbf": 4448.2216152605, "kgf": 9.80665,
               "gf": 0.00980665, "mN": 0.001}
#: Newton-meters per torque unit, as the box names them.
TORQUE_UNITS = {"Nm": 1.0, "N-m": 1.0, "Nmm": 0.001, "N-mm": 0.001, "kNm": 1000.0, "kN-m": 1000.0,
                "lbf-in": 0.1129848290276167, "lbf-ft": 1.3558179483314004, "kgf-cm": 0.0980665,
                "kgf-m": 9.80665, "ozf-in": 0.007061551814226, "gf-cm": 9.80665e-5}

PAGE = "netftapi2.xml"


@dataclass(frozen=True)
class Calibration:
    """Counts per SI unit: divide a record's force counts by `counts_per_n`, torque counts by `counts_per_nm`."""

    counts_per_n: float
    counts_per_nm: float

    def to_si(self, counts) -> tuple[list[float], list[float]]:
        """(force N, torque N m) of six counts."""
        return ([c / self.counts_per_n for c in counts[:3]], [c / self.counts_per_nm for c in counts[3:6]])


def parse(xml_text: str | bytes, source: str = PAGE) -> Calibration:
    """The calibration of a `netftapi2.xml` page (`source` names it in errors)."""
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as e:
        raise ValueError(f"{source} is not XML: {e}") from None

    def field(tag: str, default: str | None = None) -> str:
        text = root.findtext(tag)
        if text is None or not text.strip():
            if default is not None:
                return default
            raise ValueError(f"{source} has no <{tag}> (counts per unit of the active configuration)")
        return text.strip()

    fu, tu = field("scfgfu", "N"), field("scfgtu", "Nm")
    if fu not in FORCE_UNITS:
        raise ValueError(f"{source}: force unit '{fu}' is not one of {sorted(FORCE_UNITS)}")
    if tu not in TORQUE_UNITS:
        raise ValueError(f"{source}: torque unit '{tu}' is not one of {sorted(TORQUE_UNITS)}")
    cpf, cpt = float(field("cfgcpf")), float(field("cfgcpt"))
    if cpf <= 0 or cpt <= 0:
        raise ValueError(f"{source}: counts per force {cpf} / per torque {cpt} must be positive")
    return Calibration(cpf / FORCE_UNITS[fu], cpt / TORQUE_UNITS[tu])


def fetch(host: str, port: int = 80, timeout: float = 2.0) -> Calibration:
    """Read the calibration from the box's web server (`http://host:port/netftapi2.xml`)."""
    url = f"http://{host}:{port}/{PAGE}"
    with urllib.request.urlopen(url, timeout=timeout) as response:  # noqa: S310 - an http URL we built
        return parse(response.read(), url)
