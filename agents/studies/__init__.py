"""The crossing-fidelity measure, which the crossing controller imports; the studies that use
it are scripts of the repository (``scripts/``, not installed)."""
