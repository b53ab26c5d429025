"""The paper's model, Eqs. 1-26: pair, modification, profile, contact, Hertz, load sharing,
LTCA. NumPy/SciPy only."""
