"""Progress bars (tqdm) for long steps; ``enabled=None`` shows them on a terminal only."""

from __future__ import annotations

from tqdm.auto import tqdm


def progress_bar(total: int | None, desc: str, enabled: bool | None = None, unit: str = "it"):
    """A tqdm bar; ``enabled`` True/False forces it on/off, None: only on a terminal."""
    disable = None if enabled is None else not enabled
    return tqdm(total=total, desc=desc, disable=disable, unit=unit, leave=False)
