"""fmu package."""
