"""A turning move's plan (optim.turn_plan), made before the work it covers: a clearance
below what the model resolves is refused at once, and a turning optimisation whose plan
exceeds the time budget is refused before its first turning evaluation (the engine is
never called). The plan's figures against measured runs are in optim.turn_plan's
docstring; nothing here asserts a time."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import optim
import optim.stages
from jaxflex._budget import make_budget, use_budget
from jaxflex.errors import BudgetError, InputError
from optim.search import bisect
from optim.turn_plan import gallop_lengths, resolution_m

DT = 0.01
LIMITS = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)
TURN = {"rotation": optim.Rotation("x", 30.0, pivot_m=(0.6, 0.4, 0.0))}


def _no_engine(*args, **kwargs):
    raise AssertionError("the turning baselines ran before the plan refused the work")


def test_a_clearance_below_the_models_resolution_is_refused_at_once(turning_plate, monkeypatch):
    monkeypatch.setattr(optim.stages, "turn_baselines", _no_engine)
    floor, relative, deflection, acc = resolution_m(turning_plate, (0.0, 0.0, 1.0), 30.0)
    # the gentlest acceleration over 1 m in 30 s: 4 d / T^2 (a rest-to-rest move must reach it)
    assert acc == pytest.approx(4.0 / 30.0**2)
    assert floor == pytest.approx(relative * deflection) and 1e-3 <= relative < 1
    with pytest.raises(InputError, match=r"clearance_m \(--clearance\): 1e-12 m is below"):
        optim.optimize(
            turning_plate,
            (0.0, 0.0, 1.0),
            LIMITS,
            DT,
            5e-4,
            constraints=optim.Constraints(clearance_m=1e-12),
            **TURN,
        )


def test_a_turning_search_over_the_budget_is_refused_before_its_baselines(
    turning_plate, monkeypatch
):
    monkeypatch.setattr(optim.stages, "turn_baselines", _no_engine)
    with (
        use_budget(make_budget(None, 1.0)),
        pytest.raises(
            BudgetError, match=r"time: the turning move's baselines \(10 turning evaluations\)"
        ),
    ):
        optim.optimize(turning_plate, (0.0, 0.0, 1.0), LIMITS, DT, 5e-4, **TURN)


@pytest.mark.parametrize("floor, feasible_from", [(69, 69), (69, 84), (100, 171), (7, 60)])
def test_the_planned_lengths_are_the_searchs(floor, feasible_from, monkeypatch):
    """The lengths optim.search.bisect tests, recorded from bisect itself on a problem
    feasible from ``feasible_from`` steps: its gallop is gallop_lengths', and it tests no
    more lengths than the plan counts for a search bracketed there (_tests_needed)."""
    import optim.search
    from optim.turn_plan import _tests_needed

    tested = []

    def fake_attempt(problem, solver, n_steps, warm, gate=None):
        tested.append(n_steps)
        ok = n_steps >= feasible_from
        return SimpleNamespace(feasible=ok, n_steps=n_steps, acc=np.zeros((n_steps + 1, 3)),
                               reason="" if ok else "infeasible")  # fmt: skip

    monkeypatch.setattr(optim.search, "attempt", fake_attempt)
    # no cell rows: no separating plane took part, so no length below the answer is retried
    problem = SimpleNamespace(max_steps=10 * floor, cell_rows={}, restricted=lambda n: False)
    solver = SimpleNamespace(name="fake")
    best, _ = bisect(problem, solver, np.zeros((floor + 1, 3)), 10 * floor, [], progress=False)
    assert best.n_steps == feasible_from
    gallop = [n for n in tested if n == floor or n > max(tested[: tested.index(n)], default=0)]
    planned = gallop_lengths(floor, 10 * floor)
    assert gallop == planned[: len(gallop)]
    assert len(tested) <= len(_tests_needed(floor, gallop[-1]))
