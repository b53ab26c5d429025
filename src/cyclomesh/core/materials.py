"""A small table of the materials of cycloid discs, pins and housings, with their sources.

Each :class:`MaterialGrade` has Young's modulus E, Poisson's ratio ν and an allowable
(limit) contact stress σH,lim, each with where it comes from. The allowable is the
endurance limit of the material for contact (pitting) stress **without** any safety
factor; a design requirement (``[requirements] max_contact_stress_mpa``) should divide it
by the safety factor the application needs.

Sources and their limits (read the standard for your material and hardness; these are
round values, not more precise than the heat treatment they assume):

* ISO 6336-5:2016, *Calculation of load capacity of spur and helical gears, Part 5:
  Strength and quality of materials*, figures of σH,lim against surface hardness, quality
  grades ML (low), MQ (normal industrial quality, used here) and ME (high). Case-hardened
  wrought steels at MQ: 1500 MPa. Through-hardened alloy steels and nodular cast iron
  depend on the hardness: the values below are read at the hardness stated.
* ISO 6336-5 has no curve for a through-hardened bearing steel (GCr15 / AISI 52100 at
  58–62 HRC, the usual disc and pin material of RV reducers); its surface hardness equals
  that of a case-hardened steel, and its MQ value is taken here. Cycloid-drive handbooks
  give [σH] = 1300–1500 MPa for GCr15 discs and pins.
* E and ν: typical handbook values of steel; for nodular iron EN 1563:2018 (informative
  annex: EN-GJS-700-2, E = 176 GPa, ν = 0.275).

References
----------
ISO 6336-5:2016; EN 1563:2018 (spheroidal graphite cast irons).
"""

from __future__ import annotations

from dataclasses import dataclass

from cyclomesh.core.pair import Material

__all__ = ["MaterialGrade", "MATERIALS", "material_grade"]


@dataclass(frozen=True)
class MaterialGrade:
    """A named material: elastic constants, allowable contact stress and their sources.

    Attributes
    ----------
    name : str
        The key used in study files (``[material] name = "GCr15"``).
    description : str
        Designation(s) and heat treatment assumed.
    youngs_modulus : float
        E [Pa].
    poisson_ratio : float
        ν [-].
    allowable_contact_stress : float
        σH,lim [Pa], contact (pitting) endurance limit, no safety factor.
    source : str
        Where the allowable comes from, and at which hardness.
    """

    name: str
    description: str
    youngs_modulus: float
    poisson_ratio: float
    allowable_contact_stress: float
    source: str

    @property
    def material(self) -> Material:
        """The elastic constants as the core's :class:`~cyclomesh.core.pair.Material`."""
        return Material(self.youngs_modulus, self.poisson_ratio)


_ISO_CASE = "ISO 6336-5:2016, case-hardened wrought steel, quality MQ"
MATERIALS: dict[str, MaterialGrade] = {
    grade.name.lower(): grade
    for grade in (
        MaterialGrade(
            "GCr15",
            "GCr15 / AISI 52100 / 100Cr6 bearing steel, through-hardened to 58-62 HRC",
            208e9,
            0.3,
            1500e6,
            f"{_ISO_CASE} (no bearing-steel curve in ISO 6336-5; same surface hardness); "
            "cycloid-drive handbooks give 1300-1500 MPa",
        ),
        MaterialGrade(
            "20CrMnTi",
            "20CrMnTi (about 20MnCr5) carburised and hardened, 58-62 HRC at the surface",
            207e9,
            0.3,
            1500e6,
            _ISO_CASE,
        ),
        MaterialGrade(
            "42CrMo4",
            "42CrMo4 / AISI 4140 quenched and tempered, about 300 HB",
            210e9,
            0.3,
            800e6,
            "ISO 6336-5:2016, through-hardened alloy wrought steel, quality MQ, read at "
            "about 310 HV (300 HB); rises with the hardness",
        ),
        MaterialGrade(
            "EN-GJS-700-2",
            "nodular (spheroidal graphite) cast iron EN-GJS-700-2 / QT700-2, about 250 HB",
            176e9,
            0.275,
            600e6,
            "ISO 6336-5:2016, nodular cast iron, quality MQ, read at about 250 HB; "
            "E and ν from EN 1563:2018",
        ),
        MaterialGrade(
            "steel",
            "steel of Table 1 of Li et al. (2022); allowable as a case-hardened steel",
            206e9,
            0.3,
            1500e6,
            _ISO_CASE + " (the paper gives E and ν only)",
        ),
    )
}
"""Named materials by lower-case name (``"gcr15"``, ``"20crmnti"``, ``"42crmo4"``,
``"en-gjs-700-2"``, ``"steel"``); ``"nodular_iron"`` and ``"52100"`` are aliases."""
MATERIALS["nodular_iron"] = MATERIALS["en-gjs-700-2"]
MATERIALS["52100"] = MATERIALS["gcr15"]
MATERIALS["100cr6"] = MATERIALS["gcr15"]


def material_grade(name: str) -> MaterialGrade:
    """The named material (case-insensitive); ``KeyError`` with the known names otherwise."""
    try:
        return MATERIALS[name.strip().lower()]
    except KeyError:
        known = ", ".join(sorted({g.name for g in MATERIALS.values()}))
        raise KeyError(f"unknown material {name!r}; known: {known}, nodular_iron") from None
