"""A CSV of numbers, with or without one header line: the node tables and factor files the
readers take beside another tool's results (``--nodes``, ``--gamma``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxflex.errors import InputError


def load_numeric_csv(path: Path, name: str) -> np.ndarray:
    """The rows of ``path`` as an (n, k) float array; InputError naming ``name`` when the file
    is not numbers separated by commas (one header line is skipped)."""
    try:
        return np.loadtxt(path, delimiter=",", ndmin=2)
    except ValueError:
        try:
            return np.loadtxt(path, delimiter=",", ndmin=2, skiprows=1)
        except ValueError as exc:
            raise InputError(f"{name}: {str(path)!r} is not a numeric CSV ({exc})") from exc
