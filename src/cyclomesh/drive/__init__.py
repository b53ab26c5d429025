"""Drive characteristics on the core: both flanks, disc stacks, play, mesh force, torsion
curve. Pure."""
