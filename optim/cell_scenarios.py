"""The cell's constraints over every model of a robust grid, not only the nominal one.

With ``robust`` the move must keep the part clear of the obstacles, the cups and the stress
within their limits for every model of the grid (frequencies scaled by s, damping zeta:
optim.robust), as it keeps the cycle time. The models differ where it matters: a softer part
(s < 1) sags by 1 / s^2 more under gravity and vibrates with other amplitudes, its cup forces
and stresses follow its own modes (jaxflex.model.with_frequency_scale).

:class:`ScenarioFamily` wraps one family of optim.cell_rows per model (the nominal model
first, then the grid's, built on first use): the LP's rows come from the models that have
failed a certification so far (the nominal one from the start), and a move is certified on
every model; the first model that fails gives its certified worst point as a row and joins
the rows' models. Its description names the model with the smallest margin, and how many
models the certificate covers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jaxflex.response import Move
from optim.cell_rows import Row
from optim.options import RobustSpec
from optim.robust import perturbed


@dataclass(frozen=True)
class ScenarioFound:
    """The certified values of one family on the models checked: (model index, found) in
    the order checked; ``failed`` the index of the first model that failed (or None)."""

    found: list
    failed: int | None


class ScenarioFamily:
    """One constraint family over the nominal ``model`` and every model of the ``robust``
    grid (optim.robust; each built on first use: the nominal family's ``scenario(scale,
    zeta)`` where it has one, sharing its data, else ``make`` of the perturbed model, with
    its output maps where ``outputs``); ``make(model)`` builds the family of one model
    (module docstring)."""

    def __init__(self, make: Callable, model, robust: RobustSpec, *, outputs: bool) -> None:
        self.make, self.model, self.outputs = make, model, outputs
        self.models: list[tuple[str, float, float | None]] = [("nominal", 1.0, None)] + [
            (f"f x{s:.3f}" + ("" if z is None else f", zeta {z:g}"), s, z) for s, z in robust.grid()
        ]
        self.families: dict[int, object] = {}
        self.training = [0]
        self.utilisation: dict[int, float] = {}  # each model's, from its last certificate
        self.nominal = self.family(0)  # the nominal model's family
        self.name, self.limit = self.nominal.name, self.nominal.limit

    def family(self, index: int):
        if index not in self.families:
            _, scale, zeta = self.models[index]
            if index == 0:
                self.families[0] = self.make(self.model)
            elif getattr(self.family(0), "scenario", None) is not None:
                self.families[index] = self.family(0).scenario(scale, zeta)
            else:
                model = perturbed(self.model, scale, zeta, outputs=self.outputs)
                self.families[index] = self.make(model)
        return self.families[index]

    def scan(self, move: Move, axes) -> list[Row]:
        return [row for i in self.training for row in self.family(i).scan(move, axes)]

    def _order(self) -> list[int]:
        """The models in the order they are certified: the rows' models, then the others by
        their last utilisation, largest first (a failing model is found early), then in the
        grid's order."""
        rest = [i for i in range(len(self.models)) if i not in self.training]
        rest.sort(key=lambda i: -self.utilisation.get(i, -np.inf))
        return self.training + rest

    def certify(self, move: Move) -> ScenarioFound:
        """Every model's certificate for ``move`` (a Move), each decided against the limit,
        stopping at the first model that fails (what the search needs)."""
        found, failed = [], None
        for i in self._order():
            family = self.family(i)
            value = family.certify(move)
            found.append((i, value))
            self.utilisation[i] = family.describe(value)["utilisation"]
            if not family.holds(value):
                failed = i
                break
        return ScenarioFound(found, failed)

    def measure(self, move: Move, *, every: bool = True) -> ScenarioFound:
        """Every model's certificate for ``move`` with the worst model's value located
        (reports): each model is located only where it may be worse than the worst so far
        or break the limit (a family's ``measure``). Without ``every`` the check stops at
        the first model that fails (a baseline that breaks the constraint)."""
        found, failed, worst, most = [], None, None, -np.inf
        for i in self._order():
            family = self.family(i)
            value = measured(family, move, worst)
            found.append((i, value))
            share = self.utilisation[i] = family.describe(value)["utilisation"]
            if share > most:
                worst, most = value, share
            if failed is None and not family.holds(value):
                failed = i
                if not every:
                    break
        return ScenarioFound(found, failed)

    def holds(self, found: ScenarioFound) -> bool:
        return found.failed is None and len(found.found) == len(self.models)

    def failure_row(self, found: ScenarioFound, move: Move, axes):
        """The row at the certified worst point of ``move`` (a Move) for the first model that
        failed; that model's rows join the search from now on."""
        i = found.failed
        if i not in self.training:
            self.training.append(i)
        family = self.family(i)
        value = dict(found.found)[i]
        return family.failure_row(value, move, axes)

    def describe(self, found: ScenarioFound) -> dict:
        """The description of the model with the largest utilisation, with its label and the
        number of models the certificate covers."""
        worst_i, worst = max(
            ((i, self.family(i).describe(v)) for i, v in found.found),
            key=lambda pair: pair[1]["utilisation"],
        )
        return {**worst, "scenario": self.models[worst_i][0], "scenarios": len(found.found)}

    def curve(self, move: Move, t):
        """The nominal model's curve (plots)."""
        return self.family(0).curve(move, t)


def measured(family, move: Move, worst=None):
    """A family's report of ``move``: its ``measure`` (the value located where it may be
    worse than ``worst``), or its certificate where it has none."""
    measure = getattr(family, "measure", None)
    return family.certify(move) if measure is None else measure(move, worst)
