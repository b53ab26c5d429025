"""The RV-40E-size test geometry the stage tests share (``examples/rv_stage.toml``'s pair
and crank holes, SI units): 40 pins on a = 64 mm, ρp = 3 mm, groove 3.005 mm, e = 1.3 mm,
a 10 mm disc; three crank holes of 13 mm on r_c = 36 mm. Each test keeps its own
modification, rollers and crank angles."""

from cyclomesh import PairDesign
from cyclomesh.core.pair import CrankHoles

RV40 = PairDesign(
    pins=40,
    pin_circle_radius=64e-3,
    pin_radius=3e-3,
    groove_radius=3.005e-3,
    eccentricity=1.3e-3,
    width=10e-3,
)
HOLES = CrankHoles(count=3, circle_radius=36e-3, radius=13e-3)
