"""The design-space sweep (modification design maps) on the drive layer. Pure."""
